"""The least-squares problem of identification: residuals and their analytic Jacobian.

Unknowns z = (x, b₂, ..., b_S): x the values of a :class:`~pincal.ParameterSet` (total errors
relative to the nominal robot, docs/method.md §2) shared by every session, and, when the set holds
``base.*``, one more base for each extra session (data file measured from another instrument
placement): session s uses x with its base components replaced by b_s. The points of session s are
the markers of the robot ``params.apply(x_s)`` at q_s under w_s, the payload rows of the data (none
when they have no payload columns); for another measurement kind (a pose, distances, pixels:
:mod:`pincal.instruments`) its values are the kind's prediction on that robot, the residual its
difference (a rotation's composed, not subtracted) and the Jacobian its rows. A value not measured
(a target point out of view) has a zero residual and zero rows.

Rotation errors (of origins, the base, the fixtures) compose on the right, R·exp3(ω): the
Jacobian with respect to ω is the Jacobian of a perturbation on top of the current robot
(:meth:`ParameterSet.on`, Pinocchio's kinematic regressor) times the right Jacobian of exp3.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from pincal.calibration.measurements import MeasurementData
from pincal.calibration.noise import Noise
from pincal.instruments.pose import Pose
from pincal.model.jacobian import JacobianEngine
from pincal.model.kinematics import ForwardKinematics
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows


class Problem:
    """measured − model over sessions, with the noise of the measured coordinates.

    Attributes:
        params: the shared parameter set.
        sessions: the data of each session, in the robot's joint order.
        noise: the noise of the measured coordinates (their weights), sessions stacked.
        base: indices of the ``base.*`` parameters in ``params``.
        names: the name of each unknown (``base2.tx`` ... for the bases of extra sessions).
        units: the unit of each unknown.
        kind: the measurement kind of every session.
        points: the sessions measure points (today's arithmetic throughout).
        blocks: the values of a row that belong together (a marker's, a target point's), or None
            for points (three coordinates per marker).
        value_units: the unit of each value of a row (``m``, ``rad``, ``px``).
        measured: (N,) the measured coordinates, sessions stacked.
        labels: how messages name each row (configuration), sessions stacked: file and line.
    """

    def __init__(self, params: ParameterSet, sessions: Sequence[MeasurementData], noise: Noise) -> None:
        self.params = params
        self.sessions = tuple(sessions)
        self.noise = noise
        self.labels = tuple(label for d in self.sessions for label in d.labels())
        self.base = [i for i, p in enumerate(params) if p.kind == "base"]
        extra = [(s, params.names[i]) for s in range(2, len(self.sessions) + 1) for i in self.base]
        self.names = params.names + tuple(f"base{s}.{name.split('.', 1)[1]}" for s, name in extra)
        self.units = params.units + tuple(params.units[i] for i in self.base) * (len(self.sessions) - 1)
        self.kind = self.sessions[0].measure
        self.points = self.sessions[0].is_points
        self.blocks = None if self.points else self.kind.blocks(params.robot)
        self.value_units = self.kind.units(params.robot)
        self.measured = np.concatenate([d.values.reshape(-1) for d in self.sessions])
        self._rows = np.cumsum([0] + [d.values.size for d in self.sessions])
        self.linear = Linearisation(params)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def m(self) -> int:
        """The number of rows (measured configurations), sessions stacked."""
        return len(self.labels)

    def session_values(self, z: np.ndarray, s: int) -> np.ndarray:
        """x_s: the parameter values session s uses (its own base)."""
        x = np.array(z[: len(self.params)])
        if s > 0 and self.base:
            nb = len(self.base)
            start = len(self.params) + (s - 1) * nb
            x[self.base] = z[start : start + nb]
        return x

    def robot(self, z: np.ndarray, s: int = 0) -> Robot:
        """The robot of session s (its base) for unknowns z."""
        return self.params.apply(self.session_values(z, s))

    def model(self, z: np.ndarray) -> np.ndarray:
        """(N,) model coordinates, sessions stacked."""
        if not self.points:
            return np.concatenate(
                [
                    self.kind.predict(self.robot(z, s), d.q, d.payload).reshape(-1)
                    for s, d in enumerate(self.sessions)
                ]
            )
        return np.concatenate(
            [
                ForwardKinematics(self.robot(z, s)).markers(d.q, d.payload).reshape(-1)
                for s, d in enumerate(self.sessions)
            ]
        )

    def residual(self, z: np.ndarray) -> np.ndarray:
        """(N,) measured − model [m, rad or px] (0 where nothing was measured)."""
        if not self.points:
            parts = [
                self.kind.difference(d.values, self.kind.predict(self.robot(z, s), d.q, d.payload)).reshape(
                    -1
                )
                for s, d in enumerate(self.sessions)
            ]
            return np.nan_to_num(np.concatenate(parts), nan=0.0)
        return self.measured - self.model(z)

    def _jacobian_x(self, x: np.ndarray, data: MeasurementData) -> np.ndarray:
        if self.points:
            J = self.linear.points(x, data.q, data.payload)
            return J.reshape(-1, J.shape[-1])
        engine = self.linear.engine(x)
        J = self.kind.rows(engine, data.q, data.payload)
        J = np.where(np.isfinite(data.values)[..., None], J, 0.0)
        return J.reshape(-1, J.shape[-1]) @ self.linear.mapping(x)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """(N, len(self)) derivative of the model coordinates with respect to z (= −∂r/∂z)."""
        P, nb = len(self.params), len(self.base)
        out = np.zeros((self.measured.size, len(self)))
        for s, data in enumerate(self.sessions):
            rows = slice(self._rows[s], self._rows[s + 1])
            Jx = self._jacobian_x(self.session_values(z, s), data)
            if s == 0 or not nb:
                out[rows, :P] = Jx
            else:
                shared = [i for i in range(P) if i not in self.base]
                out[rows, shared] = Jx[:, shared]
                start = P + (s - 1) * nb
                out[rows, start : start + nb] = Jx[:, self.base]
        return out


class Linearisation:
    """The Jacobian of a parameter set's model at any values x of it, not only at the nominal robot.

    The columns are those of a perturbation on top of the robot ``params.apply(x)`` (Pinocchio's
    kinematic regressor on it: :meth:`ParameterSet.on`), mapped to the parameters' own
    coordinates: a rotation error composes on the right, R·exp3(ω), so its columns are the
    perturbation's times the right Jacobian of exp3 at ω (every rotation needs its three columns:
    the set is augmented with those it lacks). At x = 0 it is ``params.jacobian``; at a fit's
    values it is the Jacobian of the fitted model, the one its covariance belongs to (a prediction
    made with it does not depend on where the nominal robot put its base, docs/method.md §11.6).
    """

    def __init__(self, params: ParameterSet) -> None:
        self.params = params
        groups: dict[tuple[str, int], list[int]] = {}
        for i, p in enumerate(params.parameters):
            rotation = p.kind in ("placement", "base") or (
                p.kind == "fixture" and not params.robot.fixtures[p.index].point
            )
            if rotation and p.component >= 3:
                groups.setdefault((p.kind, p.index), []).append(i)
        extra_names = []
        for kind, index in groups:
            name = _placement_name(params.robot, kind, index)
            extra_names += [f"{name}.{c}" for c in ("rx", "ry", "rz")]
        self.augmented = ParameterSet.from_spec(params.robot, list(params.names) + extra_names)
        self.D0 = np.zeros((len(self.augmented), len(params)))
        for i, name in enumerate(params.names):
            self.D0[self.augmented.index(name), i] = 1.0
        self.rotations = []  # (augmented columns of rx ry rz, set columns, their components 0..2)
        for (kind, index), cols in groups.items():
            name = _placement_name(params.robot, kind, index)
            aug = [self.augmented.index(f"{name}.{c}") for c in ("rx", "ry", "rz")]
            self.rotations.append((aug, cols, [params.parameters[i].component - 3 for i in cols]))

    def engine(self, x: np.ndarray) -> JacobianEngine:
        """The Jacobian engine of the augmented set on the robot of values ``x``."""
        return JacobianEngine(self.augmented.on(self.params.apply(x)))

    def mapping(self, x: np.ndarray) -> np.ndarray:
        """(augmented, P) the map from the augmented perturbation's columns to the set's at ``x``."""
        D = self.D0.copy()
        for aug, cols, comps in self.rotations:
            omega = np.zeros(3)
            omega[comps] = x[cols]
            Jr = pin.Jexp3(omega)
            for col, comp in zip(cols, comps, strict=True):
                D[aug, col] = Jr[:, comp]
        return D

    def points(
        self,
        x: np.ndarray,
        qs: np.ndarray,
        payload: PayloadRows = None,
        engine: JacobianEngine | None = None,
        mapping: np.ndarray | None = None,
    ) -> np.ndarray:
        """(m, 3K, P) the markers' Jacobian in the instrument's frame at joint readings ``qs`` for the
        robot of values ``x`` (``engine`` and ``mapping``: those of :meth:`engine` and :meth:`mapping`
        at x, when the caller keeps them)."""
        engine = self.engine(x) if engine is None else engine
        D = self.mapping(x) if mapping is None else mapping
        J = engine.jacobian(qs, frame="world", payload=payload)
        return (J.reshape(-1, J.shape[-1]) @ D).reshape(J.shape[0], J.shape[1], D.shape[1])


def _placement_name(robot: Robot, kind: str, index: int) -> str:
    """The name of a placement's parameters: ``base``, an origin's, a fixture's."""
    if kind == "base":
        return "base"
    return robot.fixtures[index].name if kind == "fixture" else robot.origins[index].name


