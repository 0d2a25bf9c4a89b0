"""The command line end to end on a short simulated drive, and every bad input -> exit 2.

The drive (20 s: rest, accelerate, turn, cruise) is simulated once per module through
``inmotion simulate``. Its IMU is error-free, so pure SINS through the whole chain (files in
degrees, mechanization, result files, metrics) must reproduce the truth: this checks the units
and conventions of every edge at once.
"""
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.cli import main as cli_main
from inmotion.cli.main import cli, parse_init_error
from inmotion.errors import BadInput

SCENARIO = """\
name: cli_small
start: {lat_deg: 34.0, lon_deg: 108.0, h_m: 400.0, heading_deg: 350.0, speed_m_s: 0.0}
segments:
  - {kind: rest, duration_s: 3}
  - {kind: accelerate, to_speed_m_s: 10.0, accel_m_s2: 2.0}
  - {kind: turn, angle_deg: 30, rate_deg_s: 10}
  - {kind: cruise, duration_s: 5}
sensors:
  radar: {rate_hz: 10}
  odometer: {rate_hz: 10, pulses_per_m: 1000}
  baro: {rate_hz: 10}
"""
DESIGN_KEYS = {"pitch_arcmin", "roll_arcmin", "yaw_arcmin", "phi_E_arcmin", "phi_N_arcmin",
               "phi_U_arcmin", "vE_m_s", "vN_m_s", "vU_m_s", "horizontal_m", "vertical_m"}


def invoke(*args):
    return CliRunner().invoke(cli, ["--quiet", *map(str, args)], catch_exceptions=False)


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("scen") / "small.yaml"
    p.write_text(SCENARIO)
    return p


@pytest.fixture(scope="module")
def bundle(tmp_path_factory, scenario_file):
    out = tmp_path_factory.mktemp("bundle") / "b"
    r = invoke("simulate", scenario_file, "-o", out, "--seed", 3)
    assert r.exit_code == 0, r.output + r.stderr
    return out


@pytest.fixture
def copy(bundle, tmp_path):
    """A private copy of the bundle to break."""
    import shutil
    return Path(shutil.copytree(bundle, tmp_path / "b"))


def run_json(*args):
    r = invoke("--json", *args)
    assert r.exit_code == 0, r.output + r.stderr
    return json.loads(r.stdout)


# --------------------------------------------------------------------------- happy paths

def test_methods_lists_sins_and_dr():
    r = invoke("methods")
    assert r.exit_code == 0
    names = [line.split()[0] for line in r.stdout.splitlines()]
    assert "sins" in names and "dr" in names
    assert {"sins", "dr"} <= {m["name"] for m in run_json("methods")}


def test_info(bundle):
    info = run_json("info", bundle)
    assert info["tables"]["imu"]["rate_hz"] == pytest.approx(100.0)
    assert info["tables"]["radar"]["rate_hz"] == pytest.approx(10.0)
    assert info["duration_s"] == pytest.approx(20.0)
    assert 100 < info["distance_m"] < 200 and info["distance_from"] == "truth"
    text = invoke("info", bundle).stdout
    assert "radar" in text and "100 Hz" in text


def test_sins_reproduces_truth_through_files(bundle, tmp_path):
    s = run_json("navigate", bundle, "--method", "sins", "--output-rate", "all",
                 "-o", tmp_path / "r")
    f = s["errors"]["final"]
    assert set(f) == DESIGN_KEYS
    assert s["errors"]["max_abs_last_100s"]["horizontal_m"] < 1e-3
    assert max(abs(f[k]) for k in ("pitch_arcmin", "roll_arcmin", "yaw_arcmin")) < 1e-3
    sol = pd.read_csv(tmp_path / "r" / "solution.csv")
    truth = pd.read_csv(bundle / "truth.csv")
    np.testing.assert_allclose(sol["lat"], truth["lat"], atol=1e-9)
    assert sol["yaw"].between(0, 360, inclusive="left").all()
    d_yaw = (sol["yaw"] - truth["yaw"] + 180) % 360 - 180
    assert np.abs(d_yaw).max() < 1e-5


def test_dr_odometer(bundle, tmp_path):
    s = run_json("navigate", bundle, "-m", "dr", "--set", "sensor=odometer", "-o", tmp_path / "r")
    assert s["info"]["sensor"] == "odometer"
    assert s["errors"]["final"]["horizontal_m"] < 0.01 * s["errors"]["distance_m"]


