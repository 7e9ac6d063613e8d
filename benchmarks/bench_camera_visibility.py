"""Camera designs: the predicted error at the test pose against the one N simulated calibrations
deliver, and the share of the grid's corners seen (benchmarks/RESULTS.md, "Camera designs").

    python benchmarks/bench_camera_visibility.py weighted 40   # the design's weights (p where p >= 0.9)
    python benchmarks/bench_camera_visibility.py nominal 40    # error_std=None: the nominal view
    python benchmarks/bench_camera_visibility.py weighted 40 benchmarks/eye_to_hand_rig.yaml 12

The example rig (``pincal example rig``; or the rig file given) on a Panda, 20 configurations (or
the number given) designed with 2 starts, seed 0 (as notebook 05); each trial draws fresh 1 mm /
1 mrad errors and pixel noise, identifies, and measures the error of the tool point at the test
pose.
"""

import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import pincal
import pincal.examples
from pincal.instruments import Instrument, PerCoordinate, load_rig
from pincal.instruments.identifiability import identifiable

warnings.simplefilter("ignore")
mode, N = sys.argv[1], int(sys.argv[2])
rig = load_rig(sys.argv[3] if len(sys.argv) > 3 else Path(pincal.examples.__file__).parent / "rig.yaml")
m = int(sys.argv[4]) if len(sys.argv) > 4 else 20
kind = rig.kind if mode == "weighted" else dataclasses.replace(rig.kind, error_std=None)
panda = pincal.load_robot("panda").with_fixtures(*rig.fixtures)
pixels = PerCoordinate(sigma_px=rig.pixel_sigma)
params = identifiable(panda.parameters("full,offsets,instrument"), Instrument(kind, pixels)).identifiable
q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
t = time.process_time()
search = pincal.Search(starts=2, seed=0)
plan = pincal.design(params, m, q0, instrument=Instrument(kind, pixels), search=search).plan
rho0 = pincal.rho0(params, plan, q0, instrument=Instrument(kind, pixels))
seen_nominal = rig.kind.seen(params.robot, plan.q).mean()
errors, seen = [], []
for k in range(N):
    truth = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=1000 + k)
    data = pincal.simulate_measurements(truth, plan, seed=2000 + k, instrument=Instrument(kind, pixels))
    seen.append(1 - np.isnan(np.asarray(data.values)).mean())
    fit = pincal.identify(params, data, instrument=Instrument(kind, pixels))
    errors.append(np.linalg.norm(fit.robot.points(q0) - truth.robot.points(q0)))
errors = np.array(errors)
rms = np.sqrt(np.mean(errors**2))
se = np.std(errors**2) / np.sqrt(N) / (2 * rms)  # the delta method on the mean square
print("errors [mm], sorted:", np.sort(errors * 1e3).round(3))
print(
    f"{mode}: predicted {rho0 * 1e3:.4f} mm, delivered RMS {rms * 1e3:.4f} ± {se * 1e3:.4f} mm (N={N}), "
    f"ratio {rms / rho0:.2f} ± {se / rho0:.2f}, m={m}, corners seen: nominal {seen_nominal:.3f}, measured {np.mean(seen):.3f}, "
    f"CPU {time.process_time() - t:.0f} s"
)
