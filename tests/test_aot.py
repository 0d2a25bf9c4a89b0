"""The ahead-of-time extension (:mod:`inmotion._aot`, issue 13): ``navigate --method sins`` and
``--method sins-dr`` through it write byte for byte what the JIT path writes, and import no
numba; it is not used when the sources, the filter's functions or the argument types are not
those it was built for; :func:`inmotion._aot.type_spec` tells numba types apart as numba does.

The extension is built once for this module (``python -m inmotion._aot_build --out DIR``,
~40-90 s of CPU with numba's cache warm) on its own 7 s drive; the runs compared here are on
another drive (another seed, 200 s: two chunks of IMU rows, so two calls of the loop).
"""
import copy
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inmotion import _aot

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None,
                                reason="no C compiler: the extension cannot be built")

DRIVE = {
    "name": "aot-test", "start": {"lat_deg": 30.5, "lon_deg": 114.3, "h_m": 40, "heading_deg": 200},
    "segments": [{"kind": "rest", "duration_s": 2},
                 {"kind": "accelerate", "to_speed_m_s": 8.0, "accel_m_s2": 1.0},
                 {"kind": "turn", "angle_deg": 60, "rate_deg_s": 3},
                 {"kind": "cruise", "duration_s": 170}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.05, "arw_deg_sqrt_h": 0.005},
            "accel": {"bias_ug": 200, "vrw_ug_sqrt_hz": 20}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}

RUN = """\
import sys
from inmotion.cli.main import cli
try:
    cli.main(args=sys.argv[1:], prog_name="inmotion")
except SystemExit as e:
    assert not e.code, e.code
print("NUMBA", "numba" in sys.modules,
      "AOT", any(m.startswith("inmotion_aot_") for m in sys.modules),
      "SCIPY", "scipy" in sys.modules)
"""


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """``(extension directory, a bundle)``: the extension built for the current sources."""
    d = tmp_path_factory.mktemp("aot")
    out = subprocess.run([sys.executable, "-m", "inmotion._aot_build", "--out", str(d)],
                         capture_output=True, text=True, env=_env())
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    from inmotion.io.bundle import write_bundle
    from inmotion.sim import simulate
    from inmotion.sim.scenario import load_scenario
    b = d / "bundle"
    write_bundle(simulate(load_scenario(copy.deepcopy(DRIVE)), np.random.default_rng(7)), b,
                 fmt="parquet")
    return d, b


def _env(**extra):
    """The environment of a child: this checkout's package first (children run elsewhere)."""
    import os
    import inmotion
    here = str(Path(inmotion.__file__).resolve().parents[1])
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (here, os.environ.get("PYTHONPATH")) if p), **extra)


def _run(args, env_extra, tmp):
    env = _env(**env_extra)
    out = subprocess.run([sys.executable, "-c", RUN, *args], capture_output=True, text=True,
                         env=env, cwd=tmp)
    assert out.returncode == 0, out.stderr[-2000:]
    w = out.stdout.rsplit("NUMBA", 1)[1].split()
    return w[0] == "True", w[2] == "True", w[4] == "True"


@pytest.mark.parametrize("method,opts", [
    ("sins-dr", []), ("sins", []),
    # the velocity rows (paper 002 eq. 52) and a Markov scale factor (F[dk, dk] = -1 / tau:
    # the predict kernel of 16 active rows, as on paper 002's hour): also ahead of time, and
    # no BLAS call (scipy.linalg's import) in the loop
    ("sins-dr", ["--set", "mode=velocity-position", "--set", "noise_preset=paper"]),
    # issue 13's equal workload through the command line (bench_engine.py's second CLI line):
    # 19 states with the mounting block, the sensor's velocity and the NHC, 10 Hz feedback
    ("od-velocity-kf", ["--set", "noise_preset=paper", "--set", "use_baro=false",
                        "--set", "filter_rate_hz=100", "--set", "measurement_rate_hz=10",
                        "--set", "feedback_rate_hz=10", "--output-rate", "1"])])
def test_aot_run_is_the_jit_run_without_numba(built, tmp_path, method, opts):
    d, b = built
    res = {}
    kind = "align" if method == "od-velocity-kf" else "navigate"
    for label, env in (("aot", {"INMOTION_AOT_DIR": str(d)}), ("jit", {"INMOTION_AOT": "0"})):
        o = tmp_path / label
        res[label] = _run(["-q", kind, str(b), "--method", method, "--init", "truth",
                           *opts, "-o", str(o)], env, tmp_path)
    # no numba imported, the extension loaded, nor scipy (numba's JIT imports it)
    assert res["aot"] == (False, True, False)
    assert res["jit"][:2] == (True, False)
    files = sorted(p.name for p in (tmp_path / "jit").iterdir())
    assert "solution.csv" in files and "errors.csv" in files
    for name in files:
        a, j = (tmp_path / "aot" / name).read_bytes(), (tmp_path / "jit" / name).read_bytes()
        if name == "summary.json":              # the same but for the timing
            a, j = json.loads(a), json.loads(j)
            for s in (a, j):
                s.pop("timing", None)
                s.get("info", {}).pop("wall_time_s", None)    # od-velocity-kf's own timing
        assert a == j, f"{method}: {name} differs between the AOT and JIT runs"


