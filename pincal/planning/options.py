"""The options of a design as a few small frozen values (docs/method.md §7): how the plan is
searched (:class:`Search`), how it is kept safe (:class:`Safety`) and what loads the robot while it
is measured (:class:`Loads`). What is measured and how well is an
:class:`~pincal.instruments.Instrument` (or ``sigma=``, its shorthand for points).

Each value is checked where the design reads it (:func:`pincal.design`, once). The flat keywords
of pincal 0.1 (``design(..., starts=8, seed=1, clearance=0.02)``) keep working until pincal
:data:`~pincal.deprecation.REMOVAL`, with a DeprecationWarning naming the value to write
(:func:`regroup`, through :func:`pincal.deprecation.moved_keywords`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, fields, replace
from typing import Any

from pincal.errors import BadArgument
from pincal.planning.constraints import AnyConstraint, JointMargin, MountSpec
from pincal.typing import ConfigurationsLike, PayloadLike, PoolLike, SeedLike

__all__ = ["FLAT", "Loads", "Safety", "Search", "regroup"]


@dataclass(frozen=True)
class Search:
    """How the plan is searched: the method, its starts and where they run.

    Attributes:
        method: ``"exchange"`` (default: over a pool of candidates, the best polished) or
            ``"continuous"`` (all joint values at once, from starts drawn from the pool).
        starts: number of starts, run exactly; None (default): adaptive, batches until the starts
            agree (docs/method.md §7.6).
        seed: seed of every random choice: an int, a numpy Generator (one int drawn), or None
            (fresh entropy; ``result.seed`` repeats it).
        pool: candidates for the exchange: (N, nq) configurations or a Plan (the infeasible left
            out), or the number to draw (default 2000; 1000 configurations when each is paired
            with the payloads of :class:`Loads` or scored with a residual model).
        init: plans (each (m, nq), feasible) to start the continuous method from, first.
        polish: continue the best ``keep`` exchange results with the continuous search; default on
            for a generated pool without payloads, off otherwise.
        keep: fraction of starts run to convergence after screening (continuous), or polished.
        screen_iterations: iterations every continuous start runs before the poor ones are dropped.
        maxiter: iterations allowed per start and stage of the continuous search.
        executor: a ``concurrent.futures.Executor`` to run the starts on (a cluster's, say).
        workers: processes of the default process pool (default all CPUs; 1: serial).
        progress: report progress on stderr, stage by stage.
    """

    method: str = "exchange"
    starts: int | None = None
    seed: SeedLike = 0
    pool: PoolLike = None
    init: Sequence[ConfigurationsLike] = ()
    polish: bool | None = None
    keep: float = 0.25
    screen_iterations: int = 20
    maxiter: int = 3000
    executor: Executor | None = None
    workers: int | None = None
    progress: bool = False


@dataclass(frozen=True)
class Safety:
    """How the plan is kept safe, and regular.

    Attributes:
        constraints: constraint objects of :mod:`pincal.planning.constraints` (joint limits always
            apply), to which the safe defaults below are added.
        joint_margin: kept inside every joint limit (a number [rad or m], an (angle, length) pair or
            a JointLimits); default 2°, 1 cm on prismatic joints, at most a tenth of a range; 0: none.
        mount: the plane the robot is mounted on (``floor``, ``wall``, ``ceiling``, ``none``,
            ``"NX,NY,NZ,OFFSET"`` or a Mount); default ``floor`` for a fixed-base robot measured
            from its URDF root.
        clearance: kept from the mounting plane and every obstacle [m]; default 5 cm.
        min_conditioning: floor of the plan's conditioning (in (0, 0.1); 0 only with a prior);
            default 1e-2, adapting down to half what a D-optimal plan reaches.
    """

    constraints: Iterable[AnyConstraint] = ()
    joint_margin: JointMargin = None
    mount: MountSpec = None
    clearance: float | None = None
    min_conditioning: float | None = None


@dataclass(frozen=True)
class Loads:
    """What loads the robot: the payloads the experiment can mount and the task's.

    Attributes:
        payloads: masses [kg] or :class:`~pincal.Payload` (e.g. ``[0, 50, 100]``): each
            configuration is chosen with one of them (the pool is every configuration paired with
            every payload), and the plan carries them. Default: none (0 kg).
        task_payload: the payload at the test pose(s), the task's load: ρ0 is then at that load.
    """

    payloads: Sequence[PayloadLike] | None = None
    task_payload: PayloadLike = None

    @property
    def given(self) -> bool:
        """Payloads or a task payload were given."""
        return self.payloads is not None or self.task_payload is not None


GROUPS: dict[str, type] = {"search": Search, "safety": Safety, "loads": Loads}
"""design()'s keywords that take a value, and its type."""

FLAT: dict[str, str] = {f.name: group for group, kind in GROUPS.items() for f in fields(kind)}
"""The flat keywords of pincal 0.1 and the value each now belongs to (``measure`` and an
``instrument`` that is an error model become an :class:`~pincal.instruments.Instrument`:
:func:`pincal.instruments.given.old_instrument`)."""

ORDER_0_1 = (
    "criterion", "method", "constraints", "pool", "starts", "seed", "sigma", "executor", "workers",
    "init", "polish", "keep", "screen_iterations", "maxiter", "min_conditioning", "prior", "progress",
    "payloads", "task_payload", "residual_model", "measure", "instrument", "orientation_length",
    "joint_margin", "mount", "clearance", "with_d_optimal",
)  # fmt: skip
"""design()'s keywords in pincal 0.1's order (what arguments by position after the third meant)."""


def regroup(
    flat: dict, kwargs: dict, function: str = "design", defaults: dict[str, Any] | None = None
) -> tuple[dict, str]:
    """The keywords of today's :func:`pincal.design` (or of ``function``, which passes them on to
    it) for the flat ones ``flat`` of pincal 0.1 and the others ``kwargs``, with what to write
    instead (for the DeprecationWarning). ``measure=`` and an error model as ``instrument=`` are
    :func:`pincal.instruments.given.old_instrument`'s. ``defaults``: ``function``'s own value of a
    group where it is not the type's default (:func:`pincal.next_poses`'s 8 starts): the flat
    keywords change only what they name, and the hint writes the rest.

    Raises:
        TypeError: a flat keyword and the value it belongs to are both given.
    """
    out = dict(kwargs)
    hints = []
    for group, kind in GROUPS.items():
        given = {name: flat[name] for name in flat if FLAT.get(name) == group}
        if not given:
            continue
        if group in kwargs:
            raise TypeError(f"{function}() got {', '.join(given)} and {group}=: put them in {group}=")
        base = (defaults or {}).get(group, kind())
        out[group] = replace(base, **given)
        kept = [f"{f.name}={getattr(base, f.name)!r}" for f in fields(kind) if f.name not in given
                and getattr(base, f.name) != getattr(kind(), f.name)]  # fmt: skip
        hints.append(f"{group}=pincal.{kind.__name__}({', '.join(kept + [f'{n}=...' for n in given])})")
    return out, "; ".join(hints)


def check_value(value: object, kind: type, name: str) -> None:
    """Refuse a value of the wrong type for ``name=`` (e.g. a dict for ``search=``).

    Raises:
        BadArgument: ``value`` is not a ``kind``.
    """
    if not isinstance(value, kind):
        raise BadArgument(
            f"{name}= takes a pincal.{kind.__name__}(...), got {value!r}", argument=name, value=value
        )
