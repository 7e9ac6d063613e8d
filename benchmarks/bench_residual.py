"""The residual model's growth with the number of measured configurations (issue 29): time and
memory of ``ResidualModel.fit`` against n, its held-out error and calibration, and the exact GP
(scikit-learn) where it fits.

Data: the KUKA KR 270 (shipped), marker (0.1, 0.05, 0.2) m on tool0, random configurations
(seeded); the residual is what an unmodelled gear eccentricity leaves, a once- and twice-per-turn
error of every joint, δq_j = a_j sin(q_j + φ_j) + b_j sin(2q_j + ψ_j) with a_j ≈ 50–100 µrad and
b_j ≈ 20–50 µrad, through the world Jacobian of the joint offsets (a smooth field of about 0.1 mm
RMS), plus noise σ = 20 µm per coordinate. 2 000 held-out configurations.

Each fit runs in a child process of its own, so that its peak memory (the child's maximum
resident set, Python, NumPy and Pinocchio included) and CPU time are its alone:

* ``approximate``: the default ``ResidualModel.fit`` (exact up to 500 configurations; beyond,
  hyperparameters from a seeded 1 000-configuration subset's exact likelihood, FITC through 1 500
  inducing configurations);
* ``exact``: scikit-learn's exact GP on every configuration (``Approximation(above=n)``), as every
  fit was before issue 29, for the sizes of ``--exact``.

Columns: n, wall and CPU seconds of the fit, peak RSS [MB], held-out RMS of the error left [µm]
(the noise included: 20 µm is the floor), RMS of the held-out z-scores (error over the predicted
standard deviation, √(v + n²): 1 is calibrated), and, for the approximate model, the held-out RMS
of the exact GP with the same hyperparameters on its 1 500 inducing configurations alone (what
using every configuration buys). Last, the FITC sums at the largest n on one BLAS thread and on two.

Run:  python benchmarks/bench_residual.py [--sizes 1000 2000 5000 10000 20000] [--exact 1000 2000] [--write]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
from typing import Any

import numpy as np
from _common import footer, header, timed, write  # benchmarks/ is on sys.path when run as a script

SIGMA = 2e-5
HELD_OUT = 2000

READING = """Reading: up to 1 500 configurations every configuration is inducing, so the approximate model
differs from the exact one by its hyperparameters alone (at 1 000, the subset is every configuration
and the two agree); beyond, the time is the subset's likelihood (n-independent, a few hundred
evaluations of a 1 000 × 1 000 factorisation) plus the FITC sums (O(n m²), one BLAS thread), and the
peak memory stays near the interpreter's own (Python, NumPy, Pinocchio: about 200 MB) where the exact
GP's grows as n² times its 14 hyperparameters. The held-out error keeps falling with n (the noise,
20 µm, is its floor), which the exact GP on the inducing configurations alone (last column) does not
give; the z-scores stay calibrated. Wall times are on a shared two-core machine (load in the header):
CPU seconds are the figure to compare."""


def data(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Training (q, r), held-out (q, r) and the robot's revolute flags (seeded)."""
    import pincal

    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("offsets")
    rng = np.random.default_rng(7)
    P = len(params)
    a, phi = rng.uniform(5e-5, 1e-4, P), rng.uniform(0, 2 * np.pi, P)
    b, psi = rng.uniform(2e-5, 5e-5, P), rng.uniform(0, 2 * np.pi, P)
    q = robot.random_configurations(n + HELD_OUT, 3)
    dq = a * np.sin(q + phi) + b * np.sin(2 * q + psi)
    field = np.einsum("mrp,mp->mr", params.jacobian(q, frame="world"), dq)
    r = field + np.random.default_rng(1).normal(0, SIGMA, field.shape)
    return q[HELD_OUT:], r[HELD_OUT:], q[:HELD_OUT], r[:HELD_OUT], robot.revolute


