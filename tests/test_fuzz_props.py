"""Issue 16, property-based: hypothesis over the table readers, the YAML loaders, the option
parsers and the configuration / scenario validators.

Every generated input either is accepted (and then its values are finite and in range) or is
refused with one :class:`BadInput` line that names the thing at fault; no other exception, no
traceback, no ``None`` in the message. Example counts are small (the whole file runs in a few
seconds) and derandomized, so a failure reproduces.
"""
from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
from fuzz_common import SCENARIO, expect_ok, invoke  # noqa: E402
from test_io_bundle import make_bundle  # noqa: E402

from inmotion import registry  # noqa: E402
from inmotion.cli.main import build_config, parse_init_error  # noqa: E402
from inmotion.config_checks import check_config  # noqa: E402
from inmotion.errors import BadInput  # noqa: E402
from inmotion.io.bundle import read_bundle, write_bundle  # noqa: E402
from inmotion.io.safe_yaml import load_yaml_text  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

FAST = settings(max_examples=25, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


def _one_line(e: BadInput) -> str:
    s = str(e)
    assert "\n" not in s and "None" not in s and "Traceback" not in s, s
    return s


# --------------------------------------------------------------------------- table readers

@pytest.fixture(scope="module")
def bundle_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("props") / "b"
    write_bundle(make_bundle(np.random.default_rng(7), n=200), d)
    return d


BAD_TOKENS = st.one_of(
    st.sampled_from(["nan", "NaN", "inf", "-inf", "", "abc", "1e999", "-1e999", "1.2.3", "--1",
                     "0x10", "\u221e", "null", "true"]),
    st.text(alphabet="abcdefghijklmnopqrstuvwxyz_!?", min_size=1, max_size=8))
TABLE_COLUMNS = {"imu.csv": ["t", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y",
                             "dvel_z"],
                 "radar.csv": ["t", "v"], "odometer.csv": ["t", "ds"], "baro.csv": ["t", "h"],
                 "truth.csv": ["t", "lat", "lon", "h", "vE", "vN", "vU", "pitch", "roll", "yaw"]}


@FAST
@given(table=st.sampled_from(sorted(TABLE_COLUMNS)), data=st.data(), token=BAD_TOKENS)
def test_a_bad_cell_names_file_and_row(bundle_dir, tmp_path_factory, table, data, token):
    d = Path(shutil.copytree(bundle_dir, tmp_path_factory.mktemp("cell") / "b"))
    df = pd.read_csv(d / table, dtype=str, keep_default_na=False)
    col = data.draw(st.sampled_from(TABLE_COLUMNS[table]))
    row = data.draw(st.integers(0, len(df) - 1))
    df.loc[row, col] = token
    df.to_csv(d / table, index=False)
    with pytest.raises(BadInput) as ei:
        read_bundle(d)
    msg = _one_line(ei.value)
    assert table in msg and f"row {row + 1}" in msg and repr(col) in msg, msg


@FAST
@given(table=st.sampled_from(sorted(TABLE_COLUMNS)), data=st.data())
def test_time_not_increasing_names_file_and_row(bundle_dir, tmp_path_factory, table, data):
    d = Path(shutil.copytree(bundle_dir, tmp_path_factory.mktemp("time") / "b"))
    df = pd.read_csv(d / table)
    i = data.draw(st.integers(1, len(df) - 1))
    back = data.draw(st.floats(0.0, 5.0))
    df.loc[i, "t"] = df.loc[i - 1, "t"] - back
    df.to_csv(d / table, index=False)
    with pytest.raises(BadInput) as ei:
        read_bundle(d)
    msg = _one_line(ei.value)
    assert table in msg and "row" in msg, msg


@FAST
@given(scale=st.sampled_from([1e3, 1e6, 1e9, 1e-9]), table=st.sampled_from(
    ["radar.csv", "odometer.csv", "baro.csv", "truth.csv"]))
def test_a_table_on_another_time_unit_is_refused(bundle_dir, tmp_path_factory, scale, table):
    d = Path(shutil.copytree(bundle_dir, tmp_path_factory.mktemp("unit") / "b"))
    df = pd.read_csv(d / table)
    df["t"] = df["t"] * scale
    df.to_csv(d / table, index=False)
    with pytest.raises(BadInput) as ei:
        read_bundle(d)
    assert table in _one_line(ei.value)


# --------------------------------------------------------------------------- YAML loaders

@settings(max_examples=200, deadline=None, derandomize=True)
@given(text=st.text(alphabet=st.characters(codec="utf-8"), max_size=200))
def test_yaml_loader_never_fails_otherwise(text):
    try:
        load_yaml_text(text, file="x.yaml")
    except BadInput as e:
        assert str(e).startswith("x.yaml: "), e
        _one_line(e)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(text=st.text(alphabet="[]{}:-&*ab ,\n'\"#!|>", max_size=300))
def test_yaml_loader_on_structure_characters(text):
    try:
        load_yaml_text(text, file="x.yaml")
    except BadInput as e:
        _one_line(e)


YAML_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6),
              st.floats(allow_nan=False, allow_infinity=False, width=32),
              st.text(alphabet="abcxyz _-", max_size=10)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(alphabet="abcxyz_", min_size=1, max_size=6),
                                            inner, max_size=4)),
    max_leaves=30)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(doc=YAML_VALUES)