def _kabsch(source: np.ndarray, target: np.ndarray, reflection: bool) -> tuple[np.ndarray, np.ndarray] | None:
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    A, B = source - cs, target - ct
    if np.linalg.matrix_rank(A, tol=1e-9 * max(np.abs(A).max(), 1e-300)) < 2:
        return None
    U, _, Vt = np.linalg.svd(A.T @ B)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    d = -d if reflection else d  # det R = d·det(VᵀUᵀ)... = +1 (rotation) or −1 (mirror)
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, ct - R @ cs


def rigid_fit(source: np.ndarray, target: np.ndarray) -> pin.SE3 | None:
    """The rigid motion T minimising Σ‖T·source − target‖² (Kabsch), or None if degenerate."""
    fit = _kabsch(source, target, reflection=False)
    return None if fit is None else pin.SE3(*fit)


def fit_rms(source: np.ndarray, target: np.ndarray, mirror: bool = False) -> float:
    """RMS distance [m] left by the best rigid motion (``mirror=True``: the best motion composed
    with a reflection, as when two coordinate columns are swapped) of (n, 3) ``source`` onto
    ``target``; inf if degenerate."""
    fit = _kabsch(source, target, reflection=mirror)
    if fit is None:
        return float("inf")
    R, t = fit
    return float(np.sqrt(np.mean(np.sum((source @ R.T + t - target) ** 2, axis=1))))


