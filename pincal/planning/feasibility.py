"""Constraints bound to one robot for a search: exact checks, the polish's constraints, sampling
and repair.

Private machinery of :mod:`pincal.design`; the constraint value objects themselves are in
:mod:`pincal.planning.constraints`.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pincal.errors import BadConstraint, Infeasible, warn
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.planning.constraints import (
    TOLERANCE,
    AnyConstraint,
    Constraint,
    JointLimits,
    Kinematics,
    LimitsBound,
    MinSpacing,
    joint_margins,
    spacing_of,
)
from pincal.typing import ArrayLike


class Feasibility:
    """The constraints of a design bound to one robot: exact checks, the polish's constraints,
    sampling, repair.

    Holds Pinocchio/coal data: use one per thread or process.

    Args:
        robot: the robot.
        constraints: any mix of the constraint objects of this module (joint limits always apply,
            with the largest JointLimits margin given at each joint).
    """

    def __init__(self, robot: Robot, constraints: Iterable[AnyConstraint] = ()) -> None:
        constraints = tuple(constraints)
        for c in constraints:
            if not isinstance(c, (Constraint, MinSpacing)):
                raise BadConstraint(f"not a constraint: {c!r} (use the classes of pincal.constraints)")
        self.robot = robot
        self.constraints = constraints
        self.margins = joint_margins(robot, constraints)
        self.limits = LimitsBound(robot, self.margins)
        self.lower, self.upper = self.limits.lower, self.limits.upper
        bound = [
            (c.key, c.bind(robot))
            for c in constraints
            if isinstance(c, Constraint) and not isinstance(c, JointLimits)
        ]
        self.bound = [(key, b) for key, b in bound if not b.empty]  # a mount 'none' checks nothing
        self.spacing = spacing_of(constraints)
        self.forward = ForwardKinematics(robot)

    @property
    def trivial(self) -> bool:
        """True when only the joint limits apply (the search's box bounds are enough)."""
        return not self.bound and self.spacing == 0

    @property
    def loaded(self) -> bool:
        """True when a payload moves the robot (it has joint compliances): the checks of a
        configuration then read the payload it carries; else every payload gives the same checks."""
        return self.forward.gravity is not None

    def kinematics(self, qs: np.ndarray, payload: np.ndarray | None = None) -> Kinematics:
        """The kinematics of the readings ``qs`` (m, nq) under the payload rows ``payload`` (m, 4)
        [kg, x, y, z] (None: none)."""
        return Kinematics(self.robot, qs, payload=payload, forward=self.forward)

    def feasible(self, qs: np.ndarray, strict: bool = False, payload: np.ndarray | None = None) -> np.ndarray:
        """(m,) True where a configuration satisfies every per-configuration constraint (``strict``:
        and every margin is positive; for collisions, the convex hulls apart too), under its
        payload row of ``payload`` (m, 4) [kg, x, y, z] (None: none)."""
        ok = self.limits.satisfied(_LimitsOnly(qs))  # type: ignore[arg-type]  # the limits read only q
        if self.bound and ok.any():
            idx = np.flatnonzero(ok)
            kin = self.kinematics(qs[idx], None if payload is None else payload[idx])
            for _, b in self.bound:
                ok[idx] &= b.strictly_satisfied(kin) if strict else b.satisfied(kin)
        return ok

    def feasible_pairs(
        self, qs: np.ndarray, loads: np.ndarray, strict: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """The (configuration, payload) candidates of a loaded design: each configuration of ``qs``
        (N, nq) paired with each payload row of ``loads`` (n, 4) [kg, x, y, z] it satisfies every
        constraint under (:meth:`feasible` with that payload; every pair when the payload moves
        nothing, :attr:`loaded` False): (configurations, payload rows), configuration by
        configuration, in the order of ``loads``."""
        pairs, rows = np.repeat(qs, len(loads), axis=0), np.tile(loads, (len(qs), 1))
        if not self.loaded:
            return pairs, rows
        ok = self.feasible(pairs, strict, payload=rows)
        return pairs[ok], rows[ok]

    def _feasible_any(self, qs: np.ndarray, loads: np.ndarray | None) -> np.ndarray:
        """(m,) :meth:`feasible` under no payload, or (``loads`` (n, 4) given and :attr:`loaded`)
        under at least one payload row of ``loads``."""
        if loads is None or not self.loaded:
            return self.feasible(qs)
        ok = np.zeros(len(qs), dtype=bool)
        for row in loads:
            ok |= self.feasible(qs, payload=np.tile(row, (len(qs), 1)))
        return ok

    def feasible_pool(
        self, pool: ArrayLike, m: int, loads: np.ndarray | None = None
    ) -> tuple[np.ndarray, int]:
        """The configurations of a user's pool that satisfy every constraint, and how many did not.

        Args:
            pool: (N, nq) configurations or a Plan [rad or m].
            m: configurations a plan needs: fewer feasible ones raise.
            loads: (n, 4) the payload rows [kg, x, y, z] a configuration may carry: it is kept when
                it satisfies every constraint under one of them at least (:meth:`feasible_pairs`
                then pairs it with those); None: under none.

        Raises:
            BadConfiguration: a pool configuration of the wrong shape or outside the joint limits.
            Infeasible: fewer than m pool configurations are feasible.
        """
        qs = self.robot.configurations(pool, what="pool configuration")
        ok = self._feasible_any(qs, loads)
        dropped = self._dropped_by(qs, ok, loads if self.loaded else None)
        if ok.sum() < m:
            raise Infeasible(
                f"only {int(ok.sum())} of the {len(qs)} pool configurations satisfy the constraints "
                f"({dropped}); {m} are needed"
            )
        if not ok.all():
            warn(
                f"{int((~ok).sum())} of the {len(qs)} pool configurations dropped ({dropped}): a robot "
                "that reached them while measuring is mounted otherwise than the default says: give its "
                "mount (--mount wall|ceiling|none|NX,NY,NZ,OFFSET; mount=) or its cell"
                if "mount" in dropped
                else f"{int((~ok).sum())} of the {len(qs)} pool configurations dropped ({dropped})"
            )
        return qs[ok], int((~ok).sum())

    def _dropped_by(self, qs: np.ndarray, ok: np.ndarray, loads: np.ndarray | None = None) -> str:
        """Which constraints drop the configurations not ``ok``, in words: ``"mount 241, joint
        limits 3"`` (a configuration counts under each constraint it breaks; with payload rows
        ``loads``, that it breaks under every one of them)."""
        bad = np.flatnonzero(~ok)
        if not len(bad):
            return "none"
        outside = ~self.limits.satisfied(_LimitsOnly(qs[bad]))  # type: ignore[arg-type]  # reads q only
        counts = {"joint limits (and their margins)": int(outside.sum())}
        kins = [
            self.kinematics(qs[bad], None if row is None else np.tile(row, (len(bad), 1)))
            for row in ([None] if loads is None else loads)
        ]
        for key, b in self.bound:
            broken = np.logical_and.reduce([~b.satisfied(kin) for kin in kins])
            counts[key.replace("_", " ")] = int(broken.sum())
        return ", ".join(f"{name} {n}" for name, n in counts.items() if n)

    def spacing_ok(self, qs: np.ndarray) -> bool:
        """True when every pair of configurations is at least the minimum spacing apart."""
        return self.spacing == 0 or bool(np.all(MinSpacing(self.spacing).margins(qs) >= -TOLERANCE))

    def plan_feasible(self, qs: np.ndarray) -> bool:
        """True when the whole plan satisfies every constraint."""
        return bool(self.feasible(qs).all()) and self.spacing_ok(qs)

    # ------------------------------------------------------------ the polish's constraints
    def constraint_values(self, qs: np.ndarray) -> np.ndarray:
        """(c,) every margin the continuous search keeps non-negative, each over its bound's reach
        and at most 1 (dimensionless: a margin beyond its reach does not bind, and a bound may
        give a lower bound of it there): the per-configuration bounds' margins, configuration by
        configuration, then the minimum spacing's pairs i < j."""
        parts = [self._scaled_margins(qs).ravel()] if self.bound else []
        if self.spacing > 0 and len(qs) > 1:
            parts.append(np.minimum(MinSpacing(self.spacing).margins(qs) / MinSpacing.reach, 1.0))
        return np.concatenate(parts) if parts else np.zeros(0)

    def constraint_jacobian(self, qs: np.ndarray, step: float = 1e-5) -> np.ndarray:
        """(c, m·nq) the derivatives of :meth:`constraint_values` with respect to the joint values.

        A configuration's margins depend on its own joints only: central differences on the joints
        of every configuration, in one batch of m·2nq configurations. The spacing's rows are
        analytic.
        """
        m, nq = qs.shape
        blocks = []
        if self.bound:
            h = step * np.eye(nq)
            batch = np.concatenate([qs[None] + h[:, None], qs[None] - h[:, None]]).reshape(-1, nq)
            v = self._scaled_margins(batch).reshape(2, nq, m, -1)
            k = v.shape[3]
            J = np.zeros((m, k, m, nq))
            every = np.arange(m)
            J[every, :, every, :] = ((v[0] - v[1]) / (2 * step)).transpose(1, 2, 0)
            blocks.append(J.reshape(m * k, m * nq))
        if self.spacing > 0 and m > 1:
            i, j = np.triu_indices(m, 1)
            diff = qs[i] - qs[j]
            norm = np.linalg.norm(diff, axis=1)
            near = (norm - self.spacing) / MinSpacing.reach < 1.0
            unit = near[:, None] * diff / np.maximum(norm, 1e-300)[:, None] / MinSpacing.reach
            S = np.zeros((len(i), m, nq))
            pairs = np.arange(len(i))
            S[pairs, i] = unit
            S[pairs, j] = -unit
            blocks.append(S.reshape(len(i), m * nq))
        return np.concatenate(blocks) if blocks else np.zeros((0, m * nq))

    def _scaled_margins(self, qs: np.ndarray) -> np.ndarray:
        """(n, k) the per-configuration bounds' margins over their reach, at most 1."""
        kin = self.kinematics(qs)
        return np.minimum(np.concatenate([b.margins(kin) / b.reach for _, b in self.bound], axis=1), 1.0)

    # ------------------------------------------------------------------------ sampling
    def sample(
        self,
        n: int,
        rng: np.random.Generator,
        minimum: int | None = None,
        max_tries: int | None = None,
        strict: bool = False,
        loads: np.ndarray | None = None,
    ) -> np.ndarray:
        """Up to ``n`` random feasible configurations (uniform within the limits, then filtered).

        Args:
            n: number wanted.
            rng: the random generator.
            minimum: fewest acceptable (default ``n``); stop trying after ``max_tries`` draws.
            max_tries: random draws allowed (default max(100000, 50 n)).
            strict: keep only strictly feasible configurations (see :meth:`feasible`).
            loads: (r, 4) payload rows [kg, x, y, z]: keep the configurations feasible under one
                of them at least (when the payload moves the robot, :attr:`loaded`; the pairs are
                then :meth:`feasible_pairs`); None: under none.

        Raises:
            Infeasible: fewer than ``minimum`` found; the message says which constraint rejected
                the most draws.
        """
        minimum = n if minimum is None else minimum
        max_tries = max(100_000, 50 * n) if max_tries is None else max_tries
        found: list[np.ndarray] = []
        count, tried = 0, 0
        rejected: dict[str, int] = {}
        while count < n and tried < max_tries:
            size = int(min(max_tries - tried, max(256, 2 * (n - count)), 20_000))
            qs = self._inside_margins(self.robot.random_configurations(size, rng))
            tried += size
            ok = np.ones(size, dtype=bool)
            if self.bound:
                ok, turned = self._screen(qs, strict, loads if self.loaded else None)
                for key, n_out in turned.items():
                    rejected[key] = rejected.get(key, 0) + n_out
            found.append(qs[ok])
            count += int(ok.sum())
        if count < minimum:
            worst = sorted(rejected.items(), key=lambda kv: -kv[1])
            detail = ", ".join(f"{k} rejected {v} ({100 * v / tried:.3g} %)" for k, v in worst)
            raise Infeasible(
                f"only {count} of {tried} random configurations within the joint limits satisfy the "
                f"constraints ({minimum} needed): {detail or 'no constraint'}; relax the constraints"
            )
        return np.concatenate(found)[:n]

    def _screen(
        self, qs: np.ndarray, strict: bool, loads: np.ndarray | None
    ) -> tuple[np.ndarray, dict[str, int]]:
        """(m,) which draws ``qs`` (within the limits) satisfy every bound (``loads``: under one
        payload row at least), and how many each bound turned away: the bounds in turn, each on
        the draws the ones before kept (a draw counts under a bound when it turns it away under
        every payload)."""
        size = len(qs)
        ok = np.zeros(size, dtype=bool)
        turned: dict[str, np.ndarray] | None = None
        for row in [None] if loads is None else loads:
            kin = self.kinematics(qs, None if row is None else np.tile(row, (size, 1)))
            kept, out = np.ones(size, dtype=bool), {}
            for key, b in self.bound:
                idx = np.flatnonzero(kept)
                if not len(idx):
                    break
                sub = kin if len(idx) == size else kin.subset(idx)
                s = b.strictly_satisfied(sub) if strict else b.satisfied(sub)
                out[key] = np.zeros(size, dtype=bool)
                out[key][idx[~s]] = True
                kept[idx[~s]] = False
            ok |= kept
            turned = out if turned is None else {k: turned[k] & out[k] for k in turned if k in out}
        return ok, {key: int(mask.sum()) for key, mask in (turned or {}).items()}

    def _inside_margins(self, qs: np.ndarray) -> np.ndarray:
        """Uniform draws within the joint limits (:meth:`Robot.sampled_range`) mapped onto the limits
        shrunk by each joint's margin (the margins differ between revolute and prismatic joints)."""
        lo0, hi0 = self.robot.sampled_range()
        lo, hi = lo0 + self.margins, hi0 - self.margins
        if np.any(hi < lo):
            j = int(np.argmax(lo - hi))
            raise Infeasible(
                f"joint limit margin {self.margins[j]:g} leaves no room between the limits of joint "
                f"{self.robot.joint_names[j]}"
            )
        span = np.where(hi0 > lo0, hi0 - lo0, 1.0)
        return lo + (qs - lo0) / span * (hi - lo)

    # -------------------------------------------------------------------------- repair
    def repair(self, start: np.ndarray, end: np.ndarray, iterations: int = 40) -> np.ndarray:
        """A feasible plan on the way from the feasible plan ``start`` to ``end``.

        Each infeasible configuration of ``end`` is moved back along the straight joint-space
        segment to its start, to the last feasible point bisection finds; if the plan then breaks
        the spacing, the whole plan is moved back the same way.
        """
        q = np.array(end, dtype=float)
        bad = np.flatnonzero(~self.feasible(q))
        if len(bad):
            lo, hi = np.zeros(len(bad)), np.ones(len(bad))
            a, d = start[bad], end[bad] - start[bad]
            for _ in range(iterations):
                mid = 0.5 * (lo + hi)
                ok = self.feasible(a + mid[:, None] * d)
                lo = np.where(ok, mid, lo)
                hi = np.where(ok, hi, mid)
            q[bad] = a + lo[:, None] * d
        if not self.spacing_ok(q):
            low, high, d = 0.0, 1.0, q - start
            for _ in range(iterations):
                middle = 0.5 * (low + high)
                if self.plan_feasible(start + middle * d):
                    low = middle
                else:
                    high = middle
            q = start + low * d
        return q


class _LimitsOnly:
    """The part of Kinematics the joint-limit check reads."""

    def __init__(self, qs: np.ndarray) -> None:
        self.qs = qs
