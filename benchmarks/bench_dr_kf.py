"""Benchmark: one 600 s ``dr-kf`` run at 100 Hz IMU (paper 000 trajectory 2) on one core.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_dr_kf.py [--repeat N] [--filter-hz F]
[--measurement-hz M]``. Prints the wall time and the process CPU time of the best of N runs
(the first call compiles / loads the numba kernels and is not timed), and the split between
simulation and filter. Target (issue 3): under 1 s per run.

``--reproduce-runs R [--workers W]`` also times ``inmotion.reproductions.paper000.reproduce``
(R Monte Carlo runs of each of the three experiments, W processes, into a temporary folder):
its wall time, the CPU seconds inside the runs, and the CPU seconds of the whole call
(this process and its workers). Target (issue 3): R = 50 under 120 s wall on 2 cores.
"""
from __future__ import annotations

import argparse
import resource
import tempfile
import time

import numpy as np

from inmotion.align.dr_kalman import run_dr_kf
from inmotion.core.solution import NavState
from inmotion.sim import simulate


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenario", default="paper000_traj2")
    ap.add_argument("--filter-hz", type=float, default=None)
    ap.add_argument("--measurement-hz", type=float, default=None)
    ap.add_argument("--reproduce-runs", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    bundle = simulate(args.scenario, np.random.default_rng(0))
    t_sim = time.perf_counter() - t0
    init = NavState.from_truth(bundle.truth, euler_error=np.deg2rad([1.0, 1.0, 1.0]))
    cfg = {}
    if args.filter_hz:
        cfg["filter_rate_hz"] = args.filter_hz
    if args.measurement_hz:
        cfg["measurement_rate_hz"] = args.measurement_hz
        cfg["feedback_rate_hz"] = min(args.measurement_hz, 2.0)
    run_dr_kf(bundle, cfg, init)                   # warm-up: numba cache load
    walls, cpus = [], []
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        sol = run_dr_kf(bundle, cfg, init)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    print(f"dr-kf, {args.scenario}, {len(bundle.imu.t)} IMU rows, {len(sol.t)} filter epochs, "
          f"config {cfg or 'default'}")
    print(f"  simulation {t_sim:.2f} s (once)")
    print(f"  filter: best wall {min(walls):.3f} s, best CPU {min(cpus):.3f} s "
          f"(target < 1 s); all walls {[round(w, 3) for w in walls]}")
    if args.reproduce_runs > 0:
        _bench_reproduce(args.reproduce_runs, args.workers)


def _cpu_self_and_children():
    own, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _bench_reproduce(runs, workers):
    """Time the paper 000 Monte Carlo (three experiments, with / without Z2)."""
    from inmotion.reproductions.paper000 import reproduce
    c0, w0 = _cpu_self_and_children(), time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        js = reproduce(out, runs=runs, workers=workers, progress=False)
    wall, cpu = time.perf_counter() - w0, _cpu_self_and_children() - c0
    print(f"reproduce 000, {runs} runs x 3 experiments, {workers} worker(s): wall {wall:.1f} s "
          f"(Monte Carlo {js['wall_s']:.1f} s; target < 120 s on 2 cores), CPU in the runs "
          f"{js['cpu_s_total']:.1f} s, CPU of the whole call {cpu:.1f} s")


if __name__ == "__main__":
    main()
