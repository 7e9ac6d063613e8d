"""From a plan to a campaign: the order a technician runs the poses in, each move checked, how
long it takes, accuracy against time, and the next poses to measure from the data so far.

A campaign uses a plan and sits above planning (and calibration, for the adaptive loop):
timing.py (move times, settle, dwell), ordering.py (Held–Karp, 2-opt/Or-opt), motion.py (moves
certified collision-free, detours), line_of_sight.py, schedule.py (:func:`plan_campaign`).
"""
