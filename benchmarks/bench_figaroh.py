"""pincal's design against FIGAROH's (issue 17 item 4), on the same UR10 pool, run by hand:

    python benchmarks/bench_figaroh.py --urdf FIGAROH_EXAMPLES/examples/ur10/urdf/ur10_robot.urdf
    python benchmarks/bench_figaroh.py --urdf ... --write      # and the bench_figaroh section of RESULTS.md

FIGAROH (https://github.com/thanhndv212/figaroh-plus, Apache-2.0) runs in its own virtual
environment (``--figaroh-python``, default /work/venvs/kernels-figaroh/bin/python: ``pip install
figaroh`` there); this script writes a unified FIGAROH configuration and a small driver into a
temporary folder and runs them as a child process: no FIGAROH code is copied here.

The problem: FIGAROH's UR10 example robot (its URDF, meshes stripped: kinematics only), the
position of the wrist_3_link origin measured (x, y, z), FIGAROH's ``full_params`` calibration
model and pincal's ``full`` set, each reduced to the identifiable (base) parameters by its own
rule. The pool: ``--pool`` configurations drawn uniformly in the ranges FIGAROH's UR10 example draws
its candidates from (±2π, the elbow ±π; seeded), the same array for both.

* FIGAROH: its optimal-configuration selection (``BaseOptimalCalibration``): base kinematic
  regressor of every candidate, then the SOCP relaxation of the D-optimal design (picos +
  cvxopt), then its two selections of a subset: weights above 1e-5 (``threshold``, its default)
  and the plateau of its D criterion along the weight ranking (``iroc``).
* pincal: ``pincal.design`` on the same pool (exchange, 16 starts, one worker, no polish: the
  pool is given; no joint margin or mount, so that every candidate stays), for m = the size of
  FIGAROH's ``iroc`` selection, with the D criterion and with the test-pose criterion at ``--q0``.
* Both plans, and FIGAROH's top m by SOCP weight, scored by pincal's ρ0 at the test pose
  (σ = 0.03 mm), pincal's D criterion (log det M⁻¹ of its identifiable set, lower is better) and
  FIGAROH's own D criterion (det(M)^(1/P)/√P of its base regressor, higher is better).

CPU time is user + sys of each process (FIGAROH's child process; pincal's design in this one).
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import footer, header, publish, timed

import pincal

JOINTS = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]
RANGE = np.array([2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi])
SIGMA = 3e-5

CONFIG = """\
robot:
  name: "ur10"
  properties:
    joints:
      active_joints: {joints}
tasks:
  calibration:
    enabled: true
    type: kinematic_calibration
    parameters:
      calibration_level: "full_params"
      include_non_geometric: false
    kinematics:
      base_frame: "universe"
      tool_frame: "wrist_3_link"
    measurements:
      markers:
        - name: "marker"
          reference_joint: "wrist_3_joint"
          measurable_dof: [true, true, true, false, false, false]
          sensor_type: "mocap"
      poses:
        base_pose: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        tool_pose: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    data:
      source_file: "pool.csv"
      sample_configurations_file: "pool.yaml"
      number_of_samples: {n}
"""

DRIVER = """\
import json, resource, sys, time
import numpy as np, yaml
from figaroh.tools.load_robot import load_robot
from figaroh.optimal.base_optimal_calibration import BaseOptimalCalibration

def cpu():
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime

mode, config, urdf, pool_file, joints = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], json.loads(sys.argv[5])
pool = np.load(pool_file)
with open("pool.yaml", "w") as f:
    yaml.safe_dump({"calibration_joint_names": joints, "calibration_joint_configurations": pool.tolist()}, f)
c0, t0 = cpu(), time.perf_counter()
robot = load_robot(urdf, load_by_urdf=True)
opt = BaseOptimalCalibration(robot, config)
opt._sampleConfigs_file = "pool.yaml"
c1 = cpu()
opt.initialize()
c2 = cpu()
if mode == "design":
    opt.calculate_optimal_configurations(selection_method="threshold")
    c3, t3 = cpu(), time.perf_counter()
    out = {"n_params": int(opt.R_rearr.shape[1]), "threshold": [int(i) for i in opt._select_by_threshold()],
           "iroc": [int(i) for i in opt._select_by_iroc()], "ranking": [int(i) for i in opt.w_dict_sort],
           "cpu_load": c1 - c0, "cpu_regressor": c2 - c1, "cpu_socp": c3 - c2, "cpu_total": c3 - c0,
           "wall_total": t3 - t0}
else:
    import picos as pc
    plans = json.loads(open(sys.argv[6]).read())
    def detroot(ix):
        M = sum(opt._subX_dict[i] for i in ix)
        return float(pc.DetRootN(M) / np.sqrt(M.shape[0]))
    out = {"detroot": {name: detroot(ix) for name, ix in plans.items()}}