def test_yaml_loader_reads_valid_documents_back(doc):
    assert load_yaml_text(yaml.safe_dump(doc)) == doc


@settings(max_examples=15, deadline=None, derandomize=True)
@given(depth=st.integers(101, 5000), fanout=st.integers(2, 9), levels=st.integers(7, 12))
def test_yaml_loader_bounds(depth, fanout, levels):
    with pytest.raises(BadInput, match="nested"):
        load_yaml_text("a: " + "[" * depth + "]" * depth)
    with pytest.raises(BadInput, match="nested"):
        load_yaml_text("- " * depth + "x")
    bomb = "a0: &a0 [" + ", ".join(["x"] * fanout) + "]\n" + "".join(
        f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * fanout) + "]\n" for i in range(1, levels))
    if fanout ** levels > 2_000_000:
        with pytest.raises(BadInput, match="aliases"):
            load_yaml_text(bomb)


# --------------------------------------------------------------------------- option parsers

UNITS = {"pitch": ["deg", "arcmin", "arcsec", "rad", "mrad"], "yaw": ["deg", "arcmin"],
         "vE": ["m/s"], "north": ["m"], "up": ["m"]}


@settings(max_examples=150, deadline=None, derandomize=True)
@given(text=st.text(max_size=60))
def test_init_error_parser_random_text(text):
    try:
        out = parse_init_error(text)
    except BadInput as e:
        assert "--init-error" in _one_line(e)
        return
    for k, v in out.items():
        assert math.isfinite(v) and abs(v) <= 100e3, (k, v)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(key=st.sampled_from(sorted(UNITS)), data=st.data(),
       value=st.floats(allow_nan=False, allow_infinity=False, width=64))
def test_init_error_parser_values(key, data, value):
    unit = data.draw(st.sampled_from(UNITS[key]))
    text = f"{key}={value!r}{unit}"
    try:
        out = parse_init_error(text)
    except BadInput as e:
        msg = _one_line(e)
        assert "--init-error" in msg and key in msg, msg
        return
    assert math.isfinite(out[key])


METHODS = ["sins", "dr", "dr-kf", "usque", "od-kf", "imada-vb", "sins-dr"]
FIELD_VALUES = st.one_of(
    st.floats(), st.integers(-10**20, 10**20), st.text(max_size=6),
    st.lists(st.floats(), max_size=4), st.sampled_from([".nan", ".inf", "-.inf", "1e-300",
                                                        "1e308", "[1e308,0,0]", "-1", "[]"]))


@settings(max_examples=120, deadline=None, derandomize=True)
@given(method=st.sampled_from(METHODS), data=st.data(), value=FIELD_VALUES)
def test_config_fields_any_value(method, data, value):
    spec = registry.get(method)
    _, Config = spec.load()
    field = data.draw(st.sampled_from(sorted(Config.model_fields)))
    text = value if isinstance(value, str) else yaml.safe_dump(value, default_flow_style=True
                                                               ).strip().removesuffix("...")
    try:
        cfg = build_config(spec, sets=[f"{field}={text.strip()}"])
    except BadInput as e:
        msg = _one_line(e)
        assert method in msg and field in msg, msg
        return
    check_config(cfg, method)              # accepted: passes the plausibility checks


