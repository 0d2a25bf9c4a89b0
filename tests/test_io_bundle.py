"""Bundle files: round trips (CSV exact to ~1e-12, Parquet exact) and every validation failure.

Each bad-input test edits one file of a freshly written bundle and checks that
:func:`inmotion.io.bundle.read_bundle` raises :class:`BadInput` naming the file, the row and
the time.
"""
import warnings

import numpy as np
import pandas as pd
import pytest

from inmotion.core.bundle import BaroData, Bundle, ImuData, SpeedData, Truth
from inmotion.errors import BadInput
from inmotion.io.bundle import BundleGapWarning, find_gaps, read_bundle, write_bundle


def make_bundle(rng, n=500, dt=0.01, speed_m_s=10.0, with_truth=True):
    """A short straight drive north at constant speed: noisy but plausible sensor data."""
    t = 100.0 + dt * np.arange(1, n + 1)
    dtheta = rng.normal(0, 1e-6, (n, 3))
    dvel = rng.normal(0, 1e-4, (n, 3)) + np.array([0, 0, 9.8 * dt])
    imu = ImuData(t, dtheta, dvel)
    lat0, lon0 = np.radians(34.123456789012), np.radians(108.987654321098)
    s = speed_m_s * (t - t[0])
    truth = Truth(t, lat0 + s / 6.36e6, np.full(n, lon0) + rng.normal(0, 1e-9, n),
                  400 + rng.normal(0, 0.01, n),
                  np.column_stack([rng.normal(0, 0.01, n), np.full(n, speed_m_s), np.zeros(n)]),
                  np.column_stack([rng.normal(0, 1e-3, n), rng.normal(0, 1e-3, n),
                                   np.mod(rng.normal(0, 1e-3, n), 2 * np.pi)]))
    ts = t[::10]
    radar = SpeedData(ts, v=speed_m_s + rng.normal(0, 0.01, len(ts)))
    odo = SpeedData(ts, ds=speed_m_s * 0.1 + rng.normal(0, 1e-3, len(ts)))
    baro = BaroData(t[::5], 400 + rng.normal(0, 0.5, len(t[::5])))
    meta = {"name": "straight", "initial_position": {"lat_deg": 34.123456789012,
                                                      "lon_deg": 108.987654321098, "h_m": 400.0},
            "sensors": {"radar": {"rate_hz": 10, "lever_arm_m": [0.0, 1.0, -0.5]}}}
    return Bundle(imu, meta, radar=radar, odometer=odo, baro=baro,
                  truth=truth if with_truth else None)


def assert_bundles_close(a, b, rtol):
    np.testing.assert_allclose(b.imu.t, a.imu.t, rtol=rtol, atol=0)
    np.testing.assert_allclose(b.imu.dtheta, a.imu.dtheta, rtol=rtol, atol=0)
    np.testing.assert_allclose(b.imu.dvel, a.imu.dvel, rtol=rtol, atol=0)
    np.testing.assert_allclose(b.radar.v, a.radar.v, rtol=rtol, atol=0)
    np.testing.assert_allclose(b.odometer.ds, a.odometer.ds, rtol=rtol, atol=0)
    assert b.odometer.v is None and b.ldv is None
    np.testing.assert_allclose(b.baro.h, a.baro.h, rtol=rtol, atol=0)
    for k in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_allclose(getattr(b.truth, k), getattr(a.truth, k), rtol=rtol, atol=0)
    assert b.meta["name"] == a.meta["name"]
    assert b.meta["sensors"] == a.meta["sensors"]


@pytest.fixture
def rng():
    return np.random.default_rng(7)


@pytest.fixture
def bundle_dir(tmp_path, rng):
    return write_bundle(make_bundle(rng), tmp_path / "b")


def test_round_trip_csv(tmp_path, rng):
    a = make_bundle(rng)
    b = read_bundle(write_bundle(a, tmp_path / "b", fmt="csv"))
    assert_bundles_close(a, b, rtol=1e-12)
    # latitude in degrees keeps its 12+ significant digits through the file
    lat_deg = pd.read_csv(tmp_path / "b" / "truth.csv")["lat"].to_numpy()
    np.testing.assert_allclose(lat_deg, np.degrees(a.truth.lat), rtol=1e-15)


