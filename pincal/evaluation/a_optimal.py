r"""A-optimality: F = log tr (M + Λ)⁻¹, the log of the summed variances of the parameters (it mixes
units when they mix lengths and angles). A weighted trace with the identity for weight (see
:mod:`pincal.evaluation.weighted_trace`)."""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import singular_value_result
from pincal.evaluation.weighted_trace import WeightedTrace


class AOptimal(WeightedTrace):
    """A-optimality (see module doc); reported as tr (M + Λ)⁻¹.

    Args:
        n_params: P.
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ, or None.
    """

    name = "A"
    label = "tr M⁻¹"

    def __init__(self, n_params: int, rows: int, prior: np.ndarray | None = None) -> None:
        super().__init__(np.eye(n_params), 1, 1.0, rows, prior)

    def aggregate(self, t: np.ndarray) -> np.ndarray:
        return t.mean(axis=-1)

    def gradient_weights(self, t: np.ndarray) -> tuple[float, np.ndarray]:
        return float(np.log(t.mean())), np.full(self.k, 1.0 / t.sum())

    def report(self, F):
        return np.exp(F)

    def describe(self, value: float) -> str:
        return f"{self.label} {value:.4g}"

    def from_singular_values(self, s: np.ndarray) -> float | np.ndarray:
        """tr M⁻¹ from the singular values of the stacked Jacobian (no prior): a float, or (k,)
        for the singular values (k, P) of k plans."""
        return singular_value_result(np.sum(1.0 / s**2, axis=-1))
