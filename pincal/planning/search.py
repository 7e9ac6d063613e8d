"""The search stage of a design: the starts drawn from the pool, each searched (exchange or
continuous) on an executor, the best exchange plans polished; one :class:`Outcome` per start.

A start that fails alone (:func:`degenerate`: none of its random plans is regular) is dropped
and counted, the others go on; only when every start fails is its error raised.

With the adaptive number of starts (``Settings.adaptive``), the starts run in batches, each searched
and polished as a design of ``Settings.starts`` starts, until they agree or their cap is reached
(:mod:`pincal.planning.stopping`).

The values passed between the stages (:class:`Settings`, :class:`Pool`, :class:`Outcome`) live in
:mod:`pincal.planning.settings`.
"""

from __future__ import annotations

import math
import multiprocessing as mp
from concurrent.futures import Executor
from dataclasses import replace

import numpy as np

from pincal.errors import PincalError
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.information import conditioning
from pincal.evaluation.residual_criterion import ResidualCriterion
from pincal.instruments.instrument import RowsEngine
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.planning import multistart as _multistart
from pincal.planning import stopping as _stopping
from pincal.planning.continuous import load_optimiser
from pincal.planning.progress import Progress
from pincal.planning.results import StartRecord
from pincal.planning.settings import (
    D_OPTIMAL,
    Drawn,
    Outcome,
    Pool,
    Settings,
    degenerate,
    dropped_count,
    every_start_failed,
)
from pincal.planning.starts import draw_start, start_seed

__all__ = [
    "D_OPTIMAL",
    "Outcome",
    "Pool",
    "Settings",
    "degenerate",
    "draw_starts",
    "dropped_count",
    "every_start_failed",
    "log_scale",
    "plan_conditioning",
    "search",
    "values",
]


# ---------------------------------------------------------------------------- search
def draw_starts(
    settings: Settings,
    J_pool: np.ndarray,
    pool: np.ndarray,
    begin: int = 0,
    end: int | None = None,
    exchanged: dict | None = None,
) -> tuple[Drawn, ...]:
    """The pool indices of the plans of starts ``begin`` to ``end`` (default: the last), drawn
    here, each from its own child seed (see :func:`pincal.planning.starts.draw_start`; ``exchanged``
    keeps their D-optimal exchanges for drawing them again under another floor); for a start that
    failed alone (:func:`degenerate`), its error."""
    drawn: list[Drawn] = []
    for i in range(begin, settings.starts if end is None else end):
        try:
            drawn.append(
                draw_start(
                    J_pool,
                    pool,
                    settings.m,
                    settings.feasibility.spacing,
                    start_seed(settings.entropy, i),
                    settings.floor,
                    settings.prior_information,
                    exchanged,
                )
            )
        except PincalError as error:
            if not degenerate(error):
                raise
            drawn.append(error)
    return tuple(drawn)


def _problem_spec(s: Settings, params: ParameterSet, pooled: Pool) -> _multistart.ProblemSpec:
    """The problem every start of the design solves (the candidates only for the exchange)."""
    return _multistart.ProblemSpec(
        params,
        s.m,
        s.criterion,
        s.test_poses,
        s.sigma,
        s.constraints,
        pooled.candidates if s.method == "exchange" else None,
        s.floor,
        s.prior_information,
        s.entropy,
        instrument=s.measured,
        orientation_length=s.orientation_length,
        payload=pooled.payload,
        task_payload=s.task_payload,
        residual_model=s.residual_model,
    )


