"""Real data: MUKCa, a ball on a Franka Panda's hand placed in the sockets of a printed tool.

platonics-delft/kinematics_calibration (MIT; the files, their licence and attribution are in
data/mukca/): for each placement of the tool on the table (``front_center``, ``high``, ...) two
files of joint readings, one per socket (``hole_0.csv``, ``hole_1.csv``, about 30 rows of 7
angles [rad], no header), each recorded with the ball seated in that socket in another arm
posture. The two sockets are 50 mm apart. Nothing else is measured.

pincal reads each socket as a session of its own: a point measured at (0, 0, 0) in the socket's
frame at every row, the socket's position the session's base translation (``base.tx|ty|tz``,
``base2.*``, ...; no base rotation: a point at the frame's origin does not show it). Every row of
a socket then says the ball's centre (the tip ``ball_link`` of the repository's URDF) is the same
point. The 50 mm between the sockets of one placement cannot be told to the fit (pincal has no
constraint between two sessions' bases): the data check leaves the lengths the data cannot scale at
their nominal values, and the fitted socket distance, against 50 mm, is a check the fit never saw.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import pincal
from pincal.calibration.measurements import MeasurementData

DATA = Path(__file__).resolve().parents[2] / "data" / "mukca"
URDF = DATA / "urdf" / "panda.urdf"
TIP = "ball_link"
SOCKET_DISTANCE = 0.05
"""The distance between the tool's two sockets [m] (the repository's ``--offset-distance``)."""
BASE = ("base.tx", "base.ty", "base.tz")
GAUGE = "panda_joint1."
"""The first joint's placement moves every socket alike: with the sockets' positions free, the
data cannot see it (the fit's gauge), so it is not estimated."""


@dataclass(frozen=True)
class Socket:
    """The rows recorded with the ball in one socket.

    Attributes:
        placement: the tool's placement on the table (the data folder's name).
        hole: the socket, 0 or 1.
        q: (m, 7) the joint readings [rad].
        source: the file read, relative to the data folder.
    """

    placement: str
    hole: int
    q: np.ndarray
    source: str

    def measurements(self, joint_names: tuple[str, ...]) -> MeasurementData:
        """The rows as point measurements: the ball at the socket frame's origin."""
        lines = tuple(range(1, len(self.q) + 1))
        return MeasurementData(
            self.q, np.zeros((len(self.q), 3)), joint_names, lines=lines, source=self.source
        )


def read(arm: str = "panda_2", folder: Path = DATA / "data") -> list[Socket]:
    """Every socket of every tool placement recorded with ``arm`` (a folder of ``folder``), sorted."""
    sockets = []
    for placement in sorted(p for p in (folder / arm).iterdir() if p.is_dir()):
        for hole in (0, 1):
            path = placement / f"hole_{hole}.csv"
            q = np.loadtxt(path, delimiter=",", ndmin=2)
            sockets.append(Socket(placement.name, hole, q, str(path.relative_to(folder))))
    return sockets


def robot(urdf: Path = URDF) -> pincal.Robot:
    """The repository's Panda URDF, the ball's centre as the tip (meshes are not shipped)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its meshes are not copied: calibration does not need them
        return pincal.load_robot(urdf, tip=TIP)


def sessions(sockets: list[Socket], panda: pincal.Robot) -> list[MeasurementData]:
    return [s.measurements(panda.joint_names) for s in sockets]


def parameters(panda: pincal.Robot, spec: str) -> pincal.ParameterSet:
    """The identifiable part of ``spec`` for points, and the sockets' positions."""
    names = () if not spec else tuple(panda.parameters(spec).identifiable().identifiable.names)
    names = tuple(n for n in names if not (n.startswith(GAUGE) and n != GAUGE + "gain"))
    return panda.parameters(",".join(names + BASE))


def socket_positions(result: pincal.IdentificationResult) -> np.ndarray:
    """(S, 3) each session's socket in the robot's base frame [m]: the point the fit maps to (0, 0, 0)."""
    return np.array([base.inverse().translation for base in result.bases])


def socket_distances(result: pincal.IdentificationResult, sockets: list[Socket]) -> np.ndarray:
    """(placements,) the fitted distance between the two sockets of each tool placement [m]."""
    at = socket_positions(result)
    index = {(s.placement, s.hole): i for i, s in enumerate(sockets)}
    placements = sorted({s.placement for s in sockets})
    return np.array([np.linalg.norm(at[index[p, 0]] - at[index[p, 1]]) for p in placements])