SCENARIO_PATHS = [("start", "heading_deg"), ("start", "speed_m_s"), ("start", "lat_deg"),
                  ("imu", "rate_hz"), ("segments", 0, "duration_s"), ("segments", 1, "rate_deg_s"),
                  ("segments", 1, "angle_deg"), ("sensors", "radar", "rate_hz"),
                  ("sensors", "odometer", "pulses_per_m"), ("imu", "gyro")]


@settings(max_examples=80, deadline=None, derandomize=True)
@given(path=st.sampled_from(SCENARIO_PATHS), value=st.one_of(
    st.floats(), st.integers(-10**12, 10**12), st.text(max_size=5), st.none(),
    st.lists(st.floats(), max_size=3)))
def test_scenario_fields_any_value(path, value):
    doc = yaml.safe_load(SCENARIO)
    node = doc
    for k in path[:-1]:
        node = node.setdefault(k, {}) if isinstance(k, str) else node[k]
    node[path[-1]] = value
    try:
        sc = load_scenario(doc)
    except BadInput as e:
        msg = _one_line(e)
        assert str(path[-1]) in msg or "segments" in msg or "drive" in msg, msg
        return
    assert math.isfinite(sc.start.heading_deg) and 10 <= sc.imu.rate_hz <= 10000


@settings(max_examples=40, deadline=None, derandomize=True)
@given(key=st.sampled_from(["duration_s", "heading_deg", "rate_hz", "segments", "start"]),
       data=st.data())
def test_scenario_typos_name_the_key_meant(key, data):
    i = data.draw(st.integers(0, len(key) - 1))
    typo = key[:i] + key[i + 1:]                # one letter dropped
    if typo in ("start",) or len(typo) < 4:
        return
    text = SCENARIO.replace(f"{key}:", f"{typo}:", 1)
    if text == SCENARIO:
        return
    with pytest.raises(BadInput) as ei:
        load_scenario(yaml.safe_load(text))
    msg = _one_line(ei.value)
    assert repr(typo) in msg, msg


# --------------------------------------------------------------------------- the CLI's options

@pytest.fixture(scope="module")
def cli_bundle(tmp_path_factory):
    d = tmp_path_factory.mktemp("cliprops")
    (d / "s.yaml").write_text(SCENARIO)
    expect_ok(["simulate", d / "s.yaml", "-o", d / "b", "--seed", 2])
    return d / "b"


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(start=st.one_of(st.none(), st.floats(), st.sampled_from(["x", "1e", "--"])),
       end=st.one_of(st.none(), st.floats()))
def test_window_options_any_value(cli_bundle, tmp_path_factory, start, end):
    out = tmp_path_factory.mktemp("win") / "r"
    args = ["navigate", cli_bundle, "-m", "sins", "-o", out]
    if start is not None:
        args += ["--start", start]
    if end is not None:
        args += ["--end", end]
    code, stdout, err, secs, mib, exc = invoke(args)
    if code == 0:
        df = pd.read_csv(out / "solution.csv")
        assert np.isfinite(df.to_numpy(float)[:, :10]).all()
    else:
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("inmotion: error:"), err
        assert "None" not in lines[0] and ("--start" in lines[0] or "--end" in lines[0]
                                           or "IMU" in lines[0] or "truth" in lines[0]), lines


@pytest.fixture(scope="module")
def small_bundle(cli_bundle):
    from inmotion.io.bundle import read_bundle
    return read_bundle(cli_bundle)


RUN_VALUES = st.one_of(
    st.sampled_from(["0", "1e-90", "1e-7", "1e-3", "1e7", "9e6", "-1e11", "1e300", "[1e6,0,0]",
                     "999999999", "true", "[0,0,0]", "-1"]),
    st.floats(-1e13, 1e13).map(repr))


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(method=st.sampled_from(["sins", "dr", "sins-dr", "dr-kf", "imada-vb"]), data=st.data(),
       value=RUN_VALUES)
