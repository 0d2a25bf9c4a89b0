"""Speed of paper 001's unscented quaternion alignments.

One 300 s, 100 Hz drive simulated from ``paper001_urban`` (with its sensor errors); each scheme
(``usque``, ``ausque``, ``usque-hinf``, ``ausquhe``) aligned on it with a filter update at every
100 Hz sample (the paper's IMU and LDV rate: 30,000 filter cycles), with the paper's state (the
attitude error only, ``noise_preset: paper``), with the extended state (+ accelerometer bias,
LDV scale factor, v^b(0) error, paper preset) and with the default ``noise_preset: matched``
(attitude + integrated-noise state w + LDV scale + accelerometer bias + gyro drift: 13
states). Best of 3 after one warm-up call (JIT compilation and numba's cache load
excluded); also the peak of Python/numpy allocations of one ``ausquhe`` run (tracemalloc).
Target (issue 6): ``ausquhe`` under 2 s on one core.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_usque.py
"""
from __future__ import annotations

import time
import tracemalloc

import numpy as np

from inmotion.registry import get
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

EXTENDED = dict(estimate_accel_bias=True, estimate_scale=True, estimate_initial_speed_error=True)
PAPER = dict(noise_preset="paper")


def _best(fn, repeat=3):
    fn()
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    bundle = simulate(load_scenario(find_scenario("paper001_urban")), np.random.default_rng(0))
    print(f"paper001_urban: {bundle.imu.t[-1] - bundle.imu.t[0]:.0f} s, "
          f"{len(bundle.imu.t)} IMU rows at 100 Hz; updates at 100 Hz")
    print(f"{'method':12s} {'state':9s} {'seconds':>8s} {'us/cycle':>9s}")
    for name in ("usque", "ausque", "usque-hinf", "ausquhe"):
        run, Config = get(name).load()
        for label, kw in (("paper", PAPER), ("extended", {**PAPER, **EXTENDED}),
                          ("matched", {})):
            cfg = Config(**kw)
            sec = _best(lambda: run(bundle, cfg, None))
            print(f"{name:12s} {label:9s} {sec:8.3f} {1e6 * sec / (len(bundle.imu.t) - 1):9.1f}")
    run, Config = get("ausquhe").load()
    tracemalloc.start()
    run(bundle, Config(), None)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"ausquhe peak Python/numpy allocation: {peak / 1e6:.1f} MB "
          "(the output arrays: 30,001 epochs of attitude, covariance, R, gamma)")


if __name__ == "__main__":
    main()
