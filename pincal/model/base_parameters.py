"""Identifiability: which parameters position measurements can determine (docs/method.md §4).

The parameter Jacobian is stacked over many random configurations within the joint limits and its
columns normalised. The base set
is chosen greedily in a fixed order of preference — the base placement first (when the set holds it,
the data are in the instrument's frame and the robot's placement in it must be found: the chain
parameters it makes redundant give way to it, docs/method.md §4.2), then joint offsets, the lengths
(non-zero origin components), other translations, rotations, markers — keeping a parameter when its
column is not in the span of those kept before (QR, i.e. Gram–Schmidt, in that order); the
number kept is the numerical rank. Each
dropped parameter is reported as *invisible* (its column is zero: nothing it does moves the
measured points), as *redundant* (an exact combination of kept ones, with the coefficients), or
as *nearly redundant*: within ``tol`` (default 1e-2, scale-free: the sine of the angle between
its unit column and the span of the kept ones) of such a combination. Near dependences come from
vendor URDFs whose angles are rounded (1.5708 for π/2: the axes are then parallel to ~4e-6; 3.14
for π: to 1.6e-3) and from nearly parallel axes; identifying such a parameter would cost
1/distance times its own precision, so it is left to the kept ones, which absorb it.

Joint gains and compliances come last in that order. A gain separates from its joint's offset
only because the joint's value varies; a compliance moves the point like the offset scaled by the
joint's gravity torque τ_j, so it is invisible where τ_j ≡ 0 (a vertical first axis; a joint whose
load is balanced about its axis), redundant with the offset where τ_j barely varies, and, through
the arm's own weight, correlated with the lengths of the links that weigh on it. A change of payload
breaks that correlation: the report gives each compliance's *separation* (the sine of its
column's angle to the span of the parameters kept before it) under the arm's weight alone and, when
payloads are given, with a payload drawn for each configuration.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from pincal.arguments import fraction, generator, positive_int
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument
from pincal.model.catalogue import LENGTH_TOLERANCE, split_spec
from pincal.model.jacobian import unit_columns
from pincal.model.statics import payload_rows
from pincal.typing import PayloadLike, SeedLike

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
        separation: ``{name: sine}`` for each visible compliance: the sine of the angle between
            its column and the span of the parameters kept before it, under the arm's own weight
            alone (no payload); near 0, it cannot be told from them.
        separation_with_payloads: the same with the payloads given (one drawn per
            configuration), or None when none were given.
        measured: what the measurements are (``position``, ``pose``, ...), for the report.
    """

    params: ParameterSet
    identifiable: ParameterSet
    dropped: dict[str, str]
    combinations: dict[str, dict[str, float]]
    nearly_redundant: dict[str, float]
    rank: int
    singular_values: np.ndarray
    n_configurations: int
    separation: dict[str, float] = field(default_factory=dict)
    separation_with_payloads: dict[str, float] | None = None
    measured: str = "position"

    def report(self) -> str:
        """A human-readable text report."""
        lines = [
            f"{len(self.params)} parameters, {self.rank} identifiable from {self.measured} measurements "
            f"({self.n_configurations} random configurations):",
            "  identifiable: " + ", ".join(self.identifiable.names),
        ]
        if self.dropped:
            lines.append("  dropped:")
            lines += [f"    {name}: {reason}" for name, reason in self.dropped.items()]
        if self.separation:
            lines.append(
                "  compliance separation (sine of the angle to the parameters kept before it; near 0: "
                "it cannot be told from them):"
            )
            with_payloads = self.separation_with_payloads or {}
            for name, value in self.separation.items():
                loaded = (
                    f", {with_payloads[name]:.2g} with the payloads given" if name in with_payloads else ""
                )
                lines.append(f"    {name}: {value:.2g} under the arm's own weight{loaded}")
            if self.separation_with_payloads is None:
                lines.append(
                    "    a payload change breaks the correlation of compliance with the link lengths: "
                    "give the payloads you can mount (--payloads 0,50,100; payloads=[0, 50, 100] in Python) "
                    "to see by how much"
                )
        return "\n".join(lines)


