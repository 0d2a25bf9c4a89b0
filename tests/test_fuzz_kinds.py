"""Issue 16: every kind of bad input found by the hostile-user review, through the command line.

Each kind builds one bad input (a file, an option, an output path) from a small valid drive and
checks the suite's contract (:mod:`fuzz_common`): exit 2, exactly one line ``inmotion: error:
...`` naming the file / row / time / option / field at fault, no traceback, no ``None``,
within a time and memory bound. The valid inputs beside them must give exit 0 and a finite,
plausible result. The kinds that used to exhaust memory run in a child process with their peak
memory measured (``test_fuzz_limits.py``); property-based kinds are in ``test_fuzz_props.py``.
"""
from __future__ import annotations

import json
import os
import shutil
import sys
import textwrap
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from fuzz_common import SCENARIO, expect_bad, expect_ok, finite_solution, invoke  # noqa: E402

from inmotion.io.safe_write import PARTIAL_MARKER  # noqa: E402

BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 9)}]\n" for i in range(8))
DEEP = "a: " + "[" * 50000 + "\n"
NOT_UTF8 = "name: caf\xe9\n".encode("latin-1")


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "s.yaml").write_text(SCENARIO)
    expect_ok(["simulate", d / "s.yaml", "-o", d / "b", "--seed", 1])
    expect_ok(["navigate", d / "b", "-m", "sins", "-o", d / "r", "--end", 8])
    return d


@pytest.fixture
def ctx(base, tmp_path):
    b = Path(shutil.copytree(base / "b", tmp_path / "b"))
    r = Path(shutil.copytree(base / "r", tmp_path / "r"))
    return SimpleNamespace(tmp=tmp_path, bundle=b, result=r, scenario=SCENARIO,
                           out=tmp_path / "out")


def _csv(path):
    return pd.read_csv(path)


def _edit_csv(path, fn):
    df = _csv(path)
    fn(df)
    df.to_csv(path, index=False)


def _nav(c, *extra, method="sins"):
    return ["navigate", c.bundle, "-m", method, "-o", c.out, *extra]


def _scenario(c, old, new, name="bad.yaml"):
    text = c.scenario.replace(old, new)
    assert text != c.scenario
    p = c.tmp / name
    p.write_text(text)
    return ["simulate", p, "-o", c.out]


def _kf_gins_imu(c, deg=False):
    """The drive's IMU as a KF-GINS IMU text file (FRD axes), optionally in degrees."""
    imu = _csv(c.bundle / "imu.csv")
    f = 180 / np.pi if deg else 1.0
    rows = np.column_stack([imu.t + 1000.0, imu.dtheta_y * f, imu.dtheta_x * f, -imu.dtheta_z * f,
                            imu.dvel_y, imu.dvel_x, -imu.dvel_z])
    p = c.tmp / "imu.txt"
    np.savetxt(p, rows, fmt="%.12g")
    return p


def _kf_gins_nav(c, lat=None):
    tr = _csv(c.bundle / "truth.csv")
    n = len(tr)
    rows = np.column_stack([np.zeros(n), tr.t + 1000.0, tr.lat if lat is None else np.full(n, lat),
                            tr.lon, tr.h, tr.vN, tr.vE, -tr.vU, tr.roll, tr.pitch, tr.yaw])
    p = c.tmp / "ref.nav"
    np.savetxt(p, rows, fmt="%.12g")
    return p


def _kf_gins_gnss(c, lat):
    tr = _csv(c.bundle / "truth.csv").iloc[::50]
    n = len(tr)
    p = c.tmp / "gnss.txt"
    np.savetxt(p, np.column_stack([tr.t + 1000.0, np.full(n, lat), tr.lon, tr.h, np.ones((n, 3))]))
    return p


def _kf_gins_odo(c, v):
    t = _csv(c.bundle / "radar.csv").t
    p = c.tmp / "odo.txt"
    np.savetxt(p, np.column_stack([t + 1000.0, np.full(len(t), v)]))
    return p