def search(
    settings: Settings,
    params: ParameterSet,
    engine: JacobianEngine | RowsEngine,
    pooled: Pool,
    first: tuple[Drawn, ...],
    executor: Executor | None,
    progress: bool,
    with_d_optimal: bool = False,
) -> tuple[tuple[Outcome, ...], tuple[Outcome, ...] | None]:
    """Every start searched (and the best polished), on the executor; one outcome per start.

    ``first`` are the plans of the first starts, drawn by the caller (:func:`draw_starts`); the
    exchange's workers draw the others themselves, in parallel.

    With ``with_d_optimal`` (exchange method), the D-optimal design is searched from the same
    starts too, in the same tasks: from each start's plan the D criterion's own exchange, then
    the best ``n_keep`` of those polished, the polishes of both designs on the executor together.
    Its outcomes are those of a design with ``criterion="D"`` and the same settings (the starts,
    the pool and the floor do not depend on the criterion), without drawing the starts again.

    A start that fails alone (:func:`degenerate`) is dropped: its outcome says so
    (``Outcome.dropped``), and it is neither searched further nor polished.

    With ``settings.adaptive``, batches of ``settings.starts`` starts are searched one after the
    other, each as a design of that many starts (polished, or screened and run to convergence, on
    its own), until the starts agree on the best value or their cap is reached
    (:mod:`pincal.planning.stopping`; the D-optimal design follows the same starts). Start k draws
    its plan from its own seed whatever its batch.

    Returns:
        (the outcomes of this design's criterion, those of the D-optimal design or None).

    Raises:
        FloorUnreachable: a start found no plan above the conditioning floor (the caller adapts
            a default floor and searches again).
        SingularPlan, Infeasible: every start failed alone (the first start's error, saying so;
            adaptive: every start of the first batch).
    """
    s = settings
    spec = _problem_spec(s, params, pooled)
    objective = _multistart.objective_for(spec, engine)
    d_spec = d_objective = None
    if with_d_optimal:
        assert s.method == "exchange"  # the driver checked
        d_spec = spec.for_criterion(D_OPTIMAL)
        d_objective = _multistart.objective_for(d_spec, engine)
    n_starts, n_keep = pooled.n_starts(s), pooled.n_keep(s)
    bar = Progress(progress, ResidualCriterion.name if s.residual_model else s.criterion, objective)
    if executor is None and min(s.workers, n_starts) > 1 and mp.get_start_method() == "fork":
        if s.polish or s.method == "continuous":
            load_optimiser()  # once here, not in each forked worker
    try:
        with _multistart.executor_for(executor, s.workers, n_starts) as ex:
            own: tuple[Outcome, ...] = ()
            other: tuple[Outcome, ...] | None = None if d_spec is None else ()
            J_pool = (
                _multistart.candidate_rows(engine, pooled.candidates) if s.method == "continuous" else None
            )
            begin = 0  # the batch's first drawn start
            while True:
                end = begin + s.starts
                if s.method == "continuous":
                    assert J_pool is not None
                    indices = first[begin:] + draw_starts(
                        s, J_pool, pooled.candidates, max(begin, len(first)), end
                    )
                    init = list(pooled.init) if begin == 0 else []
                    x0s = init + [i if isinstance(i, PincalError) else pooled.candidates[i] for i in indices]
                    n_keep = pooled.n_keep(s, len(x0s))
                    offset = 0 if begin == 0 else len(pooled.init) + begin
                    own += _continuous(
                        spec, ex, x0s, n_keep, s.screen_iterations, s.maxiter, objective, bar, offset
                    )
                else:
                    bar.stage("searched" + _which(s, begin, end), end - begin)
                    designs = _exchange(
                        spec, ex, pooled, first, begin, end, objective, bar, d_spec, d_objective
                    )
                    if s.polish:
                        also = "" if d_spec is None else f", and {n_keep} D-optimal"
                        bar.stage(
                            f"polished (the best {n_keep} of {end - begin}{_which(s, begin, end)}{also})",
                            n_keep * len(designs),
                        )
                        designs = _polish(ex, designs, n_keep, s.maxiter, engine, s.floor, bar)
                    own += designs[0][1]
                    if other is not None:
                        other += designs[1][1]
                if not s.adaptive or end >= _stopping.CAP or _stopping.enough(values(own), log_scale(s)):
                    return own, other
                begin = end
    finally:
        bar.close()
        _multistart.forget(spec)
        if d_spec is not None:
            _multistart.forget(d_spec)


def values(outcomes: tuple[Outcome, ...]) -> list[float]:
    """The starts' final values in the criterion's units; inf for a start without a usable plan."""
    return [o.record.value if o.usable else math.inf for o in outcomes]


def log_scale(settings: Settings) -> bool:
    """The criterion's values are logarithms (D: log det M⁻¹; see
    :func:`pincal.planning.stopping.matched`)."""
    return settings.criterion == D_OPTIMAL


