"""Identifiability: which parameters position measurements can determine (SPEC §2).

The parameter Jacobian is stacked over many random configurations within the joint limits and its
columns normalised. The base set
is chosen greedily in a fixed order of preference — joint offsets, then the lengths (non-zero origin
components), then other translations, rotations, markers, base — keeping a parameter when its
column is not in the span of those kept before (QR, i.e. Gram–Schmidt, in that order); the
number kept is the numerical rank. Each
dropped parameter is reported either as *invisible* (its column is zero: nothing it does moves the
measured points) or as a *combination* of kept ones, with the coefficients.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from pincal.arguments import Seed, generator
from pincal.model.catalogue import LENGTH_TOLERANCE, split_spec
from pincal.model.jacobian import unit_columns

if TYPE_CHECKING:  # ParameterSet.identifiable() calls this module: parameters.py imports it
    from pincal.model.parameters import ParameterSet


@dataclass(frozen=True, eq=False)
class Identifiability:
    """The identifiability report of a parameter set.

    Attributes:
        params: the set examined.
        identifiable: the base set kept (a ParameterSet, canonical order).
        dropped: ``{name: reason}`` for each parameter not kept.
        combinations: ``{name: {kept name: coefficient}}`` for the redundant ones: the dropped
            column equals Σ coefficient × kept column (units: dropped unit / kept unit).
        rank: numerical rank of the stacked Jacobian (== len(identifiable)).
        singular_values: of the column-normalised stacked Jacobian, decreasing (how close to
            dependent the set is: the smallest ones belong to redundant combinations).
        n_configurations: random configurations used.
    """

    params: ParameterSet
    identifiable: ParameterSet
    dropped: dict[str, str]
    combinations: dict[str, dict[str, float]]
    rank: int
    singular_values: np.ndarray
    n_configurations: int

    def report(self) -> str:
        """A human-readable text report."""
        lines = [
            f"{len(self.params)} parameters, {self.rank} identifiable from position measurements "
            f"({self.n_configurations} random configurations):",
            "  identifiable: " + ", ".join(self.identifiable.names),
        ]
        if self.dropped:
            lines.append("  dropped:")
            lines += [f"    {name}: {reason}" for name, reason in self.dropped.items()]
        return "\n".join(lines)


def _preference(params: ParameterSet, prefer: frozenset[str] = frozenset()) -> list[int]:
    """Indices of ``params`` in the order the base set prefers them (names in ``prefer`` first)."""
    origins = params.robot.origins

    def rank(p) -> int:
        if p.name in prefer:
            return -1
        if p.kind == "offset":
            return 0
        if p.kind == "placement" and p.component < 3:
            length = abs(origins[p.index].origin.translation[p.component]) > LENGTH_TOLERANCE
            return 1 if length else 2
        if p.kind == "placement":
            return 3
        return 4 if p.kind == "marker" else 5

    return sorted(range(len(params)), key=lambda i: (rank(params.parameters[i]), i))


def identifiability(
    params: ParameterSet,
    n_configurations: int = 200,
    seed: Seed = 0,
    tol: float = 1e-6,
    prefer: str | Iterable[str] = (),
) -> Identifiability:
    """Identifiability report of ``params`` (see module doc).

    Args:
        params: the parameter set to examine.
        n_configurations: random configurations within the joint limits.
        seed: seed of the random configurations (same seed, same report).
        tol: a unit-normalised column whose distance to the span of the kept ones is below
            this is redundant (~1e-13 for exact dependencies, ≥ 1e-4 for weak but real
            independence). Columns below ZERO_COLUMN × the largest norm are invisible.
        prefer: names and/or groups kept before the default order (if in ``params``), e.g. ``"base"``
            when measurements are in the instrument's frame (the base is then identified and the
            chain parameters it makes redundant are dropped).
    """
    robot = params.robot
    qs = robot.random_configurations(n_configurations, generator(seed))
    J = params.jacobian(qs, frame="tip").reshape(-1, len(params))
    A, visible = unit_columns(J)
    singular_values = np.linalg.svd(A, compute_uv=False)

    kept: list[int] = []
    basis = np.zeros((A.shape[0], 0))
    preferred = frozenset(robot.parameters(prefer).names) if split_spec(prefer) else frozenset()
    for i in _preference(params, preferred):
        if not visible[i]:
            continue
        residual = A[:, i] - basis @ (basis.T @ A[:, i])
        residual -= basis @ (basis.T @ residual)  # re-orthogonalise once
        size = np.linalg.norm(residual)
        if size > tol:
            kept.append(i)
            basis = np.column_stack([basis, residual / size])
    kept.sort()
    names = params.names
    dropped: dict[str, str] = {}
    combinations: dict[str, dict[str, float]] = {}
    for i in range(len(params)):
        if i in kept:
            continue
        if not visible[i]:
            dropped[names[i]] = "invisible: it does not move the measured point(s) in any configuration"
            continue
        coef, *_ = np.linalg.lstsq(J[:, kept], J[:, i], rcond=None)
        big = np.abs(coef) > 1e-6 * max(np.abs(coef).max(), 1e-300)
        combo = {names[kept[k]]: float(round(coef[k], 9)) for k in np.flatnonzero(big)}
        combinations[names[i]] = combo
        terms = " ".join(f"{'+' if c >= 0 else '-'} {abs(c):.6g}·{n}" for n, c in combo.items())
        terms = terms[2:] if terms.startswith("+ ") else "-" + terms[2:]
        dropped[names[i]] = f"redundant: equals {terms}"
    return Identifiability(
        params=params,
        identifiable=replace(params, parameters=tuple(params.parameters[i] for i in kept)),
        dropped=dropped,
        combinations=combinations,
        rank=len(kept),
        singular_values=singular_values,
        n_configurations=n_configurations,
    )