def test_round_trip_parquet_exact(tmp_path, rng):
    a = make_bundle(rng)
    b = read_bundle(write_bundle(a, tmp_path / "b", fmt="parquet"))
    assert (tmp_path / "b" / "imu.parquet").is_file()
    np.testing.assert_array_equal(b.imu.dtheta, a.imu.dtheta)
    np.testing.assert_array_equal(b.imu.t, a.imu.t)
    assert_bundles_close(a, b, rtol=1e-15)
    # written plain-encoded and LZ4-compressed (io.bundle._write_table: faster to read)
    import pyarrow.parquet as pq
    md = pq.ParquetFile(tmp_path / "b" / "imu.parquet").metadata
    col = md.row_group(0).column(1)
    assert col.compression.startswith("LZ4") and not col.has_dictionary_page


def test_rewrite_in_other_format_leaves_one_table(tmp_path, rng):
    a = make_bundle(rng)
    write_bundle(a, tmp_path / "b", fmt="csv")
    write_bundle(a, tmp_path / "b", fmt="parquet")
    assert not (tmp_path / "b" / "imu.csv").exists()
    read_bundle(tmp_path / "b")


def test_no_truth_needs_initial_position(tmp_path, rng):
    a = make_bundle(rng, with_truth=False)
    d = write_bundle(a, tmp_path / "b")
    assert read_bundle(d).truth is None
    a.meta.pop("initial_position")
    d = write_bundle(a, tmp_path / "c")
    with pytest.raises(BadInput, match="initial_position"):
        read_bundle(d)


def _edit(path, fn):
    df = pd.read_csv(path, dtype=str)
    df = fn(df)
    df.to_csv(path, index=False)


def _expect(d, match, file, row=None, time=None):
    with pytest.raises(BadInput, match=match) as ei:
        read_bundle(d)
    e = ei.value
    assert e.file is not None and str(e.file).endswith(file)
    assert file in str(e)
    if row is not None:
        assert e.row == row and f"row {row}" in str(e)
    if time is not None:
        assert e.time == pytest.approx(time)
        assert "t=" in str(e)
    return e


def test_missing_folder(tmp_path):
    _expect(tmp_path / "nope", "does not exist", "nope")


def test_missing_meta(bundle_dir):
    (bundle_dir / "meta.yaml").unlink()
    _expect(bundle_dir, "missing meta.yaml", "meta.yaml")


def test_missing_imu_listed_in_meta(bundle_dir):
    (bundle_dir / "imu.csv").unlink()
    _expect(bundle_dir, "missing file 'imu.csv'", "imu.csv")


def test_missing_imu_unlisted(bundle_dir):
    (bundle_dir / "imu.csv").unlink()
    text = (bundle_dir / "meta.yaml").read_text()
    (bundle_dir / "meta.yaml").write_text(text.replace("imu: imu.csv, ", ""))
    _expect(bundle_dir, "missing IMU table", "b")


def test_missing_column(bundle_dir):
    _edit(bundle_dir / "imu.csv", lambda df: df.drop(columns=["dvel_y"]))
    _expect(bundle_dir, "missing column dvel_y", "imu.csv")


def test_radar_needs_v(bundle_dir):
    _edit(bundle_dir / "radar.csv", lambda df: df.rename(columns={"v": "ds"}))
    _expect(bundle_dir, "missing column v", "radar.csv")


def test_nan_value(bundle_dir):
    def f(df):
        df.loc[41, "dtheta_y"] = "nan"
        return df
    _edit(bundle_dir / "imu.csv", f)
    t = pd.read_csv(bundle_dir / "imu.csv")["t"][41]
    _expect(bundle_dir, "dtheta_y.*NaN", "imu.csv", row=42, time=t)


def test_inf_value(bundle_dir):
    def f(df):
        df.loc[3, "h"] = "inf"
        return df
    _edit(bundle_dir / "truth.csv", f)
    _expect(bundle_dir, "'h'.*not a finite number", "truth.csv", row=4)


def test_non_numeric_value(bundle_dir):
    def f(df):
        df.loc[9, "v"] = "fast"
        return df
    _edit(bundle_dir / "radar.csv", f)
    t = pd.read_csv(bundle_dir / "radar.csv", dtype=str)["t"][9]
    _expect(bundle_dir, "'fast' is not a number", "radar.csv", row=10, time=float(t))


