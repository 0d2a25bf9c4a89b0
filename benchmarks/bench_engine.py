"""Speed of the error-state engine at KF-GINS's workload, in-process and through the CLI.

The workload of issue 13 ("equal work"): one hour of 100 Hz IMU rows (the shipped
``paper002_hour`` drive, simulated once), mechanization and a 22-state covariance predict
every IMU row (``phi, dv, dp, eps, nabla, mount, dk, lever``), a forward-velocity and an NHC
measurement at 10 Hz, output at 1 Hz. KF-GINS (C++/Eigen, 21 states, predict every IMU
epoch) spends about 3.5 s of CPU per such hour in its filter, measured on this machine.

Figures (best of ``--repeat`` after a warm-up run, CPU time of this process, one BLAS
thread):

* ``engine``: :class:`inmotion.estimation.engine.ErrorStateFilter` fed the hour in chunks
  (the streaming API, as a batch run does), with the default second-order transition
  ``Phi = I + F dt + (F dt)^2 / 2``, and again with ``phi_order=1``: ``Phi = I + F dt``,
  KF-GINS's own discretization (``insPropagation`` in its ``gi_engine.cpp``: ``Phi = I + F dt``
  and the same trapezoid ``Q_d``), i.e. exactly its workload (module docstring of
  :mod:`inmotion.estimation.predict`, "First order": on this hour the two differ by 1 mm of
  position, 2.5e-4 sigma, and 1.3e-7 rad of attitude, 1e-4 sigma). The first line is the
  default's, the figure of issue 13's target;
* ``sins-dr 100 Hz``: the method ``sins-dr`` (22 states, SINS and DR) with its filter at
  100 Hz and measurements at 10 Hz, in-process;
* ``sins-dr 100 Hz smoothed``: the same with ``smooth=True`` (records at the 10 Hz update
  epochs and the 1 Hz output epochs, Rauch-Tung-Striebel backward pass);
* ``process --smooth``: the main job (``inmotion.process.run_process``) on the same hour
  with an odometer in place of the radar, smoothed (issue 14's target: 3 s);
* ``CLI``: ``inmotion navigate BUNDLE --method sins-dr`` on a Parquet bundle of the hour with
  the same settings and 1 Hz output, wall time of the whole command; ``inmotion align BUNDLE
  --method od-velocity-kf`` with ``filter_rate_hz=100``, ``measurement_rate_hz=10``,
  ``feedback_rate_hz=10``, ``use_baro=false``, ``--output-rate 1``: the equal workload itself
  through the command line (19 states: ``phi, dv, dp, eps, nabla, mount, dk``; the sensor's
  velocity and the NHC at 10 Hz), which the ahead-of-time extension also holds
  (``_aot_build.RUNS``; the line says so when a run imports numba); and ``inmotion --help``
  (the fixed start-up cost).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_engine.py [--repeat N] [--no-cli]
        [--cli-only]

What the CLI hour is made of (issue 13, branch h13cli5; AMD EPYC, 2 cores shared with other
jobs, load 2-4; ``benchmarks/bench_startup.py --parts HOUR --set mode=velocity-position --set
filter_rate_hz=100 --set measurement_rate_hz=10 --set output_rate_hz=1``, CPU best of 3-5,
and ``perf record`` of the command). Before (7a9a7cf): 2.04-2.16 s wall, 2.0-2.1 s CPU:
imports 0.25 s, configuration 0.001, opening the bundle (meta, the IMU's and truth's time
columns, radar and barometer) 0.067, initial state 0.008, **filter built 0.56** (numba
imported to load the predict kernel: the hour's radar states a Markov scale factor,
``F[dk, dk] = -1 / tau``, so its kernel has 16 active rows, and the extension held only the
15-row kernel of its 7 s drive's constant scale factor), IMU rows read and checked 0.046,
filter kernel 0.72 (with **scipy.linalg's import, 0.17 s**, at the first BLAS call of the
loop: ``V @ C_D`` of the velocity rows' mount columns, which sins-dr, having no mount block,
never read), truth rows for the errors 0.077, result written 0.051; in the process 1.87.
After: the kernel recorded ahead of time too (``_aot_build.RUNS``), the product formed only
with a mount block, the IMU's next chunk read and checked in a reader thread
(``io.bundle_stream.read_ahead``) while the extension's loop, which now releases the GIL,
runs: no numba, no scipy; filter built 0.006 s; in the process 1.28 s CPU, of which the
filter kernel ~0.7 (perf: predict kernel ~0.36 s, the loop with the SINS step 0.10, sequential
updates 0.045, DR step 0.04, attitude updates 0.025, sin/cos 0.05, DR position noise 0.012),
imports 0.21-0.25, open 0.064, truth 0.069, result 0.053. Back to back (alternating, 8-10 runs
each, three series at load 3.6-7): 7a9a7cf 1.72-2.09 s wall min, 1.48-1.70 s CPU min; h13cli5
1.13-1.26 s wall min, 1.09-1.18 s CPU min (without the reader thread 1.18-1.34 s wall);
outputs byte-identical (``summary.json`` but for its timing). This file, same load:
7a9a7cf 2.42 s, h13cli5 1.97 s (best of 3). Still above 1.0 s: the
filter alone is ~0.7 s CPU and everything else (imports, opening, truth, writing) ~0.45 s, of
which only reading overlaps. Why sins-dr's filter costs twice the equal workload: its F has
16 active rows against 9 (the DR's attitude and position errors and the Markov ``dk`` have
dynamics: paper 002's model), and the predict scales with them (``bench_predict.py``, load
12: 1.11 us a call against 0.55 us, 0.40 s against 0.20 s an hour), plus a DR step per row
(its attitude update, midpoint and position noise, ~0.1 s an hour); not overhead.

Branch h13cli6 (issue 13, the CLI hour on 2 cores): what ran after the filter now runs
beside it, while the extension's loop (which releases the GIL) runs on the other core. The
truth rows the errors need are read and checked in a thread as the outputs come
(:class:`inmotion.io.bundle_stream.TruthReducer`, fed each chunk's output times by
``VelocityAidedRun.run_stream(output_times=...)``; its result equals ``TruthStream.reduced``
array for array; two truth chunks of 16,384 rows held, no time column, Arrow's buffers from
malloc: with Arrow's default pool the thread's heap raised the hour's peak RSS from ~175 to
~211 MiB, now 186-207 MiB, 4 h / 1 h 1.02, ``bench_memory.py --only sins-dr``); the solution
and states tables are
written in a thread while the errors are computed; the writer's imports (``pyarrow.csv``,
``glob``) load during the run. ``od-velocity-kf`` and ``dr-kf`` read their next IMU chunk
ahead as ``sins-dr`` does, and a streaming method without an output rate of its own keeps only
the rows thinning can keep (:func:`inmotion.io.result.thin_select`): ``od-velocity-kf`` wrote
the same files but held, concatenated and packed every 100 Hz row (2.5 s of CPU per hour, of
which ~0.35 s concatenating them); its equal-workload case is in ``_aot_build.RUNS`` (numba
was imported: its 19-state predict kernel and fills were not in the extension). Outputs
byte-identical (``summary.json`` but its timing). Measured back to back (``benchmarks/ab_cli.py``:
the two trees' runs alternated, each child's main-thread and process CPU printed; load 3.8-5 on 2 cores, so wall times wander and the main thread's CPU, the
critical path when the other threads fit on the second core, is the steadier figure):
``sins-dr`` (11 runs each) wall min 1.057 -> 1.021 s, main thread 0.989 -> 0.865 s (min),
1.112 -> 1.048 s (median), process CPU 1.032 -> 1.010 s (min); an earlier series of 7 at
load 6-7.5: main thread 1.217 -> 0.995 s (min), 1.352 -> 1.204 s (median);
``bench_startup.py --parts`` (best of 7, load 5-5.9): truth rows 0.062 s on the main thread
-> 0.098 s in the thread, the main thread's wait for them 0.002 s, result written 0.042 ->
0.022 s, but the filter kernel's CPU 0.589 -> 0.634 s (the threads beside it; at this load
the spread is of that size). ``od-velocity-kf`` (6 runs each): wall min 3.15 -> 1.58 s,
main thread 2.39 -> 1.23 s, no numba. This file ``--cli-only --repeat 5`` at load 5-6:
sins-dr 2.08 s wall, od-velocity-kf 1.64 s wall (inflated by the load alike). Still above
1.0 s at these loads; the floor of this design is imports (~0.25 s) + opening (~0.06 s) +
the filter kernel (~0.55-0.6 s, the predict ~0.36 s of it) + ~0.05 s.

Why ``od-velocity-kf``'s CLI line (1.41 s in ``make bench`` 2026-12-02 18:23 UTC; 1.22-1.49 s
in three runs after) stays above ``sins-dr``'s although its model is the smaller one (lead's
profile, 19:08 UTC, quiet machine): ``cProfile`` of the command puts 1.11 s of its 2.2 s in the
extension's ``advance`` (22 calls), against the in-process equal workload's ~0.3 s per hour;
its predict pattern is not the cause (19 states, 10 active rows ``phi, dv, dp`` and the Markov
``dk``, 59 nonzeros of F, against the equal workload's 9). What differs: ``dr_kalman._engine_filter``
builds the run with ``out_every=1``, so the kernel writes the state and its sigma at every
100 Hz filter epoch (360,000 rows an hour) and the CLI's 1 Hz thinning (``thin_select``) only
picks from them afterwards, where ``sins-dr`` and the equal workload write at 1 Hz in the
kernel. Done right after: ``output_interval_s`` in the configuration (``dr_kalman.
OdVelocityKfConfig.output_interval_for_rate``), set by ``--output-rate`` where the rows written
are those thinning keeps: the CLI hour 1.22-1.49 -> 0.82-0.90 s wall (three runs each, load
~1), files byte-identical; in-process, ``out_every`` 1 -> 100: 1.33 -> 0.35 s CPU. This file
``--cli-only --repeat 5`` then (19:11 UTC, load 1.3): sins-dr 0.93 s, od-velocity-kf 0.85 s.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from inmotion.core.solution import NavState
from inmotion.estimation import error_model as em
from inmotion.estimation import measurements as ms
from inmotion.estimation.engine import ErrorStateFilter
from inmotion.estimation.layout import Layout
from inmotion.navigate.sins_dr import run_sins_dr
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

LAYOUT = Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk", "lever"])
ARCMIN = np.pi / 180 / 60


def engine_run(bundle, init, measurements=True, phi_order=2, outputs=None):
    """The equal-workload filter over the whole hour; returns the filter. ``measurements``
    False: the same without the 10 Hz samples (mechanization and predict only, for
    ``profile_engine.py``); ``phi_order`` the filter's (1: KF-GINS's ``Phi = I + F dt``);
    ``outputs`` a list: each chunk's output rows (``add_imu``'s dicts) are appended to it."""
    lay = LAYOUT
    model = em.ErrorModel(lay, em.ProcessNoise(gyro_arw=1e-6, accel_vrw=1e-4))
    d = np.r_[[ARCMIN * 10] * 2, [ARCMIN * 30], [0.1] * 3, [1e-7, 1e-7, 3.0], [2e-7] * 3,
              [2e-3] * 3, [ARCMIN * 10] * 3, [1e-3], [0.05] * 3]
    f = ErrorStateFilter(init, lay, model, np.diag(d ** 2),
                         [ms.ForwardVelocity([0.05, 0.1, 0.05]), ms.Nhc(0.05)],
                         step_rows=1, out_every=100, phi_order=phi_order)
    imu, radar = bundle.imu, bundle.radar
    t = imu.t[1:]
    chunk = 16384
    for a in range(0, len(t), chunk):
        b = min(a + chunk, len(t))
        tm = radar.t[(radar.t > (t[a - 1] if a else init.t)) & (radar.t <= t[b - 1])]
        if measurements:
            f.add_measurement("sensor_velocity", tm, np.interp(tm, radar.t, radar.v))
            f.add_measurement("nhc", tm)
        out = f.add_imu(t[a:b], imu.dtheta[1 + a:1 + b], imu.dvel[1 + a:1 + b],
                        flush=b == len(t))
        if outputs is not None:
            outputs.append(out)
    return f


def best_cpu(fn, repeat):
    fn()                                                  # warm-up (JIT, caches)
    best = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


def cli_wall(cmd, env, repeat):
    """Best wall time [s] of ``repeat`` runs of the command ``cmd`` after a warm-up run."""
    walls = []
    for i in range(repeat + 1):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, capture_output=True)
        if i:                                              # the first warms caches
            walls.append(time.perf_counter() - t0)
    return min(walls)


#: the command line run in-process, then whether numba was imported (the JIT path)
_NUMBA_CHECK = ("import sys, os\nimport inmotion.cli.main as M\nsys.argv = ['inmotion'] + "
                "sys.argv[1:]\ntry:\n    M.main()\nexcept SystemExit as e:\n    assert not "
                "e.code\nprint('NUMBA', 'numba' in sys.modules)\nos._exit(0)\n")


def numba_note(cmd, env):
    """``"; numba imported"`` when the command's run imports numba (no ahead-of-time case
    for it: ``python -m inmotion.warmup`` builds them), else ``""``."""
    i = cmd.index("inmotion.cli.main")
    p = subprocess.run([cmd[0], "-c", _NUMBA_CHECK, *cmd[i + 1:]], env=env,
                       capture_output=True, text=True, check=True)
    return "; numba imported (JIT path)" if "NUMBA True" in p.stdout else ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-cli", action="store_true")
    ap.add_argument("--cli-only", action="store_true", help="only the command-line lines")
    args = ap.parse_args()
    bundle = simulate(load_scenario(find_scenario("paper002_hour")), np.random.default_rng(0))
    init = NavState.from_truth(bundle.truth)
    hours = (bundle.imu.t[-1] - bundle.imu.t[0]) / 3600.0
    print(f"paper002_hour: {len(bundle.imu.t) - 1} IMU rows, {hours:.3f} h at "
          f"{1 / np.median(np.diff(bundle.imu.t)):.0f} Hz")
    if not args.cli_only:
        in_process(bundle, init, hours, args)
    if args.no_cli:
        return
    cli_lines(bundle, args)


def in_process(bundle, init, hours, args):
    """The in-process lines (CPU per hour)."""
    f = engine_run(bundle, init)
    print(f"  engine: {f.epochs} predicts, counts {f.counts()}")
    s = best_cpu(lambda: engine_run(bundle, init), args.repeat) / hours
    print(f"engine equal workload: {s:.3f} s CPU per hour (KF-GINS 3.5 s; target 0.25 s)")
    s = best_cpu(lambda: engine_run(bundle, init, phi_order=1), args.repeat) / hours
    print(f"engine equal workload, first-order Phi (KF-GINS's I + F dt): {s:.3f} s CPU per hour")
    cfg = {"mode": "velocity-position", "filter_rate_hz": 100.0, "measurement_rate_hz": 10.0,
           "output_rate_hz": 1.0}
    s = best_cpu(lambda: run_sins_dr(bundle, cfg, init), args.repeat) / hours
    print(f"sins-dr 100 Hz in-process: {s:.3f} s CPU per hour")
    s = best_cpu(lambda: run_sins_dr(bundle, {**cfg, "smooth": True}, init), 1) / hours
    print(f"sins-dr 100 Hz smoothed (forward + RTS backward) in-process: {s:.3f} s CPU per hour")
    # the main job on the same hour with an odometer instead of the radar, smoothed
    import yaml

    from inmotion.process import ProcessConfig, run_process
    sc = yaml.safe_load(open(find_scenario("paper002_hour")).read())
    sc["sensors"] = {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0,
                                  "scale_factor_sigma_ppm": 1000.0}}
    odo = simulate(load_scenario(sc), np.random.default_rng(0))
    s = best_cpu(lambda: run_process(odo, ProcessConfig(smooth=True)), 1) / hours
    print(f"process --smooth, 1 h at 100 Hz with an odometer: {s:.3f} s CPU per hour "
          f"(target 3 s)")


def cli_lines(bundle, args):
    """The command-line lines (wall time of the whole command)."""
    from inmotion.io.bundle import write_bundle
    exe = [sys.executable, "-m", "inmotion.cli.main"]
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour"
        write_bundle(bundle, path, fmt="parquet")
        cmd = exe + ["-q", "navigate", str(path), "--method", "sins-dr", "--init", "truth",
                     "--set", "mode=velocity-position", "--set", "filter_rate_hz=100",
                     "--set", "measurement_rate_hz=10", "--set", "output_rate_hz=1",
                     "-o", str(Path(tmp) / "out")]
        print(f"CLI sins-dr 100 Hz, Parquet in, 1 Hz out: {cli_wall(cmd, env, args.repeat):.2f} "
              f"s wall per hour (target 1.0 s){numba_note(cmd, env)}")
        # issue 13's equal workload itself through the command line: mechanization and a
        # 19-state predict every IMU row (phi, dv, dp, eps, nabla, mount, dk), the sensor's
        # velocity and the NHC at 10 Hz, closed-loop feedback at 10 Hz, 1 Hz out
        cmd = exe + ["-q", "align", str(path), "--method", "od-velocity-kf", "--init", "truth",
                     "--set", "filter_rate_hz=100", "--set", "measurement_rate_hz=10",
                     "--set", "feedback_rate_hz=10", "--set", "use_baro=false",
                     "--output-rate", "1", "-o", str(Path(tmp) / "out-odv")]
        print(f"CLI od-velocity-kf 100 Hz (equal workload: 19 states, velocity + NHC at 10 Hz), "
              f"Parquet in, 1 Hz out: {cli_wall(cmd, env, args.repeat):.2f} s wall per hour "
              f"(target 1.0 s){numba_note(cmd, env)}")
        walls = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            subprocess.run(exe + ["--help"], check=True, env=env, capture_output=True)
            walls.append(time.perf_counter() - t0)
        print(f"CLI start-up only (inmotion --help): {min(walls):.2f} s wall")


if __name__ == "__main__":
    main()
