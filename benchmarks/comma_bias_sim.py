"""Issue 15: the comma2k19 calibration methods on simulated truth (Monte Carlo).

:func:`inmotion.reproductions.real.simulated_calibration_check` (also part of
``inmotion reproduce real``, whose ``--runs`` sets its runs): a comma2k19-like 60 s drive with
a phone-grade IMU whose gyro bias is a random constant plus a Gauss-Markov wander, every filter
with the comma2k19 importer's assumed spec; yaw mounting error against the simulated truth and
dead reckoning with each calibration.

Run: ``PYTHONPATH=src python benchmarks/comma_bias_sim.py --runs 50`` (about 1 s per run).
"""
from __future__ import annotations

import argparse
import time

from inmotion.reproductions import real as rr


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=rr.SIM_RUNS)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    sim = rr.simulated_calibration_check(a.runs, a.seed)
    print("\n".join(rr._simulated_lines(sim)))
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
