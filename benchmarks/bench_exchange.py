"""CPU of the exchange search's scoring (issue 17 item 1), run by hand:

    python benchmarks/bench_exchange.py --before /tmp/pincal-before --repeat 3

``--before`` is a checkout of the code to compare with (``git worktree add --detach
/tmp/pincal-before <commit>``): each tree runs in child processes of this one, each importing its
own ``pincal`` (PYTHONPATH), the trees interleaved run by run. BLAS on one thread. For each run:

1. Per call: the exchange state of the README's problem (KR 270, marker (0.1, 0.05, 0.2) m,
   ``full,offsets`` identifiable, 27 parameters) for a pool of 2000 random configurations and a plan
   of 40, for the test-pose criterion of 9 test poses (27 weight columns) and for D: CPU of the
   pool's products after a swap (``_products``) and of one scoring of every candidate swap
   (``scores``), best of 5 rounds of 100 calls.
2. Per design: ``pincal.design(params, 12, around(q0, 10°), seed=0, workers=1,
   with_d_optimal=True)`` (the README's design with its D-optimal baseline, one process), CPU of the
   whole design and of its exchange (the time inside ``InformationExchange.scores`` and the
   floor checks of the fedorov loop), after a warm-up design.

Prints CPU seconds only (the figure to trust on a shared machine), with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from _common import footer, header, load  # benchmarks/ is on sys.path when run as a script

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
import numpy as np
import pincal
assert pincal.__file__.startswith(sys.argv[1]), pincal.__file__  # this tree's, not an installed one
from pincal.evaluation import low_rank
from pincal.evaluation.registry import make_criterion
from pincal.model.jacobian import JacobianEngine
from pincal.planning import exchange

robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
params = robot.parameters("full,offsets").identifiable().identifiable
out = {}
engine = JacobianEngine(params)
rng = np.random.default_rng(0)
J_pool = engine.jacobian(robot.random_configurations(2000, rng), frame="tip")
J0 = engine.jacobian(robot.random_configurations(9, rng), frame="tip")
for name in ("test-pose", "D"):
    state = make_criterion(name, len(params), 3, J0, 1e-5, None).exchange(J_pool, np.arange(40))
    allowed = np.ones(len(J_pool), bool)
    allowed[:40] = False
    products = scores = np.inf
    for _ in range(5):
        t = time.process_time()
        for _ in range(100):
            state.stale = True
            state._products()
        products = min(products, (time.process_time() - t) / 100)
        t = time.process_time()
        for k in range(100):
            state.scores(k % 40, allowed)
        scores = min(scores, (time.process_time() - t) / 100)
    out[name] = (products, scores)

spent = [0.0]
def timed(f):
    def g(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            spent[0] += time.process_time() - t
    return g
low_rank.InformationExchange.scores = timed(low_rank.InformationExchange.scores)
exchange._best_regular = timed(exchange._best_regular)
region = pincal.around(np.radians([0, -60, 60, 0, 45, 0]), np.radians(10))
design = lambda: pincal.design(params, 12, region, seed=0, workers=1, with_d_optimal=True)
design()
spent[0] = 0.0
t = time.process_time()
result = design()
out["design"] = (time.process_time() - t, spent[0], result.value)
print(json.dumps(out))
"""


def run(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(tree)],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--before", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each tree (default 3)")
    args = parser.parse_args()
    trees = [("this", ROOT)] + ([("before", args.before.resolve())] if args.before else [])
    print("\n".join(header()))
    for k in range(args.repeat):
        for label, tree in trees:
            start = load()
            r = run(tree)
            (tp_p, tp_s), (d_p, d_s) = r["test-pose"], r["D"]
            total, exch, value = r["design"]
            print(
                f"run {k + 1} {label:6s}: test-pose products {tp_p * 1e3:.3f} ms, scores {tp_s * 1e3:.3f} ms; "
                f"D products {d_p * 1e3:.3f} ms, scores {d_s * 1e3:.3f} ms; design {total:.2f} s CPU, "
                f"exchange {exch:.2f} s (rho0 {value * 1e3:.7f} mm); load {start} -> {load()}",
                flush=True,
            )
    print("\n".join(footer()))


if __name__ == "__main__":
    main()