def test_not_used_for_other_sources_or_types(built, monkeypatch):
    d, _ = built
    monkeypatch.setenv("INMOTION_AOT_DIR", str(d))
    monkeypatch.setattr(_aot, "_state", {})
    found = _aot.module()
    assert found is not None and found[1]["key"] == _aot.source_key()
    # an edited kernel source gives another key: the extension is not found
    monkeypatch.setattr(_aot, "_state", {"key": "0" * 20})
    assert _aot.module() is None
    monkeypatch.setattr(_aot, "_state", {})
    mod, man = _aot.module()
    # a case is found only for the functions and types it was built for
    from inmotion.estimation import engine as E
    entry = next(iter(man["cases"].values()))
    assert _aot.case(entry["fills"], entry["accs"], (np.zeros(3),), ()) is None
    t = np.arange(5.0)
    assert _aot.first_not_increasing(t) == -1 and _aot.first_not_increasing(t[::-1]) == 1
    assert _aot.first_nonfinite_row(np.array([[1.0], [np.nan]])) == 1
    assert E is not None


def test_extension_releases_the_gil(built, monkeypatch):
    """The extension's functions run without the GIL (the command line reads the next IMU
    rows in a reader thread meanwhile, :func:`inmotion.io.bundle_stream.read_ahead`): a
    Python thread keeps counting while one of them runs for a while in the main thread
    (with the GIL held it could not take a step)."""
    import threading
    import time
    d, _ = built
    monkeypatch.setenv("INMOTION_AOT_DIR", str(d))
    monkeypatch.setattr(_aot, "_state", {})
    mod, _ = _aot.module()
    t = np.arange(4e7)
    state = {"stop": False, "n": 0}

    def spin():
        while not state["stop"]:
            state["n"] += 1

    # a long switch interval: the main thread, once it holds the GIL, is not made to hand it
    # over before the call (measured: 0 steps with the GIL held, millions released)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.2)
    th = threading.Thread(target=spin)
    th.start()
    try:
        time.sleep(0.02)
        n0 = state["n"]
        assert mod.first_not_increasing(t) == -1
        steps = state["n"] - n0
    finally:
        state["stop"] = True
        th.join()
        sys.setswitchinterval(interval)
    assert steps > 1000, steps


def test_off_switch(monkeypatch, built):
    d, _ = built
    monkeypatch.setenv("INMOTION_AOT_DIR", str(d))
    monkeypatch.setenv("INMOTION_AOT", "0")
    monkeypatch.setattr(_aot, "_state", {})
    assert _aot.module() is None


def test_type_spec_separates_what_numba_separates():
    numba = pytest.importorskip("numba")
    a = np.zeros((4, 3))
    ro = a.copy()
    ro.flags.writeable = False
    objs = [a, a.T, a[:, ::2], a[0], a[:, 0], ro, np.zeros(3, dtype=np.int64), np.zeros(3),
            np.zeros((2, 2, 2)), 1.0, 2, True, np.float64(1.0), (1, 2), (1.0, 2), (a, 1),
            (a.T, 1), np.zeros(3, dtype=np.bool_), np.zeros(0)]
    for x in objs:
        for y in objs:
            same_type = numba.typeof(x) == numba.typeof(y)
            assert (_aot.type_spec(x) == _aot.type_spec(y)) == same_type, (x, y)


def test_extension_is_named_by_the_source_key(built):
    d, _ = built
    names = [p.name for p in Path(d).glob(_aot.EXT_PREFIX + "*.json")]
    assert names == [f"{_aot.EXT_PREFIX}{_aot.source_key()}.json"]


def test_kernel_modules_import_no_numba():
    # inmotion._jit: the kernels' modules decorate at first use, so the run path's imports
    # leave numba alone; the first call imports it and the kernels then work as before
    code = ("import sys\nimport numpy as np\n"
            "import inmotion.cli.main, inmotion.navigate.sins_dr, inmotion.navigate.pure\n"
            "import inmotion.estimation.engine, inmotion.align.aided_kf\n"
            "from inmotion.core import _kernels as K\n"
            "before = 'numba' in sys.modules\n"
            "k = K.first_not_increasing(np.array([0.0, 1.0, 1.0]))\n"
            "print(before, 'numba' in sys.modules, k, type(K.first_not_increasing).__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_env(INMOTION_AOT="0"))
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["False", "True", "2", "CPUDispatcher"]