def test_time_not_increasing(bundle_dir):
    def f(df):
        df.loc[20, "t"] = df.loc[19, "t"]
        return df
    _edit(bundle_dir / "imu.csv", f)
    _expect(bundle_dir, "not strictly increasing", "imu.csv", row=21)


def test_imu_gap_is_error(bundle_dir):
    _edit(bundle_dir / "imu.csv", lambda df: df.drop(index=range(100, 110)))
    t = pd.read_csv(bundle_dir / "imu.csv")["t"].to_numpy()
    e = _expect(bundle_dir, "gap of 0.11 s", "imu.csv", row=101, time=t[100])
    assert "11.0 sample periods" in str(e)
    with pytest.warns(BundleGapWarning, match="imu.csv: row 101"):
        b = read_bundle(bundle_dir, allow_imu_gaps=True)
    assert len(b.imu.t) == 490


def test_sensor_gap_is_warning(bundle_dir):
    _edit(bundle_dir / "radar.csv", lambda df: df.drop(index=range(10, 20)))
    with pytest.warns(BundleGapWarning, match="radar.csv: row 11"):
        b = read_bundle(bundle_dir)
    gaps = find_gaps("radar", b.radar.t)
    assert len(gaps) == 1 and gaps[0].duration_s == pytest.approx(1.1)


