r"""Gravity on a robot's joints, the payload it carries, and how compliant joints yield to both
(docs/method.md §11.2).

With the joint reading q, a joint actually stands at θ, the solution of

    θ = q + Δq + k ⊙ q + c ⊙ τ(θ, w),

Δq the joint offsets [rad or m], k the joint gains (dimensionless), c the joint compliances
[rad/(N·m), or m/N for a prismatic joint] and τ(θ, w) the torque [N·m, or N] that gravity applies
at each joint under the load w: the links' own weight (the URDF's ``<inertial>`` masses) and the
payload's. τ = −g(θ), g being Pinocchio's generalized gravity (the torque that *holds* the robot),
computed on a copy of the model whose tip body also carries the payload's inertia, so that one
gravity call covers links and payload. Gravity is the model's (``pinocchio.Model.gravity``):
(0, 0, −9.81) m/s² in the robot's base frame unless the robot is mounted otherwise.

The payload is a point mass (:class:`Payload`) at a centre fixed in the tip frame; a measurement
or a plan gives one per configuration, as the rows [kg, x, y, z] of :func:`payload_rows`.

Where payloads become rows (the door): a user gives a payload in any of the forms of
:data:`pincal.typing.PayloadLike`, and :func:`payload_rows` turns it into rows once, at the top of
the public function, method or class that takes it (``payload=``, ``task_payload=``,
``payloads=``): :class:`Payload`, :meth:`~pincal.Robot.joint_values` (so
:meth:`~pincal.Robot.points` and :meth:`~pincal.Robot.tip_poses`) and
:meth:`~pincal.Robot.joint_torques`, :meth:`~pincal.ParameterSet.jacobian`,
:meth:`~pincal.ParameterSet.identifiable`, :class:`~pincal.Plan`, :func:`~pincal.rho0` and
:class:`~pincal.evaluation.TestPoseCriterion`, :func:`~pincal.evaluation.position_covariance`,
:func:`~pincal.accuracy` and :class:`~pincal.evaluation.PredictedError` (a task's load: one row),
:func:`~pincal.design` (its :class:`~pincal.Loads`), :func:`~pincal.random_errors`,
:func:`~pincal.simulate_measurements`, :func:`~pincal.monte_carlo`, :func:`~pincal.compensate`, and
the identification result's accuracy. Below the door only :data:`PayloadRows` travels: (m, 4) rows
of the m configurations at hand, or None for none (:func:`carried` reads None as zeros, and
:func:`repeated` carries a task's one row at n configurations), and no function below the door
normalises what it receives: :class:`~pincal.model.kinematics.ForwardKinematics`,
:meth:`~pincal.Robot.joint_values_under`, the Jacobian engines, the instruments, the calibration
problem, the constraints' :class:`~pincal.planning.constraints.Kinematics` and the collision world
take rows as they are. (Code below the door that asks a public door, e.g. the instruments'
``robot.points``, hands it rows, which that door checks once more: O(m), on a compliant robot
only. :class:`~pincal.MeasurementData` checks its own payload columns, naming the file's lines.)
The doors are listed in tests/contracts/test_payload_door.py: a new call of :func:`payload_rows`
is a new door, or a sign that rows are being normalised twice.

θ is found by fixed-point iteration from θ₀ = q + Δq + k ⊙ q: each step shrinks the error by about
‖C ∂τ/∂θ‖ (C = diag c), 1e-3 for an industrial arm, so a few steps reach rounding.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeAlias

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_LENGTH
from pincal.errors import BadArgument, NoInertias
from pincal.typing import ArrayLike, PayloadLike

PayloadRows: TypeAlias = "np.ndarray | None"
"""A payload below the door: (m, 4) rows [kg, x, y, z] (the centre in the tip frame [m]), one per
configuration at hand, as :func:`payload_rows` returns them; or None, nothing carried."""

PAYLOAD_COLUMNS = ("payload_kg", "payload_x", "payload_y", "payload_z")
"""The payload columns of a plan or measurement file: mass [kg], centre of mass in the tip frame."""

MAX_PAYLOAD = 1e5
"""Heaviest payload pincal accepts [kg] (100 t): beyond any robot's, a unit or number error."""

