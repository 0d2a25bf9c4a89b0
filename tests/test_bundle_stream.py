"""A bundle read in chunks (inmotion.io.bundle_stream) gives what the whole bundle gives.

The reference is always the other reader: :func:`read_bundle` loads the tables whole and the
methods run on the arrays as before; the chunked reader must give the same solution bit for
bit, wherever the chunks are cut (inside a filter interval too), the same errors against
truth from the few truth rows it keeps, and the same message, with the row counted over the
whole table, for a bad row in a later chunk.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.cli.main import cli
from inmotion.core.bundle import regroup
from inmotion.core.metrics import error_series
from inmotion.core.solution import NavState, Solution
from inmotion.errors import BadInput
from inmotion.io import bundle_stream
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.bundle_stream import _unwrap_carry, open_bundle
from inmotion.navigate.sins_dr import run_sins_dr
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

#: 70 s through a right turn across north (yaw 340 -> 40 deg: the unwrap is exercised)
DRIVE = {
    "name": "across_north",
    "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 340},
    "segments": [{"kind": "rest", "duration_s": 5},
                 {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 15},
                 {"kind": "turn", "angle_deg": 60, "rate_deg_s": 6},
                 {"kind": "climb", "pitch_deg": 2, "duration_s": 15},
                 {"kind": "cruise", "duration_s": 15.5}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
            "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}


@pytest.fixture(scope="module")
def drive():
    return simulate(load_scenario(DRIVE), np.random.default_rng(3))


@pytest.fixture(scope="module", params=["parquet", "csv"])
def folder(request, drive, tmp_path_factory):
    p = tmp_path_factory.mktemp(f"b_{request.param}") / "bundle"
    write_bundle(drive, p, fmt=request.param)
    return p


def _same_solution(a, b):
    for k in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert a.sigma.keys() == b.sigma.keys() and a.states.keys() == b.states.keys()
    for k in a.sigma:
        np.testing.assert_array_equal(a.sigma[k], b.sigma[k], err_msg=k)
    for k in a.states:
        np.testing.assert_array_equal(a.states[k], b.states[k], err_msg=k)


@pytest.mark.parametrize("tiny, cfg", [(False, {"mode": "velocity-position",
                                                 "output_rate_hz": 1.0}),
                                        (True, {"mode": "attitude-position", "use_baro": True})])
def test_sins_dr_in_chunks_equals_whole(folder, tiny, cfg):
    """997 rows per chunk, or 3 (Parquet; 101 for CSV, whose reader pays per chunk), cut the
    10-row filter epochs anywhere; the engine's chunks are the same, so the solution is
    bit-identical to the whole-table run."""
    whole = read_bundle(folder)
    chunk_rows = (3 if folder.joinpath("imu.parquet").exists() else 101) if tiny else 997
    stream = open_bundle(folder, chunk_rows=chunk_rows)
    i1, i2 = NavState.from_truth(whole.truth), NavState.from_truth(stream.truth)
    assert i1.t == i2.t and np.array_equal(i1.q_nb, i2.q_nb)
    _same_solution(run_sins_dr(whole, cfg, i1), run_sins_dr(stream, cfg, i2))


def test_window_and_align_methods_in_chunks(folder):
    """A window (--start/--end) and the dr-kf / od-velocity-kf alignment give the same."""
    from inmotion.align.dr_kalman import run_dr_kf, run_od_velocity_kf
    whole = read_bundle(folder).window(12.0, 50.0)
    stream = open_bundle(folder, chunk_rows=512).window(12.0, 50.0)
    np.testing.assert_array_equal(whole.imu.t, stream.imu.t)
    init = NavState.from_truth(whole.truth)
    for run in (run_dr_kf, run_od_velocity_kf):
        _same_solution(run(whole, {}, init), run(stream, {}, init))


@pytest.mark.parametrize("method", ["sins", "dr"])
def test_pure_navigation_in_chunks_equals_whole(folder, method):
    """``navigate sins`` (baro-damped) and ``dr`` from chunks of 613 rows, whole and windowed."""
    from inmotion.navigate.pure import DrConfig, SinsConfig, run_dr, run_sins
    run, cfg = (run_sins, SinsConfig()) if method == "sins" else (run_dr, DrConfig())
    for window in ((None, None), (7.5, 61.0)):
        whole = read_bundle(folder).window(*window)
        stream = open_bundle(folder, chunk_rows=613).window(*window)
        init = NavState.from_truth(whole.truth)
        _same_solution(run(whole, cfg, init), run(stream, cfg, init))


@pytest.mark.parametrize("shift_s", [0.0, 0.004])
def test_errors_from_the_kept_truth_rows_equal(drive, tmp_path, shift_s):
    """The errors at 1 Hz from the truth rows kept (two around each output time, path length
    carried along every row) equal those from the whole truth table, across the yaw wrap;
    with the truth's clock shifted by 4 ms every output time falls between two truth rows."""
    from dataclasses import replace
    shifted = replace(drive, truth=replace(drive.truth, t=drive.truth.t + shift_s))
    folder = tmp_path / "b"
    write_bundle(shifted, folder, fmt="parquet")
    whole = read_bundle(folder)
    stream = open_bundle(folder, chunk_rows=700)
    sol = run_sins_dr(whole, {"output_rate_hz": 1.0}, NavState.from_truth(whole.truth))
    kept = stream.truth.reduced(sol.t)
    assert len(kept.t) < len(whole.truth.t) / 20
    assert np.ptp(np.degrees(drive.truth.euler[:, 2])) > 300      # yaw did cross north
    pd.testing.assert_frame_equal(error_series(sol, whole.truth), error_series(sol, kept),
                                  check_exact=True)
    k = (sol.t >= 20) & (sol.t <= 60)                  # a window (--start / --end)
    part = Solution(sol.t[k], sol.lat[k], sol.lon[k], sol.h[k], sol.vel_n[k], sol.euler[k])
    w = stream.window(20.0, 60.0).truth.reduced(part.t)
    assert w.t[0] >= 20.0 and w.t[-1] <= 60.0
    pd.testing.assert_frame_equal(error_series(part, whole.window(20.0, 60.0).truth),
                                  error_series(part, w), check_exact=True)


