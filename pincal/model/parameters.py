"""Parameters: the errors a calibration identifies, with stable readable names.

Conventions (docs/method.md §2, chosen to match URDF):

* ``<joint>.tx|ty|tz``: error of the joint's URDF ``<origin>`` xyz, in the parent link's
  coordinates (t ← t + δt) [m].
* ``<joint>.rx|ry|rz``: small rotation about the joint frame's own axes (R ← R·exp3(δω)) [rad].
* ``<joint>.offset``: joint zero error, q ← q + Δq [rad, or m for a prismatic joint].
* ``<tip>.tx ... rz``: the same six for the tip frame's placement on the last link (the URDF
  fixed joint whose child is the tip).
* ``marker<k>.x|y|z``: error of measured point k, in the tip frame [m].
* ``base.tx ... rz``: placement of the robot base in the instrument frame (translation in the
  instrument's coordinates, rotation about the base's own axes) — for measurements expressed in
  the instrument's frame.

* ``<fixture>.tx ... rz`` (``<fixture>.x|y|z`` for a point): the placement of a part of the
  measurement set-up (a camera, its target, a draw-wire's anchor: :mod:`pincal.model.fixtures`),
  with the conventions of a joint origin, in the frame it is fixed to (the tip or the instrument's).

* ``<joint>.gain``: the joint moves by q·(1 + gain) for a reading q (dimensionless; method §11.1).
* ``<joint>.compliance``: the joint yields by compliance·τ to the torque τ gravity applies on it
  through the links and the payload [rad/(N·m), or m/N for a prismatic joint]
  (:mod:`pincal.model.statics`, method §11.2). It needs the links' masses: a robot whose URDF has
  none is refused.

Groups: ``offsets`` (one per joint), ``lengths`` (each non-zero component of each origin's xyz on
the chain, the tip's included), ``full`` (all six of every origin, the tip's included), ``base``,
``markers``, ``gains``, ``compliance``, ``instrument`` (every fixture's), and each fixture by its
name; any mix of groups and names, separated by commas. Whatever the order asked, a set keeps the
canonical order: chain order, tx ty tz rx ry rz offset per joint, then tip, markers, base, gains,
compliances, fixtures.

Compliance columns of the Jacobian are large (a torque of 1e3 N·m times a lever of 1 m) and their
values small (1e-6 rad/(N·m)): :attr:`ParameterSet.scales` gives each parameter a natural scale, a
reference torque for a compliance and 1 otherwise, so that values × scales are all rad- or m-sized
and the columns / scales all of the size of the geometric ones.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, UnknownParameter
from pincal.model.base_parameters import NEARLY_REDUNDANT, identifiability
from pincal.model.catalogue import GROUPS, Parameter, catalogue, group, split_spec
from pincal.model.jacobian import analytic_jacobian, finite_difference_jacobian
from pincal.model.statics import payload_rows, require_masses
from pincal.typing import ConfigurationsLike, PayloadLike, SeedLike

if TYPE_CHECKING:  # a Robot builds its ParameterSets (Robot.parameters): robot.py imports this module
    from pincal.model.robot import Robot

__all__ = ["Parameter", "ParameterSet"]

REFERENCE_CONFIGURATIONS = 200
"""Random configurations (seed 0) over which a compliance's reference torque is taken."""

UNLOADED = 1e-9
"""A joint whose RMS gravity torque is below this fraction of the largest one is never loaded (a
vertical first axis): its compliance's scale is 1."""