def test_any_accepted_configuration_runs_to_a_finite_result(small_bundle, method, data, value):
    """Whatever value a field gets: refused (naming the field), or the method runs and its
    solution is finite and possible, or the solution is refused before it is written."""
    import warnings
    from inmotion.core.solution import NavState
    from inmotion.io.result import check_solution
    spec = registry.get(method)
    run, Config = spec.load()
    field = data.draw(st.sampled_from(sorted(Config.model_fields)))
    try:
        cfg = build_config(spec, sets=[f"{field}={value}"])
    except BadInput as e:
        assert field in _one_line(e)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            sol = run(small_bundle, cfg, NavState.from_truth(small_bundle.truth, None))
            check_solution(sol)
        except BadInput as e:
            _one_line(e)


# --------------------------------------------------------------------------- importers

TOKENS = st.one_of(st.floats(-1e6, 1e6).map(lambda x: f"{x:.6g}"),
                   st.sampled_from(["nan", "inf", "x", "", "1e999", "#", ",", "\t", "\x00",
                                    "\xff", "-"]))


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(st.lists(TOKENS, min_size=5, max_size=9), min_size=1, max_size=30),
       sep=st.sampled_from([" ", ",", "\t"]))
def test_kf_gins_reader_any_table(tmp_path_factory, rows, sep):
    d = tmp_path_factory.mktemp("kfg")
    src = d / "imu.txt"
    src.write_bytes("\n".join(sep.join(r) for r in rows).encode("utf-8", "surrogatepass"))
    code, out, err, secs, mib, exc = invoke(["import", "kf-gins", src, "-o", d / "b"])
    lines = err.strip().splitlines()
    if code == 0:
        return
    assert code == 2 and len(lines) == 1, (code, err, exc)
    assert "imu.txt" in lines[0] and "None" not in lines[0], lines[0]


MAPPING_KEYS = st.sampled_from(["time", "imu", "kind", "gyro", "accel", "columns", "unit",
                                "axes", "odometer", "truth", "name", "delimiter", "colum"])


@settings(max_examples=30, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=st.recursive(
    st.one_of(st.none(), st.integers(-5, 5), st.floats(allow_nan=True), st.text(max_size=6),
              st.sampled_from(["rad/s", "deg/s", "s", "ms", "rate", "increment", "forward",
                               "gx", "time"])),
    lambda inner: st.one_of(st.lists(inner, max_size=3),
                            st.dictionaries(MAPPING_KEYS, inner, max_size=4)), max_leaves=20))
def test_csv_mapping_any_document(tmp_path_factory, doc):
    d = tmp_path_factory.mktemp("map")
    (d / "log.csv").write_text("time,gx,gy,gz,ax,ay,az\n" + "".join(
        f"{i * 0.01},0,0,0,0,0,9.8\n" for i in range(50)))
    (d / "m.yaml").write_text(yaml.safe_dump(doc))
    code, out, err, secs, mib, exc = invoke(["import", "csv", d / "log.csv", "--mapping",
                                             d / "m.yaml", "-o", d / "b"])
    lines = err.strip().splitlines()
    assert code in (0, 2), (code, err, exc)
    if code == 2:
        assert len(lines) == 1 and ("m.yaml" in lines[0] or "log.csv" in lines[0]), lines


RICH_SCENARIO = yaml.safe_load("""
name: rich
start: {lat_deg: 34.0, lon_deg: 108.0, h_m: 400.0, heading_deg: 20.0, speed_m_s: 8.0}
vehicle_mounting_arcmin: [3, 10, 5]
segments:
  - {kind: cruise, duration_s: 4}
  - {kind: turn, angle_deg: 60, rate_deg_s: 10}
  - {kind: climb, pitch_deg: 4, duration_s: 5}
  - {kind: cruise, duration_s: 3}
disturbances:
  side_slips: [{t_s: 2, duration_s: 1, speed_m_s: 0.5}]
  jumps: [{t_s: 5, duration_s: 0.5, height_m: 0.05}]
  vibration: [{start_s: 1, end_s: 10, frequency_hz: 20, angular_amplitude_arcsec: 10,
               linear_amplitude_mm: 0.1}]
imu: {rate_hz: 50.0, gyro: {drift_deg_h: 0.01, arw_deg_sqrt_h: 0.01, drift_markov_deg_h: 0.01,
                            drift_markov_tau_s: 100},
      accel: {bias_ug: 50, vrw_ug_sqrt_hz: 10}}
sensors:
  radar: {rate_hz: 10, noise_m_s: 0.05, scale_markov_sigma_ppm: 1000, scale_markov_tau_s: 300,
          lever_arm_m: [0, 1, 0]}
  odometer: {rate_hz: 10, pulses_per_m: 100}
  ldv: {rate_hz: 10, output: distance}
  baro: {rate_hz: 10, noise_m: 1}
faults:
  - {sensor: radar, kind: outliers, start_s: 3, end_s: 6, probability: 0.1, magnitude_m_s: 1}
""")


