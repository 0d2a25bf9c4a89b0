"""Speed and memory of the core loops: SINS mechanization and dead reckoning.

One hour of 100 Hz increments (360,000 rows) of a vehicle driving with turns, climbs and speed
changes (plausible increments, not a truth-consistent trajectory: only the time is measured).
JIT compilation is excluded (a short warm-up run first). Prints seconds per run (best of 3) and
the peak of Python/numpy allocations during a run (tracemalloc), with every state written out
(``out_stride=1``) and decimated to 1 Hz (``out_stride=100``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_core.py [--hours H] [--rate-hz F] [--accuracy]

``--accuracy`` also runs the issue's acceptance on an analytic truth (``tests/analytic_drive.py``:
3600 s, 50.4 km, turns, +-3 deg climbs, a stop every 10 min, exact 100 Hz increments from a
rtol 1e-12 ODE solution) through the SINS with a perfect barometer and through the DR with a
perfect odometer, and prints the maximum errors; then the DR on the simulator's demo drive
with error-free radar and odometer at lever arms (with and without the lever arm).
"""
from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from inmotion.core import earth
from inmotion.core.bundle import BaroData, ImuData, SpeedData
from inmotion.core.deadreckoning import dead_reckon
from inmotion.core.mechanization import strapdown
from inmotion.core.solution import NavState


def synthetic_drive(hours: float, rate_hz: float = 100.0):
    """Increments of a drive: yaw rate, pitch and speed oscillations on a resting-Earth base."""
    n = int(hours * 3600 * rate_hz)
    dt = 1.0 / rate_hz
    t = np.arange(n) * dt
    lat = np.radians(34.0)
    w_ie_b = earth.omega_ie_n(lat)
    g = earth.gravity(lat, 0.0)
    yaw_rate = np.radians(5.0) * np.sin(2 * np.pi * t / 97.0)
    pitch_rate = np.radians(0.3) * np.cos(2 * np.pi * t / 41.0)
    accel = 0.8 * np.sin(2 * np.pi * t / 300.0)
    dtheta = np.stack([pitch_rate + w_ie_b[0], np.full(n, w_ie_b[1]),
                       -yaw_rate + w_ie_b[2]], -1) * dt
    dvel = np.stack([10.0 * yaw_rate, accel, np.full(n, g)], -1) * dt
    speed = 12.0 + 6.0 * np.sin(2 * np.pi * t / 300.0)
    init = NavState.from_euler(0.0, lat, np.radians(108.0), 400.0, [0, 12.0, 0], [0, 0, 0.3])
    return ImuData(t, dtheta, dvel), SpeedData(t, v=speed), BaroData(t, np.full(n, 400.0)), init


