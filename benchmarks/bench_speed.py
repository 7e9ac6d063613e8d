"""Speed of the README's design and of the public evaluations (issue 17), run by hand:

    python benchmarks/bench_speed.py --before /tmp/pincal-before      # print the figures
    python benchmarks/bench_speed.py --before /tmp/pincal-before --write   # and RESULTS.md

``--before`` is a checkout of the code to compare with (e.g. ``git worktree add --detach
/tmp/pincal-before 0b3eb34``): both trees run in child processes of this one, interleaved, in the
same run, each importing its own ``pincal`` (PYTHONPATH). Without it, only this tree is measured.

1. The README's main command (``pincal design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --around
   10deg --deg --marker 0.1,0.05,0.2 --baseline 2000 --out plan.csv``): wall and CPU time (user +
   sys of the command and its workers: the figure to trust on a shared machine), best and median of
   ``--repeat`` runs of each tree, and the ratios.
2. Quality: the design of that command through the API for 5 seeds, this tree with its default
   starts against the best of 64 starts of the ``--before`` tree: the ratio of ρ0 (target ≤ 1.01).
3. Evaluations against their floor, the bare Pinocchio work of the plan's configurations
   (forward kinematics + kinematic regressor): ``pincal.rho0`` for one plan, and per plan for a
   batch of k plans; ``pincal.criteria``; with the BLAS threads the process starts with. Also
   the floors Python itself sets: one plan's ρ0 and one plan's criteria written as leanly as pin,
   NumPy and LAPACK allow (nothing checked or set up), and the eigenvalues of M the criteria need.
4. Growth: design time (one worker, 4 starts, no polish) against m, the number of parameters, the
   pool size and the number of test poses, as log-log exponents.
5. ``import pincal`` and ``pincal --help``: wall time (best of 5, byte-code cached).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import footer, header, load, timed, write  # benchmarks/ is on sys.path when run as a script

ROOT = Path(__file__).resolve().parents[1]
README = (
    "design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --around 10deg --deg --marker 0.1,0.05,0.2 "
    "--baseline 2000 --no-progress --out {out}"
)

QUALITY = """
import json, sys, warnings
import numpy as np
import pincal
warnings.simplefilter("ignore")
robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
params = robot.parameters("full,offsets").identifiable().identifiable
region = pincal.around(np.radians([0, -60, 60, 0, 45, 0]), np.radians(10))
starts = json.loads(sys.argv[1])
out = {}
for seed in range(5):
    kw = {} if starts is None else {"starts": starts}
    r = pincal.design(params, 12, region, seed=seed, **kw)
    out[seed] = (r.value, r.time_s, r.starts)
print(json.dumps(out))
"""

EVALUATIONS = """
import json, time
import numpy as np
import pinocchio as pin
import pincal
robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
params = robot.parameters("full").identifiable().identifiable
rng = np.random.default_rng(0)
plans = robot.random_configurations(12 * 1000, rng).reshape(1000, 12, -1)
q0 = robot.random_configurations(1, np.random.default_rng(1))
model, data = robot.model, robot.model.createData()
joint = robot.tip_joint
point = model.frames[robot.tip_frame].placement * pin.SE3(np.eye(3), robot.markers[0])
fk, regressor, local = pin.forwardKinematics, pin.computeJointKinematicRegressor, pin.LOCAL
def bare(qs):
    for q in qs:
        fk(model, data, q)
        regressor(model, data, joint, local, point)
def cpu(f, number):
    # CPU time of the process (every thread: a spinning BLAS thread counts) per call
    t = time.process_time()
    for _ in range(number):
        f()
    return (time.process_time() - t) / number
def batch(function, k):
    try:
        function(params, plans[:2], q0) if function is pincal.rho0 else function(params, plans[:2])
    except Exception:  # the code before took one plan at a time: a loop
        if function is pincal.rho0:
            return lambda: [function(params, p, q0) for p in plans[:k]]
        return lambda: [function(params, p) for p in plans[:k]]
    return (lambda: function(params, plans[:k], q0)) if function is pincal.rho0 else (lambda: function(params, plans[:k]))
small = dict(samples=64, workspace=256)
def accuracy_batch(k):
    try:
        pincal.accuracy(params, plans[:2], q0, sigma=3e-5, **small)
        return lambda: pincal.accuracy(params, plans[:k], q0, sigma=3e-5, **small)
    except Exception:
        return lambda: [pincal.accuracy(params, p, q0, sigma=3e-5, **small) for p in plans[:k]]
