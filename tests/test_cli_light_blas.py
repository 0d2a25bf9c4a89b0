"""The command line's start-up shortcut :func:`inmotion.cli.light_blas.light_numba_blas` (issue 13:
a run's fixed cost): numba's CPU target gets SciPy's ``cython_blas`` without the
``scipy.linalg`` package, the run's result is the same file for file, and SciPy and numba's
linear algebra work afterwards."""
import os
import subprocess
import sys
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

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _python(code, **env):
    e = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]),
             OPENBLAS_NUM_THREADS="1", **env)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env=e).stdout


def test_navigate_loads_no_scipy_linalg_and_writes_the_same_result(tmp_path):
    bundle = tmp_path / "tiny"
    write_bundle(simulate(load_scenario(TINY), np.random.default_rng(0)), bundle,
                 fmt="parquet")
    code = ("import sys\nsys.argv = ['inmotion', '-q', 'navigate', %r, '--method', 'sins-dr', "
            "'-o', %%r]\nfrom inmotion.cli.main import main\n"
            "try:\n    main()\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            "print('MODULES', ' '.join(sys.modules))" % str(bundle))
    out = {}
    for light in ("1", "0"):
        o = tmp_path / f"out{light}"
        text = _python(code % str(o), INMOTION_LIGHT_BLAS=light)
        mods = set(text.rsplit("MODULES", 1)[1].split())
        assert "numba" in mods and "scipy.linalg.cython_blas" in mods
        assert ("scipy.linalg" in mods) == (light == "0")
        out[light] = o
    names = sorted(p.name for p in out["1"].iterdir())
    assert names == sorted(p.name for p in out["0"].iterdir())
    for name in names:
        if name != "summary.json":                 # it holds the wall time
            assert (out["1"] / name).read_bytes() == (out["0"] / name).read_bytes(), name


def test_scipy_linalg_and_numba_lapack_work_after_it():
    code = """
import sys
import numpy as np
from inmotion.cli.light_blas import light_numba_blas
assert light_numba_blas()
assert "scipy.linalg" not in sys.modules
blas = sys.modules["scipy.linalg.cython_blas"]
from inmotion.estimation.smoother import _pinv_times     # numba, LAPACK eigh inside: numba
                                                          # imports scipy.linalg.cython_lapack
A = np.array([[4.0, 1.0], [1.0, 3.0]])
x = _pinv_times(A, np.eye(2))
assert np.allclose(x, np.linalg.inv(A))
import scipy.linalg
from scipy.linalg import cython_blas
assert cython_blas is blas
assert np.allclose(scipy.linalg.solve(A, [1.0, 2.0]), np.linalg.solve(A, [1.0, 2.0]))
assert not light_numba_blas()                             # once only
print("ok")
"""
    assert _python(code).strip() == "ok"