def held_out(model, q: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    error = r - model.mean(q)
    z = error / np.sqrt(model.variance(q) + model.noise**2)[:, None]
    return float(np.sqrt(np.mean(error**2))), float(np.sqrt(np.mean(z**2)))


def child(kind: str, n: int) -> None:
    """Fit one model and print its figures as JSON (run in a process of its own)."""
    from pincal.model.residual import Approximation, ResidualModel

    q, r, qh, rh, revolute = data(n)
    approximation = Approximation(above=n) if kind == "exact" else Approximation()
    with timed() as clock:
        model = ResidualModel.fit(q, r, revolute, seed=0, approximation=approximation, progress=True)
    cpu, wall = clock.cpu, clock.wall
    rms, z = held_out(model, qh, rh)
    out = {"kind": kind, "n": n, "wall": wall, "cpu": cpu, "rms": rms, "z": z, "how": model.describe()}
    out["rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
    if model.inducing is not None:
        index = np.random.default_rng(0).permutation(n)[: len(model.inducing)]  # fit()'s seeded order
        assert np.array_equal(q[index], model.inducing)
        alone = ResidualModel(revolute, q[index], r[index], model.amplitude, model.lengthscales, model.noise)
        out["subset_alone"] = held_out(alone, qh, rh)[0]
    print(json.dumps(out))


def threads(n: int) -> None:
    """Print the wall time of the FITC sums (the posterior of a fitted model at n) on one BLAS
    thread and on two, as JSON."""
    from threadpoolctl import threadpool_limits

    from pincal.model._sparse_gp import Fitc
    from pincal.model.residual import ResidualModel
    from pincal.progress import Steps

    q, r, _, _, revolute = data(n)
    model = ResidualModel.fit(q, r, revolute, seed=0)  # SciPy loaded: the limits below reach its BLAS
    assert model.inducing is not None
    X, Z = model._scaled(q), model._scaled(model.inducing)
    nu = (model.noise / model.amplitude) ** 2
    times: dict[int, list[float]] = {1: [], 2: []}
    for k in (1, 2, 1, 2):
        with threadpool_limits(limits=k, user_api="blas"):
            with timed() as clock:
                Fitc.build(X, r, Z, nu, Steps(False, "", ""))
            times[k].append(clock.wall)  # threads: the wall time is what they change
    out = {"n": n, "m": len(Z), "one": min(times[1]), "two": min(times[2])}
    print(json.dumps(out))


def run(kind: str, n: int) -> dict[str, Any]:
    done = subprocess.run(
        [sys.executable, __file__, "--child", kind, str(n)], capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 5000, 10000, 20000])
    parser.add_argument("--exact", type=int, nargs="*", default=[1000, 2000])
    parser.add_argument("--write", action="store_true", help="replace the section of RESULTS.md")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, n = args.child[0], int(args.child[1])
        if kind == "threads":
            threads(n)
        else:
            child(kind, n)
        return
    lines = header() + [
        "",
        "| fit | n | wall [s] | CPU [s] | peak RSS [MB] | held-out RMS [µm] | z RMS | subset alone [µm] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for line in lines:
        print(line, flush=True)
    rows = [("approximate", n) for n in args.sizes] + [("exact", n) for n in args.exact]
    figures: dict[tuple[str, int], dict[str, Any]] = {}
    for kind, n in rows:
        f = figures[kind, n] = run(kind, n)
        alone = f"{f['subset_alone'] * 1e6:.2f}" if "subset_alone" in f else "—"
        line = (
            f"| {kind} | {n} | {f['wall']:.1f} | {f['cpu']:.1f} | {f['rss']:.0f} | {f['rms'] * 1e6:.2f} | "
            f"{f['z']:.3f} | {alone} |"
        )
        print(line, flush=True)
        lines.append(line)
    lines.append("")
    for n in args.exact:
        if ("approximate", n) in figures:
            a, e = figures["approximate", n], figures["exact", n]
            lines.append(
                f"- n = {n}: the approximate model's held-out RMS is {100 * (a['rms'] / e['rms'] - 1):+.1f} % "
                f"from the exact GP's, in {a['wall'] / e['wall']:.2g} of its time and "
                f"{a['rss'] / e['rss']:.2g} of its peak memory."
            )
            print(lines[-1], flush=True)
    f = run("threads", max(args.sizes))
    lines += [
        "",
        f"FITC sums of the fitted model at n = {f['n']} (m = {f['m']}), best of two: "
        f"{f['one']:.2f} s on one BLAS thread, {f['two']:.2f} s on two "
        f"(the fit uses one: on a shared machine threads contend).",
    ]
    print(lines[-1], flush=True)
    lines += ["", *footer(), "", READING]
    if args.write:
        write(lines, "bench_residual")


if __name__ == "__main__":
    main()