def preference_order(params: ParameterSet, prefer: frozenset[str] = frozenset()) -> list[int]:
    """Indices of ``params`` in the order the base set prefers them (names in ``prefer`` first)."""
    origins = params.robot.origins

    def rank(p) -> int:
        if p.name in prefer or p.kind == "base":
            return -1
        if p.kind == "offset":
            return 0
        if p.kind == "placement" and p.component < 3:
            length = abs(origins[p.index].origin.translation[p.component]) > LENGTH_TOLERANCE
            return 1 if length else 2
        if p.kind == "placement":
            return 3
        return {"marker": 4, "fixture": 5, "gain": 6}.get(p.kind, 7)

    def key(i: int) -> tuple:
        p = params.parameters[i]
        r = rank(p)
        if r != 1:
            return (r, i, 0.0)
        # Among the lengths of one origin, the longest first: for a link nearly along z between
        # parallel axes (x = 5 mm, z = 290 mm), x is nearly the previous joints' offsets.
        return (r, p.index, -abs(origins[p.index].origin.translation[p.component]))

    return sorted(range(len(params)), key=key)


@keywords_after(1)
def identifiability(
    params: ParameterSet,
    *,
    n_configurations: int = 200,
    seed: SeedLike = 0,
    tol: float = NEARLY_REDUNDANT,
    prefer: str | Iterable[str] = (),
    payloads: Sequence[PayloadLike] | None = None,
    rows: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
    measured: str = "position",
    configurations: np.ndarray | None = None,
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
        payloads: the payloads the experiment can mount (masses [kg] or
            :class:`~pincal.model.statics.Payload`), one drawn at random for each configuration:
            the report then also gives each compliance's separation with them. Without, the
            arm's own weight alone loads the joints.
        rows: ``rows(qs, payloads)`` the (m, r, P) Jacobian of what is measured at configurations
            qs, whitened (:mod:`pincal.instruments`); default the markers' positions.
        measured: what ``rows`` measure, in words, for the report.
        configurations: (n, nq) the configurations to use instead of random ones (where an
            instrument sees what it measures); ``n_configurations`` is then ignored.
    """
    robot = params.robot
    n_configurations = positive_int(n_configurations, "n_configurations")
    tol = fraction(tol, "tol")
    rng = generator(seed)
    qs = robot.random_configurations(n_configurations, rng) if configurations is None else configurations
    n_configurations = len(qs)
    loads = _drawn_payloads(payloads, n_configurations, rng)
    rows = rows or _positions(params)
    J = rows(qs, loads).reshape(-1, len(params))
    A, visible = unit_columns(J)
    singular_values = np.linalg.svd(A, compute_uv=False)

    preferred = frozenset(robot.parameters(prefer).names) if split_spec(prefer) else frozenset()
    order = [i for i in preference_order(params, preferred) if visible[i]]
    kept, distance = independent_columns(A, order, tol)
    compliant = [i for i, p in enumerate(params.parameters) if p.kind == "compliance"]
    torques = robot.joint_torques(qs, payload=loads, check=False) if compliant else np.zeros((0, robot.nq))
    dropped, combinations, nearly = _why_dropped(params, J, kept, visible, distance, compliant, torques)
    separation, with_payloads = {}, None
    if compliant:
        kept_order = [i for i in order if i in kept or i in compliant]
        separation = _separation(params, rows(qs, None), kept_order, compliant, visible, tol)
        if payloads is not None:
            with_payloads = _separation(params, rows(qs, loads), kept_order, compliant, visible, tol)
    return Identifiability(
        params=params,
        identifiable=replace(params, parameters=tuple(params.parameters[i] for i in kept)),
        dropped=dropped,
        combinations=combinations,
        nearly_redundant=nearly,
        rank=len(kept),
        singular_values=singular_values,
        n_configurations=n_configurations,
        separation=separation,
        separation_with_payloads=with_payloads,
        measured=measured,
    )


def _why_dropped(
    params: ParameterSet,
    J: np.ndarray,
    kept: list[int],
    visible: np.ndarray,
    distance: np.ndarray,
    compliant: list[int],
    torques: np.ndarray,
) -> tuple[dict[str, str], dict[str, dict[str, float]], dict[str, float]]:
    """(why each column not kept is dropped, the combination of kept columns each redundant one
    equals, each nearly redundant one's distance) of :func:`identifiability`."""
    names = params.names
    dropped: dict[str, str] = {}
    combinations: dict[str, dict[str, float]] = {}
    nearly: dict[str, float] = {}
    # every dropped visible column against the kept ones: one least-squares solve for them all
    # (one a column cost minutes on a chain of hundreds of joints)
    kept_set = set(kept)
    redundant = [i for i in range(len(params)) if i not in kept_set and visible[i]]
    solved = np.linalg.lstsq(J[:, kept], J[:, redundant], rcond=None)[0] if redundant else None
    coefficients = {i: solved[:, k] for k, i in enumerate(redundant)} if solved is not None else {}
    for i in range(len(params)):
        if i in kept_set:
            continue
        if not visible[i]:
            dropped[names[i]] = (
                _unloaded(params.parameters[i].index, torques)
                if i in compliant
                else "invisible: it does not move the measured point(s) in any configuration"
            )
            continue
        coef = coefficients[i]
        big = np.abs(coef) > 1e-6 * max(np.abs(coef).max(), 1e-300)
        combo = {names[kept[k]]: float(round(coef[k], 9)) for k in np.flatnonzero(big)}
        combinations[names[i]] = combo
        terms = " ".join(f"{'+' if c >= 0 else '-'} {abs(c):.6g}·{n}" for n, c in combo.items())
        terms = terms[2:] if terms.startswith("+ ") else "-" + terms[2:]
        why = _torque_range(params.parameters[i], torques) if i in compliant else ""
        if distance[i] < REDUNDANT:
            dropped[names[i]] = f"redundant: equals {terms}{why}"
        elif why:
            nearly[names[i]] = float(distance[i])
            dropped[names[i]] = f"nearly redundant: equals {terms} to within {distance[i]:.2g}{why}"
        else:
            nearly[names[i]] = float(distance[i])
            dropped[names[i]] = (
                f"nearly redundant: equals {terms} to within {distance[i]:.2g} (sine of the angle "
                f"between its column and theirs; rounded angles in the URDF, e.g. 1.5708 for pi/2, "
                f"or nearly parallel axes): left to them"
            )
    return dropped, combinations, nearly


def _positions(params: ParameterSet) -> Callable[[np.ndarray, np.ndarray | None], np.ndarray]:
    """The rows of the markers' positions (in the tip frame) as a ``rows`` function."""

    def rows(qs: np.ndarray, loads: np.ndarray | None) -> np.ndarray:
        return params.jacobian(qs, frame="tip", payload=loads)

    return rows


def _drawn_payloads(
    payloads: Sequence[PayloadLike] | None, n: int, rng: np.random.Generator
) -> np.ndarray | None:
    """(n, 4) payload rows drawn from ``payloads`` (one per configuration), or None."""
    if payloads is None:
        return None
    rows = np.array([payload_rows(p, 1)[0] for p in payloads]).reshape(-1, 4)
    if not len(rows):
        raise BadArgument(
            "payloads: give at least one payload (a mass [kg] or a Payload)", argument="payloads"
        )
    return rows[rng.integers(len(rows), size=n)]


def _separation(
    params: ParameterSet,
    J: np.ndarray,
    order: list[int],
    compliant: list[int],
    visible: np.ndarray,
    tol: float,
) -> dict[str, float]:
    """Each visible compliance's distance (sine) to the span of the parameters kept before it, in
    the rows J (m, r, P)."""
    A, shown = unit_columns(J.reshape(-1, len(params)))
    _, distance = independent_columns(A, [i for i in order if shown[i] and visible[i]], tol)
    return {params.names[i]: float(distance[i]) for i in compliant if shown[i] and visible[i]}


def _unloaded(joint: int, torques: np.ndarray) -> str:
    """Why a compliance is invisible: its joint never carries a gravity torque (or hides the point)."""
    largest = float(np.abs(torques[:, joint]).max(initial=0.0))
    if largest <= 1e-9 * max(float(np.abs(torques).max(initial=0.0)), 1e-300):
        return (
            "invisible: gravity applies no torque on this joint in any configuration (its axis is "
            "vertical, or what it carries is balanced about its axis), so it never deflects"
        )
    return "invisible: it does not move the measured point(s) in any configuration"


def _torque_range(parameter, torques: np.ndarray) -> str:
    """How little a joint's gravity torque varies, said after a compliance found (nearly) redundant."""
    lo, hi = float(torques[:, parameter.index].min()), float(torques[:, parameter.index].max())
    unit = "N·m" if parameter.unit == "rad/(N·m)" else "N"
    varies = (
        f"is the same, {lo:.4g} {unit}, in every configuration"
        if hi - lo <= 1e-9 * max(abs(lo), abs(hi))
        else f"only ranges over [{lo:.4g}, {hi:.4g}] {unit} in these configurations"
    )
    return (
        f"; its gravity torque {varies}, so it moves the point as they do: a payload change, or "
        f"configurations that load the joint differently, separate it"
    )