def _which(settings: Settings, begin: int, end: int) -> str:
    """Which starts a stage of an adaptive design runs: ``" (starts 9-16)"``; "" otherwise."""
    return f" (starts {begin + 1}-{end})" if settings.adaptive else ""


Searched = tuple[_multistart.ProblemSpec, tuple[Outcome, ...], Criterion]
"""One design's exchange outcomes, with its spec and criterion (for its polish)."""


def _exchange(
    spec,
    ex,
    pooled: Pool,
    first,
    begin: int,
    end: int,
    objective: Criterion,
    bar,
    d_spec=None,
    d_objective=None,
) -> list[Searched]:
    """The exchange search from the plan of each start ``begin`` to ``end`` (the first given, the
    others drawn by the workers); with ``d_spec``, the D-optimal design's exchange from the same
    plans, in the same task. A start that failed alone (:func:`degenerate`), given so or in its
    task, is dropped; when every start of the first batch (``begin`` 0) did, its error is raised."""
    failed: dict[int, PincalError] = {
        i: f for i, f in enumerate(first) if isinstance(f, PincalError) and begin <= i < end
    }
    searched = [i for i in range(begin, end) if i not in failed]
    items = [(spec, i, first[i] if i < len(first) else None, d_spec) for i in searched]
    for _ in failed:
        bar(None)
    results = dict(
        zip(
            searched,
            _multistart.run(ex, _multistart.exchange_task, items, lambda i, r: bar(_first(r))),
            strict=True,
        )
    )
    for i in searched:
        r = results[i]
        if isinstance(r, _multistart.CarriedError):
            error = r.error()
            if not (isinstance(error, PincalError) and degenerate(error)):
                raise error
            failed[i] = error
    if begin == 0 and len(failed) == end:
        raise every_start_failed([failed[i] for i in sorted(failed)], end)
    own = [failed[i] if i in failed else results[i][0] for i in range(begin, end)]
    designs = [(spec, _exchanged(pooled, own, objective, begin), objective)]
    if d_spec is not None:
        assert d_objective is not None
        other = [failed[i] if i in failed else results[i][1] for i in range(begin, end)]
        designs.append((d_spec, _exchanged(pooled, other, d_objective, begin), d_objective))
    return designs


def _first(result):
    """The task's outcome for the design's own criterion, for the progress bar (None for a start
    that could not be drawn: it is dropped, or its error raised, once every task is back)."""
    return None if isinstance(result, _multistart.CarriedError) else result[0]


def _exchanged(pooled: Pool, outcomes, objective: Criterion, begin: int = 0) -> tuple[Outcome, ...]:
    """Each start's exchange outcome (or the error it was dropped for) as its :class:`Outcome`
    (the first is start ``begin``), its plan's configurations and payloads from the pool."""
    return tuple(
        Outcome.degenerate(s, o)
        if isinstance(o, PincalError)
        else Outcome(
            StartRecord(
                start=s,
                value=float(objective.report(o.F)),
                screen_value=None,
                iterations=o.sweeps,
                time_s=o.time_s,
                continued=True,
                feasible=True,
                message=f"{o.swaps} exchanges",
            ),
            pooled.candidates[o.index],
            o.F,
            True,
            payload=None if pooled.payload is None else pooled.payload[o.index],
        )
        for s, o in enumerate(outcomes, begin)
    )


