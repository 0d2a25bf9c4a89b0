"""A command-line run imports neither pandas nor scipy.stats (issue 13, "a CLI run's fixed
cost"): the result is written from numpy columns with pyarrow and a Parquet bundle read with
pyarrow alone. (numba itself imports ``scipy.linalg`` when it builds its CPU target, to probe
scipy's BLAS: numba 0.68 has no setting for it, and the project does not patch numba's
internals to skip it.) The files are the ones the pandas route
wrote: CSV byte for byte, Parquet the same columns and values.
"""
import subprocess
import sys

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from inmotion.core.bundle import Bundle, ImuData, SpeedData
from inmotion.core.earth import G0
from inmotion.io.bundle import arrow_to_numpy, numpy_to_arrow, read_bundle, write_bundle, write_csv


def _bundle(seconds=6.0, rate=100.0):
    """A vehicle at rest, level, heading north (IMU, radar at 10 Hz), without truth."""
    n = int(seconds * rate) + 1
    t = np.arange(n) / rate
    dvel = np.zeros((n, 3))
    dvel[:, 2] = G0 / rate
    imu = ImuData(t, np.zeros((n, 3)), dvel)
    ts = t[::10]
    meta = {"name": "rest",
            "initial_position": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380.0},
            "initial_attitude": {"pitch_deg": 0.0, "roll_deg": 0.0, "yaw_deg": 0.0}}
    return Bundle(imu=imu, radar=SpeedData(ts, v=np.zeros(len(ts))), meta=meta)


