"""Parameter Jacobians J = ∂p/∂Π of the measured points (docs/method.md §3).

Analytic: a perturbation of origin j moves the tip like a virtual 6-dof joint at F_j = oM_parent(j)·M_j
(before joint j's motion). Pinocchio's kinematic regressor gives, in one call per configuration
(after one forward-kinematics pass), the tip's twist for a twist of *every* joint placement. Each
parameter is then a constant combination of those columns:

* ``tx|ty|tz`` of origin j: the twist (R_Lᵀ e, 0) of placement j, R_L the URDF origin's rotation;
* ``rx|ry|rz``: the twist (0, e);
* ``offset``: the joint's motion axis S_j (the joint's own Jacobian column);
* ``gain`` and ``compliance``: the same column times, per configuration, ∂θ_j/∂k_j = q_j (the
  reading) and ∂θ_j/∂c_j = τ_j(θ, w) (the gravity torque on the joint under the payload w,
  :mod:`pincal.model.statics`). These are first order in the compliances: the exact derivative
  carries (I − C ∂τ/∂θ)⁻¹, which differs from I by ‖C ∂τ/∂θ‖, about 1e-3 on industrial arms, and
  is I at zero compliance;
* the tip's own placement: a twist of the tip frame itself (identity columns);

and a marker m_k moves by v + ω × m_k for a tip twist (v, ω). So, in the tip frame,
J_i = G · Reg_i · C + const, with G = [I, −[m_k]×] stacked over markers and C, const fixed for the
parameter set. World rows are those rotated by the tip's orientation.

On a robot with gains or compliances every column is taken at the joints' actual values θ (the
static solution), not at q + offsets.

Finite differences: central differences of the measured points of perturbed robot *copies*
(:meth:`ParameterSet.apply`), step 1e-6 in the parameter's natural scale
(:attr:`ParameterSet.scales`), for checking.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument
from pincal.model.kinematics import ForwardKinematics
from pincal.model.statics import PayloadRows, carried

FD_STEP = 1e-6
"""Central finite-difference step [m or rad]."""

CHUNK = 16
"""Configurations whose regressors the Jacobian engine keeps before copying them into its array
(a few, so that they stay in cache: 256 at a time cost a fifth more on 12 000 configurations)."""

ZERO_COLUMN = 1e-9
"""A Jacobian column this much smaller than the largest is zero: rounding noise, as for the offset
of a joint whose axis passes through the measured point (a hidden parameter)."""


def unit_columns(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, visible): the stacked (rows, P) Jacobian with unit-norm columns, and which columns are
    visible; a column below ZERO_COLUMN × the largest norm is invisible and set to zero."""
    norms = np.linalg.norm(J, axis=0)
    visible = norms > ZERO_COLUMN * max(norms.max(), 1e-300)
    return np.where(visible, J / np.where(visible, norms, 1.0), 0.0), visible