MASSLESS = 1e-6
"""A chain whose moving bodies weigh less than this in all [kg] has no masses in its URDF (some
URDFs give every link a token 1e-9 kg)."""

MAX_GRAVITY = 100.0
"""Largest gravity pincal accepts [m/s²] (ten times the Earth's): beyond it, a unit error."""

STATIC_TOLERANCE = 1e-13
"""The static solve stops when no joint moves by more than this between two steps [rad or m]."""

MAX_STATIC_STEPS = 60
"""Steps after which a static solve that still moves is declared divergent: the compliances are
so large that the arm would fold under its own weight (‖C ∂τ/∂θ‖ near 1 or above)."""


@dataclass(frozen=True)
class Payload:
    """A load carried by the tip: a point mass.

    Attributes:
        mass: [kg], ≥ 0.
        centre: its centre of mass in the tip frame [m]; default the tip origin.
    """

    mass: float
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        row = payload_rows(np.r_[self.mass, np.ravel(self.centre)].reshape(1, -1), 1)[0]
        object.__setattr__(self, "mass", float(row[0]))
        object.__setattr__(self, "centre", (float(row[1]), float(row[2]), float(row[3])))

    @property
    def row(self) -> np.ndarray:
        """[kg, x, y, z] (a new array)."""
        return np.array([self.mass, *self.centre])