def _csv_log(c, gyro_unit_in_data="rad/s"):
    imu = _csv(c.bundle / "imu.csv")
    dt = np.median(np.diff(imu.t))
    f = 180 / np.pi if gyro_unit_in_data == "deg/s" else 1.0
    df = pd.DataFrame({"time": imu.t, "gx": imu.dtheta_x / dt * f, "gy": imu.dtheta_y / dt * f,
                       "gz": imu.dtheta_z / dt * f, "ax": imu.dvel_x / dt,
                       "ay": imu.dvel_y / dt, "az": imu.dvel_z / dt})
    log = c.tmp / "log.csv"
    df.to_csv(log, index=False)
    mapping = c.tmp / "map.yaml"
    mapping.write_text(textwrap.dedent("""\
        time: {column: time, unit: s}
        initial_position: {lat_deg: 34.0, lon_deg: 108.0, h_m: 400.0}
        imu:
          kind: rate
          axes: [right, forward, up]
          gyro: {columns: [gx, gy, gz], unit: rad/s}
          accel: {columns: [ax, ay, az], unit: m/s^2}
    """))
    return log, mapping


def _ems(c, time_values):
    import scipy.io
    n = 50
    z = np.zeros(n)
    scipy.io.savemat(c.tmp / "ems.mat", {"ems_data": {
        "time": time_values(n), "accel": np.zeros((n, 3)), "gyro": np.zeros((n, 3)),
        "vel_N": np.zeros((n, 3)), "roll": z, "pitch": z, "heading": z, "lat": z, "lon": z,
        "h": z}})
    return c.tmp / "ems.mat"


def _comma(c):
    seg = c.tmp / "seg"
    for sig in ("accelerometer", "gyro"):
        d = seg / "processed_log" / "IMU" / sig
        d.mkdir(parents=True)
        with open(d / "t", "wb") as f:
            np.save(f, np.array(["a"] * 20))
        with open(d / "value", "wb") as f:
            np.save(f, np.zeros((20, 3)))
    return seg


def _sweep(c, grid_text):
    (c.tmp / "s.yaml").write_text(c.scenario)
    p = c.tmp / "sweep.yaml"
    p.write_text(f"name: sw\nscenario: s.yaml\nmethod: dr\nruns: 1\n{grid_text}")
    return p


def _imu_ms(c):
    _edit_csv(c.bundle / "imu.csv", lambda df: df.__setitem__("t", df.t * 1000.0))


def _radar_clock(c, shift=0.0, scale=1.0):
    _edit_csv(c.bundle / "radar.csv", lambda df: df.__setitem__("t", df.t * scale + shift))


def _parquet_timestamps(c):
    df = _csv(c.bundle / "imu.csv")
    df["t"] = pd.to_datetime(df.t, unit="s")
    (c.bundle / "imu.csv").unlink()
    df.to_parquet(c.bundle / "imu.parquet", index=False)
    meta = (c.bundle / "meta.yaml").read_text().replace("imu.csv", "imu.parquet")
    (c.bundle / "meta.yaml").write_text(meta)


def _one_row_imu(c):
    df = _csv(c.bundle / "imu.csv")
    df.iloc[:1].to_csv(c.bundle / "imu.csv", index=False)


def _deg_imu(c):
    def f(df):
        for k in ("dtheta_x", "dtheta_y", "dtheta_z"):
            df[k] = np.degrees(df[k])
    _edit_csv(c.bundle / "imu.csv", f)


def _truth_from(c, t0):
    df = _csv(c.bundle / "truth.csv")
    df[df.t >= t0].to_csv(c.bundle / "truth.csv", index=False)


def _result_edit(c, fn):
    _edit_csv(c.result / "solution.csv", fn)


def _unsorted(df):
    df.loc[[3, 4], "t"] = df.loc[[4, 3], "t"].to_numpy()


def _damaged_campaign(c):
    (c.tmp / "s.yaml").write_text(c.scenario)
    from inmotion.evaluate.store import ResultStore
    store = ResultStore(c.tmp / "mc")
    store.write({"point_id": 0, "run_index": 0, "seed": 0, "status": "ok"})
    store.close()
    (c.tmp / "mc" / "campaign.json").write_text(json.dumps(
        {"name": "x", "runs": 1, "seed": 0, "run": "inmotion.evaluate.runs:default_run",
         "points": [{"point_id": 0, "label": "base", "params": {}, "spec": {}}]}))
    part = next((c.tmp / "mc" / "results").glob("point-*/part-*.parquet"))
    part.write_bytes(b"garbage")
    return True


def _write(p, data):
    p = Path(p)
    if isinstance(data, bytes):
        p.write_bytes(data)
    else:
        p.write_text(data)
    return p


# --------------------------------------------------------------------------- the kinds