region = pincal.around(q0[0], np.radians(10))
seeds = iter(range(1, 10**6))
n_report = 1 + 2 * small["samples"] + small["workspace"]  # the configurations an accuracy report covers
# The floors of the evaluations as Python can write them (pin, NumPy and LAPACK only): one plan's ρ0
# with nothing checked, nothing set up and nothing named (J by one product with C plus the constant
# columns, M, Cholesky, one triangular solve against the test pose's rows); one plan's criteria
# likewise (M, LAPACK's eigenvalues, the eight criteria in Python floats); and the eigenvalues the
# criteria need. Both give pincal's numbers (checked below), so they do the same work.
import math
from scipy.linalg import blas, lapack
from pincal.model.jacobian import JacobianEngine
engine = JacobianEngine(params)
C, constant = engine.C, np.tile(engine.const, (12, 1))
fk(model, data, q0[0])
W = np.ascontiguousarray((regressor(model, data, joint, local, point)[:3] @ C + engine.const).T)
potrf, trsm, syevd = lapack.dpotrf, blas.dtrsm, lapack.dsyevd
def jacobian_of(qs):
    out = []
    for q in qs:
        fk(model, data, q)
        out.append(regressor(model, data, joint, local, point)[:3])
    return np.concatenate(out) @ C + constant
def lean(qs):
    J = jacobian_of(qs)
    L, info = potrf(J.T @ J, lower=1, clean=1, overwrite_a=0)
    x = trsm(1.0, L, W, lower=1).ravel()
    return 3e-5 * np.sqrt(x @ x)
def lean_criteria(qs):
    J = jacobian_of(qs)
    s = [math.sqrt(w) for w in syevd(J.T @ J, compute_v=0, lower=1)[0].tolist()]
    log_sum = sum(map(math.log, s))
    n, small, large = len(s), s[0], s[-1]
    return (-2.0 * log_sum, sum(1.0 / (x * x) for x in s), 1.0 / (small * small), large / small,
            math.exp(log_sum / n) / math.sqrt(12), small / large, small, small * small / large)
assert abs(lean(plans[0]) / pincal.rho0(params, plans[0], q0) - 1) < 1e-9
assert np.allclose(lean_criteria(plans[0]), list(pincal.criteria(params, plans[0]).as_dict().values()), rtol=1e-9)
Ms = np.array([J.T @ J for J in map(jacobian_of, plans)])
cases = {
    "lean_one": (lambda: lean(plans[0]), 200, 1),
    "lean_criteria_one": (lambda: lean_criteria(plans[0]), 200, 1),
    "eig_one": (lambda: np.linalg.eigvalsh(Ms[0]), 200, 1),
    "eig_batch_1000": (lambda: np.linalg.eigvalsh(Ms), 1, 1000),
    "bare": (lambda: bare(plans[0]), 200, 1),
    "bare_1000": (lambda: bare(plans.reshape(-1, plans.shape[-1])), 1, 1000),
    "rho0_one": (lambda: pincal.rho0(params, plans[0], q0), 200, 1),
    "rho0_batch_100": (batch(pincal.rho0, 100), 2, 100),
    "rho0_batch_1000": (batch(pincal.rho0, 1000), 1, 1000),
    "criteria_one": (lambda: pincal.criteria(params, plans[0]), 100, 1),
    "criteria_batch_100": (batch(pincal.criteria, 100), 2, 100),
    "criteria_batch_1000": (batch(pincal.criteria, 1000), 1, 1000),
    "rho0_region_one": (lambda: pincal.rho0(params, plans[0], region), 5, 1),
    "bare_report": (lambda: bare(plans.reshape(-1, plans.shape[-1])[: 12 + n_report]), 5, 1),
    "accuracy_one": (lambda: pincal.accuracy(params, plans[0], q0, sigma=3e-5, **small), 5, 1),
    # a new seed each call: new draws, so nothing kept helps (a script's first call for a test pose)
    "accuracy_first": (lambda: pincal.accuracy(params, plans[0], q0, sigma=3e-5, seed=next(seeds), **small), 5, 1),
    "accuracy_batch_100": (accuracy_batch(100), 1, 100),
}
for f, _, _ in cases.values():  # warm-up: imports, engines, the criteria kept
    f()
times = {name: [] for name in cases}
for _ in range(5):  # interleaved, the best of five
    for name, (f, number, k) in cases.items():
        times[name].append(cpu(f, number) / k)
