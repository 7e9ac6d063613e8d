"""Identifiability: which parameters position measurements can determine (docs/method.md §4).

The parameter Jacobian is stacked over many random configurations within the joint limits and its
columns normalised. The base set
is chosen greedily in a fixed order of preference — joint offsets, then the lengths (non-zero origin
components), then other translations, rotations, markers, base — keeping a parameter when its
column is not in the span of those kept before (QR, i.e. Gram–Schmidt, in that order); the
number kept is the numerical rank. Each
dropped parameter is reported as *invisible* (its column is zero: nothing it does moves the
measured points), as *redundant* (an exact combination of kept ones, with the coefficients), or
as *nearly redundant*: within ``tol`` (default 1e-2, scale-free: the sine of the angle between
its unit column and the span of the kept ones) of such a combination. Near dependences come from
vendor URDFs whose angles are rounded (1.5708 for π/2: the axes are then parallel to ~4e-6; 3.14
for π: to 1.6e-3) and from nearly parallel axes; identifying such a parameter would cost
1/distance times its own precision, so it is left to the kept ones, which absorb it.
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


REDUNDANT = 1e-8
"""A unit column closer than this to the span of others is an exact combination of them: what
is left is the Jacobian's rounding noise (1e-12..1e-10 on the shipped and example-robot-data
arms)."""

NEARLY_REDUNDANT = 1e-2
"""A unit column closer than this to the span of others is *nearly* redundant: identifying its
parameter would cost 1/distance (over 100) times its own precision. Measured on the default (or
longest) chain of every listed robot, 200 random configurations (benchmarks/RESULTS.md): the
nearest independent parameter sits at 2.1e-2 (alexander) and above; below come rounded angles
(a URDF rounded to 4 digits, 1.5708 for π/2, leaves ~1e-6..1e-4) and nearly parallel axes. A
smaller tolerance also lets the greedy order pick an ill-conditioned base: tiago_pro writes 3.14
for π, so arm_left_7_joint.tz is 0.9999·arm_left_6_joint.ty + 0.0016·arm_left_6_joint.tx; at
1e-3 it was kept (1.4e-3 from the span before it) and arm_left_6_joint.tx was left out as
"-627·(...)", a base no plan conditions above 5e-7; at 1e-2, arm_left_7_joint.tz is the one left
out, as exactly redundant. The square, 1e-4, is 100 times the conditioning the identification
asks of the data (:data:`pincal.evaluation.data_check.MIN_DATA_CONDITIONING`): a parameter kept
here can be separated by a designed plan."""


def independent_columns(A: np.ndarray, order: list[int], tol: float = NEARLY_REDUNDANT):
    """Greedy base set of the unit columns of ``A`` (rows, P), taken in ``order``.

    A column is kept when its distance to the span of the columns kept before it exceeds ``tol``
    (Gram–Schmidt, re-orthogonalised once: QR with a fixed pivoting order). Zero columns are
    never kept.

    Returns:
        (kept, distance): the kept indices, sorted; and for every column its distance to the span
        of the *other* kept columns (kept ones: at their turn; dropped ones: to all kept ones),
        the sine of its angle to that span, 0 for a zero column.
    """
    distance = np.zeros(A.shape[1])
    kept: list[int] = []
    basis = np.zeros((A.shape[0], 0))
    for i in order:
        residual = A[:, i] - basis @ (basis.T @ A[:, i])
        residual -= basis @ (basis.T @ residual)
        size = float(np.linalg.norm(residual))
        distance[i] = size
        if size > tol:
            kept.append(i)
            basis = np.column_stack([basis, residual / size])
    for i in set(order) - set(kept):
        residual = A[:, i] - basis @ (basis.T @ A[:, i])
        residual -= basis @ (basis.T @ residual)
        distance[i] = float(np.linalg.norm(residual))
    return sorted(kept), distance


@dataclass(frozen=True, eq=False)
class Identifiability:
    """The identifiability report of a parameter set.

    Attributes:
        params: the set examined.
        identifiable: the base set kept (a ParameterSet, canonical order).
        dropped: ``{name: reason}`` for each parameter not kept.
        combinations: ``{name: {kept name: coefficient}}`` for the redundant and nearly
            redundant ones: the dropped column equals (or nearly equals) Σ coefficient × kept
            column (units: dropped unit / kept unit).
        nearly_redundant: ``{name: distance}`` for the nearly redundant ones: the sine of the angle
            between the parameter's column and the span of the identifiable ones (0 would be an
            exact combination).
        rank: numerical rank of the stacked Jacobian (== len(identifiable)).
        singular_values: of the column-normalised stacked Jacobian, decreasing (how close to
            dependent the set is: the smallest ones belong to redundant combinations).
        n_configurations: random configurations used.
    """

    params: ParameterSet
    identifiable: ParameterSet
    dropped: dict[str, str]
    combinations: dict[str, dict[str, float]]
    nearly_redundant: dict[str, float]
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


def preference_order(params: ParameterSet, prefer: frozenset[str] = frozenset()) -> list[int]:
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

    def key(i: int) -> tuple:
        p = params.parameters[i]
        r = rank(p)
        if r != 1:
            return (r, i, 0.0)
        # Among the lengths of one origin, the longest first: for a link nearly along z between
        # parallel axes (x = 5 mm, z = 290 mm), x is nearly the previous joints' offsets.
        return (r, p.index, -abs(origins[p.index].origin.translation[p.component]))

    return sorted(range(len(params)), key=key)


def identifiability(
    params: ParameterSet,
    n_configurations: int = 200,
    seed: Seed = 0,
    tol: float = NEARLY_REDUNDANT,
    prefer: str | Iterable[str] = (),
) -> Identifiability:
    """Identifiability report of ``params`` (see module doc).

    Args:
        params: the parameter set to examine.
        n_configurations: random configurations within the joint limits.
        seed: seed of the random configurations (same seed, same report).
        tol: a unit-normalised column whose distance to the span of the kept ones is below
            this is dropped: redundant below 1e-8 (exact dependences leave ~1e-12), nearly
            redundant above (see module doc). Columns below ZERO_COLUMN × the largest norm are
            invisible.
        prefer: names and/or groups kept before the default order (if in ``params``), e.g. ``"base"``
            when measurements are in the instrument's frame (the base is then identified and the
            chain parameters it makes redundant are dropped).
    """
    robot = params.robot
    qs = robot.random_configurations(n_configurations, generator(seed))
    J = params.jacobian(qs, frame="tip").reshape(-1, len(params))
    A, visible = unit_columns(J)
    singular_values = np.linalg.svd(A, compute_uv=False)

    preferred = frozenset(robot.parameters(prefer).names) if split_spec(prefer) else frozenset()
    order = [i for i in preference_order(params, preferred) if visible[i]]
    kept, distance = independent_columns(A, order, tol)
    names = params.names
    dropped: dict[str, str] = {}
    combinations: dict[str, dict[str, float]] = {}
    nearly: dict[str, float] = {}
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
        if distance[i] < REDUNDANT:
            dropped[names[i]] = f"redundant: equals {terms}"
        else:
            nearly[names[i]] = float(distance[i])
            dropped[names[i]] = (
                f"nearly redundant: equals {terms} to within {distance[i]:.2g} (sine of the angle "
                f"between its column and theirs; rounded angles in the URDF, e.g. 1.5708 for pi/2, "
                f"or nearly parallel axes): left to them"
            )
    return Identifiability(
        params=params,
        identifiable=replace(params, parameters=tuple(params.parameters[i] for i in kept)),
        dropped=dropped,
        combinations=combinations,
        nearly_redundant=nearly,
        rank=len(kept),
        singular_values=singular_values,
        n_configurations=n_configurations,
    )
