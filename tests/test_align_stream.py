"""The batch alignments on a bundle read in chunks give what they give on the bundle in memory.

Issue 13: the coarse alignments (``coarse-inertial``, the IMADA family, ``oba``) integrate
their observation vectors block by block over their window
(:func:`inmotion.align.obs_vectors.integrate_vector_blocks`, the rows read from the file as
they are taken: :func:`inmotion.align.attitude_determination.prepare`), and ``adaptive``'s
parked stage passes its windows to ``coarse-inertial`` and ``parked-kf`` unloaded. The
reference is the other reader: :func:`read_bundle` loads the tables whole and the kernel takes
the window as one block. The streamed run, with chunks of a few dozen rows and kernel blocks
of 10 rows (every interval's two rows cut apart somewhere), must give the same solution and
the same summary bit for bit, and must not load its window (``load_window`` is made to fail).
"""
from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from inmotion.align import coarse_inertial as ci
from inmotion.align import imada
from inmotion.align import obs_vectors as ov
from inmotion.cli.main import cli
from inmotion.core.solution import NavState
from inmotion.io import bundle_stream
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.bundle_stream import open_bundle
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario
from stream_checks import assert_same_solution, refuse_window_loads

#: parked 40 s (the adaptive strategy's parked stage), then a drive with a turn (~100 s)
DRIVE = {
    "name": "park_then_drive",
    "start": {"lat_deg": 39.9, "lon_deg": 116.4, "h_m": 50.0, "heading_deg": 60.0},
    "segments": [{"kind": "rest", "duration_s": 40.0},
                 {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 25.0},
                 {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                 {"kind": "cruise", "duration_s": 17.0}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.002},
            "accel": {"bias_ug": 50.0, "vrw_ug_sqrt_hz": 5.0}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.05},
                "odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0,
                             "scale_factor_sigma_ppm": 2000.0}}}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    p = tmp_path_factory.mktemp("align_stream") / "bundle"
    write_bundle(simulate(load_scenario(DRIVE), np.random.default_rng(5)), p, fmt="parquet")
    return p


@pytest.fixture
def no_load(monkeypatch):
    """Small kernel blocks, and a bundle read in chunks that refuses to load a window."""
    monkeypatch.setattr(ov, "BLOCK_ROWS", 10)

    refuse_window_loads(monkeypatch)


