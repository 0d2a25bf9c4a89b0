"""``inmotion process`` on a bundle read in chunks gives what it gives on the bundle in memory.

The reference is the old path: :func:`read_bundle` loads the tables whole, :func:`run_process`
keeps every row of every stage and the result is thinned to the output rate afterwards
(:func:`inmotion.io.result.thin`). The streamed path (:func:`open_bundle` with small chunks,
``output_rate_hz`` given, so the radar stages keep only the rows thinning can keep and the fine
stage stops at its handover) must give the same thinned result bit for bit, and the same
stage log. :meth:`BundleStream.load_window` (the time-filtered read the coarse and parked
stages use) must give :meth:`Bundle.window`'s rows and read no row outside the window.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.bundle_stream import open_bundle
from inmotion.io.result import thin
from inmotion.process import _OutputRows, run_process
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

IMU = {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.005, "arw_deg_sqrt_h": 0.0005},
       "accel": {"bias_ug": 50.0, "vrw_ug_sqrt_hz": 5.0}}
SENSORS = {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0,
                        "scale_factor_sigma_ppm": 2000.0, "lever_arm_m": [-0.8, -1.5, -0.9]},
           "ldv": {"rate_hz": 100.0, "output": "distance", "scale_factor_sigma_ppm": 500.0,
                   "noise_m_s": 0.01, "lever_arm_m": [0.3, 1.2, -0.6]},
           "radar": {"rate_hz": 10.0, "noise_m_s": 0.05, "scale_factor_sigma_ppm": 1000.0},
           "baro": {"rate_hz": 10.0, "noise_m": 0.5}}


MEMS = {"rate_hz": 100.0, "gyro": {"drift_deg_h": 100.0, "arw_deg_sqrt_h": 0.3},
        "accel": {"bias_ug": 2000.0, "vrw_ug_sqrt_hz": 100.0}}


def _drive(sensors, seed, parked_s=62.0, imu=IMU):
    """Parked 62 s (parked coarse + parked-kf), a drive with a 20 s stop and turns (~4 min)."""
    return simulate(load_scenario({
        "name": "stream", "start": {"lat_deg": 39.9, "lon_deg": 116.4, "h_m": 50.0,
                                    "heading_deg": 60.0},
        "vehicle_mounting_arcmin": [10.0, 0.0, 15.0],
        "segments": [{"kind": "rest", "duration_s": parked_s},
                     {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                     {"kind": "cruise", "duration_s": 40.0},
                     {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                     {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 20},
                     {"kind": "accelerate", "to_speed_m_s": 12.0, "accel_m_s2": 1.0},
                     {"kind": "turn", "angle_deg": -60, "rate_deg_s": 4},
                     {"kind": "cruise", "duration_s": 40.0}],
        "imu": imu, "sensors": {k: SENSORS[k] for k in sensors}}), np.random.default_rng(seed))


def _same(a, b):
    for k in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert a.sigma.keys() == b.sigma.keys() and a.states.keys() == b.states.keys()
    for d1, d2 in ((a.sigma, b.sigma), (a.states, b.states)):
        for k in d1:
            np.testing.assert_array_equal(d1[k], d2[k], err_msg=k)


def _stages(sol):
    return [{k: v for k, v in s.items() if k != "config_source"} for s in sol.info["stages"]]


#: radar: the fine stage (dr-kf) hands over to sins-dr after 60 s (its heading sigma is below
#: 60 arcmin by then), so the early stop and the output-row selection of both stages are used;
#: no velocity sensor: a MEMS still for 8 s (the still-start test, the still stage's gyro bias
#: taken off the rows as they are read), then nhc-kf
CASES = {"radar": (["radar", "baro"], {"fine_s": 60.0, "handover_heading_sigma_arcmin": 60.0},
                   {}, ["chi-square", "coarse-inertial", "parked-kf", "dr-kf", "sins-dr"]),
         "odometer+ldv": (["odometer", "ldv", "baro"], {}, {},
                          ["chi-square", "coarse-inertial", "parked-kf", "fkf"]),
         "none": (["baro"], {}, {"parked_s": 8.0, "imu": MEMS},
                  ["imu stillness", "imu", "nhc-kf"])}


@pytest.mark.parametrize("smooth", [False, True])
@pytest.mark.parametrize("case", list(CASES))
def test_process_streamed_equals_in_memory(case, smooth, tmp_path):
    sensors, cfg, drive, methods = CASES[case]
    folder = tmp_path / "b"
    write_bundle(_drive(sensors, 4, **drive), folder, fmt="parquet")
    cfg = {**cfg, "smooth": smooth}
    whole = read_bundle(folder)
    init = NavState.from_truth(whole.truth)
    ii = {"source": "truth", "has_attitude": True, "heading_sigma_deg": 0.1,
          "tilt_sigma_deg": 0.05}
    ref = run_process(whole, cfg, init, ii)
    stream = open_bundle(folder, chunk_rows=997)
    if "ldv" in sensors:        # the 100 Hz LDV stays on disk, read chunk by chunk
        from inmotion.io.bundle_stream import SpeedStream
        assert isinstance(stream.ldv, SpeedStream)
    got = run_process(stream, cfg, init, ii, output_rate_hz=1.0)
    names = [s["method"] for s in ref.info["stages"]]
    assert names[:len(methods)] == methods, names          # (radar: the handover happened)
    if case == "radar":
        assert len(got.t) < len(ref.t) / 5                  # 10 Hz stages kept at ~1 Hz
    if case == "none":
        assert "gyro_bias_deg_h" in ref.info["stages"][1], ref.info["stages"][1]
    _same(thin(got, 1.0), thin(ref, 1.0))
    assert _stages(got) == _stages(ref)


def test_output_rows_keep_what_thin_keeps():
    """Random stage cuts and chunkings of an irregular time base: thinning the rows kept
    stage by stage gives the rows thinning all of them gives."""
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.01, 0.4, 3000))
    for _ in range(20):
        cuts = np.sort(rng.choice(np.arange(1, len(t) - 1), 3, replace=False))
        kept, prev = [], None
        for part in np.split(np.arange(len(t)), cuts):
            sel = _OutputRows(t[0], 2.0, prev)
            for chunk in np.array_split(part, rng.integers(1, 6)):
                m, stop = sel(t[chunk])
                assert not stop
                kept.append(chunk[m])
            prev = t[part[-1]]
        kept = np.concatenate(kept)
        k = np.floor((t - t[0]) * 2.0 + 1e-6)            # thin()'s rule on all rows
        want = np.flatnonzero(np.r_[True, k[1:] != k[:-1]] | (np.arange(len(t)) == len(t) - 1))
        k2 = k[kept]
        again = kept[np.r_[True, k2[1:] != k2[:-1]] | (np.arange(len(kept)) == len(kept) - 1)]
        np.testing.assert_array_equal(again, want)


@pytest.fixture(scope="module")
def radar_drive():
    return _drive(["radar", "baro"], 1)


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_load_window_reads_the_windows_rows(radar_drive, tmp_path, fmt):
    folder = tmp_path / "b"
    write_bundle(radar_drive, folder, fmt=fmt)
    whole = read_bundle(folder)
    stream = open_bundle(folder, chunk_rows=1000)
    for w in ((None, 62.0), (100.0, 220.005), (230.0, None), (55.555, 55.575),
              (None, None)):
        a, b = stream.load_window(*w), whole.window(*w)
        for k in ("t", "dtheta", "dvel"):
            np.testing.assert_array_equal(getattr(a.imu, k), getattr(b.imu, k), err_msg=k)
        np.testing.assert_array_equal(a.radar.v, b.radar.v)
        np.testing.assert_array_equal(a.baro.h, b.baro.h)
    # a window of the window
    a = stream.window(50.0, 150.0).load_window(100.0, None)
    np.testing.assert_array_equal(a.imu.t, whole.window(100.0, 150.0).imu.t)


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_load_window_checks_its_rows_only(radar_drive, tmp_path, fmt):
    """A NaN at row 15001 (t = 150 s): a window before it is read without error (the row is
    not read), one holding it names the row counted over the whole table, as read_bundle."""
    folder = tmp_path / "b"
    write_bundle(radar_drive, folder, fmt=fmt)
    p = folder / f"imu.{fmt}"
    df = pd.read_parquet(p) if fmt == "parquet" else pd.read_csv(p)
    row = 15001
    df.loc[row - 1, "dtheta_y"] = np.nan
    df.to_parquet(p, index=False, row_group_size=8192) if fmt == "parquet" else \
        df.to_csv(p, index=False)
    stream = open_bundle(folder, chunk_rows=1000)
    assert len(stream.load_window(0.0, 120.0).imu.t) == 12001
    with pytest.raises(BadInput) as e:
        stream.load_window(140.0, 160.0)
    with pytest.raises(BadInput) as e_whole:
        read_bundle(folder)
    assert str(e.value) == str(e_whole.value)
    assert f"row {row}, t=" in str(e.value)


def test_gyro_bias_removed_as_rows_are_read_is_the_whole_tables(radar_drive, tmp_path):
    """The still stage's correction applied to rows as they are read (pieces of 997 rows, a
    window) equals the former whole-table ``dtheta - outer(dt, b)``, bit for bit."""
    from inmotion.process import _GyroBiasRemoved
    folder = tmp_path / "b"
    write_bundle(radar_drive, folder, fmt="parquet")
    whole = read_bundle(folder)
    imu, b = whole.imu, np.array([1e-4, -2e-4, 3e-5])
    want = imu.dtheta - np.outer(np.diff(imu.t, prepend=imu.t[0] - imu.dt), b)
    for src in (whole, open_bundle(folder, chunk_rows=997)):
        fixed = _GyroBiasRemoved(src, b)
        n, _, pieces, k0 = fixed.imu_rows_after(10.0)
        got = np.concatenate([p[1] for p in pieces])
        assert len(got) == n
        np.testing.assert_array_equal(got, want[k0:])
        w = fixed.load_window(50.0, 80.0).imu
        m = (imu.t >= 50.0) & (imu.t <= 80.0)
        np.testing.assert_array_equal(w.dtheta, want[m])
        np.testing.assert_array_equal(w.dvel, imu.dvel[m])
        assert not hasattr(fixed.imu, "dtheta")
        # a window of the corrected bundle is corrected once, however its rows are read
        win = fixed.window(50.0, 80.0)
        np.testing.assert_array_equal(win.load_window().imu.dtheta, want[m])
        _, _, pieces, k0 = win.imu_rows_after(60.0)
        got = np.concatenate([p[1] for p in pieces])
        np.testing.assert_array_equal(got, want[m][k0:])


@pytest.mark.parametrize("method", ["fine-mux", "adaptive"])
def test_fine_mux_and_adaptive_streamed_equal_in_memory(method, tmp_path):
    """Their coarse and parked stages read their windows' rows, their fine stage (fkf)
    streams: the same solution as on the bundle in memory, bit for bit."""
    from inmotion.align.multiplex import run_fine_mux
    from inmotion.align.strategy import run_adaptive
    run = {"fine-mux": run_fine_mux, "adaptive": run_adaptive}[method]
    folder = tmp_path / "b"
    write_bundle(_drive(["odometer", "ldv"], 2, parked_s=62.0 if method == "adaptive" else 5.0),
                 folder, fmt="parquet")
    whole = read_bundle(folder)
    init = NavState.from_truth(whole.truth)
    _same(run(open_bundle(folder, chunk_rows=997), {}, init), run(whole, {}, init))


@pytest.fixture(scope="module")
def ldv_bundle(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ldv") / "b"
    write_bundle(_drive(["odometer", "ldv"], 3, parked_s=5.0), folder, fmt="parquet")
    return folder


def test_long_fast_sensor_stays_on_disk(ldv_bundle):
    """The 100 Hz LDV (more rows than a chunk) is a SpeedStream, the 10 Hz odometer is read
    whole; the stream answers t / ds / v / window / load as the table read whole does."""
    from inmotion.io.bundle_stream import SpeedStream
    whole = read_bundle(ldv_bundle)
    s = open_bundle(ldv_bundle, chunk_rows=997)
    assert isinstance(s.ldv, SpeedStream) and not isinstance(s.odometer, SpeedStream)
    assert s.ldv.v is None
    np.testing.assert_array_equal(s.ldv.t, whole.ldv.t)
    np.testing.assert_array_equal(s.ldv.ds, whole.ldv.ds)
    np.testing.assert_array_equal(s.ldv.speed(), whole.ldv.speed())
    w, ww = s.ldv.window(50.0, 123.456), whole.ldv.window(50.0, 123.456)
    np.testing.assert_array_equal(w.t, ww.t)
    np.testing.assert_array_equal(w.load().ds, ww.ds)
    np.testing.assert_array_equal(s.load_window(60.0, 70.0).ldv.ds, whole.window(60.0, 70.0).ldv.ds)


def test_resampler_chunked_equals_whole_and_speed_on_epochs(ldv_bundle):
    """speed_resampler fed a drive's IMU epochs in chunks: from the stream (a chunk of rows
    in memory) the same bits as from the table in memory; against speed_on_epochs on each
    chunk (the cumulative distance summed again from the first sample) equal up to rounding
    (1e-9 m: the cumulative distance is a sum of per-chunk sums); the distance over the drive
    is the odometer-independent truth's path length within the LDV's scale error."""
    from inmotion.core.deadreckoning import speed_on_epochs, speed_resampler
    whole = read_bundle(ldv_bundle)
    s = open_bundle(ldv_bundle, chunk_rows=997)
    t = whole.imu.t
    r_mem, r_str = speed_resampler(whole.ldv, what="ldv"), speed_resampler(s.ldv, what="ldv")
    total = 0.0
    for a in range(0, len(t) - 1, 4321):
        edges = t[a:a + 4322]
        got_m, got_s = r_mem(edges), r_str(edges)
        ref = speed_on_epochs(whole.ldv, edges, what="ldv")
        for x, y, z in zip(got_m, got_s, ref):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_allclose(x, z, rtol=0, atol=1e-9)
        total += got_m[0].sum()
    from inmotion.core.metrics import _path_length
    truth_m = _path_length(whole.truth, t[[0, -1]])[-1]
    assert abs(total / truth_m - 1.0) < 5 * 500e-6, (total, truth_m)


def test_long_sensor_bad_row_named_as_read_bundle(ldv_bundle, tmp_path):
    """An impossible ds in the third chunk of a streamed LDV: open_bundle refuses the bundle
    with read_bundle's message (file, row over the whole table, time)."""
    import shutil
    folder = tmp_path / "b"
    shutil.copytree(ldv_bundle, folder)
    p = folder / "ldv.parquet"
    df = pd.read_parquet(p)
    df.loc[2500, "ds"] = 50.0
    df.to_parquet(p, index=False)
    with pytest.raises(BadInput) as e_stream:
        open_bundle(folder, chunk_rows=997)
    with pytest.raises(BadInput) as e_whole:
        read_bundle(folder)
    assert str(e_stream.value) == str(e_whole.value)
    assert "row 2501, t=" in str(e_stream.value)


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
def test_parked_kf_streams_its_window(radar_drive, tmp_path, fmt):
    """parked-kf on a window of a bundle read in chunks: the rows are fed as they are read,
    none after the window's end (a NaN at t = 150 s is never read), and the solution is that
    of the window in memory, bit for bit."""
    from inmotion.align.parked_kf import run_parked_kf
    folder = tmp_path / "b"
    write_bundle(radar_drive, folder, fmt=fmt)
    whole = read_bundle(folder)
    init = NavState.from_truth(whole.truth)
    ref = run_parked_kf(whole.load_window(None, 60.0), {}, init, end_s=60.0)
    p = folder / f"imu.{fmt}"
    df = pd.read_parquet(p) if fmt == "parquet" else pd.read_csv(p)
    df.loc[15000, "dtheta_y"] = np.nan
    df.to_parquet(p, index=False, row_group_size=8192) if fmt == "parquet" else \
        df.to_csv(p, index=False)
    stream = open_bundle(folder, chunk_rows=997)
    got = run_parked_kf(stream.window(None, 60.0), {}, init, end_s=60.0)
    _same(got, ref)
    assert len(ref.t) > 50


