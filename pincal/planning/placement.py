"""Where to put the instrument, chosen with the plan (docs/method.md §13.4).

A laser tracker's transverse error grows with the distance and depends on the direction of its
beam, and what it can see depends on where it stands; a camera fixed in the cell sees the target
only from some places. :func:`place_instrument` searches a box of positions for the instrument
together with the plan: at each position of a grid over the box (and then at the neighbours of the
best one, half a step away) it designs the plan with the instrument there, under the constraints
that position brings —

* a tracker: every marker within its range and, the reflector's normal given, within its
  acceptance angle (:class:`~pincal.planning.constraints.Visibility`), and nothing of the robot on
  the line of sight (:class:`~pincal.planning.constraints.LineOfSight`, when the URDF has
  collision geometry);
* a camera fixed in the cell (eye-to-hand): it looks at the target where the test pose holds it,
  and a configuration counts only the target points it sees in its image (its field of view);

— and keeps the position whose plan is best. A whole design at every position is slow (the
continuous polish with the line of sight takes seconds to a minute of CPU, and a design alone runs
batches of starts until they agree: up to 128 starts, two polishes every 8), so the positions are
screened first: one pool of candidate configurations is drawn for the whole box, and at each
position a quick design (:data:`SCREEN_STARTS` exchange starts, no polish) picks the plan among the
candidates that position sees; only the best ``screen`` positions of the screen (:data:`SCREEN`)
are designed in full, each as one batch of :data:`FINAL_STARTS` exchange starts with its best
quarter polished for at most :data:`FINAL_MAXITER` iterations. ``screen=None`` designs every
position in full with the design's own defaults (the exhaustive search, ``--place-screen all``).
The criterion of every position tried is kept: the map of the predicted error at the test region
against the instrument's position (:func:`pincal.viewing.plots.placement_map`). A default
placement (the box's centre unless given) is designed as the finalists are, so the gain of placing
the instrument is a measured factor.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pinocchio as pin

from pincal.arguments import positive_int, seed_entropy
from pincal.deprecation import moved_keywords
from pincal.errors import BadArgument, BadConstraint, DegenerateOptimum, Infeasible, SingularPlan, warn
from pincal.evaluation.region import resolve_test_poses
from pincal.instruments.error_model import Tracker
from pincal.instruments.given import OLD_FORM
from pincal.instruments.image import Image
from pincal.instruments.instrument import Instrument
from pincal.instruments.kind import Kind
from pincal.model.parameters import ParameterSet
from pincal.planning.constraints import AnyConstraint, LineOfSight, Visibility
from pincal.planning.driver import design
from pincal.planning.placement_grid import MAX_POSITIONS, _box, _grid, _grid_size, _point  # noqa: F401  (MAX_POSITIONS: its name here too)
from pincal.planning.placement_options import (
    FULL_ONLY,
    design_values,
    old_placed,
    placed_instrument,
    placed_tracker,
)
from pincal.planning.placement_screen import Screen
from pincal.planning.results import DesignResult
from pincal.progress import Steps
from pincal.typing import TestPoseLike

TRACKER_RANGE = (1.0, 40.0)
"""Default (min, max) distance from a tracker to a reflector [m]: a tracker measures from about a
metre; 40 m is far beyond any robot cell (give yours with ``Sight``)."""

STEPS = 3
"""Default grid positions per axis of the box searched."""

SCREEN = 3
"""Default number of positions designed in full: the best of the screen. On the UR10's boxes of
benchmarks/RESULTS.md (bench_placement), the position and ρ0 the exhaustive search finds, for a third
of its CPU without the polish and a fraction with it (a polished design a position)."""

SCREEN_STARTS = 2
"""Exchange starts of a position's quick design in the screen."""

FINAL_STARTS = 8
"""Exchange starts of a finalist's design (the screen's best, the default placement): one batch,
its best quarter polished, not batches until the starts agree (``starts=`` given is used)."""

FINAL_MAXITER = 150
"""Iterations of a finalist's polish (:func:`pincal.design`'s ``maxiter``, default 3000; given: used)."""


ACCEPTANCE = math.radians(30.0)
"""Default acceptance half-angle of a tracker's reflector [rad]: a 1.5" red-ring reflector's ±30°."""