print("RESULT " + json.dumps(out))
"""


def kinematic_urdf(urdf: Path, folder: Path) -> Path:
    """A copy of ``urdf`` without visual and collision elements (its meshes are not needed)."""
    text = re.sub(r"<(visual|collision)>.*?</\1>", "", urdf.read_text(), flags=re.S)
    out = folder / "ur10_kinematic.urdf"
    out.write_text(text)
    return out


def run_figaroh(python: str, folder: Path, mode: str, *extra: str) -> dict:
    argv = [
        python,
        "driver.py",
        mode,
        "config.yaml",
        "ur10_kinematic.urdf",
        "pool.npy",
        json.dumps(JOINTS),
        *extra,
    ]
    done = subprocess.run(argv, cwd=folder, capture_output=True, text=True)
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
    if done.returncode or not lines:
        raise RuntimeError(f"FIGAROH failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    return json.loads(lines[-1][len("RESULT ") :])


def indices(pool: np.ndarray, plan: np.ndarray) -> list[int]:
    """The pool rows of a plan's configurations."""
    return [int(np.flatnonzero(np.all(pool == q, axis=1))[0]) for q in plan]


def main() -> list[str]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--urdf", type=Path, required=True, help="FIGAROH's examples/ur10/urdf/ur10_robot.urdf"
    )
    parser.add_argument("--figaroh-python", default="/work/venvs/kernels-figaroh/bin/python")
    parser.add_argument("--pool", type=int, default=1000, help="candidate configurations")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--q0", default="0,-69,86,-57,-86,0", help="test pose [deg]")
    parser.add_argument(
        "--write", action="store_true", help="replace the bench_figaroh section of RESULTS.md"
    )
    args = parser.parse_args()
    q0 = np.radians([float(v) for v in args.q0.split(",")])
    lines = header(
        f"python benchmarks/bench_figaroh.py --urdf UR10_URDF --pool {args.pool} --seed {args.seed}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        urdf = kinematic_urdf(args.urdf, folder)
        pool = np.random.default_rng(args.seed).uniform(-RANGE, RANGE, size=(args.pool, 6))
        np.save(folder / "pool.npy", pool)
        (folder / "config.yaml").write_text(CONFIG.format(joints=json.dumps(JOINTS), n=args.pool))
        (folder / "driver.py").write_text(DRIVER)
        figaroh = run_figaroh(args.figaroh_python, folder, "design")
        m = len(figaroh["iroc"])

        robot = pincal.load_robot(str(urdf), tip="wrist_3_link")
        params = robot.parameters("full").identifiable().identifiable
        designs = {}
        for criterion in ("D", "test-pose"):
            with timed() as clock:
                result = pincal.design(
                    params,
                    m,
                    q0,
                    criterion=criterion,
                    search=pincal.Search(pool=pool, starts=16, seed=args.seed, workers=1),
                    safety=pincal.Safety(joint_margin=0, mount="none"),
                )
            designs[criterion] = (result.plan.q, clock.cpu, clock.wall)
        plans = {
            f"FIGAROH iroc ({m})": figaroh["iroc"],
            f"FIGAROH top {m} by weight": figaroh["ranking"][:m],
            f"FIGAROH threshold ({len(figaroh['threshold'])})": figaroh["threshold"],
            f"pincal D ({m})": indices(pool, designs["D"][0]),
            f"pincal test-pose ({m})": indices(pool, designs["test-pose"][0]),
        }
        (folder / "plans.json").write_text(json.dumps(plans))
        scored = run_figaroh(args.figaroh_python, folder, "score", "plans.json")["detroot"]

    lines += [
        "",
        f"UR10 (FIGAROH's example URDF), point at the wrist_3_link origin, pool of {args.pool} configurations",
        f"(seed {args.seed}); identifiable parameters: FIGAROH {figaroh['n_params']} (base parameters of"
        f" `full_params`), pincal {len(params)} (`full`); test pose {args.q0}°; σ = 0.03 mm.",
        "",
        "| design | CPU [s] | wall [s] |",
        "| --- | ---: | ---: |",
        f"| FIGAROH: regressors of the pool | {figaroh['cpu_regressor']:.2f} | |",
        f"| FIGAROH: SOCP (picos + cvxopt) | {figaroh['cpu_socp']:.2f} | |",
        f"| FIGAROH: whole (load, regressors, SOCP, selections) | {figaroh['cpu_total']:.2f} | {figaroh['wall_total']:.2f} |",
        f"| pincal: `design(criterion='D')`, m = {m}, 16 starts, 1 worker | {designs['D'][1]:.2f} | {designs['D'][2]:.2f} |",
        f"| pincal: `design(criterion='test-pose')`, m = {m}, 16 starts, 1 worker | {designs['test-pose'][1]:.2f} | {designs['test-pose'][2]:.2f} |",
        "",
        "| plan | ρ0 at the test pose [mm] | pincal D: log det M⁻¹ (lower is better) | FIGAROH D: det(M)^(1/P)/√P (higher is better) |",
        "| --- | ---: | ---: | ---: |",
    ]  # fmt: skip
    for name, ix in plans.items():
        q = pool[ix]
        rho = pincal.rho0(params, q, q0, sigma=SIGMA)
        d = pincal.criteria(params, q).log_det
        lines.append(f"| {name} | {rho * 1e3:.4f} | {d:.2f} | {scored[name]:.4g} |")
    lines += ["", *footer()]
    publish(lines, "bench_figaroh", args.write)
    return lines


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
