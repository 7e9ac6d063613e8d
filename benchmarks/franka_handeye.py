"""Real data: a Franka Emika Panda's eye-in-hand camera seeing a ChArUco board, read as pincal poses.

kvasios/franka-handeye (MIT; the files used, their licence and attribution are in
data/franka_handeye/): at 12 joint configurations the robot's joint angles and the board's pose in
the camera frame, from OpenCV's solvePnP on the ChArUco corners of one RealSense image (the
images are not published; their intrinsics are in each file). The board is fixed in the cell, the
camera rides on the hand: a pose measurement of the camera in the board's frame,
T_board_cam = T_cam_boardⁱ⁻¹.

pincal reads it as a :class:`~pincal.instruments.Pose` of one marker frame: the camera's origin
(a marker on the tool, identified), with the tool frame's axes (the camera's axes turned back by a
nominal rotation of 90° about the tool's z, as the camera is mounted; the rest of the camera's
rotation is the tool frame's identified orientation), measured in the board's frame (the robot's
base in that frame identified: ``base``). Nominal values: the camera 5 cm out and 4 cm behind the
tool centre point (rounded; the dataset's own hand-eye result is not used), the board where the
first training pose puts it. The robot is example-robot-data's Panda, whose tool centre point
(``panda_hand_tcp``) is the controller's ``O_T_EE`` to 1e-5 at every pose (checked below).

    python benchmarks/franka_handeye.py          # leave-one-out held-out errors; prints Markdown
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin

import pincal
from pincal.calibration.measurements import MeasurementData
from pincal.instruments import Instrument, PerCoordinate, Pose

DATA = Path(__file__).resolve().parents[1] / "data" / "franka_handeye"
CAMERA_TURN = pin.rpy.rpyToMatrix(0.0, 0.0, np.pi / 2)
"""The camera's nominal orientation in the tool frame (mounted turned 90° about the tool's z)."""
CAMERA_AT = (0.05, 0.0, -0.04)
"""The camera's nominal origin in the tool frame [m] (rounded)."""
NOISE = Instrument(Pose(), PerCoordinate(1e-3, 5e-3))
"""The weights of identification: 1 mm per position coordinate, 5 mrad per angle (about the
per-coordinate RMS of the hand-eye fit's residuals: 2.4 mm and 10 mrad per pose over 3)."""
HAND_EYE = "base,markers,panda_hand_tcp.rx,panda_hand_tcp.ry,panda_hand_tcp.rz"
MODELS = {
    "hand-eye and board (12 parameters)": HAND_EYE,
    "+ the 7 joint offsets": HAND_EYE + ",offsets",
}


def read(folder: Path = DATA) -> tuple[np.ndarray, list[pin.SE3], np.ndarray]:
    """(q (m, 7) [rad], the board's pose in the camera frame at each, the controller's O_T_EE (m, 4, 4))."""
    rows = [json.loads(f.read_text()) for f in sorted(folder.glob("pose_*.json"))]
    q = np.array([r["joint_pose"] for r in rows])
    board = [
        pin.SE3(pin.exp3(np.ravel(r["T_cam_target_rvec"])), np.ravel(r["T_cam_target_tvec"])) for r in rows
    ]
    ee = np.array([np.reshape(r["O_T_EE"], (4, 4)) for r in rows])  # stored row by row
    return q, board, ee


def measurements(robot: pincal.Robot, q: np.ndarray, board: list[pin.SE3]) -> MeasurementData:
    """The marker frame's pose (camera origin, tool axes) in the board's frame at each row."""
    turn_back = pin.SE3(CAMERA_TURN.T, np.zeros(3))
    values = []
    for seen in board:
        T = seen.inverse() * turn_back
        values.append(np.concatenate([T.translation, pin.log3(T.rotation)]))
    return MeasurementData(q, np.array(values), robot.joint_names, kind=Pose())


def fit(q: np.ndarray, board: list[pin.SE3], train: list[int], spec: str):
    """(identification on the rows ``train``, the nominal robot it started from)."""
    panda = pincal.load_robot("panda", markers=[CAMERA_AT])
    R, p = panda.tip_poses(q[train[:1]])
    first = pin.SE3(R[0], p[0]) * pin.SE3(CAMERA_TURN, np.array(CAMERA_AT)) * board[train[0]]
    robot = panda.replace(base=first.inverse())  # the robot's base in the board's frame
    data = measurements(robot, q[train], [board[i] for i in train])
    return pincal.identify(robot.parameters(spec), data, instrument=NOISE), robot


def held_out(q: np.ndarray, board: list[pin.SE3], spec: str) -> np.ndarray:
    """(m, 2) position [m] and angle [rad] error at each row, predicted by a fit on the others."""
    out = []
    for k in range(len(q)):
        result, robot = fit(q, board, [i for i in range(len(q)) if i != k], spec)
        measured = measurements(robot, q[[k]], [board[k]]).points
        d = Pose().difference(measured, Pose().predict(result.robot, q[[k]]))[0]
        out.append((np.linalg.norm(d[:3]), np.linalg.norm(d[3:])))
    return np.array(out)


def report() -> list[str]:
    q, board, ee = read()
    panda = pincal.load_robot("panda")
    R, p = panda.tip_poses(q)
    tcp = np.zeros_like(ee)
    tcp[:, :3, :3], tcp[:, :3, 3], tcp[:, 3, 3] = R, p, 1.0
    rows = [
        f"- {len(q)} poses; example-robot-data's panda_hand_tcp against the controller's O_T_EE: largest "
        f"difference {np.abs(tcp - ee).max():.1e} (matrix entries, m and 1).",
        "",
        "| model | fit on all 12: residual RMS per pose | leave-one-out held-out RMS | held-out largest |",
        "| --- | ---: | ---: | ---: |",
    ]
    for name, spec in MODELS.items():
        result, _ = fit(q, board, list(range(len(q))), spec)
        assert result.status == "converged", result.message
        e = result.residuals.reshape(len(q), -1)
        fitted = (
            np.sqrt(np.mean(np.sum(e[:, :3] ** 2, axis=1))),
            np.sqrt(np.mean(np.sum(e[:, 3:] ** 2, axis=1))),
        )
        errors = held_out(q, board, spec)
        rms = np.sqrt(np.mean(errors**2, axis=0))
        rows.append(
            f"| {name} | {fitted[0] * 1e3:.2f} mm, {fitted[1] * 1e3:.1f} mrad | {rms[0] * 1e3:.2f} mm, "
            f"{rms[1] * 1e3:.1f} mrad | {errors[:, 0].max() * 1e3:.2f} mm, {errors[:, 1].max() * 1e3:.1f} mrad |"
        )
    own = json.loads((DATA / "calibration_result.json").read_text())
    rows.append("")
    rows.append(
        f"- The dataset's own hand-eye result (OpenCV, Daniilidis, fitted on all 12 poses, not held out): "
        f"consistency error {own['consistency_error_mean'] * 1e3:.2f} ± {own['consistency_error_std'] * 1e3:.2f} mm."
    )
    return rows


if __name__ == "__main__":
    print("\n".join(report()))
