r"""The ``test-pose-worst`` criterion: ρ0 at the worst of several test poses.

F = log max_k tr(J0k (M + Λ)⁻¹ J0kᵀ), reported as ρ0 = σ·sqrt(exp F) [m] at the worst test pose.
The maximum is not smooth: the gradient search minimises the power mean (mean_k t_k^p)^{1/p}
instead (:meth:`TestPoseWorst.with_power`), which tends to the maximum as p grows; the value
reported is always the true maximum. Each test pose is a weighted trace of its own, so the cost
grows with their number (the mean, :class:`~pincal.evaluation.test_pose.TestPoseMean`, does not).
"""

from __future__ import annotations

import numpy as np

from pincal.evaluation.weighted_trace import WeightedTrace


class TestPoseWorst(WeightedTrace):
    """ρ0 at the worst test pose (see module doc).

    Args:
        J0: (k, r, P) tip-frame Jacobians at the test poses.
        sigma: measurement noise per coordinate [m].
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹, or None.
        power: the power p of the mean standing for the maximum in the gradient (None: the
            exact maximum).
    """

    __test__ = False  # not a pytest class
    name = "test-pose-worst"

    def __init__(
        self,
        J0: np.ndarray | None,
        sigma: float,
        rows: int,
        prior: np.ndarray | None = None,
        power: float | None = None,
        *,
        J0T: np.ndarray | None = None,
        groups: int | None = None,
    ) -> None:
        if J0 is not None:
            J0T, groups = J0.reshape(-1, J0.shape[-1]).T, len(J0)
        assert J0T is not None and groups is not None  # J0, or its factors
        super().__init__(J0T, groups, sigma, rows, prior)
        self.power = power

    def with_power(self, power: float | None) -> TestPoseWorst:
        return TestPoseWorst(None, self.scale, self.rows, self.prior, power, J0T=self.J0T, groups=self.k)

    @property
    def smoothed(self) -> bool:
        return True

    def aggregate(self, t: np.ndarray) -> np.ndarray:
        return t.max(axis=-1)

    def gradient_weights(self, t: np.ndarray) -> tuple[float, np.ndarray]:
        if self.power is None:
            j = int(np.argmax(t))
            w = np.zeros(self.k)
            w[j] = 1.0 / t[j]
            return float(np.log(t[j])), w
        # F = (1/p) log mean t^p; ∂F/∂t_k = softmax(p log t)_k / t_k.
        z = self.power * np.log(t)
        zmax = z.max()
        e = np.exp(z - zmax)
        F = float((zmax + np.log(e.sum() / self.k)) / self.power)
        return F, e / e.sum() / t
