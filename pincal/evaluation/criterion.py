r"""What every criterion of a plan is (docs/method.md §6): the interface the searches use, one
object per criterion.

A criterion scores a plan of m configurations from the rows its measurements add to the
least-squares problem: the parameter Jacobian J (m, r, P) of the plan, r rows per configuration
(3 per marker today; 6 for a pose, 1 or 2 for a partial measurement), P parameters of any kind
(geometric, gains, compliance: only columns). Rows measured with a known covariance Σᵢ are
whitened before they reach a criterion (Jᵢ ← Lᵢ⁻¹Jᵢ, Σᵢ = LᵢLᵢᵀ), so the information matrix is
always M = Σ JᵢᵀJᵢ = Σ JᵢᵀΣᵢ⁻¹Jᵢ of the raw rows.

Each criterion is a :class:`Criterion` in a file of its own under ``pincal/evaluation/`` and has:

* ``value(M, m)`` — F, a smooth dimensionless transform of the criterion (its log, except for D
  which is a log already), so that one optimiser tolerance fits every criterion and scale;
  ``report(F)`` turns F back into the criterion in its own units (ρ0 in metres, ...);
* ``value_and_gradient(M, m)`` — F and ∂F/∂M (P×P, symmetric): the continuous search chains it
  through ∂M/∂q = Σ 2 Jᵢᵀ ∂Jᵢ/∂q (:meth:`Criterion.plan_gradient`, which a criterion that
  depends on more than M — a residual model's kernel — overrides);
* ``batch_values(Ms)`` — F for a stack of information matrices (random-plan baselines);
* ``exchange(J_pool, index)`` — the state the exchange search asks for the value after swapping
  one configuration of the plan for each candidate of a pool (:class:`ExchangeState`). An
  information criterion gets :class:`~pincal.evaluation.low_rank.InformationExchange`, which
  scores every swap by low-rank (Woodbury) algebra on the pool in the basis of the plan's
  Cholesky factor and calls the criterion's ``exchange_products`` / ``exchange_values`` for
  what is its own; a criterion whose swap is not
  an update of M (the residual model, whose kernel matrix gains a row and a column) returns a
  state of its own, and the search does not change.

With a prior (Λ = σ²Σp⁻¹, see :class:`~pincal.Prior`) every criterion is taken of the posterior
information M + Λ (the Bayesian criteria), finite for every plan.

To add a criterion: one file with a :class:`Criterion` subclass, and its name in
:mod:`pincal.evaluation.registry`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pincal.evaluation.information import RCOND, jacobi_scaled
from pincal.evaluation.low_rank import InformationExchange


@dataclass(frozen=True)
class PlanSlope:
    """F of a plan and its derivatives for the continuous search.

    Attributes:
        F: the criterion's value F.
        dM: (P, P) ∂F/∂M through the information matrix M = Σ JᵢᵀJᵢ (symmetric).
        dJ: (m, r, P) ∂F/∂Jᵢ other than through M, or None.
        dq: (m, nq) ∂F/∂q other than through the Jacobians (a kernel of the configurations), or None.
    """

    F: float
    dM: np.ndarray
    dJ: np.ndarray | None = None
    dq: np.ndarray | None = None


class ExchangeState(Protocol):
    """What the exchange search needs of a criterion: the value of a plan of pool configurations
    and the values after each candidate swap. Built by :meth:`Criterion.exchange`.

    Attributes:
        index: (m,) pool indices of the plan (updated in place by :meth:`swap`).
        F: the criterion's value F of the plan.
        M: (P, P) the plan's information matrix (the data's, without a prior).
    """

    index: np.ndarray
    F: float
    M: np.ndarray

    def scores(self, i: int, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(cand, values): the allowed candidates for which swapping configuration i out leaves a
        regular plan, and F after each such swap."""
        ...

    def swap(self, i: int, best: int) -> None:
        """Make the swap of configuration i for ``cand[best]`` of the last :meth:`scores`."""
        ...

    def resync(self) -> None:
        """Recompute the state exactly from the plan (bounds the rounding of the updates)."""
        ...


