"""Result folders: round trip of a Solution, units in files, errors block, atomic writes."""
import json

import numpy as np
import pandas as pd
import pytest

from inmotion.core.solution import Solution, StateUnit
from inmotion.errors import BadInput
from inmotion.io.result import read_result, write_result

from test_metrics import DESIGN_KEYS, as_solution, straight_truth


def make_solution(rng, n=200):
    t = 10.0 + 0.1 * np.arange(n)
    euler = np.column_stack([rng.normal(0, 0.01, n), rng.normal(0, 0.01, n),
                             rng.uniform(0, 2 * np.pi, n)])
    sigma = {"north": np.abs(rng.normal(1, 0.1, n)), "phi_U": np.full(n, np.radians(0.5))}
    states = {"mount_x": rng.normal(0, 1e-3, n), "dk": rng.normal(0, 1e-4, n),
              "eps_x": rng.normal(0, 1e-7, n)}
    units = {"mount_x": StateUnit("arcmin", 180 * 60 / np.pi), "dk": StateUnit("ppm", 1e6)}
    return Solution(t, np.radians(34.1) + rng.normal(0, 1e-6, n),
                    np.radians(108.9) + rng.normal(0, 1e-6, n), 400 + rng.normal(0, 1, n),
                    rng.normal(0, 10, (n, 3)), euler, sigma=sigma, states=states,
                    state_units=units, info={"method": "test", "config": {"a_deg": 1.0},
                                             "events": [{"t_s": 11.0, "what": "fault"}]})


def test_round_trip(tmp_path):
    a = make_solution(np.random.default_rng(1))
    write_result(a, tmp_path / "r")
    b = read_result(tmp_path / "r")
    for k in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_allclose(getattr(b, k), getattr(a, k), rtol=1e-12, atol=1e-15)
    for k in a.sigma:
        np.testing.assert_allclose(b.sigma[k], a.sigma[k], rtol=1e-12)
    for k in a.states:
        np.testing.assert_allclose(b.states[k], a.states[k], rtol=1e-12)
    assert b.state_units["dk"] == StateUnit("ppm", 1e6)
    assert b.info["method"] == "test" and b.info["config"] == {"a_deg": 1.0}
    assert b.info["events"] == [{"t_s": 11.0, "what": "fault"}]


def test_files_in_human_units(tmp_path):
    a = make_solution(np.random.default_rng(2))
    write_result(a, tmp_path / "r")
    sol = pd.read_csv(tmp_path / "r" / "solution.csv")
    assert list(sol.columns[:10]) == ["t", "lat", "lon", "h", "vE", "vN", "vU",
                                      "pitch", "roll", "yaw"]
    np.testing.assert_allclose(sol["lat"], np.degrees(a.lat), rtol=1e-15)
    assert sol["yaw"].min() >= 0 and sol["yaw"].max() < 360
    np.testing.assert_allclose(sol["sigma_phi_U"], 0.5, rtol=1e-12)     # degrees
    st = pd.read_csv(tmp_path / "r" / "states.csv")
    assert set(st.columns) == {"t", "mount_x_arcmin", "dk_ppm", "eps_x_si"}
    np.testing.assert_allclose(st["dk_ppm"], a.states["dk"] * 1e6, rtol=1e-12)
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["method"] == "test"
    assert summary["final"]["lat_deg"] == pytest.approx(np.degrees(a.lat[-1]), rel=1e-15)
    assert "errors" not in summary and not (tmp_path / "r" / "errors.csv").exists()


def test_with_truth_writes_errors(tmp_path):
    tr = straight_truth(n=101, dt=1.0)
    sol = as_solution(tr, h=tr.h + 2.0)
    summary = write_result(sol, tmp_path / "r", truth=tr)
    on_disk = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert on_disk["errors"] == summary["errors"]
    for k in ("final", "rms_last_100s", "max_abs_last_100s"):
        assert set(on_disk["errors"][k]) == DESIGN_KEYS
    assert on_disk["errors"]["final"]["vertical_m"] == pytest.approx(2.0)
    err = pd.read_csv(tmp_path / "r" / "errors.csv")
    np.testing.assert_allclose(err["vertical_m"], 2.0, rtol=1e-12)


def test_nan_sigma_and_info_written_as_null(tmp_path):
    a = make_solution(np.random.default_rng(3))
    a.sigma["east"] = np.full(len(a), np.nan)
    a.info["quality"] = float("inf")
    write_result(a, tmp_path / "r")
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["info"]["quality"] is None
    b = read_result(tmp_path / "r")
    assert np.isnan(b.sigma["east"]).all()


def test_crash_keeps_written_files(tmp_path, monkeypatch):
    """Issue 16: a failure while writing leaves the earlier result whole (summary.json too) and
    no temporary files or folders; a first write that fails leaves nothing."""
    a = make_solution(np.random.default_rng(4))
    b = make_solution(np.random.default_rng(5))
    import inmotion.io.result as result
    write_result(a, tmp_path / "r")
    before = {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()}

    def boom(*args, **kw):
        raise RuntimeError("disk full")
    monkeypatch.setattr(result, "write_summary", boom)
    with pytest.raises(RuntimeError):
        write_result(b, tmp_path / "r")
    with pytest.raises(RuntimeError):
        write_result(b, tmp_path / "new")
    assert {p.name: p.read_bytes() for p in (tmp_path / "r").iterdir()} == before
    assert len(read_result(tmp_path / "r")) == len(a)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
    assert not list((tmp_path / "r").glob(".*tmp"))


