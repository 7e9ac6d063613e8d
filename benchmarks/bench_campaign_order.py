"""What ordering a plan into a campaign saves (issue 16, item 2), run by hand:

    python benchmarks/bench_campaign_order.py

For the KR 270 and the UR10 (marker (0.1, 0.05, 0.2) m, identifiable `lengths,offsets`), plans of
12 and 40 poses designed for the ±10° region around a test pose (2 seeds each, 2 starts), ordered
by pincal.campaign.plan_campaign (order and time only, check=False): the campaign from home and
back in the plan's own order against the chosen order (Held–Karp up to 12 poses, 2-opt/Or-opt
beyond), URDF speeds, 0.5 s settle and a tracker's 2 s dwell. Ordering time in CPU seconds.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from _common import footer, header, timed  # benchmarks/ is on sys.path when run as a script

import pincal
from pincal.campaign import plan_campaign

Q0 = {"kr270": np.radians([0, -60, 60, 0, 45, 0]), "ur10": np.radians([0, -70, 90, -110, -90, 0])}


def main() -> None:
    warnings.simplefilter("ignore")
    print("\n".join(header()), flush=True)
    for name in ("kr270", "ur10"):
        robot = pincal.load_robot(name, markers=[(0.1, 0.05, 0.2)])
        params = robot.parameters("lengths,offsets").identifiable().identifiable
        for m in (12, 40):
            for seed in range(2):
                region = pincal.around(Q0[name], np.radians(10))
                plan = pincal.design(
                    params, m, region, search=pincal.Search(seed=seed, starts=2, workers=1)
                ).plan
                with timed() as clock:
                    c = plan_campaign(robot, plan, check=False)
                cpu = clock.cpu
                saved = c.given_time - c.tour_time
                moving = (c.given_time - c.stop_time, c.tour_time - c.stop_time)
                print(
                    f"| {name} | {m} | {seed} | {c.given_time:.1f} | {c.tour_time:.1f} | {saved:.1f} | "
                    f"{100 * saved / c.given_time:.1f} % | {moving[0]:.1f} → {moving[1]:.1f} | "
                    f"{'Held–Karp' if c.exact else '2-opt/Or-opt'} | {cpu:.3f} |",
                    flush=True,
                )
    print("\n".join(footer()))


if __name__ == "__main__":
    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()
    main()