def test_evaluate_matches_summary(bundle, tmp_path):
    s = run_json("navigate", bundle, "-m", "sins", "-o", tmp_path / "r")
    e = run_json("evaluate", tmp_path / "r", "--truth", bundle)
    assert set(e) == {"errors"}
    assert set(e["errors"]) == {"final", "rms_last_100s", "max_abs_last_100s", "distance_m",
                                "duration_s"}
    for k in ("final", "rms_last_100s", "max_abs_last_100s"):
        assert set(e["errors"][k]) == DESIGN_KEYS
        for key in DESIGN_KEYS:      # same numbers up to the CSV round trip of the solution
            assert e["errors"][k][key] == pytest.approx(s["errors"][k][key], abs=1e-6)
    # the per-command --json flag works too
    r = CliRunner().invoke(cli, ["-q", "evaluate", str(tmp_path / "r"), "--truth", str(bundle),
                                 "--json"])
    assert json.loads(r.stdout)["errors"]["duration_s"] == pytest.approx(20.0)


def test_init_error_yaw(bundle, tmp_path):
    """A 1 deg initial heading error persists: final yaw error 60 arcmin, phi_U alike."""
    s = run_json("navigate", bundle, "-m", "sins", "--init-error", "yaw=1deg",
                 "--set", "height_damping=baro", "-o", tmp_path / "r")
    f = s["errors"]["final"]
    assert f["yaw_arcmin"] == pytest.approx(60.0, abs=0.5)
    assert f["phi_U_arcmin"] == pytest.approx(60.0, abs=0.5)


def test_window_stride_and_init_from_result(bundle, tmp_path):
    s1 = run_json("navigate", bundle, "-m", "sins", "--end", 12, "--set", "out_stride=10",
                  "-o", tmp_path / "r1")
    assert s1["final"]["t_s"] == pytest.approx(12.0)
    assert s1["epochs"] == 121
    s2 = run_json("navigate", bundle, "-m", "dr", "--init", tmp_path / "r1", "-o", tmp_path / "r2")
    assert s2["init"]["t_s"] == pytest.approx(12.0)
    sol = pd.read_csv(tmp_path / "r2" / "solution.csv")
    assert sol["t"].iloc[0] == pytest.approx(12.0) and sol["t"].iloc[-1] == pytest.approx(20.0)
    s3 = run_json("navigate", bundle, "-m", "sins", "--start", 5, "-o", tmp_path / "r3")
    assert s3["init"]["t_s"] == pytest.approx(5.0)
    assert s3["errors"]["duration_s"] == pytest.approx(15.0)


def test_init_meta_uses_simulated_start(bundle, tmp_path):
    s = run_json("navigate", bundle, "-m", "sins", "--init", "meta", "-o", tmp_path / "r")
    assert s["init"]["from"] == "meta"
    assert s["errors"]["final"]["horizontal_m"] < 0.01


