"""The Python API (``import inmotion``; issue 13, "A Python API people can use").

* ``import inmotion`` alone imports no numba, scipy or pandas (a fresh interpreter);
* simulate a scenario, run methods by name with a configuration, evaluate against truth, with
  accuracy checks against the simulated truth;
* ``inmotion.run`` is the command line's call: the same solution as the method called
  directly from the same start;
* the streaming filter from the top-level names estimates the IMU's mounting in the vehicle;
* the README's "Python" code block runs as written.
"""
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import inmotion

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy", "pandas", "pyarrow", "matplotlib", "dask", "pydantic")


def _fresh_modules(code: str) -> set:
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys\nprint(' '.join(sys.modules))"],
                         capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_import_inmotion_is_cheap_and_names_load_on_first_use():
    mods = _fresh_modules("import inmotion; inmotion.__version__; dir(inmotion)")
    assert not [m for m in mods if m.split(".")[0] in HEAVY]
    # listing methods and the registry stay light too
    mods = _fresh_modules("import inmotion; [m.name for m in inmotion.methods()]")
    assert not [m for m in mods if m.split(".")[0] in HEAVY]
    assert set(inmotion.__all__) <= set(dir(inmotion))
    for name in inmotion.__all__:
        assert getattr(inmotion, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        inmotion.nope


def test_public_functions_have_numpydoc_docstrings_with_units():
    for name in ("simulate", "load_scenario", "methods", "method_config", "run",
                 "initial_state", "error_series", "read_bundle", "write_bundle", "read_result",
                 "write_result"):
        doc = getattr(inmotion, name).__doc__
        assert doc and "Parameters\n" in doc, name
    for name in ("simulate", "run", "error_series", "read_result"):
        doc = getattr(inmotion, name).__doc__
        assert "Returns\n" in doc and re.search(r"\[(m|s|rad|m/s)\]", doc), name
    from inmotion import api
    assert "[arc-minutes]" in api.evaluate.__doc__ and "Returns\n" in api.evaluate.__doc__


@pytest.fixture(scope="module")
def drive():
    return inmotion.simulate("demo", 1)


def test_simulate_takes_a_seed_a_generator_or_a_dict(drive):
    again = inmotion.simulate("demo", np.random.default_rng(1))
    assert np.array_equal(drive.imu.dtheta, again.imu.dtheta)
    assert drive.truth is not None and drive.radar is not None
    assert "demo" in inmotion.scenarios()
    sc = inmotion.load_scenario("demo")
    short = sc.model_dump()
    short["segments"] = short["segments"][:3]
    b = inmotion.simulate(short, 2)
    assert b.imu.t[-1] < 200.0
    with pytest.raises(inmotion.BadInput):
        inmotion.simulate("no-such-scenario")


def test_run_by_name_and_evaluate_against_truth(drive):
    assert "sins-dr" in [m.name for m in inmotion.methods("navigate")]
    sol = inmotion.run("sins-dr", drive, {"mode": "velocity-position",
                                          "gate_probability": 0.9999}, end=300.0)
    assert sol.info["method"] == "sins-dr"
    assert sol.info["config"]["mode"] == "velocity-position"
    err = inmotion.evaluate(sol, drive)
    f = err["final"]
    assert 4000.0 < err["distance_m"] < 4300.0 and err["duration_s"] == pytest.approx(300.0)
    # 5 min, 4.1 km, navigation-grade IMU + radar: metres, arc-minutes (measured 2.5 m,
    # yaw -1.7', level 0.02')
    assert f["horizontal_m"] < 6.0
    assert abs(f["yaw_arcmin"]) < 4.0 and np.hypot(f["phi_E_arcmin"], f["phi_N_arcmin"]) < 0.5
    pure = inmotion.evaluate(inmotion.run("sins", drive, end=300.0), drive)
    assert f["horizontal_m"] < pure["final"]["horizontal_m"] / 3     # 2.5 m against 21 m
    series = inmotion.error_series(sol, drive.truth)
    assert series["horizontal_m"].iloc[-1] == pytest.approx(f["horizontal_m"])
    assert list(series.columns[:4]) == ["t", "pitch_arcmin", "roll_arcmin", "yaw_arcmin"]


def test_run_is_the_method_called_from_the_same_start(drive):
    spec = [m for m in inmotion.methods() if m.name == "dr"][0]
    fn, Config = spec.load()
    b = drive.window(50.0, 150.0)
    ref = fn(b, Config(), inmotion.NavState.from_truth(b.truth))
    sol = inmotion.run("dr", drive, init="truth", start=50.0, end=150.0)
    assert np.array_equal(sol.t, ref.t) and np.array_equal(sol.lat, ref.lat)
    assert np.array_equal(sol.euler, ref.euler)
    # a NavState, a Solution (continues from where it ended) and meta.yaml are starts too
    s0 = inmotion.NavState.from_truth(drive.truth, 50.0)
    assert np.array_equal(inmotion.run("dr", drive, init=s0, start=50.0, end=150.0).lat, sol.lat)
    more = inmotion.run("dr", drive, init=sol, end=200.0)
    assert more.t[0] == pytest.approx(sol.t[-1]) and more.t[-1] == pytest.approx(200.0)
    assert inmotion.run("dr", drive, init="meta", end=20.0).t[0] == drive.imu.t[0]


def test_configurations_and_bad_names_say_what_is_wrong(drive, tmp_path):
    cfg = inmotion.method_config("sins-dr", {"filter_rate_hz": 5}, mode="velocity-position")
    assert cfg.filter_rate_hz == 5 and cfg.mode == "velocity-position"
    p = tmp_path / "c.yaml"
    p.write_text("filter_rate_hz: 20\n")
    assert inmotion.method_config("sins-dr", p).filter_rate_hz == 20
    assert inmotion.method_config("sins-dr", cfg).filter_rate_hz == 5
    with pytest.raises(inmotion.BadInput, match="configuration of 'sins-dr'.*no_such_field"):
        inmotion.method_config("sins-dr", {"no_such_field": 1})
    with pytest.raises(inmotion.BadInput, match="unknown method 'nope'.*sins-dr"):
        inmotion.run("nope", drive)
    with pytest.raises(inmotion.BadInput, match="fewer than 2 IMU rows"):   # the CLI's check
        inmotion.run("sins", drive, start=1e6)
    with pytest.raises(ValueError, match="kind"):
        inmotion.methods("smoother")


def test_bundles_and_results_round_trip(drive, tmp_path):
    b = drive.window(None, 30.0)
    inmotion.write_bundle(b, tmp_path / "b")
    back = inmotion.read_bundle(tmp_path / "b")
    np.testing.assert_allclose(back.imu.dtheta, b.imu.dtheta, rtol=1e-12, atol=0)
    sol = inmotion.run("sins", back)
    inmotion.write_result(sol, tmp_path / "r", truth=back.truth)
    got = inmotion.read_result(tmp_path / "r")
    np.testing.assert_allclose(got.lat, sol.lat, rtol=1e-12)


def test_the_streaming_filter_from_the_top_level_names(drive):
    ms = inmotion.measurements
    lay = inmotion.Layout(["phi", "dv", "dp", "eps", "nabla", "mount"])
    model = inmotion.ErrorModel(lay, inmotion.ProcessNoise(gyro_arw=6e-7, accel_vrw=1e-4))
    P0 = lay.diag({"phi": [3e-4, 3e-4, 1.5e-3], "dv": 0.1, "dp": [2e-6, 2e-6, 10.0],
                   "eps": 5e-8, "nabla": 5e-4, "mount": 3e-3}) ** 2
    f = inmotion.ErrorStateFilter(inmotion.NavState.from_truth(drive.truth), lay, model, P0,
                                  [ms.ForwardVelocity([0.05, 0.1, 0.05]), ms.Nhc(0.05)],
                                  step_rows=10)
    imu, radar = drive.imu, drive.radar
    f.add_measurement("sensor_velocity", radar.t[1:], radar.v[1:])
    f.add_measurement("nhc", radar.t[1:])
    half = len(imu.t) // 2
    f.add_imu(imu.t[1:half], imu.dtheta[1:half], imu.dvel[1:half])
    f.add_imu(imu.t[half:], imu.dtheta[half:], imu.dvel[half:], flush=True)
    assert f.counts()["sensor_velocity"]["used"] == len(radar.t) - 1
    # the simulated mounting is [3, 10, 5] arcmin; x and z are observable from the
    # velocity sensor and the NHC (measured 3.05', 5.34', sigma 0.23', 0.30')
    est, sig = f.estimate(), f.sigma()
    arcmin = np.radians(1 / 60)
    for axis, true in (("x", 3.0), ("z", 5.0)):
        assert abs(est[f"mount_{axis}"] / arcmin - true) < 3 * sig[f"mount_{axis}"] / arcmin + 0.1
    from inmotion.core import rotations
    phi = rotations.misalignment(f.state().C_nb, rotations.dcm_from_euler(drive.truth.euler[-1]))
    assert np.all(np.abs(phi) < 3 * np.array([sig["phi_E"], sig["phi_N"], sig["phi_U"]]) + 1e-5)


def _readme_python_block() -> str:
    text = (ROOT / "README.md").read_text()
    m = re.search(r"^## Python\n(.*?)(?=^## )", text, re.S | re.M)
    assert m, "README.md has no '## Python' section"
    blocks = re.findall(r"```python\n(.*?)```", m.group(1), re.S)
    assert len(blocks) == 1
    return blocks[0]


def test_the_readme_python_example_runs(capsys):
    code = _readme_python_block()
    assert len(code.strip().splitlines()) <= 25
    ns = {}
    exec(compile(code, "README.md:Python", "exec"), ns)
    out = capsys.readouterr().out
    assert "sins-dr" in out and "m after" in out
    assert ns["err"]["final"]["horizontal_m"] < 6.0