@dataclass(frozen=True)
class Sight:
    """What an instrument placed at a position must see, and how.

    Attributes:
        min_range, max_range: a tracker's distance limits to every marker [m].
        normal: the reflector's normal in the tip frame (one for every marker), or None (no
            acceptance-angle limit).
        max_angle: the reflector's acceptance half-angle [rad].
        line_of_sight: refuse configurations where the robot's collision geometry crosses the
            line from the instrument to a marker (when the URDF has collision geometry).
        clearance: the line of sight's radius [m].
    """

    min_range: float = TRACKER_RANGE[0]
    max_range: float = TRACKER_RANGE[1]
    normal: tuple[float, float, float] | None = (0.0, 0.0, 1.0)
    max_angle: float = ACCEPTANCE
    line_of_sight: bool = True
    clearance: float = 0.01


@dataclass(frozen=True, eq=False)
class Placement:
    """The instrument's position chosen with the plan (see :func:`place_instrument`).

    Attributes:
        at: (3,) the chosen position in the instrument's frame [m].
        result: the plan designed with the instrument there (``result.instrument_at`` is ``at``).
        positions: (n, 3) every position tried [m].
        values: (n,) the criterion of the best plan designed at each (ρ0 [m] for the test-pose
            criteria; inf where no feasible plan was found): the screen's quick design, or the
            full design where one ran (the better of the two).
        default_at: (3,) the default placement compared with [m].
        default: the plan designed at the default placement, or None if none was feasible.
        box: ((x0, y0, z0), (x1, y1, z1)) the box searched [m].
        notes: what was not checked, in words (line of sight without collision geometry).
        full: (n,) True where the position was designed in full (every position: ``screen=None``).
        screen: the number of positions designed in full after the screen; None: every position.
    """

    at: np.ndarray
    result: DesignResult
    positions: np.ndarray
    values: np.ndarray
    default_at: np.ndarray
    default: DesignResult | None
    box: tuple[tuple[float, float, float], tuple[float, float, float]]
    notes: tuple[str, ...] = field(default=())
    full: np.ndarray | None = None
    screen: int | None = None

    @property
    def factor(self) -> float:
        """The default placement's criterion over the chosen one's (inf: no plan at the default)."""
        return math.inf if self.default is None else self.default.value / self.result.value

    def lines(self) -> list[str]:
        """The placement in words: where, the criterion there and at the default, their factor."""

        def value(v: float) -> str:
            return _value_text(self.result.criterion, v)

        def where(p: np.ndarray) -> str:
            return "(" + ", ".join(f"{v:.3g}" for v in p) + ") m"

        tried = len(self.values)
        infeasible = int(np.sum(~np.isfinite(self.values)))
        how = (
            f"{tried} positions of the box tried"
            if self.screen is None
            else f"{tried} positions of the box screened, {self.designed_in_full} designed in full"
        )
        out = [
            f"instrument placed at {where(self.at)}: {value(self.result.value)} "
            f"({how}, {infeasible} without a feasible plan)"
        ]
        if self.default is None:
            out.append(f"  at the default position {where(self.default_at)}: no feasible plan")
        else:
            out.append(
                f"  at the default position {where(self.default_at)}: {value(self.default.value)}, "
                f"{self.factor:.3g} times the chosen position's"
            )
        out += [f"  note: {n}" for n in self.notes]
        return out

    @property
    def designed_in_full(self) -> int:
        """How many positions of ``positions`` were designed in full."""
        return len(self.values) if self.full is None else int(np.sum(self.full))

    def as_dict(self) -> dict:
        return {
            "instrument_at": self.at.tolist(),
            "box": [list(self.box[0]), list(self.box[1])],
            "positions": self.positions.tolist(),
            "values": [None if not np.isfinite(v) else float(v) for v in self.values],
            "designed_in_full": (
                [True] * len(self.values) if self.full is None else [bool(f) for f in self.full]
            ),
            "screen": self.screen,
            "default_at": self.default_at.tolist(),
            "default_value": None if self.default is None else self.default.value,
            "factor": None if not np.isfinite(self.factor) else self.factor,
            "notes": list(self.notes),
        }


