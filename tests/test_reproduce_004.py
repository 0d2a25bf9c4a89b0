"""Paper 004 reproduction: the fast simulation path equals the simulator, statistics are the
paper's definitions, and a tiny campaign writes its report."""
import numpy as np
import pytest

from inmotion.reproductions import paper004 as r4
from inmotion.sim.simulate import simulate


def test_fast_path_equals_simulate_bit_for_bit():
    a = r4.simulate_run(20, np.random.default_rng(7))
    b = simulate(r4._scenario(20), np.random.default_rng(7))
    np.testing.assert_array_equal(a.imu.dtheta, b.imu.dtheta)
    np.testing.assert_array_equal(a.imu.dvel, b.imu.dvel)
    np.testing.assert_array_equal(a.radar.v, b.radar.v)
    np.testing.assert_array_equal(a.truth.euler, b.truth.euler)
    # constant errors are drawn per run (the documented reading of Table 1)
    c = r4.simulate_run(20, np.random.default_rng(8))
    assert not np.allclose(c.imu.dtheta[:10], a.imu.dtheta[:10])


def test_heading_stats_definitions():
    e = np.array([1.0, -2.0, 3.0, -0.5])
    s = r4.heading_stats(e)
    assert s["MAE"] == pytest.approx(1.625)
    assert s["mean"] == pytest.approx(0.375)
    assert s["STD"] == pytest.approx(np.std(e, ddof=1))
    assert (s["max"], s["min"], s["max_abs"]) == (3.0, -2.0, 3.0)


def test_degradation_counts_positive_differences_of_absolute_errors():
    final = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -0.5], [0.0, 0.0, 2.0]])
    first = np.array([[0.0, 0.0, -2.0], [0.0, 0.0, 0.1], [0.0, 0.0, 1.0]])
    d = r4.degradation_stats(final, first)["heading"]
    assert d["degradations"] == 2 and d["runs"] == 3
    assert d["max"] == pytest.approx(1.0) and d["min"] == pytest.approx(-1.0)


def test_tiny_campaign_writes_report_and_figures(tmp_path):
    res = r4.reproduce(tmp_path, runs=2, workers=1, seed=3, progress=False, segments=False)
    text = (tmp_path / "report.md").read_text()
    assert "1.3063" in text and "mimada-dual (centred)" in text
    for v in r4.SPEEDS_M_S:
        assert (tmp_path / f"heading_mae_std_v{v}.png").stat().st_size > 1000
        assert set(res["stats"][v]) == set(r4.VARIANTS)
    assert len((tmp_path / "runs.csv").read_text().splitlines()) == 1 + 2 * len(r4.SPEEDS_M_S)


def test_segment_drive_is_the_hour_drive_with_paper_004_sensors():
    sc = r4.drive_scenario()
    assert sc["imu"]["gyro"]["drift_deg_h"] == 0.01 and sc["imu"]["accel"]["bias_ug"] == 100.0
    assert sc["imu"]["constant_errors"] == "random"
    assert sc["sensors"]["radar"]["noise_m_s"] == 0.05
    assert sum(1 for seg in sc["segments"] if seg["kind"] == "turn") >= 5


def test_degradation_rate_against_simulated_draws_and_limits():
    rng = np.random.default_rng(0)
    for s1, s2, rho in ((1.0, 1.7, 0.0), (1.0, 1.7, 0.6), (1.7, 1.6, 0.8), (1.0, 0.6, 0.3)):
        z1, z2 = rng.standard_normal((2, 200000))
        e1 = s1 * z1
        e2 = s2 * (rho * z1 + np.sqrt(1 - rho * rho) * z2)
        assert r4.degradation_rate(s1, s2, rho) == pytest.approx(
            np.mean(np.abs(e2) > np.abs(e1)), abs=0.004)
    # equal spreads: |e2| > |e1| half the time whatever the correlation; a second level
    # without error never degrades
    assert r4.degradation_rate(1.0, 1.0, 0.5) == pytest.approx(0.5)
    assert r4.degradation_rate(1.0, 1e-9, 0.0) == pytest.approx(0.0, abs=1e-6)