def payload_rows(payload: PayloadLike, m: int) -> np.ndarray:
    """The payload of each of ``m`` configurations as a new (m, 4) array of rows [kg, x, y, z].

    Args:
        payload: None (no payload); a mass [kg], a :class:`Payload` or one row [[kg, x, y, z]]
            for every configuration; a sequence of m Payloads; (m,) masses [kg] at the tip origin;
            or (m, 4) rows [kg, x, y, z] (the centre in the tip frame [m]).
        m: the number of configurations.

    Raises:
        BadArgument: a shape that fits none of these, a mass that is negative, not finite or over
            :data:`MAX_PAYLOAD`, or a centre that is not finite or over
            :data:`~pincal.arguments.MAX_LENGTH`.
    """
    if payload is None:
        return np.zeros((m, 4))
    if isinstance(payload, Payload):
        return np.tile(payload.row, (m, 1))
    if isinstance(payload, (list, tuple)) and payload and all(isinstance(p, Payload) for p in payload):
        payload = np.array([p.row for p in payload])
    try:
        arr = np.array(payload, dtype=float)
    except (TypeError, ValueError):
        raise BadArgument(
            f"payload must be a mass [kg], a Payload, or one per configuration, got {payload!r}",
            argument="payload",
            value=payload,
        ) from None
    if arr.ndim == 0:
        arr = np.r_[arr, 0.0, 0.0, 0.0][None, :].repeat(m, axis=0)
    elif arr.ndim == 1 and len(arr) == m:
        arr = np.column_stack([arr, np.zeros((m, 3))])
    elif arr.shape == (1, 4):
        arr = arr.repeat(m, axis=0)
    if arr.shape != (m, 4):
        raise BadArgument(
            f"payload: expected a mass, {m} masses or {m} rows [kg, x, y, z] (one per configuration), "
            f"got shape {arr.shape}",
            argument="payload",
            valid=f"a mass, ({m},) or ({m}, 4)",
        )
    mass, centre = arr[:, 0], arr[:, 1:]
    bad = ~np.isfinite(mass) | (mass < 0) | (mass > MAX_PAYLOAD)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadArgument(
            f"payload {i}: mass {float(mass[i])!r} kg is not a mass from 0 to {MAX_PAYLOAD:g} kg",
            argument="payload",
            value=float(mass[i]),
            valid=(0.0, MAX_PAYLOAD),
        )
    bad = ~np.all(np.isfinite(centre) & (np.abs(centre) <= MAX_LENGTH), axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadArgument(
            f"payload {i}: centre of mass {centre[i].tolist()} m must be finite and within "
            f"{MAX_LENGTH:.0e} m of the tip",
            argument="payload",
        )
    return arr


def carried(loads: PayloadRows, m: int | None) -> np.ndarray:
    """The (m, 4) rows ``loads`` as they are (any number of rows when ``m`` is None), or m rows of
    zeros for None (nothing carried; one row when ``m`` is None): below
    the door, no copy, and only the shape checked, so that a mass or a :class:`Payload` given to a
    function below the door (:class:`~pincal.model.kinematics.ForwardKinematics`) is named, not
    a NumPy error.

    Raises:
        BadArgument: ``loads`` is not None nor (m, 4) rows.
    """
    if loads is None:
        return np.zeros((1 if m is None else m, 4))
    if not (isinstance(loads, np.ndarray) and loads.ndim == 2 and loads.shape[1] == 4) or (
        m is not None and len(loads) != m
    ):
        count = "" if m is None else f" for the {m} configuration(s)"
        given = f"an array of shape {loads.shape}" if isinstance(loads, np.ndarray) else f"{loads!r:.60}"
        raise BadArgument(
            f"payload: below pincal's payload door this takes (m, 4) rows [kg, x, y, z]{count}, got "
            f"{given}; turn a mass or a Payload into rows with "
            "pincal.model.statics.payload_rows(payload, m)",
            argument="payload",
        )
    return loads


def repeated(row: PayloadRows, n: int) -> PayloadRows:
    """(n, 4) the one payload row ``row`` (1, 4) carried at each of n configurations (a task's
    load, asked at any number of them), or None for None."""
    return None if row is None else np.repeat(row, n, axis=0)


def payload_columns(
    header: list[str], rows: np.ndarray, where: str, error: type[BadArgument] = BadArgument
) -> np.ndarray | None:
    """(m, 4) payload rows [kg, x, y, z] from a file's ``payload_*`` columns, or None without them:
    ``payload_kg``, with the centre ``payload_x,payload_y,payload_z`` (all three) or none of them.

    Raises:
        ``error`` naming ``where`` and the valid columns.
    """
    columns = [h for h in header if h.startswith("payload_")]
    if not columns:
        return None
    unknown = [c for c in columns if c not in PAYLOAD_COLUMNS]
    centre = [c for c in PAYLOAD_COLUMNS[1:] if c in columns]
    if unknown or "payload_kg" not in columns or len(centre) not in (0, 3):
        raise error(
            f"{where}: payload columns {','.join(columns)}; valid: payload_kg, with "
            f"payload_x,payload_y,payload_z (all three) or none of them"
        )
    out = np.zeros((len(rows), 4))
    for c, name in enumerate(PAYLOAD_COLUMNS):
        if name in columns:
            out[:, c] = rows[:, header.index(name)]
    return out


def mounted(model: pin.Model, gravity: ArrayLike) -> pin.Model:
    """A copy of ``model`` whose gravity is ``gravity`` (3,) [m/s²] in its base frame.

    Raises:
        BadArgument: not three finite numbers of at most :data:`MAX_GRAVITY` m/s².
    """
    try:
        g = np.array(gravity, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        g = np.full(1, np.nan)
    # each component first: the norm of 1e308 overflows
    if g.shape != (3,) or not np.all(np.abs(g) <= MAX_GRAVITY) or np.linalg.norm(g) > MAX_GRAVITY:
        raise BadArgument(
            f"gravity must be three finite numbers [m/s²] of at most {MAX_GRAVITY:g} m/s², got {gravity!r}",
            argument="gravity",
            value=gravity,
        )
    copy = pin.Model(model)
    copy.gravity = pin.Motion(g, np.zeros(3))
    return copy


def chain_mass(model: pin.Model) -> float:
    """Total mass of the bodies the chain's joints move [kg]."""
    return float(sum(model.inertias[j].mass for j in range(1, model.njoints)))


def require_masses(model: pin.Model, robot: str, what: str = "joint compliance") -> None:
    """Raise :class:`~pincal.errors.NoInertias` (one line naming ``robot`` and ``what`` needs the
    masses) when the chain's links carry no mass."""
    if chain_mass(model) < MASSLESS:
        raise NoInertias(
            f"{robot}: {what} needs the gravity torques on the joints, and this robot's URDF gives its "
            f"links no mass (no <inertial> elements); give a URDF with the links' masses and centres "
            f"of mass, or leave the compliance group out"
        )


class Gravity:
    """Gravity torques on the joints of one chain, for many configurations and payloads.

    Holds ``pinocchio.Data`` (and model copies loaded with each payload met so far): one per thread.

    Args:
        model: the chain's model (not modified; its ``gravity`` is used).
        tip_joint: the joint the tip frame is fixed to.
        tip_placement: the tip frame's placement in that joint's frame.
    """

    def __init__(self, model: pin.Model, tip_joint: int, tip_placement: pin.SE3) -> None:
        self.model = model
        self.tip_joint = tip_joint
        self.tip_placement = pin.SE3(tip_placement)
        self._loaded: dict[tuple[float, ...], tuple[pin.Model, pin.Data]] = {}

    def _with(self, row: np.ndarray) -> tuple[pin.Model, pin.Data]:
        """The model with payload ``row`` [kg, x, y, z] on the tip body, and a Data of it."""
        key = tuple(float(v) for v in row)
        cached = self._loaded.get(key)
        if cached is None:
            model = pin.Model(self.model)
            if row[0] > 0:
                centre = self.tip_placement.act(np.asarray(row[1:], dtype=float))
                model.inertias[self.tip_joint] = model.inertias[self.tip_joint] + pin.Inertia(
                    float(row[0]), centre, np.zeros((3, 3))
                )
            if len(self._loaded) >= 32:
                self._loaded.clear()
            cached = self._loaded[key] = (model, model.createData())
        return cached

    def torques(self, thetas: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """(m, nq) torques τ = −g(θ) [N·m or N] gravity applies at each joint.

        Args:
            thetas: (m, nq) actual joint values [rad or m].
            loads: (m, 4) payload rows [kg, x, y, z] (:func:`payload_rows`).
        """
        out = np.empty_like(thetas, dtype=float)
        rows, which = np.unique(loads, axis=0, return_inverse=True)
        gravity = pin.computeGeneralizedGravity
        for k, row in enumerate(rows):
            model, data = self._with(row)
            for i in np.flatnonzero(which.reshape(-1) == k):
                out[i] = -gravity(model, data, thetas[i])
        return out

    def torque_derivatives(self, theta: np.ndarray, load: np.ndarray) -> np.ndarray:
        """(nq, nq) ∂τ/∂θ at one configuration ``theta`` under the payload row ``load``
        (Pinocchio's derivatives of the generalized gravity, negated)."""
        model, data = self._with(np.asarray(load, dtype=float))
        return -pin.computeGeneralizedGravityDerivatives(model, data, np.asarray(theta, dtype=float))

    def deflected(self, start: np.ndarray, compliances: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """θ solving θ = start + c ⊙ τ(θ, w), by fixed-point iteration (see module doc).

        Args:
            start: (m, nq) q + Δq + k ⊙ q [rad or m].
            compliances: (nq,) c [rad/(N·m) or m/N].
            loads: (m, 4) payload rows.

        Raises:
            BadArgument: the iteration does not settle (compliances large enough to fold the arm).
        """
        theta = start + compliances * self.torques(start, loads)
        for _ in range(MAX_STATIC_STEPS):
            new = start + compliances * self.torques(theta, loads)
            step = float(np.max(np.abs(new - theta), initial=0.0))
            theta = new
            if step <= STATIC_TOLERANCE * max(1.0, float(np.max(np.abs(theta), initial=0.0))):
                return theta
        raise BadArgument(
            f"the joint compliances {np.asarray(compliances).tolist()} are too large for the static "
            f"deflection to settle (the arm would fold under gravity); industrial joints have "
            f"1e-7 to 1e-5 rad/(N·m)",
            argument="compliance",
        )