def test_config_file(bundle, tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("out_stride: 100\nheight_damping: none\n")
    s = run_json("navigate", bundle, "-m", "sins", "--config", cfg, "-o", tmp_path / "r")
    assert s["epochs"] == 21 and s["config"]["height_damping"] == "none"


def test_demo_runs_end_to_end(scenario_file, monkeypatch):
    monkeypatch.setattr(cli_main, "DEMO_SCENARIO", str(scenario_file))
    r = invoke("demo")
    assert r.exit_code == 0, r.output
    lines = r.stdout.splitlines()
    assert lines[0].split()[0] == "method"
    rows = {line.split()[0]: line.split() for line in lines
            if line.strip() and not line.startswith((" ", "-", "("))}
    assert {"sins", "dr", "process"} <= set(rows)
    assert float(rows["sins"][3]) < 0.01           # horizontal error [m] of error-free SINS
    d = run_json("demo")
    assert {m["method"] for m in d["methods"]} >= {"sins", "dr"}
    assert d["process"]["rows"][-1]["method"] == "process"


def test_demo_process_on_the_shipped_drive():
    """The demo's main job is ``inmotion process`` with no attitude given: parked 31 s (< 60 s),
    so in-motion coarse alignment from the start, radar fine alignment (dr-kf) and sins-dr to
    the end, with zero-velocity updates at the drive's two stops (a 'stops' stage). Bounds: coarse level within a few arcmin (accelerometer bias 50 ug ~ 0.2'),
    final heading within 15' (gyrocompass limit drift / (omega_ie cos L) = 0.01 deg/h -> 2.8'
    1-sigma; the filters report 4-8'), level within 1', position within 0.3 % of 8.7 km."""
    d = run_json("demo")
    rows = {r["method"].split(":")[0]: r for r in d["process"]["rows"]}
    assert set(rows) == {"moving coarse", "fine", "navigate", "stops", "process"}, rows
    assert rows["moving coarse"]["level_arcmin"] < 5.0
    p = rows["process"]
    assert abs(p["heading_arcmin"]) < 15.0 and p["level_arcmin"] < 1.0, p
    assert p["horizontal_pct"] < 0.3, p
    assert d["process"]["heading"]["can"]


def test_shipped_demo_scenario_exists():
    from inmotion.sim.scenario import find_scenario, load_scenario
    load_scenario(find_scenario("demo"))


# --------------------------------------------------------------------------- bad input -> 2

def expect_bad(args, *fragments):
    r = CliRunner().invoke(cli, ["--quiet", *map(str, args)])
    assert r.exit_code == 2, (r.exit_code, r.output, r.stderr)
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("inmotion: error: "), r.stderr
    for f in fragments:
        assert f in err[0], (f, err[0])
    return err[0]


def _edit(path, fn):
    df = pd.read_csv(path, dtype=str)
    fn(df).to_csv(path, index=False)


def _set(col, row, value):
    def f(df):
        df.loc[row, col] = value
        return df
    return f


def nav(bundle, tmp_path, *extra):
    return ["navigate", bundle, "-m", "sins", "-o", tmp_path / "r", *extra]


def test_bad_missing_bundle(tmp_path):
    expect_bad(nav(tmp_path / "none", tmp_path), "none", "does not exist")


def test_bad_missing_file(copy, tmp_path):
    (copy / "radar.csv").unlink()
    expect_bad(nav(copy, tmp_path), "radar.csv", "missing file 'radar.csv' that meta.yaml lists")


def test_bad_missing_column(copy, tmp_path):
    _edit(copy / "imu.csv", lambda df: df.drop(columns=["dtheta_z"]))
    expect_bad(nav(copy, tmp_path), "imu.csv", "missing column dtheta_z")


def test_bad_nan(copy, tmp_path):
    _edit(copy / "truth.csv", _set("vN", 500, "NaN"))
    expect_bad(nav(copy, tmp_path), "truth.csv", "row 501", "t=5 s", "'vN'")


def test_bad_non_numeric(copy, tmp_path):
    _edit(copy / "imu.csv", _set("dvel_x", 1000, "12,5"))
    expect_bad(nav(copy, tmp_path), "imu.csv", "row 1001", "t=10 s", "'12,5' is not a number")


def test_bad_time_not_increasing(copy, tmp_path):
    _edit(copy / "baro.csv", _set("t", 50, "4.8"))
    expect_bad(nav(copy, tmp_path), "baro.csv", "row 51", "t=4.8 s", "not strictly increasing")


def test_bad_imu_gap(copy, tmp_path):
    _edit(copy / "imu.csv", lambda df: df.drop(index=range(300, 320)))
    expect_bad(nav(copy, tmp_path), "imu.csv", "row 301", "t=3.2 s", "gap of 0.21 s")


def test_sensor_gap_is_a_note_not_an_error(copy, tmp_path):
    _edit(copy / "radar.csv", lambda df: df.drop(index=range(100, 120)))
    r = CliRunner().invoke(cli, ["navigate", str(copy), "-m", "dr", "-o", str(tmp_path / "r")])
    assert r.exit_code == 0
    assert "warning" in r.stderr and "radar.csv: row 101" in r.stderr


def test_bad_impossible_gyro(copy, tmp_path):
    _edit(copy / "imu.csv", _set("dtheta_x", 700, "5.0"))
    expect_bad(nav(copy, tmp_path), "imu.csv", "row 701", "t=7 s", "500 rad/s")


def test_bad_yaml(copy, tmp_path):
    (copy / "meta.yaml").write_text("name: x\n  bad: [indent\n")
    expect_bad(nav(copy, tmp_path), "meta.yaml", "malformed YAML at line")


@pytest.mark.parametrize("text,fragment", [
    ("pitch=1", "needs a unit"),
    ("pitch=1furlong", "needs a unit"),
    ("tilt=1deg", "unknown key 'tilt'"),
    ("pitch:1deg", "cannot read"),
    (",", "empty"),
])
def test_bad_init_error(bundle, tmp_path, text, fragment):
    expect_bad(nav(bundle, tmp_path, "--init-error", text), "--init-error", fragment)


def test_parse_init_error_units():
    e = parse_init_error("pitch=1deg, roll=-30arcmin,yaw=3600arcsec,vE=0.5m/s,north=2m,up=1e-1m")
    assert e["pitch"] == pytest.approx(math.radians(1))
    assert e["roll"] == pytest.approx(-math.radians(0.5))
    assert e["yaw"] == pytest.approx(math.radians(1))
    assert (e["vE"], e["north"], e["up"]) == (0.5, 2.0, 0.1)
    assert parse_init_error("yaw=0.01rad")["yaw"] == 0.01
    with pytest.raises(BadInput):
        parse_init_error("yaw=1 deg deg")


def test_bad_unknown_method(bundle, tmp_path):
    expect_bad(["navigate", bundle, "-m", "kalman-magic", "-o", tmp_path / "r"],
               "unknown method 'kalman-magic'", "sins")


def test_bad_option_for_method(bundle, tmp_path):
    expect_bad(nav(bundle, tmp_path, "--mode", "fast"), "configuration of 'sins'", "mode")
    expect_bad(nav(bundle, tmp_path, "--set", "out_stride=0"), "out_stride")


def test_bad_init_source(bundle, tmp_path):
    expect_bad(nav(bundle, tmp_path, "--init", tmp_path / "nothing"), "--init must be")


def test_bad_evaluate_without_truth(copy, tmp_path):
    s = run_json("navigate", copy, "-m", "sins", "-o", tmp_path / "r")
    assert s["epochs"] > 0
    (copy / "truth.csv").unlink()
    import yaml
    meta = yaml.safe_load((copy / "meta.yaml").read_text())
    del meta["files"]["truth"]
    (copy / "meta.yaml").write_text(yaml.safe_dump(meta))
    expect_bad(["evaluate", tmp_path / "r", "--truth", copy], "no truth")


def test_bad_scenario(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text("name: x\nstart: {lat_deg: 95, lon_deg: 0, h_m: 0}\nsegments: []\n")
    expect_bad(["simulate", p, "-o", tmp_path / "b"], "s.yaml")
    expect_bad(["simulate", "no-such-scenario", "-o", tmp_path / "b"], "no-such-scenario")


def test_internal_failure_exits_1(bundle, tmp_path, monkeypatch):
    import inmotion.navigate.pure as pure

    def broken(*a, **k):
        raise RuntimeError("boom")
    monkeypatch.setattr(pure, "run_sins", broken)
    r = CliRunner().invoke(cli, ["-q", *map(str, nav(bundle, tmp_path))])
    assert r.exit_code == 1
    assert "inmotion: internal error: RuntimeError: boom" in r.stderr


def test_usage_error_exits_2(bundle):
    r = CliRunner().invoke(cli, ["navigate", str(bundle)])      # no --method, no -o
    assert r.exit_code == 2


def test_demo_reports_a_broken_method_and_exits_1(scenario_file, monkeypatch):
    import inmotion.navigate.pure as pure

    def broken(*a, **k):
        raise RuntimeError("boom")
    monkeypatch.setattr(cli_main, "DEMO_SCENARIO", str(scenario_file))
    monkeypatch.setattr(pure, "run_sins", broken)
    r = CliRunner().invoke(cli, ["-q", "demo"])
    assert r.exit_code == 1
    assert "sins: internal error: RuntimeError: boom" in r.stderr
    assert any(line.startswith("dr ") for line in r.stdout.splitlines())


def test_info_without_truth_uses_odometer(copy, bundle):
    import yaml
    (copy / "truth.csv").unlink()
    meta = yaml.safe_load((copy / "meta.yaml").read_text())
    del meta["files"]["truth"]
    (copy / "meta.yaml").write_text(yaml.safe_dump(meta))
    info = run_json("info", copy)
    assert info["distance_from"] == "odometer" and "truth" not in info["tables"]
    with_truth = run_json("info", bundle)          # error-free odometer, 1 mm pulses
    assert info["distance_m"] == pytest.approx(with_truth["distance_m"], abs=0.01)


def test_parquet_bundle_gives_the_same_result(scenario_file, bundle, tmp_path):
    r = invoke("simulate", scenario_file, "-o", tmp_path / "pq", "--seed", 3,
               "--format", "parquet")
    assert r.exit_code == 0 and (tmp_path / "pq" / "imu.parquet").is_file()
    a = run_json("navigate", bundle, "-m", "dr", "-o", tmp_path / "ra")
    b = run_json("navigate", tmp_path / "pq", "-m", "dr", "-o", tmp_path / "rb")
    assert a["final"] == b["final"]          # same seed, exact round trips: identical runs


def test_imu_gap_listed_by_info_and_allowed_on_request(copy, tmp_path):
    _edit(copy / "imu.csv", lambda df: df.drop(index=range(300, 320)))
    info = run_json("info", copy)
    (gap,) = info["tables"]["imu"]["gaps"]
    assert gap["row"] == 301 and gap["duration_s"] == pytest.approx(0.21)
    s = run_json("navigate", copy, "-m", "dr", "--allow-imu-gaps", "--output-rate", "all",
                 "-o", tmp_path / "r")
    assert s["epochs"] == 2001 - 20


def test_dr_uses_meta_mounting_with_the_simulator_convention(tmp_path):
    """An IMU yawed 30 arcmin in the vehicle: DR told the mounting (from meta.yaml) removes the
    cross-track error of 0.5 deg x distance that DR assuming a straight mount makes."""
    scen = tmp_path / "s.yaml"
    scen.write_text(SCENARIO.replace("segments:",
                                     "vehicle_mounting_arcmin: [0, 0, 30]\nsegments:"))
    assert invoke("simulate", scen, "-o", tmp_path / "b").exit_code == 0
    told = run_json("navigate", tmp_path / "b", "-m", "dr", "-o", tmp_path / "r1")
    naive = run_json("navigate", tmp_path / "b", "-m", "dr", "--set", "mounting_arcmin=[0,0,0]",
                     "-o", tmp_path / "r2")
    assert told["info"]["mounting_arcmin"] == [0.0, 0.0, 30.0]
    d = told["errors"]["distance_m"]
    assert naive["errors"]["final"]["horizontal_m"] > 0.5 * d * math.radians(0.5)
    assert told["errors"]["final"]["horizontal_m"] < 0.2 * naive["errors"]["final"]["horizontal_m"]


def test_method_input_errors(copy, tmp_path):
    import yaml
    expect_bad(["navigate", copy, "-m", "dr", "--set", "sensor=ldv", "-o", tmp_path / "r"],
               "no velocity sensor 'ldv'")
    (copy / "baro.csv").unlink()
    meta = yaml.safe_load((copy / "meta.yaml").read_text())
    del meta["files"]["baro"]
    (copy / "meta.yaml").write_text(yaml.safe_dump(meta))
    expect_bad(nav(copy, tmp_path, "--set", "height_damping=baro"), "no barometer")
    s = run_json(*nav(copy, tmp_path))                 # auto: no baro, free vertical channel
    assert s["info"]["height_damping"] == "none"


def test_init_meta_without_attitude(copy, tmp_path):
    import yaml
    (copy / "truth.csv").unlink()
    meta = yaml.safe_load((copy / "meta.yaml").read_text())
    del meta["files"]["truth"]
    del meta["initial_attitude_deg"]
    (copy / "meta.yaml").write_text(yaml.safe_dump(meta))
    expect_bad(nav(copy, tmp_path), "--init meta", "needs an initial attitude")
    expect_bad(nav(copy, tmp_path, "--init", "truth"), "--init truth", "no truth")


def test_empty_window(bundle, tmp_path):
    expect_bad(nav(bundle, tmp_path, "--start", 50, "--init", "meta"), "fewer than 2 IMU rows")


def test_bad_config_inputs(bundle, tmp_path):
    expect_bad(nav(bundle, tmp_path, "--set", "out_stride"), "--set 'out_stride'", "key=value")
    expect_bad(nav(bundle, tmp_path, "--config", tmp_path / "none.yaml"),
               "none.yaml", "does not exist")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1\n")
    expect_bad(nav(bundle, tmp_path, "--config", bad), "bad.yaml", "malformed YAML")
    bad.write_text("- 1\n- 2\n")
    expect_bad(nav(bundle, tmp_path, "--config", bad), "bad.yaml", "must be a mapping")
    expect_bad(["align", bundle, "-m", "sins", "-o", tmp_path / "r"],
               "'sins' is a navigate method", "inmotion navigate")


def test_bad_linearization_floor_value(bundle, tmp_path):
    """``linearization_floor`` takes true, false or auto (issue 15, session 17): anything else
    is one message naming the method, the field and what it takes, exit status 2."""
    expect_bad(["align", bundle, "-m", "od-kf", "--init", "truth", "--set",
                "linearization_floor=maybe", "-o", tmp_path / "r"],
               "configuration of 'od-kf'", "linearization_floor", "'auto'")


def test_bad_start_outside_previous_result(bundle, tmp_path):
    run_json("navigate", bundle, "-m", "sins", "--end", 10, "-o", tmp_path / "r1")
    expect_bad(nav(bundle, tmp_path, "--init", tmp_path / "r1", "--start", 15),
               "--start 15 s is outside the result's time span")
