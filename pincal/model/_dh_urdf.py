"""The pieces of a DH robot's URDF: the elementary transforms of a DH row (exact at right angles)
and the URDF text of an origin and a fixed frame."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin


def rx(angle: float) -> np.ndarray:
    c, s = _cos_sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rz(angle: float) -> np.ndarray:
    c, s = _cos_sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def tx(a: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = a
    return T


def tz(d: float) -> np.ndarray:
    T = np.eye(4)
    T[2, 3] = d
    return T


def _cos_sin(angle: float) -> tuple[float, float]:
    """cos and sin, exact at multiples of 90° (so a right-angle twist leaves no 6e-17 in the URDF)."""
    quarter = angle / (math.pi / 2)
    if abs(quarter - round(quarter)) < 1e-12:
        return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][round(quarter) % 4]
    return math.cos(angle), math.sin(angle)


def quoteattr(value: str) -> str:
    """``value`` quoted as an XML attribute value (``xml.sax.saxutils.quoteattr``, imported here on
    first use: it imports urllib.request, http.client and ssl, a noticeable part of every command's
    start-up otherwise)."""
    from xml.sax.saxutils import quoteattr as quoted

    return quoted(value)


def _text(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) if abs(v) > 1e-15 else "0" for v in values)


def origin_text(T: np.ndarray) -> str:
    rpy = pin.rpy.matrixToRpy(T[:3, :3])
    return f'<origin xyz="{_text(T[:3, 3])}" rpy="{_text(rpy)}"/>'


def fixed_frame(parent: str, child: str, T: np.ndarray) -> list[str]:
    return [
        f"  <link name={quoteattr(child)}/>",
        f'  <joint name={quoteattr(child + "_joint")} type="fixed">',
        f'    <parent link="{parent}"/>',
        f"    <child link={quoteattr(child)}/>",
        f"    {origin_text(T)}",
        "  </joint>",
    ]