#: (kind, category, builder(ctx) -> (args, fragments the one line must hold))
KINDS = [
    # ---- exit 1 "internal error" on bad input, before issue 16
    ("meta-not-utf8", "internal", lambda c: (
        _write(c.bundle / "meta.yaml", NOT_UTF8) and ["info", c.bundle], ["meta.yaml", "UTF-8"])),
    ("meta-nested-50000", "internal", lambda c: (
        _write(c.bundle / "meta.yaml", DEEP) and ["info", c.bundle], ["meta.yaml", "nested"])),
    ("config-not-utf8", "internal", lambda c: (
        _nav(c, "--config", _write(c.tmp / "c.yaml", NOT_UTF8)), ["c.yaml", "UTF-8"])),
    ("config-nested-50000", "internal", lambda c: (
        _nav(c, "--config", _write(c.tmp / "c.yaml", DEEP)), ["c.yaml", "nested"])),
    ("scenario-not-utf8", "internal", lambda c: (
        ["simulate", _write(c.tmp / "sc.yaml", NOT_UTF8), "-o", c.out], ["sc.yaml", "UTF-8"])),
    ("sweep-nested-50000", "internal", lambda c: (
        ["montecarlo", _write(c.tmp / "sw.yaml", DEEP), "-o", c.out], ["sw.yaml", "nested"])),
    ("mapping-not-utf8", "internal", lambda c: (
        ["import", "csv", _csv_log(c)[0], "--mapping", _write(c.tmp / "m.yaml", NOT_UTF8),
         "-o", c.out], ["m.yaml", "UTF-8"])),
    ("seed-negative", "internal", lambda c: (
        ["simulate", _write(c.tmp / "s.yaml", c.scenario), "-o", c.out, "--seed", -1],
        ["--seed", "-1"])),
    ("baro-tau-1e-300", "internal", lambda c: (
        _nav(c, "--set", "baro_tau_s=1e-300"), ["baro_tau_s", "1e-300"])),
    ("sigma0-nan", "internal", lambda c: (
        ["align", c.bundle, "-m", "usque", "-o", c.out, "--set", "sigma0_deg=[.nan,3,12]"],
        ["sigma0_deg", "nan"])),
    ("truth-not-covering-start", "internal", lambda c: (
        _truth_from(c, 6.0) or _nav(c, "--start", 2), ["--init truth", "2 s"])),
    ("import-csv-no-mapping", "internal", lambda c: (
        ["import", "csv", _csv_log(c)[0], "-o", c.out], ["--mapping"])),
    ("import-ems-order-3", "internal", lambda c: (
        ["import", "ems", _ems(c, lambda n: np.arange(n) * 0.01), "-o", c.out, "-O", "order=3"],
        ["order=3"])),
    ("ems-time-strings", "internal", lambda c: (
        ["import", "ems", _ems(c, lambda n: np.array(["x"] * n)), "-o", c.out],
        ["ems.mat", "time"])),
    ("comma2k19-time-strings", "internal", lambda c: (
        ["import", "comma2k19", _comma(c), "-o", c.out], ["t", "not numbers"])),
    ("kf-gins-garbage-bytes", "internal", lambda c: (
        ["import", "kf-gins", _write(c.tmp / "g.txt", bytes(range(256)) * 40), "-o", c.out],
        ["g.txt"])),
    ("output-under-a-file", "internal", lambda c: (
        _nav(c) [:-1] + [_write(c.tmp / "f", "x") / "r"], ["f/r", "a file"])),
    ("output-dangling-symlink", "internal", lambda c: (
        os.symlink(c.tmp / "nowhere", c.tmp / "link") or _nav(c)[:-1] + [c.tmp / "link"],
        ["link", "dangling"])),
    ("output-name-too-long", "internal", lambda c: (
        _nav(c)[:-1] + [c.tmp / ("n" * 300)], ["too long"])),
    ("output-is-a-file", "internal", lambda c: (
        ["simulate", _write(c.tmp / "s.yaml", c.scenario), "-o", _write(c.tmp / "f", "x")],
        ["--output", "is a file"])),
    ("export-under-a-file", "internal", lambda c: (
        ["export", "kf-gins", c.result, "-o", _write(c.tmp / "f", "x") / "x.nav"],
        ["x.nav"])),
    ("scheduler-nothing", "internal", lambda c: (
        ["montecarlo", _write(c.tmp / "s.yaml", c.scenario), "--method", "dr", "--runs", 1,
         "-o", c.out, "--scheduler", "nothing"], ["--scheduler", "nothing"])),
    # ---- accepted in silence before issue 16
    ("imu-in-degrees", "silent", lambda c: (_deg_imu(c) or ["info", c.bundle],
                                            ["imu.csv", "degrees"])),
    ("imu-time-ms", "silent", lambda c: (_imu_ms(c) or ["info", c.bundle],
                                         ["imu.csv", "seconds"])),
    ("parquet-timestamps", "silent", lambda c: (_parquet_timestamps(c) or ["info", c.bundle],
                                                ["imu.parquet", "timestamps"])),
    ("radar-other-clock", "silent", lambda c: (_radar_clock(c, shift=1e5) or ["info", c.bundle],
                                               ["radar.csv", "clock"])),
    ("radar-time-ms", "silent", lambda c: (_radar_clock(c, scale=1000.0) or ["info", c.bundle],
                                           ["radar.csv", "seconds"])),
    ("init-error-yaw-1e999", "silent", lambda c: (
        _nav(c, "--init-error", "yaw=1e999deg"), ["--init-error", "yaw"])),
    ("init-error-north-1e30", "silent", lambda c: (
        _nav(c, "--init-error", "north=1e30m"), ["--init-error", "north"])),
    ("lever-arm-1e308", "silent", lambda c: (
        _nav(c, "--set", "lever_arm_m=[1e308,1e308,0]", method="dr"), ["lever_arm_m"])),
    ("gyro-drift-inf", "silent", lambda c: (
        ["align", c.bundle, "-m", "dr-kf", "-o", c.out, "--set", "gyro_drift_deg_h=.inf"],
        ["gyro_drift_deg_h", "finite"])),
    ("negative-noise-list", "silent", lambda c: (
        ["align", c.bundle, "-m", "od-kf", "-o", c.out, "--set", "od_noise_m_s=[-0.1,0.1]"],
        ["od_noise_m_s", "negative"])),
    ("scenario-nan-heading", "silent", lambda c: (
        _scenario(c, "heading_deg: 20.0", "heading_deg: .nan"), ["heading_deg", "finite"])),
    ("scenario-inf-drift", "silent", lambda c: (
        _scenario(c, "imu: {rate_hz: 50.0}", "imu: {rate_hz: 50.0, gyro: {drift_deg_h: .inf}}"),
        ["drift_deg_h", "finite"])),
    ("scenario-6g-turn", "silent", lambda c: (
        _scenario(c, "speed_m_s: 8.0}\nsegments:\n  - {kind: cruise, duration_s: 4}\n"
                     "  - {kind: turn, angle_deg: 60, rate_deg_s: 10}",
                  "speed_m_s: 40.0}\nsegments:\n  - {kind: cruise, duration_s: 4}\n"
                  "  - {kind: turn, angle_deg: 60, rate_deg_s: 89}"), ["6.34 g", "turn"])),
    ("scenario-imu-0.01hz", "silent", lambda c: (
        _scenario(c, "rate_hz: 50.0", "rate_hz: 0.01"), ["imu.rate_hz"])),
    ("result-unsorted-evaluate", "silent", lambda c: (
        _result_edit(c, _unsorted) or ["evaluate", c.result, "--truth", c.bundle],
        ["solution.csv", "row 5", "time"])),
    ("result-lat-3000-init", "silent", lambda c: (
        _result_edit(c, lambda df: df.__setitem__("lat", 3000.0)) or
        _nav(c, "--init", c.result), ["solution.csv", "latitude"])),
    ("kf-gins-nav-lat-3000", "silent", lambda c: (
        ["import", "kf-gins", _kf_gins_imu(c), "-O", f"nav={_kf_gins_nav(c, lat=3000.0)}",
         "-o", c.out], ["latitude", "3000"])),
    ("kf-gins-increments-in-degrees", "silent", lambda c: (
        ["import", "kf-gins", _kf_gins_imu(c, deg=True), "-o", c.out], ["imu.txt", "degrees"])),
    ("csv-gyro-deg-s-as-rad-s", "silent", lambda c: (
        ["import", "csv", *(lambda lm: [lm[0], "--mapping", lm[1]])(_csv_log(c, "deg/s")),
         "-o", c.out], ["log.csv", "rad/s"])),
    # ---- memory (in process here: they must fail fast and small; test_fuzz_limits runs them
    #      in a child with a measured peak)
    ("meta-alias-bomb", "memory", lambda c: (
        _write(c.bundle / "meta.yaml", BOMB) and ["info", c.bundle], ["meta.yaml", "aliases"])),
    ("montecarlo-runs-1e9", "memory", lambda c: (
        ["montecarlo", _write(c.tmp / "s.yaml", c.scenario), "--method", "dr",
         "--runs", 1000000000, "-o", c.out], ["runs", "1e+09"])),
    ("sweep-grid-1e10", "memory", lambda c: (
        ["montecarlo", _sweep(c, "grid:\n" + "".join(
            f"  k{i}: [1,2,3,4,5,6,7,8,9,10]\n" for i in range(10))), "-o", c.out],
        ["sweep.yaml", "1e+10 points"])),
    ("scenario-31-years", "memory", lambda c: (
        _scenario(c, "duration_s: 6", "duration_s: 978000000"), ["bad.yaml", "rows"])),
    # ---- messages that missed the point
    ("one-row-imu", "message", lambda c: (_one_row_imu(c) or _nav(c, "--init", "meta"),
                                          ["imu.csv", "2"])),
    ("start-nan", "message", lambda c: (_nav(c, "--start", "nan"), ["--start", "nan"])),
    ("speed-scale-inf", "message", lambda c: (
        _nav(c, "--set", "speed_scale=.inf", method="dr"), ["speed_scale"])),
    ("scenario-key-typo", "message", lambda c: (
        _scenario(c, "duration_s: 6", "duraton_s: 6"), ["duraton_s", "duration_s"])),
    ("empty-window", "message", lambda c: (_nav(c, "--start", 1000, "--init", "meta"),
                                           ["--start", "IMU"])),
    # ---- found while fixing the above
    ("meta-key-wrong-type", "found", lambda c: (
        _write(c.bundle / "meta.yaml", "name: x\nfaults: 7\n") and ["info", c.bundle],
        ["meta.yaml", "'faults'"])),
    ("cell-value-megabyte", "found", lambda c: (
        _edit_csv(c.bundle / "radar.csv", lambda df: df.__setitem__(
            "v", df.v.astype(object).where(df.index != 2, "x" * 10**6))) or ["info", c.bundle],
        ["radar.csv", "row 3", "'v'"])),
    ("campaign-init-error-1e999", "found", lambda c: (
        ["montecarlo", _write(c.tmp / "s.yaml", c.scenario), "--method", "dr", "--runs", 1,
         "--init-error", "yaw=1e999deg", "-o", c.out], ["init_error", "yaw"])),
    ("campaign-method-option-nan", "found", lambda c: (
        ["montecarlo", _write(c.tmp / "s.yaml", c.scenario), "--method", "dr", "--runs", 1,
         "--set", "speed_scale=.nan", "-o", c.out], ["speed_scale", "nan"])),
    ("sweep-grid-key-outside-spec", "found", lambda c: (
        ["montecarlo", _sweep(c, "grid: {start.speed_m_s: [5, 10]}"), "-o", c.out],
        ["'start'", "scenario.start.speed_m_s"])),
    ("report-output-under-a-file", "found", lambda c: (
        ["report", c.result, "-o", _write(c.tmp / "f", "x") / "p.html"], ["p.html", "a file"])),
    ("report-output-dangling-symlink", "found", lambda c: (
        os.symlink(c.tmp / "nowhere", c.tmp / "p.html") or
        ["report", c.result, "-o", c.tmp / "p.html"], ["p.html", "dangling"])),
    ("demo-keep-under-a-file", "found", lambda c: (
        ["demo", "--keep", _write(c.tmp / "f", "x") / "d"], ["f/d", "a file"])),
    ("reproduce-output-under-a-file", "found", lambda c: (
        ["reproduce", "004", "-o", _write(c.tmp / "f", "x") / "d"], ["f/d", "a file"])),
    ("montecarlo-workers-100000", "found", lambda c: (
        ["montecarlo", _write(c.tmp / "s.yaml", c.scenario), "--method", "dr", "--runs", 1,
         "--workers", 100000, "-o", c.out], ["--workers", "100000"])),
    ("result-into-an-unrelated-folder", "found", lambda c: (
        _write(c.tmp / "thesis.tex", "x") and _nav(c)[:-1] + [c.tmp],
        ["not a result folder"])),
    ("campaign-part-damaged", "found", lambda c: (
        _damaged_campaign(c) and ["report", c.tmp / "mc"], ["part-", "unreadable"])),
    ("summary-not-an-object", "found", lambda c: (
        _write(c.result / "summary.json", "[1, 2]") and ["evaluate", c.result, "--truth",
                                                         c.bundle],
        ["summary.json", "JSON object"])),
    ("init-result-on-another-clock", "found", lambda c: (
        _result_edit(c, lambda df: df.__setitem__("t", df.t + 1e5)) or
        _nav(c, "--init", c.result), ["--init", "IMU time span"])),
    ("campaign-manifest-wrong-shape", "found", lambda c: (
        _damaged_campaign(c) and _write(c.tmp / "mc" / "campaign.json", '{"points": 3}') and
        ["report", c.tmp / "mc"], ["campaign.json", "'runs'"])),
    ("kf-gins-gnss-lat-3000", "found", lambda c: (
        ["import", "kf-gins", _kf_gins_imu(c), "-O", f"gnss={_kf_gins_gnss(c, 3000.0)}",
         "-o", c.out], ["latitude 3000"])),
    ("kf-gins-odometer-impossible", "found", lambda c: (
        ["import", "kf-gins", _kf_gins_imu(c), "-O", f"odo={_kf_gins_odo(c, 1e6)}",
         "-o", c.out], ["odo.txt", "speed"])),
    ("export-result-lat-3000", "found", lambda c: (
        _result_edit(c, lambda df: df.__setitem__("lat", 3000.0)) or
        ["export", "kf-gins", c.result, "-o", c.tmp / "x.nav"], ["solution.csv", "latitude"])),
    ("meta-files-outside-the-bundle", "found", lambda c: (
        _write(c.bundle / "meta.yaml", (c.bundle / "meta.yaml").read_text().replace(
            "imu: imu.csv", "imu: ../../imu.csv")) and ["info", c.bundle],
        ["meta.yaml", "outside the bundle"])),
    # ---- writes that lost or mixed data
    ("half-written-bundle", "write", lambda c: (
        _write(c.bundle / PARTIAL_MARKER, "") and ["info", c.bundle], ["half-written bundle"])),
    ("half-written-result", "write", lambda c: (
        _write(c.result / PARTIAL_MARKER, "") and ["evaluate", c.result, "--truth", c.bundle],
        ["half-written result"])),
]

