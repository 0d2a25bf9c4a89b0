"""Speed of the attitude-determination coarse alignments (paper 004's setting).

One 120 s, 100 Hz drive simulated from ``paper004_v80`` (with its sensor errors); every method
aligned on it, best of 5, JIT compilation excluded (one warm-up call first). Also the peak of
Python/numpy allocations during one ``mimada-dual`` call (tracemalloc) and, with ``--hour``,
the time and memory for one hour of data (the kernel's memory is the decimated output only).
With ``--reproduce`` it times the whole 3 x 50-run paper 004 reproduction on 2 workers.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_coarse.py [--hour] [--reproduce]
"""
from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc

import numpy as np

from inmotion.core.bundle import Bundle, ImuData, SpeedData
from inmotion.registry import get
from inmotion.sim.simulate import simulate

METHODS = ("imada-vb", "imada-vn", "imada-dual", "oba", "mimada", "mimada-dual", "coarse-inertial")


def _time(fn, *args, repeat=5):
    fn(*args)                                   # warm-up (JIT, caches)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best


def _repeat_hour(b: Bundle) -> Bundle:
    """30 copies of the 120 s drive end to end (only the time is measured)."""
    k = 30
    n = len(b.imu.t)
    dt = b.imu.t[1] - b.imu.t[0]
    t = np.arange(n * k) * dt
    imu = ImuData(t, np.tile(b.imu.dtheta, (k, 1)), np.tile(b.imu.dvel, (k, 1)))
    return Bundle(imu, b.meta, radar=SpeedData(t, v=np.tile(b.radar.v, k)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hour", action="store_true")
    ap.add_argument("--reproduce", action="store_true")
    args = ap.parse_args()
    b = simulate("paper004_v80", np.random.default_rng(0))
    print(f"one 120 s alignment at 100 Hz ({len(b.imu.t)} rows), best of 5:")
    for name in METHODS:
        run, Cfg = get(name).load()
        print(f"  {name:16s} {_time(run, b, Cfg(), None) * 1e3:7.1f} ms")
    run, Cfg = get("mimada-dual").load()
    tracemalloc.start()
    run(b, Cfg(), None)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"  mimada-dual peak allocation {peak / 1e6:.1f} MB")
    if args.hour:
        h = _repeat_hour(b)
        tracemalloc.start()
        t0 = time.perf_counter()
        run(h, Cfg(output_interval_s=10.0), None)
        el = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        inputs = (h.imu.dtheta.nbytes + h.imu.dvel.nbytes + h.imu.t.nbytes) / 1e6
        print(f"one hour (360,000 rows), mimada-dual: {el:.2f} s, peak allocation "
              f"{peak / 1e6:.1f} MB (inputs {inputs:.1f} MB)")
    if args.reproduce:
        from inmotion.reproductions.paper004 import reproduce
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            reproduce(d, runs=50, workers=2, seed=0, progress=False)
            print(f"paper 004 reproduction, 3 x 50 runs, 10 alignments each, 2 workers: "
                  f"{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