def _skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _selection(C: np.ndarray) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(rows, scale) when every column of C has at most one non-zero entry: Reg·C is then
    Reg[:, rows] · scale (scale None when it is all ones), each entry the one product the matrix
    product forms (the others are exact zeros); else None."""
    nonzero = C != 0
    if (nonzero.sum(axis=0) > 1).any():
        return None
    rows = np.abs(C).argmax(axis=0)
    scale = C[rows, np.arange(C.shape[1])]
    return rows, (None if (scale == 1.0).all() else scale)


def _plain_take(
    selection: tuple[np.ndarray, np.ndarray | None] | None, C: np.ndarray, const: np.ndarray, n: int
) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """(flat, fixed, scale) for :meth:`JacobianEngine._plain`: the indices of the picked columns of
    the three linear rows in a whole regressor flattened (6·n entries, n = 6·nq), the columns of C
    that are zero (their Jacobian column is the constant one: None if there is none), and the scale
    of the others (None when it is one); flat is None without a selection, or when a column has
    both a regressor part and a constant one (then :meth:`JacobianEngine._columns`)."""
    zero = (C == 0).all(axis=0)
    if selection is None or const[:, ~zero].any():
        return None, None, None
    rows, scale = selection
    flat = (np.arange(3)[:, None] * n + rows[None, :]).ravel()
    fixed = zero if zero.any() else None
    if scale is not None:
        scale = np.where(zero, 1.0, scale)
        scale = None if (scale == 1.0).all() else scale
    return flat, fixed, scale


def _split(pairs: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
    """(columns, joints) as two integer arrays, from (column, joint) pairs."""
    return np.array([c for c, _ in pairs], dtype=int), np.array([j for _, j in pairs], dtype=int)


class JacobianEngine:
    """Precomputed constant parts of the analytic parameter Jacobian of one ParameterSet.

    Holds its own ``pinocchio.Data``: use one engine per thread.
    """

    def __init__(self, params) -> None:
        robot = params.robot
        self.params = params
        self.robot = robot
        self.model = robot.model
        self.data = robot.model.createData()
        self.joint = robot.tip_joint
        self.placement = pin.SE3(robot.model.frames[robot.tip_frame].placement)
        self.offsets = np.array(robot.joint_offsets)
        self.has_offsets = bool(self.offsets.any())
        # One frame per marker: the tip frame moved to the marker (same axes).
        self.points = [self.placement * pin.SE3(np.eye(3), m) for m in robot.markers]
        nj, n_params, n_markers = robot.nq, len(params), robot.n_markers
        self.rows = 3 * n_markers
        self.n_params = n_params

        C = np.zeros((6 * nj, n_params))
        tip_twist = np.zeros((6, n_params))
        const = np.zeros((self.rows, n_params))
        base_cols: list[tuple[int, int]] = []
        joint_terms: dict[str, list[tuple[int, int]]] = {"gain": [], "compliance": []}
        for col, p in enumerate(params.parameters):
            if p.kind == "placement":
                twist = np.zeros(6)
                if p.component < 3:
                    twist[:3] = robot.origins[p.index].origin.rotation[p.component]  # R_Lᵀ e_c
                else:
                    twist[p.component] = 1.0
                if p.index < nj:
                    C[6 * p.index : 6 * p.index + 6, col] = twist
                else:
                    tip_twist[:, col] = twist
            elif p.kind in ("offset", "gain", "compliance"):
                C[6 * p.index : 6 * p.index + 6, col] = robot.motion_axes[p.index + 1]
                if p.kind != "offset":
                    joint_terms[p.kind].append((col, p.index))
            elif p.kind == "marker":
                const[3 * p.index + p.component, col] = 1.0
            elif p.kind == "base":
                base_cols.append((col, p.component))
            # a fixture does not move the markers: its columns are zero (pincal.instruments)
        self.G = np.vstack([np.hstack([np.eye(3), -_skew(m)]) for m in robot.markers])
        self.tip_twist = tip_twist
        self.C = C
        self.selection = _selection(C)
        self.const = self.G @ tip_twist + const
        self._flat, self._fixed, self._scale = _plain_take(self.selection, C, self.const, 6 * nj)
        self.base_cols = base_cols
        self.needs_pose = bool(base_cols)
        # J_i = Reg_i·C + const: one matrix product for all configurations, then the constant.
        self.has_const = bool(self.const.any())
        # Gain and compliance columns: the joint's column times q_j or τ_j, per configuration.
        self.gain_cols, self.gain_joints = _split(joint_terms["gain"])
        self.compliance_cols, self.compliance_joints = _split(joint_terms["compliance"])
        self.rigid = not robot.is_elastic and not self.compliance_cols.size
        needs_gravity = self.compliance_cols.size or robot.joint_compliances.any()
        self.gravity = robot.gravity_model() if needs_gravity else None
        # Rigid, one marker, no pose, no gain: the tip-frame Jacobian is the regressors' columns.
        self.plain = self.rigid and len(self.points) == 1 and not self.needs_pose and not self.gain_cols.size

    def joint_values(
        self, qs: np.ndarray, payload: PayloadRows = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """(θ, τ): the joints' actual values (m, nq) at readings ``qs`` (:meth:`Robot.joint_values`),
        and the gravity torques (m, nq) on them under ``payload`` when the set has compliances
        (else None)."""
        if self.rigid:
            return (qs + self.offsets if self.has_offsets else qs), None
        loads = carried(payload, len(qs))
        theta = self.robot.joint_values_under(qs, loads, self.gravity)
        if not self.compliance_cols.size:
            return theta, None
        assert self.gravity is not None  # built when the set has compliances
        return theta, self.gravity.torques(theta, loads)

    def regressors(self, qs: np.ndarray, pose: bool = False, payload: PayloadRows = None):
        """Linear rows of the kinematic regressor at each marker, in the tip frame's axes, at the
        joint readings ``qs`` (under ``payload`` on a compliant robot).

        Returns:
            (m, 3K, 6·nq) regressors: a twist of joint placement j moves marker k by
            ``reg[i, 3k:3k+3, 6(j-1):6j] @ twist``. With ``pose``, also the tip's world rotations
            (m, 3, 3) and positions (m, 3) in the robot base frame, else None, None.
        """
        return self._regressors(self.joint_values(qs, payload)[0], pose)

    def _regressors(self, configurations: np.ndarray, pose: bool):
        """:meth:`regressors` at the joints' actual values (one forward kinematics and one
        kinematic regressor per configuration and marker)."""
        model, data, joint = self.model, self.data, self.joint
        m = len(configurations)
        regressor, fk, local = pin.computeJointKinematicRegressor, pin.forwardKinematics, pin.LOCAL
        points = self.points
        if not pose and len(points) == 1 and m:  # the hot path: one marker, no pose
            return self._single(configurations), None, None
        if not pose and m:  # several markers, no pose
            return self._markers(configurations), None, None
        reg = np.empty((m, self.rows, 6 * model.nq))
        rot = np.empty((m, 3, 3)) if pose else None
        pos = np.empty((m, 3)) if pose else None
        for i, q in enumerate(configurations):
            fk(model, data, q)
            for k, point in enumerate(points):
                reg[i, 3 * k : 3 * k + 3] = regressor(model, data, joint, local, point)[:3]
            if rot is not None and pos is not None:
                tip = data.oMi[joint] * self.placement
                rot[i] = tip.rotation
                pos[i] = tip.translation
        return reg, rot, pos

    def _markers(self, configurations: np.ndarray) -> np.ndarray:
        """(m, 3K, 6·nq) the linear rows of every marker's kinematic regressors: each regressor kept
        whole as Pinocchio returns it and copied CHUNK configurations at a time into one array, the
        linear rows taken from it at the end (writing each regressor's rows into place cost about
        twice the Pinocchio work with two markers)."""
        model, data, joint, points = self.model, self.data, self.joint, self.points
        regressor, fk, local = pin.computeJointKinematicRegressor, pin.forwardKinematics, pin.LOCAL
        m, K, n = len(configurations), len(points), 6 * model.nq
        whole = np.empty((m * K * 6, n))
        for a in range(0, m, CHUNK):
            out: list[np.ndarray] = []
            keep = out.append
            for q in configurations[a : a + CHUNK]:
                fk(model, data, q)
                for point in points:
                    keep(regressor(model, data, joint, local, point))
            np.concatenate(out, out=whole[6 * K * a : 6 * K * a + 6 * len(out)])
        return whole.reshape(m, K, 6, n)[:, :, :3].reshape(m, 3 * K, n)

    def _single(self, configurations: np.ndarray) -> np.ndarray:
        """(m, 3, 6·nq) the linear rows of the one marker's kinematic regressors."""
        return self._kept(configurations, whole=False).reshape(len(configurations), 3, 6 * self.model.nq)

    def _whole(self, configurations: np.ndarray) -> np.ndarray:
        """(m, 6·6·nq) the one marker's whole kinematic regressors, one row per configuration (for
        :meth:`_plain`, which picks from them)."""
        return self._kept(configurations, whole=True).reshape(len(configurations), 36 * self.model.nq)

    def _kept(self, configurations: np.ndarray, whole: bool) -> np.ndarray:
        """(m·r, 6·nq) the one marker's kinematic regressors, r = 6 rows each (``whole``) or their 3
        linear rows: the bare Pinocchio work, each regressor kept as Pinocchio returns it (whole:
        not even a slice made of it) and copied once into one array, CHUNK at a time (writing each
        into a buffer cost about twice as much)."""
        model, data, joint, point = self.model, self.data, self.joint, self.points[0]
        regressor, fk, local = pin.computeJointKinematicRegressor, pin.forwardKinematics, pin.LOCAL
        m, r = len(configurations), 6 if whole else 3
        reg = np.empty((r * m, 6 * model.nq))
        for a in range(0, m, CHUNK):  # a chunk's regressors stay in cache until copied
            out: list[np.ndarray] = []
            keep = out.append
            if whole:
                for q in configurations[a : a + CHUNK]:
                    fk(model, data, q)
                    keep(regressor(model, data, joint, local, point))
            else:
                for q in configurations[a : a + CHUNK]:
                    fk(model, data, q)
                    keep(regressor(model, data, joint, local, point)[:3])
            np.concatenate(out, out=reg[r * a : r * (a + len(out))])
        return reg

    def _plain(self, whole: np.ndarray) -> np.ndarray:
        """(m, 3, P) the tip-frame Jacobian of a plain set (:attr:`plain`) with a selection, from
        its whole regressors (m, 6·6·nq) (:meth:`_whole`): one ``take`` of the linear rows' picked
        columns (and the constant columns set), the numbers of :meth:`_columns`."""
        assert self._flat is not None  # called only with a selection (see jacobian)
        J = np.take(whole, self._flat, axis=1).reshape(len(whole), 3, self.n_params)
        if self._fixed is not None:
            J[:, :, self._fixed] = self.const[:, self._fixed]
        if self._scale is not None:
            J *= self._scale
        return J

    def _columns(self, reg: np.ndarray) -> np.ndarray:
        """(m, r, P) Reg·C + const for contiguous regressor rows (m, r, 6·nq): when every column
        of C has at most one non-zero entry (the URDF origins' axes are the parent's, as on most
        arms), the regressor's columns picked and scaled, the same numbers as the product for
        half its time."""
        m, r, n = reg.shape
        if self.selection is not None:
            picked, scale = self.selection
            J = np.take(reg, picked, axis=2)
            if scale is not None:
                J *= scale
        else:
            J = (reg.reshape(-1, n) @ self.C).reshape(m, r, self.n_params)
        if self.has_const:
            J += self.const
        return J

    def jacobian(self, qs: np.ndarray, frame: str = "tip", payload: PayloadRows = None) -> np.ndarray:
        """(m, 3K, P) parameter Jacobian at configurations ``qs`` (validated by the caller).

        Args:
            qs: (m, nq) joint values.
            frame: ``"tip"``: each configuration's rows in its own tip frame (enough for every
                criterion: M = Σ JᵢᵀJᵢ is unchanged by a rotation of each configuration's rows);
                ``"world"``: in the instrument's frame.
            payload: (m, 4) the payload rows of the configurations
                (:func:`~pincal.model.statics.payload_rows`), or None (none).
        """
        if self.plain and frame == "tip":  # the common case (a rigid robot: no payload matters)
            thetas = qs + self.offsets if self.has_offsets else qs
            if self._flat is None:
                return self._columns(self._single(thetas))
            return self._plain(self._whole(thetas))
        pose = frame == "world" or self.needs_pose
        configurations, tau = self.joint_values(qs, payload)
        reg, rot, pos = self._regressors(configurations, pose)
        J = self._columns(reg)
        if self.gain_cols.size:
            J[:, :, self.gain_cols] *= qs[:, None, self.gain_joints]
        if tau is not None:  # the set has compliances
            J[:, :, self.compliance_cols] *= tau[:, None, self.compliance_joints]
        if not pose:
            return J
        base = self.robot.base
        # World rotation of each configuration's tip frame (instrument <- tip).
        world = np.matmul(base.rotation, rot)
        if self.base_cols:
            K = self.robot.n_markers
            # Points in robot-base coordinates, (m, K, 3).
            points = pos[:, None, :] + np.einsum("mij,kj->mki", rot, self.robot.markers)
            for col, c in self.base_cols:
                if c < 3:
                    d_world = np.broadcast_to(np.eye(3)[c], (len(qs), K, 3))
                else:
                    axis = np.eye(3)[c - 3]
                    d_world = np.cross(axis, points) @ base.rotation.T
                # Express in each configuration's tip frame: Rwᵀ d.
                J[:, :, col] = np.einsum("mji,mkj->mki", world, d_world).reshape(len(qs), -1)
        if frame == "world":
            K = self.robot.n_markers
            J = np.einsum("mij,mkjp->mkip", world, J.reshape(len(qs), K, 3, -1)).reshape(J.shape)
        return J

    def frame_rows(
        self, qs: np.ndarray, placement: pin.SE3 | None = None, payload: PayloadRows = None, pose: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Twist rows of a frame fixed to the tip, and the frame's poses, at joint readings ``qs``.

        The frame F sits at ``placement`` in the tip frame (default: the tip frame itself). A
        parameter error δΠ moves it by the twist ξ = J δΠ expressed in F's own axes,
        F' = F·exp(ξ), ξ = (v, ω): its origin by v and its axes by the rotation ω (docs/method.md
        §3.1 and §13.1). The markers' and the fixtures' columns are zero (a marker does not carry
        F; a fixture's columns belong to the measurement kind that uses it).

        Args:
            qs: (m, nq) joint readings (validated by the caller).
            placement: F in the tip frame.
            payload: (m, 4) the payload rows of the configurations, or None.
            pose: also return F's poses (else None, None, unless the set has ``base.*``): cheaper.

        Returns:
            (J, R, p): (m, 6, P) rows in F's axes [m or rad per parameter unit], and F's
            orientations (m, 3, 3) and positions (m, 3) [m] in the instrument's frame.
        """
        frame = self.placement if placement is None else self.placement * placement
        inner = pin.SE3.Identity() if placement is None else placement
        configurations, tau = self.joint_values(qs, payload)
        model, data, joint = self.model, self.data, self.joint
        m = len(configurations)
        reg = np.empty((m, 6, 6 * model.nq))
        pose = pose or bool(self.base_cols)
        rot, pos = np.empty((m, 3, 3)), np.empty((m, 3))  # filled only with ``pose``
        fk, regressor, local = pin.forwardKinematics, pin.computeJointKinematicRegressor, pin.LOCAL
        for i, q in enumerate(configurations):
            fk(model, data, q)
            reg[i] = regressor(model, data, joint, local, frame)
            if pose:
                placed = data.oMi[joint] * frame
                rot[i], pos[i] = placed.rotation, placed.translation
        const = inner.inverse().toActionMatrix() @ self.tip_twist  # a tip twist seen from F
        J = (reg.reshape(-1, reg.shape[2]) @ self.C).reshape(m, 6, self.n_params) + const
        if self.gain_cols.size:
            J[:, :, self.gain_cols] *= qs[:, None, self.gain_joints]
        if self.compliance_cols.size:
            assert tau is not None  # joint_values gives the torques when the set has compliances
            J[:, :, self.compliance_cols] *= tau[:, None, self.compliance_joints]
        base = self.robot.base
        for col, c in self.base_cols:
            # F = B·X; a base twist (Rᵦᵀδt, δω) on the left is Ad(X⁻¹) of it in F's axes.
            if c < 3:
                J[:, :3, col] = np.einsum("mji,j->mi", rot, base.rotation[c])
                J[:, 3:, col] = 0.0
            else:
                axis = np.eye(3)[c - 3]
                J[:, :3, col] = np.einsum("mji,mj->mi", rot, np.cross(axis, pos))
                J[:, 3:, col] = rot[:, c - 3, :]
        if not pose:
            return J, None, None
        world = np.matmul(base.rotation, rot)
        return J, world, pos @ base.rotation.T + base.translation

    def marker_columns(self) -> np.ndarray:
        """(K, 3, P) how each marker's own parameters move it in the tip frame's axes (the
        identity on its ``marker<k>.x|y|z`` columns, zero elsewhere)."""
        out = np.zeros((self.robot.n_markers, 3, self.n_params))
        for col, p in enumerate(self.params.parameters):
            if p.kind == "marker":
                out[p.index, p.component, col] = 1.0
        return out


def analytic_jacobian(
    params, qs: np.ndarray, frame: str = "world", payload: PayloadRows = None
) -> np.ndarray:
    """(m, 3K, P) analytic parameter Jacobian (see :meth:`ParameterSet.jacobian`) under the
    (m, 4) payload rows ``payload``."""
    if frame not in ("world", "tip"):
        raise BadArgument(f"unknown Jacobian frame {frame!r}; valid: world, tip")
    return JacobianEngine(params).jacobian(qs, frame=frame, payload=payload)


def finite_difference_jacobian(
    params, qs: np.ndarray, step: float = FD_STEP, payload: PayloadRows = None
) -> np.ndarray:
    """(m, 3K, P) world-frame Jacobian by central differences on perturbed robot copies, under the
    (m, 4) payload rows ``payload``; the step of each parameter is ``step`` / its natural scale
    (:attr:`ParameterSet.scales`)."""
    m, n = len(qs), len(params)
    J = np.empty((m, 3 * params.robot.n_markers, n))
    for col in range(n):
        h = step / params.scales[col]
        dx = np.zeros(n)
        dx[col] = h
        plus = ForwardKinematics(params.apply(dx)).markers(qs, payload)
        minus = ForwardKinematics(params.apply(-dx)).markers(qs, payload)
        J[:, :, col] = ((plus - minus) / (2 * h)).reshape(m, -1)
    return J
