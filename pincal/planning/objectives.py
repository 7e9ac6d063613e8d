r"""The criteria a design minimises, as functions of the information matrix M (docs/method.md §7.1).

One interface serves both search methods: an objective gives its value F(M) and the gradient
G = ∂F/∂M (symmetric P×P), and, for the exchange method, the value after a low-rank change of M
(see :mod:`pincal.planning.exchange`). F is a smooth, dimensionless transform of the criterion (its log,
except for D which is a log already), so that one optimiser tolerance fits every criterion and
scale; :meth:`Objective.report` turns F back into the criterion in its own units.

=====================  =========================================  ==============================
criterion              F(M)                                       reported value
=====================  =========================================  ==============================
``test-pose``          log mean_k tr(J0k M⁻¹ J0kᵀ)                ρ0 = σ·sqrt(exp F) [m]
``test-pose-worst``    log max_k tr(J0k M⁻¹ J0kᵀ)                 ρ0 at the worst test pose [m]
``D``                  −log det M                                 log det M⁻¹
``A``                  log tr M⁻¹                                 tr M⁻¹
``E``                  −log λ_min(M)                              λ_max(M⁻¹)
``cond``               ½ log(λ_max(M)/λ_min(M))                   σ_max(J)/σ_min(J)
=====================  =========================================  ==============================

The mean over several test poses (a path, a region) is one weighted trace tr(M⁻¹A), A = FFᵀ with
F from :func:`~pincal.evaluation.test_pose.mean_weight_factor` (at most P columns): the cost of an
evaluation does not grow with the number of test poses. With a prior (Λ = σ²Σp⁻¹, see
:class:`~pincal.Prior`) every criterion is taken of the posterior information M + Λ (the Bayesian
criteria: tr(J0(M + Λ)⁻¹J0ᵀ), −log det(M + Λ), ...), finite for every plan.

The reported values are those of :func:`pincal.rho0` and :func:`pincal.criteria` (``log_det``,
``trace``, ``max_eig``, ``cond``). For ``test-pose-worst`` the gradient-based search minimises the
power mean (mean_k t_k^p)^{1/p}, which tends to the maximum as p grows; the reported value is
always the true maximum.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dtrtrs as _trtrs

from pincal.arguments import DEFAULT_SIGMA
from pincal.errors import BadArgument, UnknownName
from pincal.evaluation.information import RCOND, factor, jacobi_scaled
from pincal.evaluation.region import resolve_test_poses
from pincal.evaluation.test_pose import mean_weight_factor
from pincal.model.parameters import ParameterSet

CRITERIA = ("test-pose", "test-pose-worst", "D", "A", "E", "cond")
"""Names of the criteria a design can minimise."""

_ALIASES = {
    "test-pose": "test-pose",
    "testpose": "test-pose",
    "rho0": "test-pose",
    "test-pose-mean": "test-pose",
    "test-pose-worst": "test-pose-worst",
    "worst": "test-pose-worst",
    "d": "D",
    "log_det": "D",
    "logdet": "D",
    "a": "A",
    "trace": "A",
    "e": "E",
    "max_eig": "E",
    "cond": "cond",
}

TEST_POSE_CRITERIA = ("test-pose", "test-pose-worst")
"""The criteria that need a test pose."""


def checked_test_poses(params: ParameterSet, test_pose: object, criterion: str) -> np.ndarray | None:
    """The (k, nq) test poses of a design (a region's or path's sample configurations), checked
    against the robot; None if none is given and the criterion needs none.

    Raises:
        PincalError: the criterion needs a test pose and none is given.
        BadConfiguration: a test pose of the wrong shape or outside the joint limits.
    """
    if test_pose is None:
        if criterion in TEST_POSE_CRITERIA:
            raise BadArgument(f"criterion {criterion!r} needs a test pose (test_pose=...)")
        return None
    return resolve_test_poses(params.robot, test_pose)[0]


def criterion_name(name: str) -> str:
    """The canonical name of a criterion (case and ``_``/``-`` insensitive).

    Raises:
        UnknownName: the name is not a criterion; the message lists the valid ones.
    """
    key = str(name).strip().lower().replace("_", "-")
    key = {"log-det": "log_det", "max-eig": "max_eig"}.get(key, key)
    if key not in _ALIASES:
        raise UnknownName("criterion", str(name), CRITERIA)
    return _ALIASES[key]


class Objective:
    """A criterion as a function of the information matrix M = Σ JᵢᵀJᵢ.

    Attributes:
        name: the criterion's canonical name (one of :data:`CRITERIA`).
        family: ``"trace"`` (weighted traces of M⁻¹), ``"logdet"`` or ``"spectral"``; the
            exchange method updates each family its own way.
        rows: measured coordinates per configuration (3 per marker), for error messages.
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹ added to M, or None.
    """

    name: str
    family: str
    prior: np.ndarray | None = None

    def __init__(self, rows: int, prior: np.ndarray | None = None) -> None:
        self.rows = rows
        self.prior = prior

    def posterior(self, M: np.ndarray) -> np.ndarray:
        """M + Λ for one or a stack of information matrices (M itself without a prior)."""
        return M if self.prior is None else M + self.prior

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


def _scaled_eigh(
    Ms: np.ndarray, vectors: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """Eigen-decomposition of the Jacobi-scaled stack D⁻¹MD⁻¹; returns (d, w, V, singular)
    (V is None without ``vectors``: eigenvalues only, cheaper)."""
    d, scaled = jacobi_scaled(Ms)
    w, V = np.linalg.eigh(scaled) if vectors else (np.linalg.eigvalsh(scaled), None)
    singular = w[:, 0] <= RCOND * np.maximum(w[:, -1], 1e-300)
    return d, w, V, singular


class TraceObjective(Objective):
    """Weighted traces t_k = tr(Wk M⁻¹), Wk = J0kᵀJ0k, aggregated over k (test-pose and A).

    Args:
        name: ``"test-pose"``, ``"test-pose-worst"`` or ``"A"``.
        J0T: (P, R) the transposed weights' factors stacked over k groups of R/k columns (the test
            poses' tip-frame Jacobians; the identity for A).
        groups: k.
        scale: σ for the test-pose criteria (ρ0 = σ·sqrt(t)); 1 for A.
        rows: measured coordinates per configuration.
        power: for ``test-pose-worst`` in the gradient search, the power p of the mean that
            stands for the maximum (None: the exact maximum).
    """

    family = "trace"

    def __init__(
        self,
        name: str,
        J0T: np.ndarray,
        groups: int,
        scale: float,
        rows: int,
        power: float | None = None,
        prior: np.ndarray | None = None,
    ) -> None:
        super().__init__(rows, prior)
        self.name = name
        self.J0T = np.ascontiguousarray(J0T)
        self.k = groups
        self.scale = scale
        self.worst = name == "test-pose-worst"
        self.power = power if self.worst else None

    def with_power(self, power: float | None) -> TraceObjective:
        """The same objective with another power-mean exponent (test-pose-worst only)."""
        return TraceObjective(self.name, self.J0T, self.k, self.scale, self.rows, power, self.prior)

    def _solve(self, M: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
        L = factor(self.posterior(M), self.rows, m)
        X, _ = _trtrs(L, self.J0T, lower=1)
        return L, X

    def traces(self, M: np.ndarray, m: int) -> np.ndarray:
        """(k,) t_k = tr(J0k M⁻¹ J0kᵀ)."""
        _, X = self._solve(M, m)
        return np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)

    def from_traces(self, t: np.ndarray) -> np.ndarray:
        """F from traces (..., k) (exact maximum for the worst case, whatever ``power``)."""
        t = np.asarray(t)
        agg = t.max(axis=-1) if self.worst else t.mean(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(agg > 0, np.log(np.where(agg > 0, agg, 1.0)), np.inf)

    def value(self, M: np.ndarray, m: int) -> float:
        return float(self.from_traces(self.traces(M, m)))

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        L, X = self._solve(M, m)
        Y, _ = _trtrs(L, X, lower=1, trans=1)  # M⁻¹ J0ᵀ
        t = np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)
        if not self.worst:
            F = float(np.log(t.mean()))
            w = np.full(self.k, 1.0 / t.sum())
        elif self.power is None:
            j = int(np.argmax(t))
            F = float(np.log(t[j]))
            w = np.zeros(self.k)
            w[j] = 1.0 / t[j]
        else:
            # F = (1/p) log mean t^p; ∂F/∂t_k = softmax(p log t)_k / t_k.
            z = self.power * np.log(t)
            zmax = z.max()
            e = np.exp(z - zmax)
            F = float((zmax + np.log(e.sum() / self.k)) / self.power)
            w = e / e.sum() / t
        cols = np.repeat(w, Y.shape[1] // self.k)
        return F, -(Y * cols) @ Y.T

    def report(self, F):
        return self.scale * np.sqrt(np.exp(F)) if self.name != "A" else np.exp(F)

    def batch_traces(self, Ms: np.ndarray) -> np.ndarray:
        """(n, k) traces for a stack of information matrices; NaN rows where M is singular."""
        d, w, V, singular = _scaled_eigh(self.posterior(Ms))
        w = np.where(singular[:, None], 1.0, w)
        X = np.swapaxes(V, 1, 2) @ (self.J0T[None] / d[:, :, None])
        X /= np.sqrt(np.abs(w))[:, :, None]
        t = np.einsum("npr,npr->nr", X, X).reshape(len(Ms), self.k, -1).sum(axis=2)
        t[singular] = np.nan
        return t

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        t = self.batch_traces(Ms)
        out = np.full(len(Ms), np.nan)
        ok = ~np.isnan(t[:, 0])
        out[ok] = self.from_traces(t[ok])
        return out


class LogDetObjective(Objective):
    """D-optimality: F = −log det M = log det M⁻¹."""

    family = "logdet"
    name = "D"

    def value(self, M: np.ndarray, m: int) -> float:
        L = factor(self.posterior(M), self.rows, m)
        return float(-2.0 * np.log(L.diagonal()).sum())

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        L = factor(self.posterior(M), self.rows, m)
        Linv, _ = _trtrs(L, np.eye(len(M)), lower=1)
        return float(-2.0 * np.log(L.diagonal()).sum()), -(Linv.T @ Linv)

    def report(self, F):
        return F

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        d, w, _, singular = _scaled_eigh(self.posterior(Ms), vectors=False)
        F = -(2.0 * np.log(d).sum(axis=1) + np.log(np.where(singular[:, None], 1.0, w)).sum(axis=1))
        F[singular] = np.nan
        return F


class SpectralObjective(Objective):
    """E (F = −log λ_min) or cond (F = ½ log(λ_max/λ_min)) of M."""

    family = "spectral"

    def __init__(self, name: str, rows: int, prior: np.ndarray | None = None) -> None:
        super().__init__(rows, prior)
        self.name = name

    def from_eigenvalues(self, w: np.ndarray) -> np.ndarray:
        """F from ascending eigenvalues (..., P) of M (inf where λ_min ≤ 0)."""
        w = np.asarray(w)
        lo = w[..., 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.log(np.where(lo > 0, lo, 1.0))
            F = -logs if self.name == "E" else 0.5 * (np.log(np.abs(w[..., -1]) + 1e-300) - logs)
        return np.where(lo > RCOND * np.abs(w[..., -1]), F, np.inf)

    def value(self, M: np.ndarray, m: int) -> float:
        M = self.posterior(M)
        factor(M, self.rows, m)
        return float(self.from_eigenvalues(np.linalg.eigvalsh(M)))

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        M = self.posterior(M)
        factor(M, self.rows, m)
        w, V = np.linalg.eigh(M)
        lo, hi = V[:, 0], V[:, -1]
        G = -np.outer(lo, lo) / w[0]
        if self.name == "cond":
            G = 0.5 * (G + np.outer(hi, hi) / w[-1])
        return float(self.from_eigenvalues(w)), G

    def report(self, F):
        return np.exp(F)

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        Ms = self.posterior(Ms)
        *_, singular = _scaled_eigh(Ms, vectors=False)
        F = self.from_eigenvalues(np.linalg.eigvalsh(Ms))
        F[singular] = np.nan
        return F


def make_objective(
    criterion: str,
    n_params: int,
    rows: int,
    J0: np.ndarray | None = None,
    sigma: float = DEFAULT_SIGMA,
    prior: np.ndarray | None = None,
) -> Objective:
    """The objective of a criterion.

    Args:
        criterion: a canonical name (see :func:`criterion_name`).
        n_params: P.
        rows: measured coordinates per configuration.
        J0: (k, 3K, P) tip-frame Jacobians at the test poses (the test-pose criteria need them).
        sigma: measurement noise per coordinate [m] (scales the reported ρ0).
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹ (:meth:`pincal.Prior.information`), or None.
    """
    if criterion in TEST_POSE_CRITERIA:
        if J0 is None:
            raise BadArgument(f"criterion {criterion!r} needs a test pose")
        if criterion == "test-pose":  # the mean: one weighted trace, whatever the number of poses
            return TraceObjective(criterion, mean_weight_factor(J0), 1, sigma, rows, prior=prior)
        return TraceObjective(criterion, J0.reshape(-1, n_params).T, len(J0), sigma, rows, prior=prior)
    if criterion == "A":
        return TraceObjective("A", np.eye(n_params), 1, 1.0, rows, prior=prior)
    if criterion == "D":
        return LogDetObjective(rows, prior)
    return SpectralObjective(criterion, rows, prior)
