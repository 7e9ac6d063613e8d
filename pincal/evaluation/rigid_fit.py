"""The best rigid fit of measured poses onto reference poses: where the instrument's frame is in the
robot's, and how the measured frame sits on the tool.

A laser tracker or a motion-capture system measures in its own frame; to compare what it measured
with what was commanded (ISO 9283) or predicted (a calibrated model), the measurements are
expressed in the reference frame by the rigid motion that brings the measured positions closest to
the reference ones in the least-squares sense (Kabsch, *Acta Cryst.* A32, 1976): with centred
positions a_i (measured) and b_i (reference), H = Σ a_i b_iᵀ = U S Vᵀ, R = V diag(1, 1, det(V Uᵀ)) Uᵀ
and t = b̄ − R ā. When orientations are measured too, the measured frame (a T-Mac, a rigid body of
markers) is never mounted exactly as the tool frame: its constant rotation on the tool is the
chordal mean of R_ref,iᵀ R R_meas,i (the rotation nearest, in the Frobenius norm, to their
average). Both absorb what is constant in the errors: the mean position error into the base (in
part), the mean orientation error into the tool rotation. See docs/method.md §8.5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import BadMeasurementData


@dataclass(frozen=True, eq=False)
class RigidFit:
    """The rigid motion that expresses measured poses in a reference frame.

    Attributes:
        rotation: (3, 3) rotation of the measured frame in the reference frame.
        translation: (3,) origin of the measured frame in the reference frame [m].
        tool_rotation: (3, 3) the measured frame's constant rotation relative to the reference
            tool frame (``R_ref ≈ R @ R_meas @ tool_rotation.T``), or None (no orientations).
        rms: root mean square of the position residuals after the fit [m].
    """

    rotation: np.ndarray
    translation: np.ndarray
    tool_rotation: np.ndarray | None
    rms: float

    def positions(self, measured: np.ndarray) -> np.ndarray:
        """(N, 3) measured positions [m] expressed in the reference frame."""
        return np.asarray(measured, dtype=float) @ self.rotation.T + self.translation

    def rotations(self, measured: np.ndarray) -> np.ndarray:
        """(N, 3, 3) measured orientations expressed in the reference frame, as the tool frame's."""
        tool = np.eye(3) if self.tool_rotation is None else self.tool_rotation
        return np.einsum("ij,njk,lk->nil", self.rotation, np.asarray(measured, dtype=float), tool)


def nearest_rotation(matrix: np.ndarray) -> np.ndarray:
    """The rotation nearest to a 3 x 3 ``matrix`` in the Frobenius norm (its polar factor, det +1)."""
    u, _, vt = np.linalg.svd(matrix)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    return u @ np.diag([1.0, 1.0, d]) @ vt


def rigid_fit(
    reference: np.ndarray,
    measured: np.ndarray,
    reference_rotations: np.ndarray | None = None,
    measured_rotations: np.ndarray | None = None,
) -> RigidFit:
    """The best rigid fit of ``measured`` positions onto ``reference`` ones (Kabsch), and with
    orientations, the measured frame's constant rotation on the tool (their chordal mean).

    Args:
        reference: (N, 3) reference positions (commanded, or predicted by a model) [m].
        measured: (N, 3) measured positions, in the instrument's frame [m].
        reference_rotations: (N, 3, 3) reference orientations, or None.
        measured_rotations: (N, 3, 3) measured orientations (instrument frame), or None.

    Raises:
        BadMeasurementData: fewer than 3 positions, or all on one line (the rotation is not
            determined).
    """
    b = np.asarray(reference, dtype=float)
    a = np.asarray(measured, dtype=float)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3:
        raise BadMeasurementData(f"rigid fit: expected two (N, 3) arrays, got {a.shape} and {b.shape}")
    a0, b0 = a - a.mean(axis=0), b - b.mean(axis=0)
    s = np.linalg.svd(a0, compute_uv=False) if len(a) >= 3 else np.zeros(1)
    if len(a) < 3 or s[1] <= 1e-9 * max(s[0], 1e-12):
        raise BadMeasurementData(
            f"rigid fit: {len(a)} measured positions, not spread in a plane: at least 3 positions off "
            "one line are needed to place the instrument's frame"
        )
    u, _, vt = np.linalg.svd(a0.T @ b0)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    translation = b.mean(axis=0) - rotation @ a.mean(axis=0)
    residual = a @ rotation.T + translation - b
    tool = None
    if reference_rotations is not None and measured_rotations is not None:
        each = np.einsum("nji,jk,nkl->nil", reference_rotations, rotation, measured_rotations)
        tool = nearest_rotation(each.mean(axis=0))
    rms = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    return RigidFit(rotation, translation, tool, rms)