def measure(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return best, peak / 2 ** 20


def accuracy(rate_hz=100.0):
    """Max errors of SINS (perfect baro) and DR (perfect odometer) on the analytic hour."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from analytic_drive import stop_and_go_hills

    from inmotion.core.rotations import dcm_from_euler, misalignment

    t = np.arange(0.0, 3600.0 + 1e-9, 1.0 / rate_hz)
    t0 = time.perf_counter()
    d = stop_and_go_hills(t)
    print(f"analytic truth, {len(t)} rows at {rate_hz:g} Hz, made in "
          f"{time.perf_counter() - t0:.1f} s")
    imu = ImuData(t, d["dtheta"], d["dvel"])
    init = NavState.from_euler(t[0], d["lat"][0], d["lon"][0], d["h"][0], d["vel_n"][0],
                               d["euler"][0])
    v = np.linalg.norm(d["vel_n"], axis=1)
    ds = np.concatenate([[0.0], 0.5 * (v[1:] + v[:-1]) * np.diff(t)])
    print(f"distance {ds.sum() / 1000:.1f} km")
    runs = [("SINS, perfect baro", strapdown(imu, init, BaroData(t, d["h"]), damping="baro")),
            ("DR, perfect odometer ds", dead_reckon(imu, SpeedData(t, ds=ds), init))]
    for name, sol in runs:
        dn, de = earth.local_ne_offsets(sol.lat, sol.lon, d["lat"], d["lon"])
        att = np.abs(misalignment(sol.C_nb, dcm_from_euler(d["euler"]))).max()
        print(f"{name:26s} max horizontal {np.hypot(dn, de).max():.2e} m, "
              f"vertical {np.abs(sol.h - d['h']).max():.2e} m, "
              f"velocity {np.abs(sol.vel_n - d['vel_n']).max():.2e} m/s, "
              f"attitude {np.degrees(att) * 3600:.2e} arcsec")


def simulator_check():
    """DR with error-free sensors from :mod:`inmotion.sim` (the demo drive, vehicle mounting,
    radar and odometer at lever arms): with the mounting and lever arms the DR must reproduce
    the simulated truth; without the lever arm it must not."""
    import yaml

    from inmotion.core.rotations import mounting_dcm
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    d = yaml.safe_load(open(find_scenario("demo")))
    d["imu"] = {"rate_hz": 100.0}
    d["sensors"] = {"radar": {"rate_hz": 100.0, "lever_arm_m": [0.5, 1.8, -0.6]},
                    "odometer": {"rate_hz": 20.0, "pulses_per_m": 1e6,
                                 "lever_arm_m": [-0.75, -1.4, -0.9]}}
    b = simulate(load_scenario(d), np.random.default_rng(0))
    tr = b.truth
    init = NavState.from_truth(tr)
    C_vb = mounting_dcm(np.radians(np.array(d["vehicle_mounting_arcmin"]) / 60))
    print(f"simulator demo drive, error-free sensors, vehicle mounting "
          f"{d['vehicle_mounting_arcmin']} arcmin")
    for name in ("radar", "odometer"):
        for lever in (d["sensors"][name]["lever_arm_m"], None):
            sol = dead_reckon(b.imu, getattr(b, name), init, C_bm=C_vb, lever_arm_b=lever)
            k = np.searchsorted(tr.t, sol.t)
            dn, de = earth.local_ne_offsets(sol.lat, sol.lon, tr.lat[k], tr.lon[k])
            print(f"DR {name:8s} lever arm {'given' if lever else 'ignored':7s} "
                  f"max horizontal {np.hypot(dn, de).max():.2e} m, "
                  f"vertical {np.abs(sol.h - tr.h[k]).max():.2e} m, "
                  f"velocity {np.abs(sol.vel_n - tr.vel_n[k]).max():.2e} m/s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--rate-hz", type=float, default=100.0, help="IMU rate (KF-GINS: 200 Hz)")
    ap.add_argument("--accuracy", action="store_true",
                    help="also run the acceptance drive against analytic truth, and the DR "
                         "against the simulator with lever arms")
    args = ap.parse_args()
    imu, speed, baro, init = synthetic_drive(args.hours, args.rate_hz)
    warm = synthetic_drive(0.001)
    strapdown(warm[0], warm[3], warm[2], damping="baro")
    dead_reckon(warm[0], warm[1], warm[3])
    n = len(imu.t)
    input_mib = (imu.dtheta.nbytes + imu.dvel.nbytes + imu.t.nbytes) / 2 ** 20
    print(f"{n} rows of {args.rate_hz:g} Hz increments ({args.hours:g} h); "
          f"input arrays {input_mib:.1f} MiB")
    cases = [
        ("strapdown, baro damping, every row out",
         lambda: strapdown(imu, init, baro, damping="baro")),
        ("strapdown, baro damping, 1 Hz out",
         lambda: strapdown(imu, init, baro, damping="baro", out_stride=int(args.rate_hz))),
        ("strapdown, free, every row out", lambda: strapdown(imu, init)),
        ("dead reckoning, every row out", lambda: dead_reckon(imu, speed, init)),
        ("dead reckoning, 1 Hz out",
         lambda: dead_reckon(imu, speed, init, out_stride=int(args.rate_hz))),
    ]
    for name, fn in cases:
        sec, peak = measure(fn)
        print(f"{name:42s} {sec:6.3f} s   peak alloc {peak:7.1f} MiB   "
              f"{sec / n * 1e9:5.0f} ns/row")
    if args.accuracy:
        accuracy()
        simulator_check()


if __name__ == "__main__":
    main()