def _modules_after_cli(args):
    code = ("import sys\nsys.argv = ['inmotion', *%r]\nfrom inmotion.cli.main import main\n"
            "try:\n    main()\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            "print('MODULES', ' '.join(sys.modules))" % (list(args),))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    return set(out.stdout.rsplit("MODULES", 1)[1].split())


@pytest.mark.parametrize("method,fmt", [("sins-dr", "csv"), ("sins", "parquet")])
def test_navigate_imports_no_pandas_no_scipy_stats(tmp_path, method, fmt):
    bundle = tmp_path / "b"
    write_bundle(_bundle(), bundle, fmt="parquet")
    out = tmp_path / "out"
    mods = _modules_after_cli(["-q", "navigate", str(bundle), "--method", method, "--init",
                               "meta", "-o", str(out), "--format", fmt])
    assert (out / f"solution.{fmt}").is_file() and (out / "summary.json").is_file()
    # it ran compiled code: numba's, or the ahead-of-time extension's (inmotion._aot)
    assert "numba" in mods or any(m.startswith("inmotion_aot_") for m in mods)
    for heavy in ("pandas", "scipy.stats", "pyarrow.dataset"):
        assert heavy not in mods, f"inmotion navigate --method {method} imports {heavy}"


def test_read_bundle_parquet_without_pandas_gives_what_pandas_gave(tmp_path):
    write_bundle(_bundle(), tmp_path / "b", fmt="parquet")
    code = ("import sys\nfrom inmotion.io.bundle import read_bundle\n"
            f"b = read_bundle({str(tmp_path / 'b')!r})\n"
            "print('pandas' in sys.modules, b.imu.t.flags.writeable)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["False", "True"]
    b = read_bundle(tmp_path / "b")
    df = pd.read_parquet(tmp_path / "b" / "imu.parquet")
    assert np.array_equal(b.imu.t, df["t"].to_numpy(float))
    assert np.array_equal(b.imu.dvel[:, 2], df["dvel_z"].to_numpy(float))
    assert np.array_equal(b.radar.v, pd.read_parquet(tmp_path / "b" / "radar.parquet")["v"])


def test_a_bad_parquet_value_is_named_as_before(tmp_path):
    write_bundle(_bundle(), tmp_path / "b", fmt="parquet")
    p = tmp_path / "b" / "radar.parquet"
    tab = pq.read_table(p)
    v = tab.column("v").to_pylist()
    v[3] = None
    pq.write_table(tab.set_column(tab.column_names.index("v"), "v", pa.array(v)), p)
    from inmotion.errors import BadInput
    with pytest.raises(BadInput, match=r"column 'v': value NaN or empty is not a finite number"
                       ) as e:
        read_bundle(tmp_path / "b")
    assert "row 4" in str(e.value)


def test_columns_written_from_numpy_are_the_files_pandas_wrote(tmp_path):
    """write_csv / the Parquet writer of a result on ordered numpy columns give the bytes
    (CSV) and the table (Parquet, less pandas' schema note) of the same columns as a
    DataFrame: NaN as an empty field / null, shortest round-trip floats, ints, booleans,
    strided columns."""
    rng = np.random.default_rng(3)
    m = rng.normal(size=(50, 3)) * 10.0 ** rng.integers(-12, 12, size=(50, 3))
    x = m[:, 1].copy()
    x[[0, 7, 49]] = np.nan
    cols = {"t": np.arange(50) / 100.0, "a": m[:, 0], "b": x, "n": np.arange(50) - 20,
            "flag": rng.random(50) > 0.5, "tiny": np.full(50, 5e-324)}
    write_csv(cols, tmp_path / "np.csv")
    write_csv(pd.DataFrame(cols), tmp_path / "pd.csv")
    assert (tmp_path / "np.csv").read_bytes() == (tmp_path / "pd.csv").read_bytes()
    back = pd.read_csv(tmp_path / "np.csv")
    assert np.array_equal(back["a"].to_numpy(), m[:, 0])        # round trip, bit for bit
    assert back["b"].isna().sum() == 3
    from inmotion.io.bundle import arrow_table
    pq.write_table(arrow_table(cols), tmp_path / "np.parquet")
    pd.DataFrame(cols).to_parquet(tmp_path / "pd.parquet", index=False)
    a, b = pd.read_parquet(tmp_path / "np.parquet"), pd.read_parquet(tmp_path / "pd.parquet")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert pq.read_schema(tmp_path / "np.parquet").equals(
        pq.read_schema(tmp_path / "pd.parquet").remove_metadata())


def test_arrow_numpy_views_match_pyarrow_conversions():
    for arr in (pa.array(np.linspace(0, 1, 11)), pa.array(np.arange(-5, 6, dtype=np.int32)),
                pa.array(np.arange(9, dtype=np.uint16)), pa.array([1.0, None, 3.0])):
        for x in (arr, arr.slice(2, 5)):                         # an offset into the buffer
            got = arrow_to_numpy(x)
            want = x.to_numpy(zero_copy_only=False)
            assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=True)
    x = np.array([1.5, np.nan, -0.0])
    a = numpy_to_arrow(x)
    assert a.equals(pa.array(x, from_pandas=True)) and a.null_count == 1
    assert numpy_to_arrow(np.array([True, False, True])).equals(pa.array([True, False, True]))


def test_the_command_exits_fast_with_its_output_and_status(tmp_path):
    """``python -m inmotion`` ends with ``os._exit`` after a run (no interpreter teardown):
    what it printed arrives whole through a pipe, and the exit status is the command's."""
    import json
    write_bundle(_bundle(), tmp_path / "b", fmt="parquet")
    run = subprocess.run([sys.executable, "-m", "inmotion", "--json", "navigate",
                          str(tmp_path / "b"), "--method", "sins", "--init", "meta", "-o",
                          str(tmp_path / "out")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["method"] == "sins"
    bad = subprocess.run([sys.executable, "-m", "inmotion", "navigate", str(tmp_path / "none"),
                          "--method", "sins", "-o", str(tmp_path / "o2")], capture_output=True,
                         text=True)
    assert bad.returncode == 2 and bad.stderr.startswith("inmotion: error: ")


def test_fast_exit_falls_back_to_a_normal_exit_when_not_safe(monkeypatch):
    import threading

    from inmotion.cli.main import fast_exit
    release = threading.Event()
    worker = threading.Thread(target=release.wait)
    worker.start()
    try:
        with pytest.raises(SystemExit) as e:          # another thread alive: Python's exit
            fast_exit(3)
        assert e.value.code == 3
    finally:
        release.set()
        worker.join()
    monkeypatch.setenv("INMOTION_FAST_EXIT", "0")
    with pytest.raises(SystemExit) as e:
        fast_exit(None)
    assert e.value.code == 0


@pytest.mark.parametrize("mode", ["attitude-position", "velocity-position"])
def test_sins_dr_ahead_of_time_imports_no_numba_no_scipy(tmp_path, mode):
    """With the ahead-of-time extension built for these sources (``python -m inmotion.warmup``;
    skipped otherwise: the JIT path imports numba, and numba scipy.linalg), ``navigate
    --method sins-dr`` in either mode, with a Markov scale factor (no sensor spec in meta:
    the 300 s default, the 16-active-row predict kernel of paper 002's hour), imports
    neither: its predict kernel is in the extension and its loop makes no BLAS call (a
    matrix product there imported scipy.linalg, 0.17 s of the run)."""
    from inmotion import _aot
    if _aot.module() is None:
        pytest.skip("no ahead-of-time extension for these sources (python -m inmotion.warmup)")
    bundle = tmp_path / "b"
    write_bundle(_bundle(), bundle, fmt="parquet")
    out = tmp_path / "out"
    mods = _modules_after_cli(["-q", "navigate", str(bundle), "--method", "sins-dr", "--init",
                               "meta", "--set", f"mode={mode}", "-o", str(out)])
    assert (out / "solution.csv").is_file()
    assert any(m.startswith("inmotion_aot_") for m in mods)
    for heavy in ("numba", "scipy", "pandas"):
        assert heavy not in mods, f"navigate --method sins-dr --set mode={mode} imports {heavy}"
