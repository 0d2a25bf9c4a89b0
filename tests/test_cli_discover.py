"""Finding things from the command line (issue 18): ``inmotion methods NAME``, ``inmotion
scenarios``, "did you mean", global options anywhere, messages without Python ``None``."""
import json

import pytest
from click.testing import CliRunner

from inmotion import registry
from inmotion.cli.main import cli, hoist_global_options
from inmotion.cli.method_docs import ESTIMATES, SENSORS, method_detail, settings, unit_of

SCENARIO = """\
name: discover_small
start: {lat_deg: 34.0, lon_deg: 108.0, h_m: 400.0, heading_deg: 10.0, speed_m_s: 0.0}
segments:
  - {kind: rest, duration_s: 2}
  - {kind: accelerate, to_speed_m_s: 5.0, accel_m_s2: 2.0}
  - {kind: cruise, duration_s: 3}
sensors:
  radar: {rate_hz: 10}
"""


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    d = tmp_path_factory.mktemp("disc")
    (d / "s.yaml").write_text(SCENARIO)
    r = run("-q", "simulate", d / "s.yaml", "-o", d / "b")
    assert r.exit_code == 0, r.output
    return d / "b"


@pytest.mark.parametrize("spec", registry.methods(), ids=lambda s: s.name)
def test_every_setting_has_a_description_and_the_method_its_sensors(spec):
    _, config = spec.load()
    for s in settings(config):
        assert s.meaning, f"{spec.name}: {s.name} has no description"
        assert "None" not in s.meaning
    assert spec.name in SENSORS and spec.name in ESTIMATES


def test_units_from_names():
    assert unit_of("gyro_drift_deg_h") == "deg/h"
    assert unit_of("accel_vrw_ug_sqrt_hz") == "ug/sqrt(Hz)"
    assert unit_of("gyro_bias_rw_deg_h_sqrt_h") == "deg/h/sqrt(h)"
    assert unit_of("init_velocity_sigma_m_s") == "m/s"
    assert unit_of("fdi") == ""


def test_methods_name_prints_settings_sensors_paper():
    r = run("methods", "sins-dr")
    assert r.exit_code == 0, r.output
    assert "gyro_drift_deg_h [deg/h]" in r.output
    assert "paper 002" in r.output and "needs:" in r.output
    assert "None" not in r.output
    r = run("methods", "fkf", "--json")
    d = json.loads(r.stdout)
    assert d["paper"]["number"] == "003" and "odometer" in d["sensors"]
    beta = next(s for s in d["settings"] if s["name"] == "beta_od")
    assert beta["default"] == 0.5 and beta["allowed"] == "> 0, <= 1"
    assert method_detail("sins")["settings"][0]["name"] == "height_damping"


def test_scenarios_lists_shipped_ones():
    r = run("scenarios")
    assert r.exit_code == 0
    lines = r.stdout.splitlines()
    assert any(line.startswith("paper002_hour ") and "3600 s" in line for line in lines)
    assert {d["name"] for d in json.loads(run("--json", "scenarios").stdout)} >= {"demo"}


def test_did_you_mean():
    r = run("methods", "sins-kf")
    assert r.exit_code == 2 and "did you mean 'sins' or 'sins-dr'" in r.stderr
    r = run("simulate", "paper002_hours", "-o", "unused")
    assert r.exit_code == 2 and "did you mean 'paper002_hour'" in r.stderr