class Criterion:
    """A criterion of the posterior information M + Λ of a plan (see module doc).

    Args:
        rows: measured coordinates per configuration (r), for the messages of a singular plan.
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹ added to M, or None.

    Attributes:
        name: the criterion's canonical name (see :mod:`pincal.evaluation.registry`).
    """

    name: str = ""

    def __init__(self, rows: int, prior: np.ndarray | None = None) -> None:
        self.rows = rows
        self.prior = prior

    def posterior(self, M: np.ndarray) -> np.ndarray:
        """M + Λ for one or a stack of information matrices (M itself without a prior)."""
        return M if self.prior is None else M + self.prior

    # ------------------------------------------------------------------ the value
    def value(self, M: np.ndarray, m: int) -> float:
        """F(M) for a plan of m configurations. Raises SingularPlan."""
        raise NotImplementedError

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        """F(M) and ∂F/∂M (P×P, symmetric). Raises SingularPlan."""
        raise NotImplementedError

    def report(self, F: float | np.ndarray) -> float | np.ndarray:
        """The criterion in its own units for objective value(s) F."""
        raise NotImplementedError

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        """F for a stack (n, P, P) of information matrices; NaN where M is singular."""
        raise NotImplementedError

    label: str = ""
    """What the reported value is, for people (``"log det M⁻¹"``)."""

    def describe(self, value: float) -> str:
        """A reported value with its name and unit, for a progress line (``"ρ0 0.0203 mm"``)."""
        return f"{self.label or self.name} {value:.4g}"

    def with_power(self, power: float | None) -> Criterion:
        """The criterion the gradient search minimises at a smoothing stage ``power`` (a power
        mean standing for a maximum); itself for a criterion with nothing to smooth."""
        return self

    @property
    def smoothed(self) -> bool:
        """True if the gradient search minimises a smoothed stand-in (see :meth:`with_power`)."""
        return False

    # ----------------------------------------------------- the plan (continuous search)
    def plan_value(self, J: np.ndarray, qs: np.ndarray) -> float:
        """F of the plan with Jacobian rows J (m, r, P) at configurations qs. Raises SingularPlan."""
        flat = J.reshape(-1, J.shape[-1])
        return self.value(flat.T @ flat, len(J))

    def plan_gradient(self, J: np.ndarray, qs: np.ndarray) -> PlanSlope:
        """F and its derivatives (see :class:`PlanSlope`) for the plan J (m, r, P) at qs."""
        flat = J.reshape(-1, J.shape[-1])
        F, G = self.value_and_gradient(flat.T @ flat, len(J))
        return PlanSlope(F, G)

    # ------------------------------------------------------------- the exchange search
    def exchange(self, J_pool: np.ndarray, index: np.ndarray) -> ExchangeState:
        """The exchange state of the plan ``J_pool[index]`` (see :class:`ExchangeState`)."""
        return InformationExchange(self, J_pool, index)

    def exchange_products(self, Y: np.ndarray, Linv: np.ndarray, Q: np.ndarray) -> object:
        """What :meth:`exchange_values` needs of every pool candidate, from the pool in the basis of
        the plan's Cholesky factor (M + Λ = LLᵀ): Y = L⁻¹J_cᵀ (P, r, N), L⁻¹ (P, P) and Q = L_c⁻¹
        (r, r, N), X_c = I + Y_cᵀY_c = L_cL_cᵀ; recomputed after each accepted swap (None: nothing)."""
        return None

    def exchange_columns(self, products: object, yi: np.ndarray) -> np.ndarray | None:
        """(P, s) columns whose products with every Y_c a swap of configuration i needs
        (:attr:`~pincal.evaluation.low_rank.Swaps.projected`), from :meth:`exchange_products` and
        yᵢ = L⁻¹Jᵢᵀ (P, r); None: none."""
        return None

    def exchange_values(self, swap: object) -> tuple[np.ndarray, object]:
        """(values, aux) after each candidate swap ``swap.cand`` of a
        :class:`~pincal.evaluation.low_rank.Swaps`: F, and what the criterion would keep of each
        swapped plan (None: nothing)."""
        raise NotImplementedError

    def exchange_exact(self, M: np.ndarray, m: int) -> tuple[float, object]:
        """(F, aux) of the plan of information M, exactly (aux as in :meth:`exchange_values`)."""
        return self.value(M, m), None


def scaled_eigh(
    Ms: np.ndarray, vectors: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """Eigen-decomposition of the Jacobi-scaled stack D⁻¹MD⁻¹; returns (d, w, V, singular)
    (V is None without ``vectors``: eigenvalues only, cheaper)."""
    d, scaled = jacobi_scaled(Ms)
    w, V = np.linalg.eigh(scaled) if vectors else (np.linalg.eigvalsh(scaled), None)
    singular = w[:, 0] <= RCOND * np.maximum(w[:, -1], 1e-300)
    return d, w, V, singular


def singular_value_result(value: np.ndarray) -> float | np.ndarray:
    """A criterion from singular values: a float for one plan's (P,), the (k,) array for k plans'
    (k, P) (the ``from_singular_values`` of the criteria)."""
    return float(value) if np.ndim(value) == 0 else value