@moved_keywords(("measure",), old_placed, OLD_FORM)
def place_instrument(
    params: ParameterSet,
    m: int,
    test_pose: TestPoseLike,
    box: object,
    *,
    criterion: str = "test-pose",
    instrument: Instrument | None = None,
    constraints: tuple[AnyConstraint, ...] = (),
    sight: Sight = Sight(),
    steps: int = STEPS,
    refine: int = 1,
    default_at: object = None,
    screen: int | None = SCREEN,
    progress: bool = False,
    **options: Any,
) -> Placement:
    """The instrument's position in ``box`` and the plan that together minimise the criterion.

    Args:
        params: the parameters identified (on the robot, with the camera's fixture for a camera).
        m, test_pose, criterion: as for :func:`pincal.design`.
        box: ((x0, y0, z0), (x1, y1, z1)) the positions allowed [m], instrument frame.
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`):
            points or poses with a :class:`~pincal.instruments.Tracker`, moved to each position
            (its ``at``), or an eye-to-hand :class:`~pincal.instruments.Image` (its camera is
            placed, looking at the target at the test pose); default points with a tracker of
            pincal's defaults. Its error model has its own σ: no ``sigma=`` among ``options``.
        constraints: the workcell's other constraints.
        sight: what a tracker at a position must see (range, acceptance angle, line of sight).
        steps: grid positions per axis of the box (an axis of zero width has one).
        refine: rounds of the best position's six neighbours at half the previous step.
        default_at: the placement compared with (default: the box's centre).
        screen: how many positions are designed in full: the best of the screen, where every
            position gets a quick design (:data:`SCREEN_STARTS` exchange starts over one pool drawn
            for the whole box, no polish; see the module doc), each finalist with
            :data:`FINAL_STARTS` starts and :data:`FINAL_MAXITER` polish iterations unless
            ``starts`` or ``maxiter`` are given. None: every position designed in full with the
            design's defaults (the exhaustive search). The default placement is designed as the
            finalists are.
        progress: report the positions screened and designed in full on stderr, with the full
            designs' own progress: a bar on a terminal, else a line every few seconds.
        options: more arguments of :func:`pincal.design` (``starts``, ``seed``, ``pool``,
            ``workers``, ``orientation_length``, ...), for the full designs; the screen's quick
            designs take the pool's size, the seed and the criterion's options.

    Raises:
        BadArgument: a bad box, a grid of more than :data:`MAX_POSITIONS` positions, or an
            instrument pincal cannot place (a camera on the tool, a distance sensor).
        Infeasible: no position of the box gives a feasible plan.
    """
    lower, upper = _box(box)
    _grid_size(lower, upper, steps)
    if screen is not None:
        screen = positive_int(screen, "screen (positions designed in full)")
    given = placed_instrument(instrument, options.pop("sigma", None))
    kind = given.kind
    camera = isinstance(kind, Image)
    if isinstance(kind, Image) and kind.eye_in_hand:
        raise BadArgument(
            "a camera on the tool moves with it: place_instrument places a camera fixed in the cell"
        )
    tracker = None if camera else placed_tracker(given.error)  # none when a camera is placed
    base_constraints, notes = tuple(constraints), _sight_notes(params, sight, camera)
    options = dict(options, seed=seed_entropy(options.get("seed", 0)))  # one seed for every design
    quick = {k: v for k, v in options.items() if k not in FULL_ONLY}
    quick.update(starts=SCREEN_STARTS, workers=1, polish=False)
    final = options if screen is None else _finalist(options)  # the exhaustive search: full designs
    shared = None if screen is None else Screen(params, base_constraints, options, m)
    steps_done = Steps(progress, "placement", "position")
    trials = _Trials(
        lambda at: _placed(params, kind, tracker, at, test_pose, sight, notes),
        lambda at: given if tracker is None else Instrument(kind, replace(tracker, at=tuple(at))),
        dict(m=m, test_pose=test_pose, criterion=criterion, constraints=base_constraints),
        quick, final, shared, steps_done, progress,
    )  # fmt: skip
    look, in_full, designed = trials.look, trials.in_full, trials.designed
    reasons, tried, full = trials.reasons, trials.tried, trials.full
    grid = _grid(lower, upper, steps)
    steps_done.stage("designed in full" if shared is None else "screened", len(grid))
    for at in grid:
        look(at)
    trials.refine(lower, upper, (upper - lower) / max(steps - 1, 1), refine)
    if _best(tried) is None:
        raise _nothing_seen(lower, upper, m, reasons, shared is not None)
    default = (lower + upper) / 2 if default_at is None else _point(default_at, "default_at")
    ranked = [] if shared is None else [at for _, at in sorted((r.value, at) for at, r in tried.items() if r)]
    key, chosen = tuple(default), ranked[:screen]
    alone = key not in tried  # the default placement, designed apart from the positions tried
    last = [] if key in full or key in chosen else [key]
    if chosen or last:
        steps_done.stage("designed in full", len(chosen) + len(last))
    for at in chosen + ([] if alone else last):  # the best of the screen, then the default placement
        in_full(at)
    default_result = tried[key] if not alone else designed(default)
    if alone:
        steps_done.advance(_best_note(tried, criterion))
    steps_done.close()
    best = _best(tried)
    assert best is not None  # a position with a feasible plan was found above
    positions = np.array(list(tried))
    values = np.array([math.inf if r is None else r.value for r in tried.values()])
    for note in notes:
        warn(note)
    result = tried[best]
    assert result is not None  # _best picks a position with a feasible plan
    return Placement(np.array(best), result, positions, values, default, default_result,
                     (tuple(lower.tolist()), tuple(upper.tolist())), tuple(notes),
                     np.array([at in full for at in tried]), screen)  # fmt: skip