def test_no_gap_no_warning(bundle_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_bundle(bundle_dir)


def test_impossible_gyro(bundle_dir):
    def f(df):
        df.loc[7, "dtheta_z"] = "3.0"      # 3 rad in 10 ms: 300 rad/s
        return df
    _edit(bundle_dir / "imu.csv", f)
    _expect(bundle_dir, "angular rate .* 300 rad/s is physically impossible", "imu.csv", row=8)


def test_impossible_accel(bundle_dir):
    def f(df):
        df.loc[0, "dvel_x"] = "200"        # 200 m/s in 10 ms: 2000 g
        return df
    _edit(bundle_dir / "imu.csv", f)
    _expect(bundle_dir, "specific force", "imu.csv", row=1)


def test_impossible_speed(bundle_dir):
    def f(df):
        df.loc[2, "ds"] = "30"             # 30 m in 0.1 s
        return df
    _edit(bundle_dir / "odometer.csv", f)
    _expect(bundle_dir, "speed ds/dt = 300 m/s", "odometer.csv", row=3)


def test_truth_latitude_beyond_pole(bundle_dir):
    def f(df):
        df.loc[5, "lat"] = "95"
        return df
    _edit(bundle_dir / "truth.csv", f)
    _expect(bundle_dir, "latitude", "truth.csv", row=6)


def test_bad_yaml(bundle_dir):
    (bundle_dir / "meta.yaml").write_text("name: [unclosed\nfiles: {imu: imu.csv\n")
    _expect(bundle_dir, "malformed YAML at line", "meta.yaml")


def test_yaml_not_a_mapping(bundle_dir):
    (bundle_dir / "meta.yaml").write_text("- a\n- b\n")
    _expect(bundle_dir, "mapping", "meta.yaml")


def test_empty_table(bundle_dir):
    (bundle_dir / "baro.csv").write_text("t,h\n")
    _expect(bundle_dir, "no data rows", "baro.csv")


def test_both_formats_present(bundle_dir):
    pd.read_csv(bundle_dir / "baro.csv").to_parquet(bundle_dir / "baro.parquet")
    _expect(bundle_dir, "present twice", "b")


def test_bad_parquet(bundle_dir, rng):
    write_bundle(make_bundle(rng), bundle_dir, fmt="parquet")
    (bundle_dir / "baro.parquet").write_bytes(b"not parquet at all")
    _expect(bundle_dir, "cannot read table", "baro.parquet")


def test_simulator_meta_spelling(tmp_path, rng):
    """``files`` as a list of table names and a top-level initial position (the simulator's)."""
    import yaml
    a = make_bundle(rng, with_truth=False)
    a.meta.pop("initial_position")
    a.meta.update(lat_deg=34.0, lon_deg=108.0, h_m=10.0,
                  initial_attitude_deg={"pitch": 1.0, "roll": 0.0, "yaw": 90.0})
    d = write_bundle(a, tmp_path / "b")
    meta = yaml.safe_load((d / "meta.yaml").read_text())
    meta["files"] = ["imu", "radar", "odometer", "baro"]
    (d / "meta.yaml").write_text(yaml.safe_dump(meta))
    from inmotion.io.bundle import meta_initial
    ini = meta_initial(read_bundle(d).meta)
    assert (ini["lat_deg"], ini["h_m"], ini["euler_deg"]) == (34.0, 10.0, [1.0, 0.0, 90.0])
    (d / "baro.csv").unlink()
    _expect(d, "missing table 'baro'", "baro.csv")


def test_meta_initial_not_a_number(tmp_path, rng):
    a = make_bundle(rng, with_truth=False)
    a.meta["initial_position"]["lat_deg"] = "north-ish"
    d = write_bundle(a, tmp_path / "b")
    _expect(d, "lat_deg = 'north-ish' is not a finite number", "meta.yaml")


def test_dvel_in_g_units(bundle_dir):
    """dvel written in g*s instead of m/s: the mean specific force is ~1 instead of ~9.8."""
    df = pd.read_csv(bundle_dir / "imu.csv")
    for k in ("dvel_x", "dvel_y", "dvel_z"):
        df[k] = df[k] / 9.80665
    df.to_csv(bundle_dir / "imu.csv", index=False)
    _expect(bundle_dir, "mean specific force .* are dvel_x/y/z velocity increments in m/s",
            "imu.csv")


def test_zero_dvel_accepted(bundle_dir):
    """A log without accelerometers (zeros) still reads: dead reckoning needs only gyros."""
    df = pd.read_csv(bundle_dir / "imu.csv")
    df[["dvel_x", "dvel_y", "dvel_z"]] = 0.0
    df.to_csv(bundle_dir / "imu.csv", index=False)
    read_bundle(bundle_dir)


def test_truth_lat_lon_in_radians(tmp_path, rng):
    d = write_bundle(make_bundle(rng, n=2000, speed_m_s=20.0), tmp_path / "b")   # 400 m
    read_bundle(d)
    df = pd.read_csv(d / "truth.csv")
    df["lat"], df["lon"] = np.radians(df["lat"]), np.radians(df["lon"])
    df.to_csv(d / "truth.csv", index=False)
    _expect(d, "are lat/lon in degrees", "truth.csv")


def test_rewrite_removes_tables_the_new_bundle_lacks(tmp_path, rng):
    a = make_bundle(rng)
    d = write_bundle(a, tmp_path / "b")
    (d / "notes.txt").write_text("mine")
    a.baro = None
    write_bundle(a, d)
    assert not (d / "baro.csv").exists() and (d / "notes.txt").exists()
    assert read_bundle(d).baro is None


@pytest.mark.parametrize("file,col,row,value,match", [
    ("radar.csv", "v", 4, "-200", "speed v = -200 m/s is physically impossible"),
    ("baro.csv", "h", 6, "40000", "barometric height 40000 m outside"),
    ("truth.csv", "pitch", 2, "91", "pitch 91 deg is physically impossible"),
    ("truth.csv", "vE", 8, "300", r"speed \|v\| = 300\.\d+ m/s"),
])
def test_impossible_values(bundle_dir, file, col, row, value, match):
    _edit(bundle_dir / file, _set_value(col, row - 1, value))
    t = float(pd.read_csv(bundle_dir / file)["t"][row - 1])
    _expect(bundle_dir, match, file, row=row, time=t)


def _set_value(col, i, value):
    def f(df):
        df.loc[i, col] = value
        return df
    return f


def test_speed_sensor_needs_v_or_ds(bundle_dir):
    _edit(bundle_dir / "odometer.csv", lambda df: df.rename(columns={"ds": "pulses"}))
    _expect(bundle_dir, "needs 'ds' or 'v'", "odometer.csv")


def test_bundle_path_is_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    _expect(tmp_path / "f", "must be a folder", "f")


def test_files_entry_malformed(bundle_dir):
    text = (bundle_dir / "meta.yaml").read_text()
    import yaml
    meta = yaml.safe_load(text)
    meta["files"] = "imu.csv"
    (bundle_dir / "meta.yaml").write_text(yaml.safe_dump(meta))
    _expect(bundle_dir, "'files' must list table names", "meta.yaml")