def _polish(
    ex, designs: list[Searched], n_keep: int, maxiter: int, engine, floor: float, bar
) -> list[Searched]:
    """The best ``n_keep`` exchange plans of each design continued by the continuous search, all
    on the executor at once (the last design's first: the D-optimal polishes are the longer); a
    polished plan replaces its start's plan if feasible, no worse and above the conditioning floor."""
    orders: list[tuple[int, list[int], int]] = []  # (design, its starts polished, where its items begin)
    items: list[tuple] = []
    for d in reversed(range(len(designs))):
        spec, outcomes, _ = designs[d]
        live = [s for s in range(len(outcomes)) if not outcomes[s].dropped]
        order = sorted(live, key=lambda s: (outcomes[s].F, s))[:n_keep]
        orders.append((d, order, len(items)))
        items += [(spec, outcomes[s].q, outcomes[s].q, maxiter) for s in order]
    own = orders[-1][2]  # this design's items come last; the bar reports its values only
    polished = _multistart.run(ex, _multistart.polish_task, items, lambda i, r: bar(r if i >= own else None))
    out = list(designs)
    for d, order, begin in orders:
        spec, outcomes, objective = designs[d]
        new = list(outcomes)
        for s, o in zip(order, polished[begin : begin + len(order)], strict=True):
            old = outcomes[s]
            better = o.feasible and o.F <= old.F and plan_conditioning(engine, o.q) > floor
            record = replace(
                old.record,
                value=float(objective.report(o.F if better else old.F)),
                iterations=old.record.iterations + o.iterations,
                time_s=old.record.time_s + o.time_s,
                feasible=o.feasible,
                message=old.record.message + "; polished: " + o.message + ("" if better else " (not kept)"),
            )
            new[s] = Outcome(record, o.q if better else old.q, o.F if better else old.F, True)
        out[d] = (spec, tuple(new), objective)
    return out


def _continuous(
    spec, ex, x0s, n_keep, screen_iterations, maxiter, objective, bar, offset: int = 0
) -> tuple[Outcome, ...]:
    """Screen every start, continue the best ``n_keep`` to convergence; a start that failed alone
        (its error in ``x0s`` in place of its plan) is dropped; when every start of the first batch
    (``offset`` 0) did, its error is raised. The first start is start ``offset``."""
    n = len(x0s)
    failed = {s: x for s, x in enumerate(x0s) if isinstance(x, PincalError)}
    if len(failed) == n and offset == 0:  # a later batch of an adaptive design: the others remain
        raise every_start_failed(list(failed.values()), n)
    live = [s for s in range(n) if s not in failed]
    screened: dict | None = None
    if n_keep < len(live) and screen_iterations > 0:
        items = [(spec, x0s[s], screen_iterations) for s in live]
        bar.stage("screened", len(live))
        screens = _multistart.run(ex, _multistart.screen_task, items, lambda i, r: bar(r))
        screened = dict(zip(live, screens, strict=True))
        order = sorted(live, key=lambda s: (screened[s].F, s))
        kept = sorted(order[:n_keep])
        starts_from = [screened[s].q for s in kept]
    else:
        kept = live
        starts_from = [x0s[s] for s in kept]
    polish_items = [(spec, q, x0s[s], maxiter) for s, q in zip(kept, starts_from, strict=True)]
    bar.stage(
        "run to convergence" if len(kept) == len(live) else f"run to convergence (the best {len(kept)})",
        len(kept),
    )
    runs = _multistart.run(ex, _multistart.polish_task, polish_items, lambda i, r: bar(r))
    finals = dict(zip(kept, runs, strict=True))

    def outcome(s: int) -> Outcome:
        if s in failed:
            return Outcome.degenerate(offset + s, failed[s])
        first = None if screened is None else screened[s]
        screen_value = None if first is None else _report_value(objective, first.F)
        final = finals.get(s)
        last = final if final is not None else first
        assert last is not None  # a start is screened, run to convergence, or both
        record = StartRecord(
            start=offset + s,
            value=_report_value(objective, last.F),
            screen_value=screen_value,
            iterations=(0 if first is None else first.iterations)
            + (0 if final is None else final.iterations),
            time_s=(0.0 if first is None else first.time_s) + (0.0 if final is None else final.time_s),
            continued=final is not None,
            feasible=last.feasible,
            message="dropped after screening" if final is None else final.message,
        )
        if final is None:
            return Outcome(record, None, math.inf, False)
        return Outcome(record, final.q, final.F, final.feasible)

    return tuple(outcome(s) for s in range(n))


def _report_value(objective: Criterion, F: float) -> float:
    return float(objective.report(F)) if np.isfinite(F) else math.inf


def plan_conditioning(
    engine: JacobianEngine | RowsEngine, q: np.ndarray, payload: np.ndarray | None = None
) -> float:
    """Conditioning of the plan q under its payloads (see
    :func:`pincal.evaluation.information.conditioning`)."""
    J = engine.jacobian(q, frame="tip", payload=payload).reshape(-1, engine.n_params)
    return conditioning(J.T @ J)
