"""The paper 003 fine filters on a bundle read in chunks give what they give on it in memory.

Issue 13: ``od-kf``, ``ldv-kf``, ``nhc-kf`` and ``fkf`` feed the engine chunk by chunk
(:func:`inmotion.align.aided_kf._feed`); from a bundle read in chunks they read only the rows
of their window, a chunk at a time as they are fed
(:meth:`inmotion.io.bundle_stream.BundleStream.imu_rows_in_window`), and the 100 Hz LDV is
resampled chunk by chunk from disk. The reference is the other reader: :func:`read_bundle`
loads the tables whole and the filter takes the window as one piece. The streamed run, with
chunks of a few dozen rows, must give the same solution and summary bit for bit without
loading its window (``load_window`` is made to fail), for windows that start after the log's
first row (the window's rows counted from its own first row).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.align import aided_kf as ak
from inmotion.cli.main import cli
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.io import bundle_stream
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.bundle_stream import SpeedStream, open_bundle
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario
from stream_checks import assert_same_solution, refuse_window_loads

#: a short drive (~2 min) with turns and a stop, an odometer at 10 Hz and an LDV at 100 Hz
#: giving distance (its table longer than a chunk: it stays on disk), a barometer
DRIVE = {
    "name": "aided_stream",
    "start": {"lat_deg": 39.9, "lon_deg": 116.4, "h_m": 50.0, "heading_deg": 60.0},
    "vehicle_mounting_arcmin": [10.0, 0.0, 15.0],
    "segments": [{"kind": "rest", "duration_s": 5.0},
                 {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 20.0},
                 {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                 {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 8},
                 {"kind": "accelerate", "to_speed_m_s": 12.0, "accel_m_s2": 1.0},
                 {"kind": "turn", "angle_deg": -60, "rate_deg_s": 4},
                 {"kind": "cruise", "duration_s": 20.0}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.005, "arw_deg_sqrt_h": 0.0005},
            "accel": {"bias_ug": 50.0, "vrw_ug_sqrt_hz": 5.0}},
    "sensors": {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0,
                             "scale_factor_sigma_ppm": 2000.0,
                             "lever_arm_m": [-0.8, -1.5, -0.9]},
                "ldv": {"rate_hz": 100.0, "output": "distance",
                        "scale_factor_sigma_ppm": 500.0, "noise_m_s": 0.01,
                        "lever_arm_m": [0.3, 1.2, -0.6]},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}

#: rows per chunk of the reader (the LDV's 100 Hz table is longer: it stays on disk)
CHUNK = 37


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    p = tmp_path_factory.mktemp("aided_stream") / "bundle"
    write_bundle(simulate(load_scenario(DRIVE), np.random.default_rng(7)), p, fmt="parquet")
    return p


@pytest.fixture
def no_load(monkeypatch):
    """Engine chunks of 300 rows, and a bundle read in chunks that refuses to load a window."""
    monkeypatch.setattr(ak, "CHUNK_ROWS", 300)

    refuse_window_loads(monkeypatch)


#: method -> (run, configuration): each of the four, the fkf bank and a single filter with
#: its NHC fallback smoothed (the central filter fed a second time), zero-velocity updates
CASES = {
    "od-kf": (ak.run_od_kf, {}),
    "ldv-kf velocity form": (ak.run_ldv_kf, {"measurement": "velocity"}),
    "nhc-kf": (ak.run_nhc_kf, {}),
    "fkf": (ak.run_fkf, {}),
    "fkf smoothed": (ak.run_fkf, {"smooth": True}),
    "od-kf fallback smoothed, stops": (ak.run_od_kf, {"smooth": True, "nhc_fallback": True,
                                                      "stops_s": [[50.0, 55.0]]}),
    "nhc-kf smoothed": (ak.run_nhc_kf, {"smooth": True}),
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("window", [(6.0, 90.0), (12.345, None)])
def test_fine_filter_in_chunks_equals_whole(folder, no_load, case, window):
    run, cfg = CASES[case]
    whole = read_bundle(folder).window(*window)
    stream = open_bundle(folder, chunk_rows=CHUNK).window(*window)
    assert isinstance(stream.ldv, SpeedStream)
    n = len(whole.imu.t)
    assert n == len(stream.imu.t) and n > 5000
    init = NavState.from_truth(whole.truth, window[0])
    a, b = run(whole, cfg, init), run(stream, cfg, init)
    assert_same_solution(a, b)
    # the filter ran to the window's end (its outputs every output_interval_s = 1 s)
    assert whole.imu.t[-1] - 1.0 < a.t[-1] <= whole.imu.t[-1]


def test_only_the_window_is_read_and_checked(folder, tmp_path):
    """A NaN in the IMU table at row 9001 (t = 90 s): ``fkf`` over a window that ends
    before it runs (the row is neither read nor checked, as ``load_window`` reads a
    window) and gives the clean bundle's result; over a window holding it, it stops with
    :func:`read_bundle`'s message, the row counted over the whole table."""
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
    ref_bundle = read_bundle(folder)
    init = NavState.from_truth(ref_bundle.truth, 20.0)
    ok = ak.run_fkf(stream.window(20.0, 85.0), {}, init)
    assert_same_solution(ok, ak.run_fkf(ref_bundle.window(20.0, 85.0), {}, init))
    with pytest.raises(BadInput) as e:
        ak.run_fkf(stream.window(20.0, 95.0), {}, init)
    with pytest.raises(BadInput) as e_whole:
        read_bundle(bad)
    assert str(e.value) == str(e_whole.value) and f"row {row}, t=" in str(e.value)


@pytest.mark.parametrize("args", [["-m", "fkf", "--start", "12"],
                                  ["-m", "od-kf", "--start", "6", "--end", "90",
                                   "--output-rate", "2"],
                                  ["-m", "ldv-kf", "--set", "smooth=true", "--start", "6"],
                                  ["-m", "nhc-kf", "--start", "30"]])
def test_cli_fine_filters_in_chunks(folder, tmp_path, monkeypatch, args):
    """``inmotion align`` writes, reading the bundle in chunks, the files it writes reading
    the window into memory (``load_window``), byte for byte."""
    import inmotion.cli.main as cli_main
    monkeypatch.setattr(bundle_stream, "CHUNK_ROWS", 777)
    assert args[1] in cli_main.STREAMED
    for out, streamed in (("r", cli_main.STREAMED), ("w", ())):
        monkeypatch.setattr(cli_main, "STREAMED", streamed)
        r = CliRunner().invoke(cli, ["-q", "align", str(folder), *args, "--init", "truth",
                                     "-o", str(tmp_path / out)])
        assert r.exit_code == 0, r.output
    for f in ("solution.csv", "states.csv", "errors.csv", "events.csv"):
        assert (tmp_path / "r" / f).exists() == (tmp_path / "w" / f).exists(), f
        if (tmp_path / "w" / f).exists():
            assert (tmp_path / "r" / f).read_bytes() == (tmp_path / "w" / f).read_bytes(), f
    assert (tmp_path / "w" / "solution.csv").exists()