def _nothing_seen(lower: np.ndarray, upper: np.ndarray, m: int, reasons: dict, screened: bool) -> Infeasible:
    """The error when no position of the box gives a feasible plan."""
    how = " (screened: a larger pool, or screen=None, designs each in full)" if screened else ""
    return Infeasible(
        f"no position of the box {lower.tolist()} - {upper.tolist()} lets the instrument see a feasible "
        f"plan of {m} configurations: move or grow the box, or relax the sight limits "
        f"({'; '.join(reasons.values())}){how}"
    )


@dataclass
class _Trials:
    """The positions tried by :func:`place_instrument`, with their best plans (None: no feasible
    plan), those designed in full, and why positions failed (one reason per error type)."""

    place: Callable[[np.ndarray], tuple[ParameterSet, tuple[AnyConstraint, ...]]]
    instrument: Callable[[np.ndarray], Instrument]
    problem: dict  # m, test_pose, criterion, constraints
    quick: dict
    final: dict
    shared: Screen | None
    steps_done: Steps
    progress: bool
    reasons: dict[str, str] = field(default_factory=dict)
    tried: dict[tuple[float, ...], DesignResult | None] = field(default_factory=dict)
    full: set[tuple[float, ...]] = field(default_factory=set)

    def designed(self, at: np.ndarray, quickly: Screen | None = None) -> DesignResult | None:
        """The plan designed with the instrument at ``at``: in full, or quickly (the screen)."""
        placed, extra = self.place(at)
        instrument = self.instrument(at)
        how, m = self.final, self.problem["m"]
        try:
            if quickly is not None:
                pool = quickly.seen(placed, extra)
                if len(pool) < m:
                    raise Infeasible(
                        f"only {len(pool)} of the screen's candidate configurations are seen from "
                        f"({', '.join(f'{v:.3g}' for v in at)}) m, {m} needed"
                    )
                how = dict(self.quick, pool=pool)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                given = dict(how, constraints=self.problem["constraints"] + extra,
                             progress=self.progress and quickly is None)  # fmt: skip
                result = design(placed, m, self.problem["test_pose"], criterion=self.problem["criterion"],
                                instrument=instrument, **design_values(given))  # fmt: skip
        except (Infeasible, SingularPlan, DegenerateOptimum) as failure:  # nothing it can see there
            self.reasons.setdefault(type(failure).__name__, str(failure))
            return None
        return replace(result, instrument_at=(float(at[0]), float(at[1]), float(at[2])))

    def look(self, at: np.ndarray) -> None:
        """The position tried: screened, or designed in full when nothing is screened."""
        if tuple(at) not in self.tried:
            self.tried[tuple(at)] = self.designed(at, self.shared)
            if self.shared is None:
                self.full.add(tuple(at))
        self.steps_done.advance(_best_note(self.tried, self.problem["criterion"]))

    def refine(self, lower: np.ndarray, upper: np.ndarray, step: np.ndarray, rounds: int) -> None:
        """``rounds`` rounds of the best position's six neighbours, at half the previous step."""
        for _ in range(rounds):
            best = _best(self.tried)
            if best is None:
                break
            step = step / 2
            self.steps_done.stage("refined", 6)
            for axis in range(3):
                for sign in (-1, 1):
                    self.look(np.clip(np.array(best) + sign * step * np.eye(3)[axis], lower, upper))

    def in_full(self, at: tuple[float, ...]) -> None:
        """The position designed in full: its best plan, the screen's or the full design's."""
        result = self.designed(np.array(at))
        self.full.add(at)
        screened = self.tried.get(at)
        if screened is None or (result is not None and result.value <= screened.value):
            self.tried[at] = result
        self.steps_done.advance(_best_note(self.tried, self.problem["criterion"]))


