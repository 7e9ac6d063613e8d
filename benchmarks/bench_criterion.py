"""Time of one ρ0 evaluation against the bare Pinocchio calls it needs, measured in the same run.

Problem: KUKA KR 270 (robots/kr270.urdf), an off-axis marker (0.1, 0.05, 0.2) m on tool0, the
identifiable base set of the `full` group (27 parameters), m = 12 configurations, one test pose.

* bare:    for each of the 12 configurations, pinocchio.forwardKinematics + the kinematic regressor
           (computeJointKinematicRegressor) — the Pinocchio work one evaluation cannot avoid;
* inner:   TestPoseCriterion.__call__ — the path searches evaluate millions of times (J₀ cached);
* public:  pincal.rho0(params, plan, q0) — validation, J₀ and everything, for information.

Run:  python benchmarks/bench_criterion.py [--repeat 7] [--number 2000]
"""

from __future__ import annotations

import argparse
import os
import timeit

import numpy as np
import pinocchio as pin
from _common import header  # benchmarks/ is on sys.path when run as a script

import pincal
from pincal.evaluation.test_pose import TestPoseCriterion


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--number", type=int, default=2000)
    args = parser.parse_args()

    robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("full").identifiable().identifiable
    qs = robot.random_configurations(12, np.random.default_rng(0))
    q0 = robot.random_configurations(1, np.random.default_rng(1))
    criterion = TestPoseCriterion(params, q0, sigma=3e-5)

    model, data = robot.model, robot.model.createData()
    joint = robot.tip_joint
    point = model.frames[robot.tip_frame].placement * pin.SE3(np.eye(3), robot.markers[0])
    fk, regressor, local = pin.forwardKinematics, pin.computeJointKinematicRegressor, pin.LOCAL

    def bare() -> None:
        for q in qs:
            fk(model, data, q)
            regressor(model, data, joint, local, point)

    def inner() -> None:
        criterion(qs)

    def public() -> None:
        pincal.rho0(params, qs, q0, sigma=3e-5)

    timings: dict[str, list[float]] = {"bare": [], "inner": [], "public": []}
    funcs = {"bare": bare, "inner": inner, "public": public}
    for _ in range(args.repeat):  # interleaved, so drifts of the machine hit all three alike
        for name, func in funcs.items():
            timings[name].append(timeit.timeit(func, number=args.number) / args.number)
    best = {name: min(t) for name, t in timings.items()}

    print("\n".join(header()))
    print(f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE', '(unset)')}")
    print(
        f"problem: kr270, {len(params)} parameters, m = {len(qs)}, 1 test pose; "
        f"best of {args.repeat} x {args.number} calls"
    )
    print(f"rho0 = {criterion(qs):.6e} m")
    for name in ("bare", "inner", "public"):
        print(f"  {name:7s} {best[name] * 1e6:8.2f} us per evaluation")
    print(f"ratio inner / bare  = {best['inner'] / best['bare']:.2f}   (target <= 3)")
    print(f"ratio public / bare = {best['public'] / best['bare']:.2f}")


if __name__ == "__main__":
    main()
