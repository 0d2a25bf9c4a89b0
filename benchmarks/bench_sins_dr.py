"""Speed and memory of ``sins-dr`` (paper 002) on the paper's one-hour drive.

The shipped ``paper002_hour`` scenario (3600 s, 50.6 km, 100 Hz IMU, 10 Hz radar) is simulated
once; ``sins-dr`` then runs on it in both modes with the filter, the measurements and the
output at 10 Hz (the default). JIT compilation is excluded (one warm-up run first). Prints the
seconds per run (best of ``--repeat``), the IMU rows and filter epochs per second, and the peak
of Python/numpy allocations during a run (tracemalloc; the output arrays dominate it).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_sins_dr.py [--repeat N] [--filter-hz F]

The issue's target: under 3 s per run on one core.
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from inmotion.core.solution import NavState
from inmotion.navigate.sins_dr import run_sins_dr
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--filter-hz", type=float, default=10.0)
    args = ap.parse_args()
    bundle = simulate(load_scenario(find_scenario("paper002_hour")), np.random.default_rng(0))
    init = NavState.from_truth(bundle.truth)
    rows = len(bundle.imu.t) - 1
    print(f"paper002_hour: {rows} IMU rows ({bundle.imu.t[-1]:.0f} s at "
          f"{1 / np.median(np.diff(bundle.imu.t)):.0f} Hz), filter {args.filter_hz:g} Hz")
    for mode in ("attitude-position", "velocity-position"):
        cfg = {"mode": mode, "filter_rate_hz": args.filter_hz,
               "measurement_rate_hz": args.filter_hz}
        run_sins_dr(bundle.window(0.0, 20.0), cfg, init)          # JIT warm-up
        best = np.inf
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            sol = run_sins_dr(bundle, cfg, init)
            best = min(best, time.perf_counter() - t0)
        tracemalloc.start()
        run_sins_dr(bundle, cfg, init)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        epochs = len(sol.t) - 1
        print(f"  {mode:18s} {best:6.2f} s per run  ({rows / best / 1e3:6.0f} k rows/s, "
              f"{epochs / best / 1e3:5.1f} k epochs/s)  peak alloc {peak / 2**20:6.1f} MiB  "
              f"{'OK' if best < 3.0 else 'SLOWER THAN 3 s'}")


if __name__ == "__main__":
    main()