def test_smooth_record_from_files_with_reused_buffers_equals_memory(tmp_path):
    """The backward pass over a record on disk (block buffers reused, a budget of a few
    records: many blocks) returns every output of the pass over the same record in memory
    bit for bit, the forward sigma of the records where blocks meet included."""
    from inmotion.estimation.layout import Layout
    from inmotion.estimation.smoother import ForwardRecord, smooth_record
    lay = Layout(["phi", "dv", "dp"])
    n, N = lay.n, 60
    rng = np.random.default_rng(3)
    recs = {k: [] for k in ("t", "phi", "p_pred", "x", "p", "fb", "fed", "xs", "epoch")}
    P = np.eye(n) * 1e-2
    for k in range(N):
        Phi = np.eye(n) + 0.01 * rng.standard_normal((n, n))
        Pp = Phi @ P @ Phi.T + np.eye(n) * 1e-4
        H = rng.standard_normal((2, n))
        K = Pp @ H.T @ np.linalg.inv(H @ Pp @ H.T + np.eye(2) * 1e-3)
        P = (np.eye(n) - K @ H) @ Pp
        P = 0.5 * (P + P.T)
        xs = np.r_[0.7, 2.0, 50.0, 1.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0]
        for key, v in (("t", k * 0.1), ("phi", Phi), ("p_pred", Pp), ("x", 1e-3 * rng.standard_normal(n)),
                       ("p", P), ("fb", np.zeros(n)), ("fed", np.zeros(n)), ("xs", xs), ("epoch", k)):
            recs[key].append(v)
    chunk = {k: np.asarray(v, dtype=float) for k, v in recs.items()}
    mem = ForwardRecord(n, N)
    disk = ForwardRecord(n, N, memory_budget_bytes=7 * 8 * (3 * n * n + 3 * n + 13), folder=tmp_path)
    for r in (mem, disk):
        r.append({k: v[:20] for k, v in chunk.items()})
        r.append({k: v[20:] for k, v in chunk.items()})
    assert disk.on_disk and not mem.on_disk
    rows = np.arange(0, N, 3)
    a, b = smooth_record(mem, lay, rows), smooth_record(disk, lay, rows)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    disk.close()