def test_read_missing_result(tmp_path):
    with pytest.raises(BadInput, match="does not exist"):
        read_result(tmp_path / "none")
    (tmp_path / "r").mkdir()
    with pytest.raises(BadInput, match="summary.json"):
        read_result(tmp_path / "r")


def test_read_corrupt_solution(tmp_path):
    a = make_solution(np.random.default_rng(5))
    write_result(a, tmp_path / "r")
    df = pd.read_csv(tmp_path / "r" / "solution.csv", dtype=str)
    df.loc[7, "lat"] = "x"
    df.to_csv(tmp_path / "r" / "solution.csv", index=False)
    with pytest.raises(BadInput, match="'lat': value 'x'") as ei:
        read_result(tmp_path / "r")
    assert ei.value.row == 8 and ei.value.time == pytest.approx(a.t[7])
    (tmp_path / "r" / "solution.csv").write_text("")
    with pytest.raises(BadInput, match="solution.csv: cannot read CSV"):
        read_result(tmp_path / "r")
    (tmp_path / "r" / "summary.json").write_text("{not json")
    with pytest.raises(BadInput, match="malformed JSON"):
        read_result(tmp_path / "r")


def test_rewrite_removes_stale_files(tmp_path):
    tr = straight_truth(n=101, dt=1.0)
    a = make_solution(np.random.default_rng(6), n=101)
    a.t = tr.t
    write_result(a, tmp_path / "r", truth=tr)
    assert (tmp_path / "r" / "errors.csv").exists() and (tmp_path / "r" / "states.csv").exists()
    write_result(as_solution(tr), tmp_path / "r")          # no truth, no states
    assert not (tmp_path / "r" / "errors.csv").exists()
    assert not (tmp_path / "r" / "states.csv").exists()
    assert read_result(tmp_path / "r").states == {}


def test_states_file_damaged(tmp_path):
    a = make_solution(np.random.default_rng(8))
    write_result(a, tmp_path / "r")
    st = pd.read_csv(tmp_path / "r" / "states.csv")
    st.drop(columns=["dk_ppm"]).to_csv(tmp_path / "r" / "states.csv", index=False)
    with pytest.raises(BadInput, match="states.csv: missing column dk_ppm"):
        read_result(tmp_path / "r")
    st.iloc[:5].to_csv(tmp_path / "r" / "states.csv", index=False)
    with pytest.raises(BadInput, match="5 rows but solution.csv has 200"):
        read_result(tmp_path / "r")
    (tmp_path / "r" / "states.csv").unlink()
    with pytest.raises(BadInput, match="missing states.csv"):
        read_result(tmp_path / "r")


@pytest.mark.parametrize("rate_hz", [1.0, 2.0, 7.3])
def test_thin_select_chunk_by_chunk_then_thin_is_thin(rate_hz):
    """``thin_select`` (the command line's row selection inside a streaming run) keeps a
    superset of ``thin``'s rows chunk by chunk; ``thin`` of those is ``thin`` of all rows,
    row for row: 100 Hz times with jitter and a gap, cut into uneven chunks (single rows,
    a chunk inside one period, the initial row alone as a run's first output is)."""
    from inmotion.io.result import thin, thin_select
    rng = np.random.default_rng(5)
    t = 12.345 + np.cumsum(np.full(4000, 0.01) + rng.normal(0, 2e-4, 4000))
    t[2500:] += 3.0                                            # a gap of 3 s
    n = len(t)
    cuts = np.unique(np.r_[1, 2, 3, 150, 151, rng.choice(np.arange(4, n - 1), 30), n - 1])

    def sol(k):
        z = np.zeros(len(k))
        return Solution(t[k], z, z, z, np.zeros((len(k), 3)), np.zeros((len(k), 3)),
                        sigma={"h": np.arange(n, dtype=float)[k]})
    sel = thin_select(rate_hz)
    kept = np.concatenate([np.flatnonzero(sel(t[a:b], None)[0]) + a
                           for a, b in zip(np.r_[0, cuts], np.r_[cuts, n])])
    want, got = thin(sol(np.arange(n)), rate_hz), thin(sol(kept), rate_hz)
    assert len(kept) < n / 2 and len(got.t) < len(kept)
    np.testing.assert_array_equal(got.t, want.t)
    np.testing.assert_array_equal(got.sigma["h"], want.sigma["h"])
    # every row starting a period is among those kept (the reference written out)
    k = np.floor((t - t[0]) * rate_hz + 1e-6)
    starts = np.r_[0, np.flatnonzero(np.diff(k) != 0) + 1, n - 1]
    assert np.isin(starts, kept).all()