def test_global_options_anywhere(bundle, tmp_path):
    assert hoist_global_options(["navigate", "b", "-q", "--json"]) == ["-q", "--json",
                                                                       "navigate", "b"]
    assert hoist_global_options(["x", "--", "-q"]) == ["x", "--", "-q"]
    r = run("navigate", bundle, "-m", "sins", "-o", tmp_path / "r", "-q", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["method"] == "sins"
    assert r.stderr == ""
    r = run("info", bundle, "--debug", "--quiet")
    assert r.exit_code == 0, r.output


def test_window_message_says_what_the_drive_covers(bundle, tmp_path):
    r = run("navigate", bundle, "-m", "sins", "--start", 5000, "-o", tmp_path / "r")
    assert r.exit_code == 2
    assert "None" not in r.stderr and "5000 s" in r.stderr
    # the start is checked against the truth first (--init truth), else against the IMU
    assert ("the truth table covers 0 .. " in r.stderr
            or ("the drive covers 0-" in r.stderr and "from 5000 s to the end" in r.stderr))
    r = run("navigate", bundle, "-m", "sins", "--init", "meta", "--start", 5000, "-o",
            tmp_path / "r")
    assert r.exit_code == 2 and "None" not in r.stderr
    assert "the drive covers 0-" in r.stderr and "from 5000 s to the end" in r.stderr


def test_real_data_folder_from_option_env_or_cwd(monkeypatch, tmp_path):
    from inmotion.reproductions import real as rr
    monkeypatch.setenv("INMOTION_REAL_DATA", str(tmp_path / "mine"))
    assert rr.default_data_root() == tmp_path / "mine"
    monkeypatch.delenv("INMOTION_REAL_DATA")
    (tmp_path / "shared" / "data" / "real").mkdir(parents=True)
    (tmp_path / "clone").mkdir()
    monkeypatch.chdir(tmp_path / "clone")
    assert rr.default_data_root() == (tmp_path / "shared" / "data" / "real").resolve()
    r = run("reproduce", "real", "--data", tmp_path / "nothing", "-o", tmp_path / "out", "-q")
    assert r.exit_code == 2 and "real data folder not found" in r.stderr


def test_parquet_result_and_default_output_rate(bundle, tmp_path):
    """navigate writes 1 row per second by default, every row with --output-rate all, Parquet
    with --format parquet; evaluate, report and --init read a Parquet result back."""
    import pandas as pd
    from inmotion.io.result import read_result
    a = json.loads(run("--json", "-q", "navigate", bundle, "-m", "dr", "-o", tmp_path / "a").stdout)
    sol = pd.read_csv(tmp_path / "a" / "solution.csv")
    assert len(sol) == a["epochs"] and sol["t"].iloc[-1] == pytest.approx(a["final"]["t_s"])
    assert sol["t"].diff().iloc[1:-1].round(6).eq(1.0).all() and a["output_rate_hz"] == 1.0
    assert a["config"]["out_stride"] == 100                     # the method's own stride set
    b = json.loads(run("--json", "-q", "navigate", bundle, "-m", "dr", "--output-rate", "all",
                       "--format", "parquet", "-o", tmp_path / "b").stdout)
    assert b["format"] == "parquet" and b["epochs"] > 10 * a["epochs"]
    assert (tmp_path / "b" / "solution.parquet").is_file()
    assert not (tmp_path / "b" / "solution.csv").exists()
    assert (tmp_path / "b" / "errors.parquet").is_file()
    assert b["errors"]["final"] == pytest.approx(a["errors"]["final"], abs=1e-6)  # same end
    assert len(read_result(tmp_path / "b").t) == b["epochs"]
    e = run("--json", "evaluate", tmp_path / "b", "--truth", bundle)
    assert e.exit_code == 0, e.output
    assert run("-q", "report", tmp_path / "b").exit_code == 0
    c = run("-q", "navigate", bundle, "-m", "sins", "--init", tmp_path / "b", "--start", 5,
            "-o", tmp_path / "c")
    assert c.exit_code == 0, c.output
    r = run("navigate", bundle, "-m", "dr", "--output-rate", "fast", "-o", tmp_path / "x")
    assert r.exit_code == 2 and "--output-rate" in r.stderr


def test_exports_ned_csv_geojson_and_kf_gins_of_a_parquet_result(bundle, tmp_path):
    import numpy as np
    import pandas as pd
    r = run("-q", "navigate", bundle, "-m", "sins", "--format", "parquet", "-o", tmp_path / "r")
    assert r.exit_code == 0, r.output
    assert run("-q", "export", "ned-csv", tmp_path / "r", "-o", tmp_path / "t.csv").exit_code == 0
    text = (tmp_path / "t.csv").read_text()
    assert text.startswith("# frames:") and "R_z(yaw) R_y(pitch) R_x(roll)" in text
    df = pd.read_csv(tmp_path / "t.csv", comment="#")
    last = pd.read_parquet(tmp_path / "r" / "solution.parquet").iloc[-1]
    assert df["yaw_deg"].iloc[-1] == pytest.approx(last["yaw"], abs=1e-4)   # heading alike
    assert df["vN_m_s"].iloc[-1] == pytest.approx(last["vN"], abs=1e-4)
    assert df["vD_m_s"].iloc[-1] == pytest.approx(-last["vU"], abs=1e-4)
    assert df["pitch_deg"].iloc[-1] == pytest.approx(last["pitch"], abs=1e-3)  # level road
    assert df["north_m"].iloc[0] == 0.0 and np.hypot(df["north_m"], df["east_m"]).max() > 10
    r = run("-q", "export", "geojson", tmp_path / "r", "-o", tmp_path / "t.geojson")
    assert r.exit_code == 0, r.output
    g = json.loads((tmp_path / "t.geojson").read_text())
    line = g["features"][0]["geometry"]
    assert line["type"] == "LineString"
    lon, lat, _ = line["coordinates"][-1]
    assert lat == pytest.approx(last["lat"], abs=1e-8)
    assert lon == pytest.approx(last["lon"], abs=1e-8)
    assert run("-q", "export", "kf-gins", tmp_path / "r", "-o", tmp_path / "t.nav").exit_code == 0
    assert len(np.loadtxt(tmp_path / "t.nav")) == len(df)


@pytest.mark.parametrize("name", ["sins-dr", "fkf", "usque", "adaptive", "dr"])
def test_config_template_round_trips(name, tmp_path):
    """``inmotion methods NAME --template`` is a valid configuration equal to the defaults."""
    import yaml
    r = run("methods", name, "--template")
    assert r.exit_code == 0, r.output
    data = yaml.safe_load(r.stdout)
    _, config = registry.get(name).load()
    assert config.model_validate(data) == config()
    assert "# " in r.stdout.splitlines()[3]
