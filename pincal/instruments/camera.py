"""A calibrated pinhole camera with the usual lens distortion (docs/method.md §13.1).

A point p = (X, Y, Z) in the camera's frame (z along the optical axis, x to the right of the image,
y down, as OpenCV and ROS ``camera_info`` have it) projects to x = X/Z, y = Y/Z, is distorted by
the Brown–Conrady model with OpenCV's coefficients (k1, k2, p1, p2, k3),

    r² = x² + y²,   s = 1 + k1 r² + k2 r⁴ + k3 r⁶,
    x' = x s + 2 p1 x y + p2 (r² + 2x²),   y' = y s + p1 (r² + 2y²) + 2 p2 x y,

and lands on the pixel (u, v) = (fx x' + cx, fy y' + cy). The intrinsics are the camera's own
calibration (OpenCV's ``calibrateCamera``, ROS ``camera_info``'s K and D): pincal uses them as given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from pincal.errors import BadArgument

MIN_DEPTH = 1e-3
"""A point closer than this in front of the camera [m] (or behind it) is not seen."""


@dataclass(frozen=True)
class Camera:
    """A pinhole camera's intrinsics (see module doc).

    Attributes:
        fx, fy: focal lengths [px].
        cx, cy: principal point [px].
        distortion: (k1, k2, p1, p2, k3), OpenCV's order; fewer are padded with zeros.
        width, height: the image's size [px], or None: a point is seen when it projects inside
            it (and lies in front of the camera).
    """

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    width: int | None = None
    height: int | None = None

    def __post_init__(self) -> None:
        values = [self.fx, self.fy, self.cx, self.cy, *self.distortion]
        if not all(isinstance(v, (int, float, np.floating)) and np.isfinite(v) for v in values):
            raise BadArgument(f"camera intrinsics must be finite numbers, got {values!r}", argument="camera")
        if self.fx <= 0 or self.fy <= 0:
            raise BadArgument(
                f"camera focal lengths must be positive, got {self.fx}, {self.fy}", argument="camera"
            )
        if len(self.distortion) > 5:
            raise BadArgument(
                "camera distortion: at most five coefficients k1, k2, p1, p2, k3", argument="camera"
            )
        object.__setattr__(
            self, "distortion", tuple(float(d) for d in self.distortion) + (0.0,) * (5 - len(self.distortion))
        )
        for name in ("width", "height"):
            size = getattr(self, name)
            if size is not None and not (isinstance(size, (int, np.integer)) and size > 0):
                raise BadArgument(
                    f"camera {name} must be a positive number of pixels, got {size!r}", argument="camera"
                )

    def project(self, p: np.ndarray) -> np.ndarray:
        """(..., 2) pixels (u, v) of points (..., 3) in the camera's frame [m]."""
        x, y = p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]
        xd, yd = self._distorted(x, y)
        return np.stack([self.fx * xd + self.cx, self.fy * yd + self.cy], axis=-1)

    def _distorted(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k1, k2, p1, p2, k3 = self.distortion
        r2 = x * x + y * y
        s = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return x * s + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * s + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        """(..., 2, 3) ∂(u, v)/∂p at points (..., 3) in the camera's frame [px/m]."""
        k1, k2, p1, p2, k3 = self.distortion
        X, Y, Z = p[..., 0], p[..., 1], p[..., 2]
        x, y = X / Z, Y / Z
        r2 = x * x + y * y
        s = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        g = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # ds/d(r²)
        dxx = s + 2 * g * x * x + 2 * p1 * y + 6 * p2 * x
        dxy = 2 * g * x * y + 2 * p1 * x + 2 * p2 * y
        dyy = s + 2 * g * y * y + 6 * p1 * y + 2 * p2 * x
        D = np.stack(
            [np.stack([self.fx * dxx, self.fx * dxy], -1), np.stack([self.fy * dxy, self.fy * dyy], -1)], -2
        )
        zero = np.zeros_like(Z)
        P = np.stack(
            [np.stack([1 / Z, zero, -x / Z], -1), np.stack([zero, 1 / Z, -y / Z], -1)], -2
        )  # ∂(x, y)/∂p
        return D @ P

    def in_view(self, p: np.ndarray) -> np.ndarray:
        """(...) True where points (..., 3) in the camera's frame are in front of it and project
        inside the image."""
        front = p[..., 2] > MIN_DEPTH
        safe = np.where(front[..., None], p, np.array([0.0, 0.0, 1.0]))
        uv = self.project(safe)
        inside = np.ones_like(front)
        if self.width is not None:
            inside &= (uv[..., 0] >= 0) & (uv[..., 0] <= self.width)
        if self.height is not None:
            inside &= (uv[..., 1] >= 0) & (uv[..., 1] <= self.height)
        return front & inside

    def inside_probability(self, uv: np.ndarray, spread: np.ndarray) -> np.ndarray:
        """(...) the probability that points whose pixels (..., 2) are Gaussian about ``uv`` with
        standard deviations ``spread`` (..., 2) [px] land inside the image (1 on an unbounded
        side; a spread of 0 is the hard test of :meth:`in_view`)."""
        probability = np.ones(uv.shape[:-1])
        for axis, size in enumerate((self.width, self.height)):
            if size is None:
                continue
            u, s = uv[..., axis], spread[..., axis]
            with np.errstate(divide="ignore", invalid="ignore"):
                inside = ndtr((size - u) / s) - ndtr(-u / s)
            probability *= np.where(s > 0, inside, (u >= 0) & (u <= size))
        return probability

    def as_dict(self) -> dict:
        return {
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "distortion": list(self.distortion),
            "width": self.width,
            "height": self.height,
        }
