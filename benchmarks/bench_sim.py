"""Speed and memory of the drive simulator: one hour at 100 Hz with every sensor.

The paper 002 one-hour drive (3600 s, 50.6 km) with a Doppler radar (10 Hz), an LDV (100 Hz,
distance output), an odometer (10 Hz) and a barometer (10 Hz), IMU noise and constants, faults,
the IMU mounted in the vehicle at 3', 10', 5'.
Prints seconds per ``simulate`` (best of ``--repeat``), the peak of Python/numpy allocations
during one run (tracemalloc) and the size of the arrays the bundle holds. Target: < 10 s.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_sim.py [--hours H] [--repeat N]
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from inmotion.sim import load_scenario, simulate


def scenario(hours: float) -> dict:
    d = load_scenario("paper002_hour").model_dump()
    d["vehicle_mounting_arcmin"] = [3.0, 10.0, 5.0]      # the mounted-IMU path (the costlier one)
    d["sensors"]["ldv"] = {"rate_hz": 100.0, "output": "distance", "noise_m_s": 0.01,
                           "scale_factor_sigma_ppm": 500.0, "lever_arm_m": [0.3, 1.2, -0.6],
                           "mounting_arcmin": [2.0, 0.0, 3.0]}
    d["sensors"]["odometer"] = {"rate_hz": 10.0, "pulses_per_m": 200.0,
                                "scale_factor_sigma_ppm": 2000.0,
                                "lever_arm_m": [-0.8, -1.5, -0.9]}
    d["faults"] = [{"sensor": "odometer", "kind": "slip", "start_s": 700, "end_s": 710,
                    "slip_ratio": 0.1},
                   {"sensor": "ldv", "kind": "outliers", "start_s": 1000, "end_s": 1100,
                    "probability": 0.2, "magnitude_m_s": 2.0}]
    if hours != 1.0:       # repeat the drive's segments to make a longer log
        d["segments"] = d["segments"] * max(1, int(round(hours)))
    return d


def bundle_bytes(b) -> int:
    arrays = [b.imu.t, b.imu.dtheta, b.imu.dvel, b.truth.lat, b.truth.lon, b.truth.h,
              b.truth.vel_n, b.truth.euler]
    for s in (b.radar, b.ldv, b.odometer):
        arrays += [x for x in (s.t, s.v, s.ds) if x is not None]
    arrays += [b.baro.t, b.baro.h]
    return sum(a.nbytes for a in arrays)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sc = load_scenario(scenario(args.hours))
    simulate(load_scenario("paper004_v20"), np.random.default_rng(0))   # imports warm
    times = []
    for i in range(args.repeat):
        t0 = time.perf_counter()
        b = simulate(sc, np.random.default_rng(i))
        times.append(time.perf_counter() - t0)
    tracemalloc.start()
    b = simulate(sc, np.random.default_rng(0))
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(f"simulate {b.meta['duration_s']:.0f} s at {sc.imu.rate_hz:.0f} Hz "
          f"({len(b.imu.t)} IMU rows, {b.meta['distance_m'] / 1000:.1f} km, "
          f"sensors {', '.join(b.meta['files'][2:])}):")
    print(f"  best {min(times):.2f} s, runs {', '.join(f'{t:.2f}' for t in times)} s  "
          f"(target < 10 s per hour)")
    print(f"  peak allocations {peak / 2**20:.0f} MiB; bundle arrays {bundle_bytes(b) / 2**20:.0f} MiB")


if __name__ == "__main__":
    main()
