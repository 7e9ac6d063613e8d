"""What each measurement kind makes visible (docs/method.md §4 and §13.1).

:func:`identifiable` runs the model's identifiability analysis (:mod:`pincal.model.base_parameters`)
on the rows an instrument measures instead of the markers' positions: a pose sees the offset of the
last joint that a point on its axis hides; a height gauge (``z`` alone) cannot see horizontal
translations of the base; distances need the anchors identified with the robot. The instrument's
fixtures (its camera, target or anchors) are kept before the robot's other parameters, as the base
is when the data are in the instrument's frame.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from pincal.arguments import generator
from pincal.errors import Infeasible
from pincal.model.base_parameters import NEARLY_REDUNDANT, Identifiability
from pincal.model.catalogue import split_spec
from pincal.model.parameters import ParameterSet
from pincal.typing import PayloadLike, SeedLike

if TYPE_CHECKING:  # Instrument.identifiable calls this module: instrument.py imports it
    from pincal.instruments.instrument import Instrument

SEEN_DRAWS = 50
"""An instrument that sees from some configurations only (a camera) is analysed at random
configurations where it sees: drawn among up to this many times as many."""

MIN_SEEN = 4
"""Values a configuration must let the instrument read to count (two target points of an image)."""


def seen_configurations(
    params: ParameterSet, instrument: Instrument, n: int, seed: SeedLike
) -> np.ndarray | None:
    """(n, nq) random configurations at which the instrument reads at least :data:`MIN_SEEN` values,
    or None when it reads every value everywhere (any random configuration will do).

    Raises:
        Infeasible: too few such configurations among :data:`SEEN_DRAWS`·n random ones.
    """
    robot, kind = params.robot, instrument.kind
    pool = robot.random_configurations(SEEN_DRAWS * n, generator(seed))
    seen = kind.seen(robot, pool).sum(axis=1)
    if np.all(seen == kind.size(robot)):
        return None
    good = pool[seen >= MIN_SEEN]
    if len(good) < n:
        raise Infeasible(
            f"{kind.describe()}: the instrument reads {MIN_SEEN} values or more in only {len(good)} of "
            f"{len(pool)} random configurations; check the nominal placements of the camera and the target "
            f"(they must face each other within the joint limits)"
        )
    return good[:n]


def identifiable(
    params: ParameterSet,
    instrument: Instrument,
    n_configurations: int = 200,
    seed: SeedLike = 0,
    tol: float = NEARLY_REDUNDANT,
    prefer: str | Iterable[str] = (),
    payloads: Sequence[PayloadLike] | None = None,
) -> Identifiability:
    """Which of ``params`` the ``instrument``'s measurements can identify (arguments as
    :meth:`pincal.ParameterSet.identifiable`), at random configurations where it reads what it
    measures (:func:`seen_configurations`).

    Raises:
        Infeasible: the instrument reads too little at random configurations (a camera that never
            sees its target).
    """
    engine = instrument.engine(params)
    configurations = seen_configurations(params, instrument, n_configurations, seed)

    def rows(qs: np.ndarray, loads: np.ndarray | None) -> np.ndarray:
        return engine.jacobian(qs, frame="tip", payload=loads)

    fixtures = ["instrument"] if any(p.kind == "fixture" for p in params) else []
    return params.identifiable(
        n_configurations=n_configurations,
        seed=seed,
        tol=tol,
        prefer=split_spec(prefer) + fixtures,
        payloads=payloads,
        rows=rows,
        measured=instrument.kind.describe(),
        configurations=configurations,
    )