@dataclass(frozen=True, eq=False)
class ParameterSet:
    """An ordered set of geometric parameters of one robot.

    Build one with :meth:`Robot.parameters` (``robot.parameters("lengths,offsets")``). Values of
    the parameters are always *errors*, ΔΠ, relative to the robot's current geometry.

    Attributes:
        robot: the robot whose geometry is perturbed.
        parameters: the parameters, in canonical order.
    """

    robot: Robot
    parameters: tuple[Parameter, ...]

    @classmethod
    def from_spec(cls, robot: Robot, spec: str | Iterable[str]) -> ParameterSet:
        """Parameters named by groups and/or names, comma-separated (see module doc)."""
        every = catalogue(robot)
        by_name = {p.name: p for p in every}
        groups = GROUPS + tuple(f.name for f in robot.fixtures)
        chosen: set[str] = set()
        tokens = split_spec(spec)
        if not tokens:
            raise UnknownParameter("", list(groups) + list(by_name))
        for token in tokens:
            if token in groups:
                chosen.update(p.name for p in group(robot, every, token))
            elif token in by_name:
                chosen.add(token)
            else:
                raise UnknownParameter(token, list(groups) + list(by_name))
        if not chosen:
            raise BadArgument(f"parameter set {spec!r} is empty for robot {robot.name!r}")
        parameters = tuple(p for p in every if p.name in chosen)
        if any(p.kind == "compliance" for p in parameters):
            require_masses(robot.model, robot.name)
        return cls(robot, parameters)

    # ---------------------------------------------------------------------- naming
    @cached_property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in order."""
        return tuple(p.name for p in self.parameters)

    def __len__(self) -> int:
        return len(self.parameters)

    def __iter__(self):
        return iter(self.parameters)

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def index(self, name: str) -> int:
        """Position of parameter ``name`` in this set."""
        try:
            return self.names.index(name)
        except ValueError:
            raise UnknownParameter(name, self.names) from None

    def select(self, names: str | Iterable[str]) -> ParameterSet:
        """The subset named by ``names`` (names or groups, as in :meth:`Robot.parameters`)."""
        sub = ParameterSet.from_spec(self.robot, names)
        outside = [n for n in sub.names if n not in self.names]
        if outside:
            raise UnknownParameter(outside[0], self.names)
        return sub

    def on(self, robot: Robot) -> ParameterSet:
        """The same parameters on another robot of the same structure (e.g. a perturbed one)."""
        return ParameterSet(robot, self.parameters)

    @cached_property
    def units(self) -> tuple[str, ...]:
        """Unit of each parameter (``"m"``, ``"rad"``, ``"1"``, ``"rad/(N·m)"`` or ``"m/N"``)."""
        return tuple(p.unit for p in self.parameters)

    @cached_property
    def scales(self) -> np.ndarray:
        """(P,) natural scale of each parameter: a compliance's reference torque [N·m or N] (the
        root-mean-square gravity torque on its joint over the joint ranges, without payload; 1 when
        gravity never loads the joint), 1 for every other parameter. ``values * scales`` are all
        in rad or m (a compliance's: its deflection at the reference torque), and the Jacobian's
        ``J / scales`` has columns of comparable size. Read-only."""
        out = np.ones(len(self))
        joints = [(i, p.index) for i, p in enumerate(self.parameters) if p.kind == "compliance"]
        if joints:
            qs = self.robot.random_configurations(REFERENCE_CONFIGURATIONS, 0)
            tau = self.robot.joint_torques(qs, check=False)
            rms = np.sqrt(np.mean(tau**2, axis=0))
            for i, j in joints:
                out[i] = rms[j] if rms[j] > UNLOADED * max(rms.max(), 1e-300) else 1.0
        out.flags.writeable = False
        return out

    def __repr__(self) -> str:
        return f"ParameterSet({len(self)} parameters of {self.robot.name!r}: {', '.join(self.names)})"

    # -------------------------------------------------------------------- applying
    def _values(self, values: Sequence[float] | np.ndarray) -> np.ndarray:
        try:
            arr = np.array(values, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise BadArgument(f"parameter values must be numbers, got {values!r}") from None
        if arr.shape != (len(self),):
            raise BadArgument(
                f"expected {len(self)} parameter values ({', '.join(self.names)}), got {arr.size}"
            )
        if not np.all(np.isfinite(arr)):
            raise BadArgument("parameter values must be finite")
        return arr

    def as_dict(self, values: Sequence[float] | np.ndarray) -> dict[str, float]:
        """``{name: value}`` for a vector of values of this set."""
        return dict(zip(self.names, map(float, self._values(values))))

    def apply(self, values: Sequence[float] | np.ndarray) -> Robot:
        """A new Robot whose geometry is this robot's with errors ``values`` added.

        The caller's robot and model are not touched. Translations add; rotations compose on the
        right (R ← R·exp3(δω)); offsets, gains, compliances and marker errors add.
        """
        dx = self._values(values)
        robot = self.robot
        n_origins = len(robot.origins)
        placement = np.zeros((n_origins, 6))
        offsets = np.array(robot.joint_offsets)
        gains = np.array(robot.joint_gains)
        compliances = np.array(robot.joint_compliances)
        markers = np.array(robot.markers)
        base = np.zeros(6)
        fixtures = np.zeros((len(robot.fixtures), 6))
        for p, v in zip(self.parameters, dx):
            if p.kind == "placement":
                placement[p.index, p.component] += v
            elif p.kind == "offset":
                offsets[p.index] += v
            elif p.kind == "marker":
                markers[p.index, p.component] += v
            elif p.kind == "gain":
                gains[p.index] += v
            elif p.kind == "compliance":
                compliances[p.index] += v
            elif p.kind == "fixture":
                fixtures[p.index, p.component] += v
            else:
                base[p.component] += v
        model = pin.Model(robot.model)
        for o, origin in enumerate(robot.origins):
            if not placement[o].any():
                continue
            new = origin.parent * _perturb(origin.origin, placement[o])
            if o < robot.nq:
                model.jointPlacements[origin.joint] = new
            else:
                _move_tip(model, robot.tip_frame, new)
        return robot.replace(
            model=model,
            joint_offsets=offsets,
            joint_gains=gains,
            joint_compliances=compliances,
            markers=markers,
            base=_perturb(robot.base, base),
            fixtures=tuple(f.moved(d) if d.any() else f for f, d in zip(robot.fixtures, fixtures)),
        )

    # ---------------------------------------------------------------- derivatives
    @keywords_after(2)
    def jacobian(
        self,
        plan: ConfigurationsLike,
        *,
        method: str = "analytic",
        frame: str = "world",
        payload: PayloadLike = None,
    ) -> np.ndarray:
        """Parameter Jacobian ∂p/∂Π at each configuration of ``plan``.

        Args:
            plan: (nq,) or (m, nq) joint values, or a :class:`~pincal.Plan`.
            method: ``"analytic"`` (Pinocchio's kinematic regressor, one forward-kinematics pass
                per configuration) or ``"fd"`` (central finite differences on perturbed copies).
            frame: ``"world"`` (the instrument's frame) or ``"tip"`` (each configuration's rows in
                its tip frame: the same information matrix, cheaper).
            payload: the payload at each configuration (see
                :func:`~pincal.model.statics.payload_rows`; default none): it changes the gravity
                torques, hence the compliance columns and, on a compliant robot, the joint values.

        Returns:
            (m, 3K, P) array: for configuration i, rows 3k..3k+2 are marker k's x, y, z;
            ``J.reshape(-1, P)`` is the stacked Jacobian.
        """
        qs = self.robot.configurations(plan)
        loads = payload_rows(payload, len(qs))  # the door: rows below
        if method == "analytic":
            return analytic_jacobian(self, qs, frame=frame, payload=loads)
        if method == "fd":
            if frame != "world":
                raise BadArgument("finite differences give world-frame rows only (frame='world')")
            return finite_difference_jacobian(self, qs, payload=loads)
        raise BadArgument(f"unknown Jacobian method {method!r}; valid: analytic, fd")

    @keywords_after(1)
    def identifiable(
        self,
        *,
        n_configurations: int = 200,
        seed: SeedLike = 0,
        tol: float = NEARLY_REDUNDANT,
        prefer: str | Iterable[str] = (),
        payloads: Sequence[PayloadLike] | None = None,
        rows: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
        measured: str = "position",
        configurations: np.ndarray | None = None,
    ):
        """Which of these parameters the measurements can identify (by default, the markers'
        positions; ``rows`` gives another instrument's, see :func:`pincal.instruments.identifiable`).

        See :func:`pincal.model.base_parameters.identifiability`.
        """
        return identifiability(
            self,
            n_configurations=n_configurations,
            seed=seed,
            tol=tol,
            prefer=prefer,
            payloads=payloads,
            rows=rows,
            measured=measured,
            configurations=configurations,
        )


def _perturb(placement: pin.SE3, twist: np.ndarray) -> pin.SE3:
    """(R·exp3(δω), t + δt) for twist = (δt, δω): the convention of docs/method.md §2.1."""
    return pin.SE3(
        placement.rotation @ pin.exp3(np.asarray(twist[3:], dtype=float)),
        placement.translation + np.asarray(twist[:3], dtype=float),
    )


def _move_tip(model: pin.Model, tip_frame: int, placement: pin.SE3) -> None:
    """Set the tip frame's placement (and its URDF fixed-joint frame's, which coincides)."""
    tip = model.frames[tip_frame]
    old = pin.SE3(tip.placement)
    parent = tip.parentFrame
    if (
        0 < parent < len(model.frames)
        and model.frames[parent].type == pin.FIXED_JOINT
        and model.frames[parent].placement.isApprox(old)
    ):
        fixed = model.frames[parent]
        fixed.placement = placement
        model.frames[parent] = fixed
    tip.placement = placement
    model.frames[tip_frame] = tip
