"""Benchmark: one 600 s ``fkf`` run with FDI at 100 Hz IMU (paper 003 faults drive) on one core.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_fkf.py [--repeat N]
[--measurement velocity|displacement]``. Prints the wall and process CPU time of the best of N
runs (the first call loads the numba kernels and is not timed). Target (issue 7): under 2 s.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from inmotion.align.aided_kf import run_fkf
from inmotion.core.solution import NavState
from inmotion.sim import simulate


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenario", default="paper003_faults")
    ap.add_argument("--measurement", default="displacement")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    bundle = simulate(args.scenario, np.random.default_rng(0))
    t_sim = time.perf_counter() - t0
    init = NavState.from_truth(bundle.truth, euler_error=np.deg2rad([0.1, 0.1, 1.0]))
    cfg = {"measurement": args.measurement}
    run_fkf(bundle, cfg, init)                      # warm-up: numba cache load
    walls, cpus = [], []
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        sol = run_fkf(bundle, cfg, init)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    n_det = sum(e["event"] == "detected" for e in sol.info["events"])
    print(f"fkf + FDI, {args.scenario}, {len(bundle.imu.t)} IMU rows, {len(sol.t)} outputs, "
          f"{n_det} detections, config {cfg}")
    print(f"  simulation {t_sim:.2f} s (once)")
    print(f"  filter: best wall {min(walls):.3f} s, best CPU {min(cpus):.3f} s "
          f"(target < 2 s); all walls {[round(w, 3) for w in walls]}")


if __name__ == "__main__":
    main()