def initial_values(problem: Problem) -> np.ndarray:
    """Zero errors, except each session's base from a rigid fit (Kabsch) of the nominal points
    onto the measured ones, when base.* is identified: the linearisation then holds even when the
    instrument is metres away and rotated."""
    z0 = np.zeros(len(problem))
    if not problem.base:
        return z0
    robot = problem.params.robot
    components = [problem.params.parameters[i].component for i in problem.base]
    P, nb = len(problem.params), len(problem.base)
    for s, data in enumerate(problem.sessions):
        measured = measured_points(data)
        if measured is None:  # no positions to fit the base to: it starts at the identity
            continue
        fit = rigid_fit(robot.points(data.q, check=False).reshape(-1, 3), measured.reshape(-1, 3))
        if fit is None:
            continue
        new = fit * robot.base
        twist = np.concatenate(
            [new.translation - robot.base.translation, pin.log3(robot.base.rotation.T @ new.rotation)]
        )
        cols = problem.base if s == 0 else list(range(P + (s - 1) * nb, P + s * nb))
        z0[cols] = twist[components]
    return z0


def measured_points(data: MeasurementData) -> np.ndarray | None:
    """(m, K, 3) the measured positions of the markers: the points, a pose's positions; None for the
    other kinds."""
    if data.is_points:
        return data.points
    if isinstance(data.kind, Pose):
        return data.values.reshape(data.m, -1, 6)[:, :, :3]
    return None