def _finalist(options: dict) -> dict:
    """The options of a finalist's design: those given, and :data:`FINAL_STARTS` starts and
    :data:`FINAL_MAXITER` polish iterations where none (or None: adaptive) is given."""
    given = {k: v for k, v in options.items() if not (k in ("starts", "maxiter") and v is None)}
    return {"starts": FINAL_STARTS, "maxiter": FINAL_MAXITER, **given}


def _best_note(tried: dict[tuple[float, ...], DesignResult | None], criterion: str) -> str:
    """The best value so far, for the progress line."""
    values = [r.value for r in tried.values() if r is not None]
    return f"best {_value_text(criterion, min(values))}" if values else ""


def _value_text(criterion: str, v: float) -> str:
    return (
        f"rho0 {v * 1e3:.4g} mm" if criterion in ("test-pose", "test-pose-worst") else f"{criterion} {v:.4g}"
    )


def _best(tried: dict[tuple[float, ...], DesignResult | None]) -> tuple[float, ...] | None:
    feasible = [(r.value, at) for at, r in tried.items() if r is not None]
    return min(feasible)[1] if feasible else None


def _sight_notes(params: ParameterSet, sight: Sight, camera: bool) -> list[str]:
    """What the placement cannot check, in words."""
    if camera or not sight.line_of_sight:
        return []
    try:
        LineOfSight((0.0, 0.0, 0.0)).bind(params.robot)
    except BadConstraint as error:
        return [f"the line of sight is not checked: {error}"]
    return []


def _placed(
    params: ParameterSet,
    kind: Kind | None,
    tracker: Tracker | None,
    at: np.ndarray,
    test_pose: TestPoseLike,
    sight: Sight,
    notes: list[str],
) -> tuple[ParameterSet, tuple[AnyConstraint, ...]]:
    """(parameters on the robot with the instrument at ``at``, the constraints it brings)."""
    robot = params.robot
    if isinstance(kind, Image):
        target = robot.fixture("target").placement
        poses, _ = resolve_test_poses(robot, test_pose)
        R, p = robot.tip_poses(poses)
        centre = target.translation + target.rotation @ kind.points.mean(axis=0)  # in the tip frame
        aim = np.mean(p + np.einsum("mij,j->mi", R, centre), axis=0)
        camera = robot.fixture("camera")
        moved = robot.with_fixtures(replace(camera, placement=look_at(at, aim)))
        return params.on(moved), ()
    angle = sight.max_angle if sight.normal else None
    extra: list[AnyConstraint] = [
        Visibility(tuple(at), sight.max_range, sight.min_range, sight.normal, angle)
    ]
    if sight.line_of_sight and not notes:
        extra.append(LineOfSight(tuple(at), sight.clearance))
    return params, tuple(extra)


def look_at(eye: np.ndarray, target: np.ndarray) -> pin.SE3:
    """A camera's placement at ``eye`` whose optical axis (z) points at ``target``, its image's x
    axis horizontal (z up in the instrument's frame)."""
    z = np.asarray(target, dtype=float) - np.asarray(eye, dtype=float)
    if np.linalg.norm(z) < 1e-9:
        raise BadArgument("a camera cannot look at the point it stands on")
    z /= np.linalg.norm(z)
    up = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return pin.SE3(np.column_stack([x, y, z]), np.asarray(eye, dtype=float))