def test_mechanism_requirement_of_the_papers_table_4():
    # mean change = MAE2 - MAE1: paper 004's car, imada-vb MAE 0.7991, Table 4 +0.5523
    q = r4.mechanism_requirement(0.7991, 0.5523)
    assert q["mae2_deg"] == pytest.approx(1.3514) and q["ratio"] == pytest.approx(1.6912, abs=1e-4)
    # equal spreads give no change and half degradations
    q = r4.mechanism_requirement(1.0, 0.0)
    assert q["rate_rho0"] == pytest.approx(0.5) and q["rate_rho09"] == pytest.approx(0.5)


def test_omitted_earth_rate_term_is_bounded_by_omega_v_t():
    rows = {(t["term"], t["setting"]): t for t in r4.omitted_term_sizes(
        {"lag": ("", {"lag_s": 0.1})})}
    from inmotion.core.earth import OMEGA_IE
    sc = r4.drive_scenario()
    vmax = max([sc["start"]["speed_m_s"]] + [s.get("to_speed_m_s") or 0 for s in sc["segments"]])
    w = [v for (term, _), v in rows.items() if term.startswith("omitted int")]
    assert len(w) == 1                       # no "high speed" effect given: the 1x row only
    assert 0.0 < w[0]["max_m_s"] <= OMEGA_IE * vmax * r4.SEGMENT_S
    lag = [v for (term, _), v in rows.items() if term.startswith("speed lag")][0]
    # a tau: the drive's accelerations stay below 2 m/s^2
    assert 0.0 < lag["max_m_s"] <= 2.0 * 0.1
    assert not any(term.startswith("lever arm") for term, _ in rows)


def test_conditions_name_the_term_sizes_settings_and_the_drives_run():
    rows = {row[0]: row for row in r4.conditions(7)}
    assert rows["car test (Tables 4-5)"][2].startswith("7 simulated one-hour drives")
    assert rows["noise the omitted terms are set against"][2].startswith(
        f"{r4.PAPER_VB_NOISE_M_S} m/s")
    assert f"{r4.PITCH_GRADIENT_DEG_PER_G:g} deg per g" in rows["pitch and bounce"][2]
    assert r4.conditions()[0] == r4.conditions(None)[0]


def test_campaign_files_keep_the_streams(monkeypatch):
    from inmotion.evaluate.campaign import run_seed_sequence
    from inmotion.evaluate.sweep import load_sweep
    from inmotion.reproductions.common import campaign_file, unpack_record
    car = load_sweep(campaign_file("paper004_car"))
    assert [p.params["effect"] for p in car.points] == list(r4.CAR_EFFECTS)
    assert car.runs == r4.CAR_DRIVES >= 15
    assert tuple(p.params["speed_m_s"] for p in load_sweep(campaign_file("paper004")).points) \
        == r4.SPEEDS_M_S
    seen = {}
    monkeypatch.setattr(r4, "run_car_segments", lambda task: seen.setdefault("car", task) and {})
    monkeypatch.setattr(r4, "run_one", lambda task: seen.setdefault("one", task) and {})
    rng = np.random.default_rng(run_seed_sequence(0, 3))
    unpack_record(r4.run_car({"effect": "lag"}, rng)["record"], {})
    unpack_record(r4.run({"speed_m_s": 60}, rng)["record"], {})
    # drive d of every effect: SeedSequence([seed, 4]).spawn(n)[d], the former car seeds
    eff, d, ss = seen["car"]
    ref = np.random.SeedSequence([0, 4]).spawn(5)[3]
    assert (eff, d) == ("lag", 3) and ss.entropy == ref.entropy and ss.spawn_key == ref.spawn_key
    # run r at every speed: SeedSequence(seed).spawn(runs)[r], the former straight runs
    v, k, ss = seen["one"]
    ref = np.random.SeedSequence(0).spawn(5)[3]
    assert (v, k) == (60, 3) and ss.entropy == ref.entropy and ss.spawn_key == ref.spawn_key