out = {"P": len(params), "m": 12, "n_report": n_report}
out.update({name: min(t) for name, t in times.items()})
print(json.dumps(out))
"""

GROWTH = """
import json, resource, sys, warnings
import numpy as np
import pincal
warnings.simplefilter("ignore")
robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
q0 = np.radians([0, -60, 60, 0, 45, 0])
sweep = np.radians([30, 10, -10, 20, 15, 30])
def path(n):
    return pincal.TestPath(q0 + np.linspace(-1, 1, n)[:, None] * sweep)
def cpu():
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
def timed(params, m=12, pool=2000, test=q0):
    t = cpu()
    pincal.design(params, m, test, search=pincal.Search(starts=4, seed=0, workers=1, pool=pool, polish=False))
    return cpu() - t
full = robot.parameters("full,offsets").identifiable().identifiable
sets = [robot.parameters(g).identifiable().identifiable for g in ("offsets", "lengths,offsets", "full,offsets", "full,offsets,gains")]
timed(full)  # warm-up: imports, the engine's first build
out = {
    "m": [(m, timed(full, m=m)) for m in (10, 20, 40, 80)],
    "P": [(len(p), timed(p)) for p in sets],
    "pool": [(n, timed(full, pool=n)) for n in (500, 1000, 2000, 4000, 8000)],
    "poses": [(n, timed(full, test=path(n))) for n in (1, 100, 1000, 10000)],
    "samples": [(n, timed(full, test=pincal.around(q0, np.radians(10), samples=n))) for n in (16, 256, 4096)],
}
print(json.dumps(out))
"""


def run_python(tree: Path, code: str, *args: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, cwd=tree
    )
    if out.returncode:
        raise RuntimeError(f"{tree}: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def readme_wall(tree: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of the README command run by ``tree``: CPU is user + sys of the command
    and its workers (what a shared machine does not inflate the way it inflates wall time)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    with tempfile.TemporaryDirectory() as tmp:
        argv = README.format(out=Path(tmp) / "plan.csv").split()
        with timed() as clock:
            subprocess.run(
                [sys.executable, "-m", "pincal", *argv], env=env, capture_output=True, check=True, cwd=tmp
            )
        return clock.wall, clock.cpu


def best_wall(tree: Path, argv: list[str], repeat: int = 5) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    times = []
    for _ in range(repeat):
        with timed() as clock:
            subprocess.run([sys.executable, *argv], env=env, capture_output=True, check=True, cwd=tree)
        times.append(clock.wall)
    return min(times)


def exponent(points: list) -> float:
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def main() -> list[str]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--before", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--repeat", type=int, default=3, help="runs of the README command per tree")
    parser.add_argument("--write", action="store_true", help="replace the bench_speed section of RESULTS.md")
    parser.add_argument(
        "--skip", default="", help="comma-separated parts to skip: readme,quality,eval,growth,import"
    )
    args = parser.parse_args()
    skip = set(args.skip.split(","))
    trees = {"this": ROOT} | ({"before": args.before.resolve()} if args.before else {})
    lines: list[str] = []

    def say(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    for line in header():
        say(line)
    if args.before:
        say("- TREE: the code before, a detached worktree.")
    say()
    if "readme" not in skip:
        say("### The README's design command")
        say()
        say(
            f"`pincal {README.format(out='plan.csv').replace(' --no-progress', '')}`, wall and CPU time of the whole command"
        )
        say(f"(import, design, baseline, accuracy report), {args.repeat} runs per tree, interleaved:")
        say()
        walls: dict[str, list[float]] = {name: [] for name in trees}
        cpus: dict[str, list[float]] = {name: [] for name in trees}
        for _ in range(args.repeat):
            for name, tree in trees.items():
                wall, cpu = readme_wall(tree)
                walls[name].append(wall)
                cpus[name].append(cpu)
        say("| code | wall best | wall median | CPU (user + sys) median | wall runs |")
        say("| --- | ---: | ---: | ---: | --- |")
        for name, w in walls.items():
            say(
                f"| {name} | {min(w):.2f} s | {statistics.median(w):.2f} s | "
                f"{statistics.median(cpus[name]):.2f} s | {', '.join(f'{x:.2f}' for x in w)} |"
            )
        if "before" in walls:
            say()
            say(
                f"- Ratio this / before: wall {min(walls['this']) / min(walls['before']):.2f} (best), "
                f"{statistics.median(walls['this']) / statistics.median(walls['before']):.2f} (median); "
                f"CPU {statistics.median(cpus['this']) / statistics.median(cpus['before']):.2f} (median)."
            )
        say(f"- Load average after: {load()}.")
        say()
    if "quality" not in skip:
        say("### Quality: ρ0 of the design, 5 seeds")
        say()
        this = run_python(ROOT, QUALITY, "null")
        before = run_python(args.before, QUALITY, "64") if args.before else None
        say("| seed | this (default starts) | design time | before, 64 starts | ratio |")
        say("| ---: | ---: | ---: | ---: | ---: |")
        for seed, (value, t, starts) in this.items():
            ref = before[seed][0] if before else float("nan")
            say(
                f"| {seed} | {value * 1e3:.5f} mm ({starts} starts) | {t:.2f} s | {ref * 1e3:.5f} mm | {value / ref:.4f} |"
            )
        say()
    if "eval" not in skip:
        say("### Public evaluations against the bare Pinocchio work (KR 270, 27 parameters, m = 12)")
        say()
        say(
            "CPU time of the process per plan (every thread counted), best of 5 interleaved; BLAS threads as "
            f"the process starts (OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')})."
        )
        say()
        results = {name: run_python(tree, EVALUATIONS) for name, tree in trees.items()}
        say("| evaluation | " + " | ".join(f"{n} [µs per plan]" for n in results) + " | this / bare |")
        say("| --- |" + " ---: |" * (len(results) + 1))
        n_report = results["this"]["n_report"]
        rows = [
            ("bare: FK + regressor, 12 configurations", "bare", "bare"),
            ("bare, per 12 of 12 000 configurations", "bare_1000", "bare"),
            ("floor: one plan's ρ0 in Python, nothing checked or set up", "lean_one", "bare"),
            ("floor: one plan's criteria in Python, nothing checked or set up", "lean_criteria_one", "bare"),
            ("floor: the eigenvalues of one M (numpy.linalg.eigvalsh)", "eig_one", "bare"),
            ("floor: the eigenvalues of 1000 M, per plan", "eig_batch_1000", "bare"),
            ("rho0, one plan", "rho0_one", "bare"),
            ("rho0, batch of 100 plans (before: a loop)", "rho0_batch_100", "bare"),
            ("rho0, batch of 1000 plans (before: a loop)", "rho0_batch_1000", "bare"),
            ("criteria, one plan", "criteria_one", "bare"),
            ("criteria, batch of 100 plans (before: a loop)", "criteria_batch_100", "bare"),
            ("criteria, batch of 1000 plans (before: a loop)", "criteria_batch_1000", "bare"),
            ("rho0 over a ±10° region (256 samples), one plan", "rho0_region_one", "bare"),
            (
                f"bare: FK + regressor, 12 + {n_report} configurations (an accuracy report's)",
                "bare_report",
                "bare_report",
            ),
            ("accuracy, one plan (64 + 64 + 256 samples)", "accuracy_one", "bare_report"),
            ("accuracy, one plan, its report new (new draws each call)", "accuracy_first", "bare_report"),
            ("accuracy, batch of 100 plans (before: a loop)", "accuracy_batch_100", "bare_report"),
        ]
        for label, key, floor in rows:
            cells = [("—" if r.get(key) is None else f"{r[key] * 1e6:.1f}") for r in results.values()]
            this = results["this"]
            ratio = this[key] / this[floor] if this.get(key) else float("nan")
            say(f"| {label} | " + " | ".join(cells) + f" | {ratio:.2f} ({floor}) |")
        say()
    if "growth" not in skip:
        say("### Growth of the design time (this code; CPU time, one worker, 4 starts, no polish)")
        say()
        g = run_python(ROOT, GROWTH)
        for key, what in (
            ("m", "m"),
            ("P", "parameters"),
            ("pool", "pool size"),
            ("poses", "test poses (path points)"),
            ("samples", "region samples (±10°)"),
        ):
            pts = ", ".join(f"{n}: {t:.2f} s" for n, t in g[key])
            say(f"- {what}: {pts}; exponent {exponent(g[key]):.2f}.")
        say()
    if "import" not in skip:
        say("### Import and help (best of 5, byte-code cached)")
        say()
        for name, tree in trees.items():
            imp = best_wall(tree, ["-c", "import pincal"])
            helped = best_wall(tree, ["-m", "pincal", "--help"])
            bare = best_wall(tree, ["-c", "import numpy, pinocchio"])
            say(
                f"- {name}: `import pincal` {imp:.3f} s, `pincal --help` {helped:.3f} s "
                f"(of which `import numpy, pinocchio` alone: {bare:.3f} s)."
            )
        say()
    for line in footer():
        say(line)
    if args.write:
        write(lines, "bench_speed")
    return lines


if __name__ == "__main__":
    main()
