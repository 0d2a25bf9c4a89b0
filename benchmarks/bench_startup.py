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
  function does. No run that calls a numba kernel can start faster than this.

Best of ``--repeat`` wall times of each, after one warm-up (file caches, numba's cache).

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


def best_wall(cmd, repeat, env, cwd=None):
    subprocess.run(cmd, check=True, env=env, cwd=cwd, capture_output=True)     # warm-up
    walls = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, cwd=cwd, capture_output=True)
        walls.append(time.perf_counter() - t0)
    return min(walls)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        bundle = Path(tmp) / "tiny"
        write_bundle(simulate(load_scenario(TINY), np.random.default_rng(0)), bundle,
                     fmt="parquet")
        for method in ("sins-dr", "sins"):
            cmd = [py, "-m", "inmotion.cli.main", "-q", "navigate", str(bundle), "--method",
                   method, "-o", str(Path(tmp) / f"out-{method}")]
            print(f"CLI fixed cost (navigate {method}, 7 s bundle): "
                  f"{best_wall(cmd, args.repeat, env):.3f} s wall (target 0.4 s)")
        help_s = best_wall([py, "-m", "inmotion.cli.main", "--help"], args.repeat, env)
        print(f"CLI --help: {help_s:.3f} s wall")
        (Path(tmp) / "k.py").write_text(NJIT)
        floors = {"python": "pass"}
        for mod in ("numpy", "pandas", "pydantic", "pyarrow.parquet", "scipy.linalg", "numba"):
            floors[f"import {mod}"] = f"import {mod}"
        floors["numba floor"] = "import numpy as np, k; k.f(np.ones(3))"
        for name, code in floors.items():
            s = best_wall([py, "-c", code], args.repeat, env, cwd=tmp)
            print(f"  bare interpreter, {name}: {s:.3f} s wall")


if __name__ == "__main__":
    main()