def _number_paths(d, pre=()):
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _number_paths(v, pre + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from _number_paths(v, pre + (i,))
    elif isinstance(d, (int, float)) and not isinstance(d, bool):
        yield pre


@settings(max_examples=40, deadline=None, derandomize=True)
@given(path=st.sampled_from(list(_number_paths(RICH_SCENARIO))),
       value=st.sampled_from([0, -1, 1e-9, 1e9, 1e300, -1e300, 0.5, 89.9, 1e-300, 1000, 300,
                              1e-4, float("nan"), float("inf")]))
def test_simulate_any_number_gives_a_valid_bundle_or_one_line(path, value):
    """A number anywhere in a rich scenario set to an extreme: refused in one line naming the
    field, or simulated into a bundle that passes every check a read would make."""
    import copy
    import warnings
    from inmotion.io.bundle import check_bundle
    from inmotion.sim import simulate
    doc = copy.deepcopy(RICH_SCENARIO)
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    try:
        sc = load_scenario(doc)
    except BadInput as e:
        _one_line(e)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            check_bundle(simulate(sc, np.random.default_rng(0)), "scenario")
        except BadInput as e:
            _one_line(e)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(text=st.one_of(st.text(max_size=40), st.builds(
    lambda k, v, u: f"{k}={v}{u}", st.sampled_from(["pitch", "roll", "yaw", "x"]),
    st.text(alphabet="0123456789.eE+-", max_size=8), st.sampled_from(["deg", "rad", "arcmin", ""]))))
def test_campaign_init_error_parser_random_text(text):
    from inmotion.evaluate.runs import parse_init_error as campaign_init_error
    try:
        out = campaign_init_error(text)
    except BadInput as e:
        _one_line(e)
        return
    assert np.isfinite(out["angles_rad"]).all() and (np.abs(out["angles_rad"]) <= np.pi).all()


SWEEP_KEYS = st.sampled_from(["scenario.start.speed_m_s", "method", "method_options.speed_scale",
                              "scenario", "start.x", "", "a..b", "init_error", "scenario.imu",
                              "method_options", "scenario.segments.0"])
SWEEP_VALUES = st.one_of(st.none(), st.integers(-3, 3), st.floats(), st.text(max_size=5),
                         st.sampled_from(["dr", "sins", "nope", "paper004_v20"]),
                         st.lists(st.floats(), max_size=2), st.dictionaries(
                             st.sampled_from(["a", "lat_deg"]), st.floats(), max_size=2))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(grid=st.one_of(st.none(), st.integers(), st.dictionaries(
    st.one_of(SWEEP_KEYS, st.integers(0, 3)),
    st.one_of(st.lists(SWEEP_VALUES, max_size=3), SWEEP_VALUES), max_size=3)),
       runs=st.one_of(st.integers(-2, 10**12), st.floats(), st.none(), st.text(max_size=3)),
       seed=st.one_of(st.integers(-2, 2**70), st.none(), st.floats()))
def test_sweep_documents_any_content(grid, runs, seed):
    """A sweep with any grid, runs and seed: refused in one line, or valid points whose every
    specification passes the run function's check (so no run fails on input later)."""
    from inmotion.evaluate.montecarlo import _validate, check_size
    from inmotion.evaluate.sweep import load_sweep
    doc = {"name": "fz", "scenario": yaml.safe_load(SCENARIO), "method": "dr", "grid": grid,
           "runs": runs, "seed": seed}
    try:
        sweep = load_sweep(doc)
        check_size(sweep)
        _validate(sweep)
    except BadInput as e:
        _one_line(e)
        return
    assert 1 <= sweep.runs <= 10**7 and len(sweep.points) <= 10**4


# --------------------------------------------------------------------------- any command line

@pytest.fixture(scope="module")
def cli_paths(cli_bundle, tmp_path_factory):
    d = tmp_path_factory.mktemp("argv")
    expect_ok(["navigate", cli_bundle, "-m", "sins", "-o", d / "r", "--end", 5])
    (d / "s.yaml").write_text(SCENARIO)
    (d / "afile").write_text("x")
    (d / "garbage.txt").write_bytes(bytes(range(256)))
    return {"B": str(cli_bundle), "R": str(d / "r"), "S": str(d / "s.yaml"),
            "F": str(d / "afile"), "G": str(d / "garbage.txt"), "N": str(d / "nope"),
            "D": str(d)}


ARG_VALUES = ["B", "R", "S", "F", "G", "N", "nan", "inf", "-1", "0", "1e9", "5", "x", "",
              "sins", "dr", "imada-vb", "truth", "meta", "yaw=1deg", "pitch=1e999deg", "a=b",
              "speed_scale=2", "out_stride=0", "--", "kf-gins", "csv", "{}", "[1"]
COMMANDS = {
    "info": (["B"], ["--json"]),
    "navigate": (["B"], ["--method", "--init", "--init-error", "--start", "--end", "--set",
                         "--config", "--mode"]),
    "align": (["B"], ["--method", "--init", "--init-error", "--start", "--end", "--set"]),
    "evaluate": (["R"], ["--truth"]),
    "export": (["kf-gins", "R"], ["--gps-week"]),
    "import": (["kf-gins", "G"], ["-O", "--mapping", "--bundle-format"]),
    "simulate": (["S"], ["--seed", "--format"]),
    "report": (["R"], ["--title", "--paper"]),
}


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cmd=st.sampled_from(sorted(COMMANDS)), data=st.data())
def test_any_command_line_exits_0_or_2(cli_paths, tmp_path_factory, cmd, data):
    """Random arguments and options for every command: exit 0, or exit 2 with one line and no
    ``None``; never an internal error, never a traceback."""
    pos, opts = COMMANDS[cmd]
    value = st.sampled_from(ARG_VALUES).map(lambda v: cli_paths.get(v, v))
    args = [cmd] + [data.draw(st.one_of(st.just(cli_paths.get(p, p)), value)) for p in pos]
    for _ in range(data.draw(st.integers(0, 4))):
        opt = data.draw(st.sampled_from(opts))
        args += [opt] if opt == "--json" else [opt, data.draw(value)]
    if cmd not in ("info", "evaluate"):
        args += ["-o", str(tmp_path_factory.mktemp("o") / "out")]
    code, out, err, secs, mib, exc = invoke(args)
    lines = err.strip().splitlines()
    assert code in (0, 2), (args, code, err, exc)
    if code == 2:
        assert len(lines) == 1 and lines[0].startswith("inmotion: error: "), (args, err)
        assert "None" not in lines[0] and "Traceback" not in err, (args, err)