def test_unwrap_carried_across_chunks_is_numpys():
    rng = np.random.default_rng(1)
    p = np.mod(np.cumsum(rng.normal(0, 1.3, (5000, 3)), axis=0), 2 * np.pi) - np.pi
    ref = np.unwrap(p, axis=0)
    cuts = np.sort(rng.choice(np.arange(1, 5000), 40, replace=False))
    out, carry, prev = [], np.zeros(3), None
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, 5000]):
        u, carry = _unwrap_carry(p[a:b], prev, carry)
        out.append(u)
        prev = p[b - 1]
    np.testing.assert_array_equal(np.concatenate(out), ref)
    # a slow turn whose wraps fall on chunk boundaries: the chunks have no inner step of pi and
    # take the shortcut, the step at their first row is found all the same
    slow = np.mod(np.linspace(0.0, 40.0, 6000) + np.pi, 2 * np.pi) - np.pi
    wraps = np.flatnonzero(np.abs(np.diff(slow)) >= np.pi) + 1
    cuts = np.unique(np.r_[wraps, wraps[1::2] + 300, 1, 5999])
    out, carry, prev = [], 0.0, None
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, 6000]):
        u, carry = _unwrap_carry(slow[a:b], prev, carry)
        out.append(u)
        prev = slow[b - 1]
    assert len(wraps) >= 5
    np.testing.assert_array_equal(np.concatenate(out), np.unwrap(slow))