KIND_IDS = [k[0] for k in KINDS]


@pytest.mark.parametrize("kind,category,build", KINDS, ids=KIND_IDS)
def test_bad_input_kind(ctx, kind, category, build):
    args, fragments = build(ctx)
    expect_bad(args, *fragments)
    assert not ctx.out.exists()                 # nothing written for bad input


def test_kinds_are_unique():
    assert len(set(KIND_IDS)) == len(KIND_IDS)


# --------------------------------------------------------------------------- valid inputs

@pytest.mark.parametrize("args", [
    ["navigate", "{b}", "-m", "sins", "-o", "{o}"],
    ["navigate", "{b}", "-m", "dr", "-o", "{o}", "--init-error", "yaw=30arcmin,north=5m"],
    ["navigate", "{b}", "-m", "sins", "-o", "{o}", "--set", "baro_tau_s=20", "--end", "10"],
    ["align", "{b}", "-m", "mimada-dual", "-o", "{o}", "--start", "1", "--end", "15"],
], ids=["sins", "dr-init-error", "sins-baro-tau", "mimada-dual"])
def test_valid_inputs_give_finite_results(ctx, args):
    args = [a.format(b=ctx.bundle, o=ctx.out) for a in args]
    expect_ok(args)
    finite_solution(ctx.out)
    summary = json.loads((ctx.out / "summary.json").read_text())
    assert abs(summary["final"]["lat_deg"] - 34.0) < 0.1
    assert summary["errors"]["final"]["horizontal_m"] < 1000


def test_valid_import_and_export_round_trip(ctx):
    log, mapping = _csv_log(ctx)
    expect_ok(["import", "csv", log, "--mapping", mapping, "-o", ctx.out])
    expect_ok(["info", ctx.out])
    expect_ok(["export", "kf-gins", ctx.result, "-o", ctx.tmp / "x.nav"])
    rows = len((ctx.result / "solution.csv").read_text().splitlines()) - 1   # header
    assert rows > 5 and len((ctx.tmp / "x.nav").read_text().splitlines()) == rows


def test_rerun_into_existing_result_that_fails_keeps_it(ctx):
    """A rerun that fails (bad input found while running) leaves the earlier result whole."""
    before = {p.name: p.read_bytes() for p in ctx.result.iterdir()}
    code = invoke(["navigate", ctx.bundle, "-m", "dr", "-o", ctx.result,
                   "--set", "lever_arm_m=[1e308,1e308,0]"])[0]
    assert code == 2
    assert {p.name: p.read_bytes() for p in ctx.result.iterdir()} == before