@pytest.mark.parametrize("path", [p for p in _number_paths(RICH_SCENARIO)
                                  if any(k in str(p[-1]) for k in ("noise", "vrw", "arw", "sigma",
                                                                   "bias", "drift", "amplitude"))
                                  and not str(p[-1]).endswith("_s")])
def test_zero_error_terms_are_always_accepted(path):
    """An error-free sensor (every noise, random walk, bias, drift or amplitude 0) is valid:
    the plausibility checks must not take a noise density (``vrw_ug_sqrt_hz``) for a rate."""
    import copy
    doc = copy.deepcopy(RICH_SCENARIO)
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = 0
    load_scenario(doc)


@pytest.mark.parametrize("method", ["sins", "dr", "sins-dr", "dr-kf", "od-kf", "usque", "imada-vb"])
def test_zero_noise_fields_pass_the_config_checks(method):
    spec = registry.get(method)
    _, Config = spec.load()
    for field in Config.model_fields:
        if any(k in field for k in ("noise", "vrw", "arw", "sigma")):
            default = Config().model_dump()[field]
            zero = [0.0] * len(default) if isinstance(default, (list, tuple)) else 0.0
            try:
                cfg = Config.model_validate({field: zero})
            except Exception:                # the method's own schema wants it positive
                continue
            check_config(cfg, method)