#: method -> (run, config, window): windows of an odd and an even number of rows (the last
#: interval one row or two), the radar's speed samples and the odometer's distance increments
CASES = {
    "imada-vb": (imada.run_imada_vb, imada.ImadaConfig(), (45.0, 109.995)),
    "imada-vn fading": (imada.run_imada_vn,
                        imada.ImadaConfig(fading_time_constant_s=20.0, output_interval_s=0.37,
                                          velocity_sensor="odometer"), (45.0, None)),
    "imada-dual": (imada.run_imada_dual, imada.ImadaConfig(center_vectors=False),
                   (41.3, 120.0)),
    "oba": (imada.run_oba, imada.ImadaConfig(update_interval_s=0.5), (45.0, None)),
    "mimada": (imada.run_mimada, imada.MimadaConfig(), (45.0, None)),
    "mimada-dual": (imada.run_mimada_dual, imada.MimadaConfig(levels=3), (45.0, 113.995)),
    "coarse-inertial moving": (ci.run_coarse_inertial, ci.CoarseInertialConfig(),
                               (None, None)),
    "coarse-inertial parked": (ci.run_coarse_inertial,
                               ci.CoarseInertialConfig(mode="parked",
                                                       lowpass_time_constant_s=None),
                               (0.5, 38.995)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_batch_alignment_in_chunks_equals_whole(folder, no_load, case):
    run, cfg, window = CASES[case]
    whole = read_bundle(folder).window(*window)
    stream = open_bundle(folder, chunk_rows=37).window(*window)
    n = len(whole.imu.t)
    assert n == len(stream.imu.t) and n > 1000
    a, b = run(whole, cfg), run(stream, cfg)
    assert_same_solution(a, b)
    # and every row of the window was integrated: the last epoch is the window's last row
    assert a.t[-1] == whole.imu.t[-1] and a.info["quality"]["n_vector_pairs"] == n // 2


def test_row_counts_of_the_windows_differ_in_parity(folder):
    """The cases above end on a two-row interval and on a one-row interval."""
    b = read_bundle(folder)
    parities = {len(b.window(*w).imu.t) % 2 for _, _, w in CASES.values()}
    assert parities == {0, 1}


def test_adaptive_parked_stage_streams(folder, no_load):
    """``adaptive`` on a drive parked 40 s (Strategy 1: parked coarse + parked-kf, then the
    in-motion fine filter): the parked stage reads its windows in chunks, and the result is
    the in-memory one."""
    from inmotion.align.strategy import run_adaptive
    cfg = {"parked_coarse_s": 20.0}
    whole, stream = read_bundle(folder), open_bundle(folder, chunk_rows=37)
    init = NavState.from_truth(whole.truth)
    a, b = run_adaptive(whole, cfg, init), run_adaptive(stream, cfg, init)
    assert a.info["strategy"].startswith("1:") and a.info["switch_time_s"] is not None
    assert_same_solution(a, b)


@pytest.mark.parametrize("args", [["-m", "imada-vb", "--start", "45"],
                                  ["-m", "coarse-inertial", "--output-rate", "2"],
                                  ["-m", "parked-kf", "--init", "truth", "--end", "38"],
                                  ["-m", "parked-kf", "--init", "truth", "--start", "5.005",
                                   "--end", "38"]])
def test_cli_align_to_the_end_in_chunks(folder, tmp_path, monkeypatch, args):
    """``inmotion align`` with no ``--end`` writes, reading the bundle in chunks, the files it
    writes reading it whole."""
    import inmotion.cli.main as cli_main
    monkeypatch.setattr(bundle_stream, "CHUNK_ROWS", 777)
    assert args[1] in cli_main.STREAMED
    for out, streamed in (("r", cli_main.STREAMED), ("w", ())):
        monkeypatch.setattr(cli_main, "STREAMED", streamed)
        r = CliRunner().invoke(cli, ["-q", "align", str(folder), *args, "-o",
                                     str(tmp_path / out)])
        assert r.exit_code == 0, r.output
    for f in ("solution.csv", "states.csv", "errors.csv"):
        assert (tmp_path / "r" / f).exists() == (tmp_path / "w" / f).exists(), f
        if (tmp_path / "w" / f).exists():
            assert (tmp_path / "r" / f).read_bytes() == (tmp_path / "w" / f).read_bytes(), f


@pytest.mark.parametrize("method", ["imada-vb", "usque"])
def test_window_rows_only_are_read_and_checked(folder, tmp_path, method):
    """A NaN at row 9001 (t = 90 s): the method over a window that ends before it runs
    (the row is neither read nor checked, as ``load_window`` reads a window), one holding it
    stops with read_bundle's message, the row counted over the whole table."""
    from inmotion.registry import get
    run, Cfg = get(method).load()
    import pandas as pd
    from inmotion.errors import BadInput
    bad = tmp_path / "bad"
    bad.mkdir()
    for f in folder.iterdir():
        (bad / f.name).write_bytes(f.read_bytes())
    p = bad / "imu.parquet"
    df = pd.read_parquet(p)
    row = 9001
    df.loc[row - 1, "dtheta_y"] = np.nan
    df.to_parquet(p, index=False, row_group_size=2048)
    stream = open_bundle(bad, chunk_rows=500)
    ok = run(stream.window(45.0, 85.0), Cfg())
    ref = run(read_bundle(folder).window(45.0, 85.0), Cfg())
    assert_same_solution(ok, ref)
    with pytest.raises(BadInput) as e:
        run(stream.window(45.0, 95.0), Cfg())
    with pytest.raises(BadInput) as e_whole:
        read_bundle(bad)
    assert str(e.value) == str(e_whole.value) and f"row {row}, t=" in str(e.value)


@pytest.fixture
def small_usque_blocks(monkeypatch):
    from inmotion.align import usque
    monkeypatch.setattr(usque, "BLOCK_ROWS", 7)     # strides of 1 and 3 rows cut anywhere


@pytest.mark.parametrize("cfg", [{}, {"noise_preset": "paper", "update_rate_hz": 30.0},
                                 {"output_interval_s": 0.35},
                                 {"noise_preset": "paper", "vectors": "obs_vectors"},
                                 {"noise_preset": "paper", "vectors": "obs_vectors",
                                  "output_interval_s": 0.5}])
@pytest.mark.parametrize("method", ["usque", "ausquhe"])
def test_usque_in_chunks_equals_whole(folder, no_load, small_usque_blocks, method, cfg):
    """The USQUE filters take their rows block by block (the filter carried across blocks of
    7 rows, the bundle read in chunks of 37): the solution of the bundle in memory."""
    from inmotion.registry import get
    run, Cfg = get(method).load()
    window = (45.0, 100.0)
    whole = read_bundle(folder).window(*window)
    stream = open_bundle(folder, chunk_rows=37).window(*window)
    assert_same_solution(run(whole, Cfg(**cfg)), run(stream, Cfg(**cfg)))


@pytest.mark.parametrize("stride_hz, interval, vectors",
                         [(100.0, 0.35, "own"), (30.0, 1.0, "own"), (100.0, 0.01, "own"),
                          (100.0, 0.3, "obs_vectors")])
def test_usque_output_interval_keeps_the_rows_of_every_epoch(folder, stride_hz, interval,
                                                             vectors):
    """``output_interval_s``: the rows of the run that keeps every update epoch, every k-th
    (k = round(interval / update interval)) and the last, nothing else changed."""
    from inmotion.align import usque
    b = read_bundle(folder).window(45.0, 100.0)
    base = {"update_rate_hz": stride_hz, "vectors": vectors}
    if vectors == "obs_vectors":
        base["noise_preset"] = "paper"              # (its attitude-only state)
    every = usque.run(b, usque.UsqueConfig(**base))
    some = usque.run(b, usque.UsqueConfig(**base, output_interval_s=interval))
    n = len(every.t) - 1                       # update epochs (row 0 is the start)
    k = max(1, round(interval / float(np.median(np.diff(every.t)))))
    keep = np.r_[0, np.arange(k, n + 1, k)]
    if keep[-1] != n:
        keep = np.r_[keep, n]
    assert len(some.t) == len(keep) and (k == 1 or len(keep) < len(every.t) / (k - 1) + 2)
    for f in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_array_equal(getattr(some, f), getattr(every, f)[keep], err_msg=f)
    for d1, d2 in ((some.sigma, every.sigma), (some.states, every.states)):
        for key in d2:
            np.testing.assert_array_equal(d1[key], d2[key][keep], err_msg=key)


@pytest.mark.parametrize("rate_hz, update_hz", [(2.0, 100.0), (0.5, 100.0), (2.0, 30.0)])
def test_usque_output_interval_is_the_thinned_every_epoch_run(folder, rate_hz, update_hz):
    """``--output-rate`` sets a USQUE filter's ``output_interval_s`` (it writes every update
    epoch unless told): its rows are those :func:`inmotion.io.result.thin` keeps of the
    every-epoch run, so the command line's result is unchanged, without the other rows held."""
    from inmotion.align import usque
    from inmotion.cli.main import apply_output_rate
    from inmotion.io.result import thin
    b = read_bundle(folder).window(45.0, 100.0)
    base = usque.AusquheConfig(update_rate_hz=update_hz)
    cfg, thin_rate = apply_output_rate(base, b, rate_hz, True)
    assert thin_rate == rate_hz
    # on the rate's grid (100 Hz updates) the interval is set; off it (30 Hz updates, a
    # 0.5 s step is 16.7 updates) every epoch is kept and thinned as before
    assert cfg.output_interval_s == (1.0 / rate_hz if update_hz == 100.0 else None)
    some, every = usque.run(b, cfg), usque.run(b, base)
    assert len(some.t) < len(every.t) / 40 or update_hz != 100.0
    assert_same_solution(thin(some, thin_rate), thin(every, rate_hz), skip=("config",))
    # a method with an output interval of its own (imada: 1 s) keeps it
    from inmotion.align.imada import ImadaConfig
    assert apply_output_rate(ImadaConfig(), b, rate_hz, True)[0].output_interval_s == 1.0


@pytest.mark.parametrize("bad_row", [None, 0, 1, 23, 57])
def test_usque_covariances_checked_block_by_block(bad_row):
    """The USQUE outputs keep of each row's covariance only its attitude block and check
    positive definiteness block by block as the kernel writes them (``_Outputs.block`` /
    ``commit``): the verdict of checking every row at once (:func:`usque._positive_definite`
    of the whole stack), the attitude blocks those of the stack; one indefinite row (its
    states 0 and 1 correlated beyond 1) anywhere, in the start row, in a block's first or
    middle row or the last, makes it False."""
    from inmotion.align import usque
    layout = usque._Filter(usque.UsqueConfig(estimate_accel_bias=True)).layout
    n, rows = layout.n, 58
    rng = np.random.default_rng(3)
    A = rng.normal(size=(rows, n, n))
    units = 10.0 ** rng.uniform(-6, 2, n)                 # states of very different units
    P = (A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(n)) * units[:, None] * units[None, :]
    if bad_row is not None:
        P[bad_row, 0, 1] = P[bad_row, 1, 0] = 1.5 * np.sqrt(P[bad_row, 0, 0] * P[bad_row, 1, 1])
    expected = usque._positive_definite(P)
    assert expected == (bad_row is None)
    out = usque._Outputs(rows, layout)
    out.set_P(0, P[0])
    done = 0
    for size in (9, 1, 30, 17):                # epochs per block, every 2nd one written
        slot = usque._slots(done, 2 * size, 2 * (rows - 1), 2)
        rel, buf, *_ = out.block(slot)
        w = slot >= 0
        buf[rel[w]] = P[slot[w]]                # what the kernel writes
        out.commit()
        done += 2 * size
    assert done == 2 * (rows - 1)
    assert out.pd == expected
    np.testing.assert_array_equal(out.P_att, P[:, layout["dR"], layout["dR"]])
