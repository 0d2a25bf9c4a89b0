"""The fixed cost of a command-line run, measured as a real run, and what it is made of.

Issue 13: "a CLI run's fixed cost (imports, start-up) <= 0.4 s". ``inmotion --help`` imports
almost nothing, so it is not the figure: the fixed cost is the wall time of a real
``inmotion navigate`` on a bundle of a few seconds (7 s of a 100 Hz IMU, 10 Hz radar and
barometer, truth), where reading, filtering and writing take milliseconds and the rest is
start-up. Beside it, each in a bare interpreter (``python -c``), the floors it stands on:

* ``python``: the interpreter alone;
* ``numpy``, ``pandas``, ``pydantic``, ``pyarrow.parquet``, ``scipy.linalg``: ``import X``;
* ``numba floor``: ``import numba`` and the first call of one trivial ``@njit(cache=True)``
  function loaded from numba's cache: numba builds its CPU target on the first call, which
  imports ``scipy.linalg`` for its BLAS (``numba.np.linalg.ensure_blas``) whatever the
  function does. No run that calls a numba kernel can start faster than this;
* ``numba floor as the command line runs it``: the same, ending with ``os._exit`` as
  :func:`inmotion.cli.main.fast_exit` does (the plain floor above includes Python's teardown
  of numba's modules, about 0.2 s);
* ``run-path imports``: importing what ``navigate --method sins-dr`` imports before it calls
  a kernel (the command line, the method, the result writer, the chunked Parquet reader).

Beside the real run, the same run with
``INMOTION_FAST_EXIT=0`` (Python's own exit, tearing down every module) what
:func:`inmotion.cli.main.fast_exit` saves.

Best of ``--repeat`` wall times of each, and best CPU time (user + system of the child: on a
shared machine the wall time waits for a core, the CPU time hardly moves), after one warm-up
(file caches, numba's cache).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_startup.py [--repeat N]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

import inmotion
from inmotion.io.bundle import write_bundle
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

TINY = {
    "name": "tiny", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "segments": [{"kind": "rest", "duration_s": 1},
                 {"kind": "accelerate", "to_speed_m_s": 3.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 3}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
            "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}

NJIT = textwrap.dedent("""\
    import numba
    @numba.njit(cache=True)
    def f(x):
        s = 0.0
        for i in range(x.shape[0]):
            s += x[i]
        return s
    """)


def _run(cmd, env, cwd):
    """``(wall, cpu)`` [s] of one child: its wall time and its user + system CPU time (the
    latter barely moves when the machine is shared)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    if status:
        raise SystemExit(f"failed: {' '.join(cmd)}")
    return time.perf_counter() - t0, ru.ru_utime + ru.ru_stime


def best_wall(cmd, repeat, env, cwd=None):
    """``(best wall, best CPU)`` [s] of ``repeat`` runs after a warm-up."""
    _run(cmd, env, cwd)                                                  # warm-up
    runs = [_run(cmd, env, cwd) for _ in range(repeat)]
    return min(r[0] for r in runs), min(r[1] for r in runs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    here = str(Path(inmotion.__file__).resolve().parents[1])     # children run in a tmp dir
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p))
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        bundle = Path(tmp) / "tiny"
        write_bundle(simulate(load_scenario(TINY), np.random.default_rng(0)), bundle,
                     fmt="parquet")
        for method in ("sins-dr", "sins"):
            cmd = [py, "-m", "inmotion.cli.main", "-q", "navigate", str(bundle), "--method",
                   method, "-o", str(Path(tmp) / f"out-{method}")]
            wall, cpu = best_wall(cmd, args.repeat, env)
            print(f"CLI fixed cost (navigate {method}, 7 s bundle): {wall:.3f} s wall "
                  f"(target 0.4 s), {cpu:.3f} s CPU")
            if method == "sins-dr":
                wall, cpu = best_wall(cmd, args.repeat, dict(env, INMOTION_FAST_EXIT="0"))
                print(f"CLI fixed cost (navigate {method}) with Python's own exit: {wall:.3f} s "
                      f"wall, {cpu:.3f} s CPU")
        wall, cpu = best_wall([py, "-m", "inmotion.cli.main", "--help"], args.repeat, env)
        print(f"CLI --help: {wall:.3f} s wall, {cpu:.3f} s CPU")
        (Path(tmp) / "k.py").write_text(NJIT)
        floors = {"python": "pass"}
        for mod in ("numpy", "pandas", "pydantic", "pyarrow.parquet", "scipy.linalg",
                    "scipy.special", "numba"):
            floors[f"import {mod}"] = f"import {mod}"
        floors["numba floor"] = "import numpy as np, k; k.f(np.ones(3))"
        floors["numba floor as the command line runs it (fast exit)"] = (
            "import os, numpy as np, k; k.f(np.ones(3)); os._exit(0)")
        floors["run-path imports (navigate sins-dr, before a kernel runs)"] = (
            "import inmotion.cli.main, inmotion.navigate.sins_dr, inmotion.io.result, "
            "inmotion.io.bundle_stream, pyarrow.parquet")
        for name, code in floors.items():
            wall, cpu = best_wall([py, "-c", code], args.repeat, env, cwd=tmp)
            print(f"  bare interpreter, {name}: {wall:.3f} s wall, {cpu:.3f} s CPU")


if __name__ == "__main__":
    main()