def test_regroup_gives_the_whole_tables_blocks():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(1000, 3))
    t = np.arange(1000.0)
    cuts = np.r_[0, np.sort(rng.choice(np.arange(1, 1000), 25, replace=False)), 1000]
    pieces = [(t[a:b], x[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    blocks = list(regroup(iter(pieces), 96))
    assert [len(b[0]) for b in blocks] == [96] * 10 + [40]
    for k, (tb, xb) in enumerate(blocks):
        np.testing.assert_array_equal(tb, t[96 * k:96 * (k + 1)])
        np.testing.assert_array_equal(xb, x[96 * k:96 * (k + 1)])


def _spoil(folder, table, fmt, edit):
    """Rewrite ``table`` of the bundle with ``edit(DataFrame)`` applied."""
    p = folder / f"{table}.{fmt}"
    df = pd.read_parquet(p) if fmt == "parquet" else pd.read_csv(p)
    df = edit(df)
    if fmt == "parquet":
        df.to_parquet(p, index=False, row_group_size=1500)
    else:
        df.to_csv(p, index=False)


def _message(fn):
    with pytest.raises(BadInput) as e:
        fn()
    return str(e.value)


def _stream_run(folder, chunk_rows=1000):
    s = open_bundle(folder, chunk_rows=chunk_rows)
    run_sins_dr(s, {}, NavState.from_truth(s.truth))


@pytest.mark.parametrize("fmt", ["parquet", "csv"])
@pytest.mark.parametrize("bad", ["nan", "text", "rate", "degrees", "g_units", "backwards"])
def test_a_bad_row_in_chunk_3_is_named(drive, tmp_path, fmt, bad):
    """Row 2500 is in the third chunk of 1000 rows: the chunked reader names the same file,
    row (counted over the whole table) and time as read_bundle, which reads it whole."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt=fmt)
    row = 2500                                     # 1-based data row
    if bad == "text" and fmt == "parquet":
        pytest.skip("a Parquet float column holds no text")

    def edit(df):
        if bad == "nan":
            df.loc[row - 1, "dtheta_y"] = np.nan
        elif bad == "text":
            df["dvel_z"] = df["dvel_z"].astype(object)
            df.loc[row - 1, "dvel_z"] = "abc"
        elif bad == "rate":
            df.loc[row - 1, "dtheta_z"] = 1.0          # 100 rad/s
        elif bad == "degrees":                         # the turn reads 57 times too fast
            for c in ("dtheta_x", "dtheta_y", "dtheta_z"):
                df[c] = np.degrees(df[c])
        elif bad == "g_units":
            for c in ("dvel_x", "dvel_y", "dvel_z"):
                df[c] = df[c] / 9.80665
        elif bad == "backwards":
            df.loc[row - 1, "t"] = df.loc[row - 3, "t"]
        return df
    _spoil(folder, "imu", fmt, edit)
    expected = _message(lambda: read_bundle(folder))
    got = _message(lambda: _stream_run(folder))
    assert got == expected
    if bad in ("nan", "text", "rate"):
        assert f"imu.{fmt}, row {row}, t=" in got


def _bad_truth_bundle(drive, tmp_path):
    """A Parquet bundle of ``drive`` whose truth row 6001 has a pitch of 95 deg."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")

    def edit(df):
        df.loc[6000, "pitch"] = 95.0
        return df
    _spoil(folder, "truth", "parquet", edit)
    return folder


def test_a_bad_truth_row_late_in_the_table(drive, tmp_path):
    folder = _bad_truth_bundle(drive, tmp_path)
    expected = _message(lambda: read_bundle(folder))
    s = open_bundle(folder, chunk_rows=1000)
    assert _message(lambda: s.truth.reduced(np.arange(0.0, 70.0))) == expected
    assert "row 6001" in expected


@pytest.mark.parametrize("kind,method", [("navigate", "sins-dr"), ("align", "od-velocity-kf")])
def test_cli_bad_row_in_chunk_3_exit_2_nothing_written(drive, tmp_path, monkeypatch, kind,
                                                       method):
    """Through the command line: exit 2, one line naming file, row and time, no result (the
    row read and checked in the reader thread of sins-dr and od-velocity-kf)."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")

    def edit(df):
        df.loc[2499, "dvel_x"] = np.inf
        return df
    _spoil(folder, "imu", "parquet", edit)
    monkeypatch.setattr(bundle_stream, "CHUNK_ROWS", 1000)
    out = tmp_path / "r"
    r = CliRunner().invoke(cli, ["-q", kind, str(folder), "-m", method, "-o", str(out)])
    assert r.exit_code == 2
    err = r.stderr if hasattr(r, "stderr") else r.output
    line = [x for x in err.splitlines() if x.startswith("inmotion: error:")]
    assert len(line) == 1 and "imu.parquet, row 2500, t=24.99" in line[0], err
    assert not out.exists() and not list(tmp_path.glob(".r*"))


@pytest.mark.parametrize("args", [["-m", "sins-dr", "--mode", "velocity-position"],
                                  ["-m", "sins", "--start", "10", "--end", "61.5"],
                                  ["-m", "dr-kf", "--start", "12", "--output-rate", "2"],
                                  ["-m", "od-velocity-kf", "--output-rate", "1"]])
def test_cli_chunked_result_equals_whole(drive, tmp_path, monkeypatch, args):
    """The files ``inmotion navigate`` / ``align`` write when it reads the bundle in chunks
    equal those it writes when it reads the bundle whole (the reader it uses for every other
    method), windows and output rates included."""
    import inmotion.cli.main as cli_main
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")
    monkeypatch.setattr(bundle_stream, "CHUNK_ROWS", 777)
    kind = "align" if ("dr-kf" in args or "od-velocity-kf" in args) else "navigate"
    for out, streamed in (("r", cli_main.STREAMED), ("w", ())):
        monkeypatch.setattr(cli_main, "STREAMED", streamed)
        r = CliRunner().invoke(cli, ["-q", kind, str(folder), *args, "-o", str(tmp_path / out)])
        assert r.exit_code == 0, r.output
    for f in ("solution.csv", "states.csv", "errors.csv"):
        if (tmp_path / "w" / f).exists():
            assert (tmp_path / "r" / f).read_bytes() == (tmp_path / "w" / f).read_bytes(), f


@pytest.mark.parametrize("first", [2950, 5930])
def test_a_sustained_turn_across_chunks_is_named(drive, tmp_path, first):
    """A turn at 3.5 rad/s for 1.2 s (over the 3 rad/s limit for a whole second, each row far
    under the 50 rad/s row limit) across a chunk boundary: the chunked reader computes the
    window rates there (its shortcut, no row turning faster than 0.99 of the limit, does not
    hold) and gives read_bundle's message, row and time."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")

    def edit(df):
        df.loc[first:first + 119, "dtheta_z"] = 3.5 * 0.01
        return df
    _spoil(folder, "imu", "parquet", edit)
    expected = _message(lambda: read_bundle(folder))
    assert "turn rate over one second" in expected
    assert _message(lambda: _stream_run(folder)) == expected


def test_row_spikes_under_the_row_limit_are_no_sustained_turn(drive, tmp_path):
    """Single rows at 5 rad/s (vibration: above the sustained limit, under the row limit)
    every 40 rows: no second averages 3 rad/s, and neither reader refuses the bundle (the
    chunked reader computes the window rates of those chunks)."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")

    def edit(df):
        df.loc[1000:4000:40, "dtheta_x"] = 5.0 * 0.01
        return df
    _spoil(folder, "imu", "parquet", edit)
    read_bundle(folder)
    _stream_run(folder)


def test_row_norm_is_numpys_norm_bit_for_bit():
    from inmotion.io.bundle import row_norm
    rng = np.random.default_rng(4)
    x = rng.standard_normal((200000, 3)) * 10.0 ** rng.integers(-8, 8, (200000, 3))
    ref = np.linalg.norm(x, axis=1)
    np.testing.assert_array_equal(row_norm(x), ref)
    np.testing.assert_array_equal(row_norm(*(np.ascontiguousarray(c) for c in x.T)), ref)
    # the three squares summed in another order differ: the test can tell
    s = x * x
    assert not np.array_equal(np.sqrt(s[:, 0] + (s[:, 1] + s[:, 2])), ref)


def test_wrap_pi_shortcut_is_rotations_wrap_pi():
    from inmotion.core.rotations import wrap_pi
    rng = np.random.default_rng(5)
    for x in (rng.normal(0, 1e-4, 100000), rng.uniform(-np.pi, np.pi, 100000),
              rng.uniform(-20, 20, 100000), np.array([-np.pi, np.pi, 0.0, -0.0, 1e-300])):
        np.testing.assert_array_equal(bundle_stream._wrap_pi(x), wrap_pi(x))


# ------------------------------------------------------------------ the IMU reader thread

def test_read_ahead_gives_the_items_in_order_from_another_thread_bounded():
    """read_ahead yields what the iterator yields, in order, produced in a reader thread
    never more than ``depth`` items beyond those the consumer has taken (memory: the item in
    use and ``depth`` more), and the thread has ended when the items have (a live thread
    would cost the command line its fast exit)."""
    import threading
    import time
    produced, threads = [], set()

    def gen():
        for i in range(20):
            threads.add(threading.get_ident())
            produced.append(i)
            yield i

    r = bundle_stream.read_ahead(gen(), depth=2)
    got, ahead = [], []
    for x in r:
        got.append(x)
        time.sleep(0.002)                      # the reader fills the queue meanwhile
        ahead.append(len(produced) - len(got))
    assert got == list(range(20))
    assert threads and threading.get_ident() not in threads
    assert 1 <= max(ahead) <= 2                # read ahead, but no further than depth
    assert r._thread is not None and not r._thread.is_alive()
    assert list(r) == []                       # exhausted stays exhausted


def test_read_ahead_raises_the_readers_exception_at_its_place():
    """Items before the failure arrive first; then the consumer gets the reader's exception
    itself (the same BadInput: message, file, row, time), and the thread has ended."""
    def gen():
        yield 1
        yield 2
        raise BadInput("column 'dvel_x': value inf is not a finite number", file="imu.parquet",
                       row=2500, time=24.99)

    r = bundle_stream.read_ahead(gen())
    assert next(r) == 1 and next(r) == 2
    with pytest.raises(BadInput) as e:
        next(r)
    assert (e.value.what, e.value.row, e.value.time) == (
        "column 'dvel_x': value inf is not a finite number", 2500, 24.99)
    assert str(e.value) == str(BadInput("column 'dvel_x': value inf is not a finite number",
                                        file="imu.parquet", row=2500, time=24.99))
    assert not r._thread.is_alive()


def test_read_ahead_close_stops_the_reader_and_closes_its_iterator():
    closed = []

    def gen():
        try:
            for i in range(10 ** 6):
                yield i
        finally:
            closed.append(True)

    r = bundle_stream.read_ahead(gen(), depth=1)
    assert next(r) == 0
    r.close()
    assert not r._thread.is_alive() and closed == [True]
    with pytest.raises(StopIteration):
        next(r)
    bundle_stream.read_ahead(gen()).close()     # never started: nothing to stop


def test_sins_dr_stopped_early_leaves_no_reader_thread(folder):
    """A run that ends before its rows do (``select`` says stop) or fails in the filter's
    thread stops the reader: no thread is left behind."""
    import threading
    s = open_bundle(folder, chunk_rows=500)
    before = threading.active_count()
    run_sins_dr(s, {"output_rate_hz": 1.0}, NavState.from_truth(s.truth),
                select=lambda t, sig: (np.ones(len(t), bool), True))
    assert threading.active_count() == before
    with pytest.raises(BadInput):
        run_sins_dr(s, {"output_rate_hz": 1.0}, NavState.from_truth(s.truth),
                    progress=lambda f: (_ for _ in ()).throw(BadInput("stop here")))
    assert threading.active_count() == before


_TRUTH_FIELDS = ("t", "lat", "lon", "h", "vel_n", "euler", "path_length_m")


def _same_truth(a, b):
    for f in _TRUTH_FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype, f
        np.testing.assert_array_equal(x, y, err_msg=f)


def test_truth_reducer_gives_reduced(drive, tmp_path):
    """``TruthReducer`` (the truth rows read in a thread while the run feeds its output times,
    issue 13) returns ``TruthStream.reduced``'s arrays exactly: output times fed in uneven
    pieces across the 700-row chunks and the yaw wrap, the result asked for them or for a
    subset (a thinned output), in a window, and (by ``reduced`` itself) for times fed out of
    order or not fed."""
    folder = tmp_path / "b"
    write_bundle(drive, folder, fmt="parquet")
    whole = read_bundle(folder)
    t_imu = whole.imu.t
    t_out = np.r_[t_imu[0], t_imu[10::10], t_imu[-1]]           # 10 Hz and the last row

    def fed(stream, times, cuts, ask=None, fell_back=False):
        r = stream.truth.reducer()
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(times)]):
            r.feed(times[a:b])
        try:
            return r.result(times if ask is None else ask)
        finally:
            r.close()
            assert r.fell_back == fell_back     # its own rows, or reduced's answer

    s = open_bundle(folder, chunk_rows=700)
    cuts = [1, 5, 6, 200, 201, 555]
    _same_truth(fed(s, t_out, cuts), s.truth.reduced(t_out))
    sub = t_out[::7]                                            # thinned
    _same_truth(fed(s, t_out, cuts, ask=sub), s.truth.reduced(sub))
    w = s.window(20.0, 60.0)
    tw = t_out[(t_out >= 20.0) & (t_out <= 60.0)]
    got = fed(w, tw, [3, 100])
    assert got.t[0] >= 20.0 and got.t[-1] <= 60.0
    _same_truth(got, w.truth.reduced(tw))
    t_tr = whole.truth.t
    for k0 in (698, 699, 700, 1399):           # windows starting 2, 1, 0 rows before a chunk's end
        w = s.window(t_tr[k0], t_tr[k0 + 900])
        # 10 Hz, and times before the window's first row and after its last (clipped rows)
        tw = np.r_[t_tr[k0] - 0.5, t_tr[k0] - 0.001, t_out[(t_out >= t_tr[k0])
                                                          & (t_out <= t_tr[k0 + 900])],
                   t_tr[k0 + 900] + 0.3]
        for cuts_w in ([1], [2, 3, 40], [60]):
            _same_truth(fed(w, tw, cuts_w), w.truth.reduced(tw))
        _same_truth(fed(w, tw, [5], ask=tw[1::4]), w.truth.reduced(tw[1::4]))
    shuffled = t_out[np.r_[100:200, 0:100, 200:len(t_out)]]     # out of order: reduced's
    _same_truth(fed(s, shuffled, [100, 200], ask=t_out, fell_back=True),
                s.truth.reduced(t_out))
    more = np.r_[t_out, t_imu[-5]]                              # rows not asked for by the feed
    _same_truth(fed(s, t_out[:300], [150], ask=np.sort(more), fell_back=True),
                s.truth.reduced(np.sort(more)))
    r = s.truth.reducer()                                       # closed mid-run: thread ends
    r.feed(t_out[:50])
    r.close()
    import threading
    assert not [th for th in threading.enumerate() if th.name == "inmotion-truth"]


def test_cli_bad_truth_row_read_in_the_thread_exit_2(drive, tmp_path, monkeypatch):
    """A bad truth row found by the reducer's thread while ``navigate`` runs: exit 2, one line
    with read_bundle's message (file, row, time), nothing written; the thread was used."""
    folder = _bad_truth_bundle(drive, tmp_path)
    expected = _message(lambda: read_bundle(folder))
    monkeypatch.setattr(bundle_stream, "CHUNK_ROWS", 1000)
    threads = []
    run = bundle_stream.TruthReducer._run

    def spy(self):
        import threading
        threads.append(threading.current_thread().name)
        run(self)
    monkeypatch.setattr(bundle_stream.TruthReducer, "_run", spy)
    out = tmp_path / "r"
    r = CliRunner().invoke(cli, ["-q", "navigate", str(folder), "-m", "sins-dr", "-o", str(out)])
    assert r.exit_code == 2
    err = r.stderr if hasattr(r, "stderr") else r.output
    line = [x for x in err.splitlines() if x.startswith("inmotion: error:")]
    assert line == [f"inmotion: error: {expected}"], err
    assert threads == ["inmotion-truth"]
    assert not out.exists() and not list(tmp_path.glob(".r*"))
