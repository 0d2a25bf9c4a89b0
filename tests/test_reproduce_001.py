"""Paper 001 reproduction: the statistics of the report (ranking, NEES), its assembly, and the
scenario of our test 3 (stale / biased LDV bursts)."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.core.bundle import Truth
from inmotion.core.solution import Solution
from inmotion.reproductions import paper001 as r
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

N_GRID = len(r.GRID_S)


def test_ranking_stats_closed_form():
    # run k has the constant heading error c_k over the whole grid
    c = np.array([0.5, -1.5, 2.0, 0.1])
    E = np.tile(c[:, None], (1, N_GRID))
    st = r.ranking_stats(E, (181, 300), off_deg=1.0)
    assert np.isclose(st["rms"], np.sqrt(np.mean(c ** 2)))
    assert np.isclose(st["mean"], c.mean())
    assert np.isclose(st["sd"], c.std(ddof=1))
    assert np.isclose(st["max_abs_mean"], 2.0)
    assert st["runs_off"] == 2 and st["runs"] == 4


def test_ranking_stats_sees_spread_a_mean_hides():
    # two runs at +-3 deg: mean 0, RMS 3
    E = np.vstack([np.full(N_GRID, 3.0), np.full(N_GRID, -3.0)])
    st = r.ranking_stats(E)
    assert abs(st["mean"]) < 1e-12 and np.isclose(st["rms"], 3.0)


def test_nees_stats_consistent_and_overconfident():
    rng = np.random.default_rng(0)
    runs = 30
    z = rng.standard_normal((runs, N_GRID, 3))
    honest = r.nees_stats((z ** 2).sum(-1), r.WINDOWS[2])
    lo, hi = honest["band"]
    assert lo < 3.0 < hi
    for mean, inside in zip(honest["mean"], honest["inside"]):
        assert abs(mean - 3.0) < 0.3
        assert inside > 0.85                        # 95 % expected
    # errors twice what the filter claims: NEES 12, outside the band
    over = r.nees_stats(((2 * z) ** 2).sum(-1), r.WINDOWS[2])
    assert max(over["inside"]) < 0.05 and min(over["mean"]) > 10.0


def test_nees_on_grid_of_a_known_misalignment():
    t = np.arange(0.0, 300.01, 0.5)
    n = len(t)
    euler = np.tile(np.radians([1.0, -2.0, 30.0]), (n, 1))
    truth = Truth(t, np.full(n, 0.5), np.full(n, 2.0), np.zeros(n), np.zeros((n, 3)), euler)
    phi = np.array([1e-3, -2e-3, 5e-3])
    C_est = rotations.apply_misalignment(rotations.dcm_from_euler(euler[0]), phi)
    est = np.tile(rotations.euler_from_dcm(C_est), (n, 1))
    sigma = {"phi_E": np.full(n, 1e-3), "phi_N": np.full(n, 1e-3), "phi_U": np.full(n, 1e-2)}
    sol = Solution(t, truth.lat, truth.lon, truth.h, truth.vel_n, est, sigma=sigma)
    z2 = r._nees_on_grid(sol, truth)
    assert z2.shape == (N_GRID, 3)
    assert np.allclose(z2, [1.0, 4.0, 0.25], rtol=1e-6)


def test_paper_rank_of_table_2():
    rank = r._paper_rank(r.PAPER_TABLE2)
    # |mean| at 181-300 s: ausquhe 0.62, ausque 10.18, oba 12.45, usque-hinf 14.46, usque 14.51
    assert rank == {"ausquhe": 1, "ausque": 2, "oba": 3, "usque-hinf": 4, "usque": 5}


def _fake_results(runs=3):
    rng = np.random.default_rng(1)
    scale = {k: 0.1 * (i + 1) for i, k in enumerate(r._keys())}
    out = []
    for test in r.TESTS:
        for run in range(runs):
            res = {"test": test, "run": run, "errors": {}, "nees": {}, "time_s": {}}
            for key in r._keys():
                res["errors"][key] = scale[key] * rng.standard_normal((N_GRID, 3))
                if not key.startswith("oba"):
                    res["nees"][key] = rng.standard_normal((N_GRID, 3)) ** 2
                res["time_s"][key] = 0.5
            out.append(res)
    return out


def test_report_assembles_every_section_and_ranks_by_rms(tmp_path):
    S = r._summarize(_fake_results())
    keys = r._keys()
    S["time_s"] = {t: {k: 0.5 for k in keys} for t in ("1", "2")}
    S["time_cpu_s"] = S["time_s"]
    S.update(elapsed_s=1.0, runs=3, seed=0, workers=1)
    text = r._report(S)
    for title in ("## Table 1", "## Table 2:", "## Table 2b", "## Ranking against the paper",
                  "## NEES of the attitude", "## Table 3", "oba` (paper-form)"):
        assert title in text
    # test 2's ranking table lists the keys in increasing RMS (fake errors grow with the index)
    sec = text.split("Ranking, test 2,")[1].split("Ranking, test 3")[0]
    rows = [ln for ln in sec.splitlines() if ln.startswith("| ") and ln[2].isdigit()]
    rms = [float(ln.split("|")[3]) for ln in rows]
    assert len(rows) == len(keys) and rms == sorted(rms)
    # rewrite_report gives the same text from results.json
    import json
    (tmp_path / "results.json").write_text(json.dumps(S))
    assert r.rewrite_report(tmp_path) == text


def test_test3_ldv_is_stale_while_the_car_brakes_and_biased_later():
    sc = load_scenario(find_scenario("paper001_urban_stale"))
    b = simulate(sc, np.random.default_rng(0))
    _, ldv = b.velocity_sensor("ldv")
    v = ldv.speed()
    true_speed = np.interp(ldv.t, b.truth.t, np.linalg.norm(b.truth.vel_n, axis=1))
    t = ldv.t - b.truth.t[0]
    stuck = (t > 111.0) & (t < 124.9)
    assert np.ptp(v[stuck]) == 0.0                     # one held value ...
    assert v[stuck][0] - true_speed[stuck].min() > 5.0  # ... while the car brakes by > 5 m/s
    late = (t > 241.0) & (t < 254.0)
    assert abs(np.mean(v[late] - true_speed[late]) - 0.5) < 0.1   # +0.5 m/s bias, noise 0.3


# ----------------------------------------------------------------------------- issue 17
def test_binomial_interval_matches_clopper_pearson_tables():
    # exact 95 % intervals (Clopper & Pearson 1934; e.g. Newcombe 1998, table I)
    assert r.binomial_interval(0, 10) == (0.0, pytest.approx(0.3085, abs=1e-4))
    lo, hi = r.binomial_interval(5, 10)
    assert lo == pytest.approx(0.1871, abs=1e-4) and hi == pytest.approx(0.8129, abs=1e-4)
    assert r.binomial_interval(10, 10) == (pytest.approx(0.6915, abs=1e-4), 1.0)
    # 0 of n: the upper bound is 1 - 0.025^(1/n)
    assert r.binomial_interval(0, 39)[1] == pytest.approx(1 - 0.025 ** (1 / 39), rel=1e-6)


def test_single_run_interval():
    # one run's outcome is decided only when the success probability is surely < 2.5 % or > 97.5 %
    assert r.single_run_interval(0, 200) == (0.0, 0.0)
    assert r.single_run_interval(200, 200) == (1.0, 1.0)
    assert r.single_run_interval(0, 10) == (0.0, 1.0)       # upper bound 0.31
    assert r.single_run_interval(3, 10) == (0.0, 1.0)


def test_circle_stats_of_a_known_sample():
    st = r.circle_stats([0.5, -0.2, 3.0, -170.0, 0.99, 1.0], success_deg=1.0)
    assert st["n"] == 6 and st["successes"] == 3 and st["rate"] == 0.5
    assert st["median_abs_deg"] == pytest.approx(0.995)
    assert st["max_abs_deg"] == 170.0
    assert st["interval"] == r.binomial_interval(3, 6)


def test_earth_rate_heading_bound_against_the_discrete_sum():
    # information of the heading from the Earth-rate part of beta, summed update by update
    from inmotion.core import earth
    lat, noise, rate, T = 28.0, 0.3, 100.0, 60.0
    t = np.arange(1, int(T * rate) + 1) / rate
    k = 9.79 * earth.OMEGA_IE * np.cos(np.radians(lat)) / 2.0
    info = np.sum((k * t ** 2) ** 2) / noise ** 2 + 1.0 / np.radians(12.0) ** 2
    assert r.earth_rate_heading_sigma_deg(T, lat, noise, rate, 12.0) == pytest.approx(
        np.degrees(info ** -0.5), rel=1e-2)
    # in the first seconds the prior is all there is
    assert r.earth_rate_heading_sigma_deg(2.0, lat, noise, rate, 12.0) > 11.9


def test_conditions_ours_are_the_settings_the_runs_use():
    rows = {p: (paper, ours) for p, paper, ours, _ in r.conditions(30)}
    # the configuration a run really gets (a 0.2 s drive is enough to read it back)
    from inmotion.core.bundle import Bundle, ImuData, SpeedData
    t = np.arange(0.0, 0.2, 0.01)
    n = len(t)
    b = Bundle(ImuData(t, np.zeros((n, 3)), np.tile([0.0, 0.0, 0.098], (n, 1))),
               {"initial_position": {"lat_deg": 28.0, "lon_deg": 113.0, "h_m": 0.0}},
               ldv=SpeedData(t, v=np.zeros(n)))
    sol, _ = r._run_scheme("ausquhe", "paper", b)
    cfg = sol.info["config"]
    assert rows["initial covariance [deg]"][1] == "diag(%s)^2" % ", ".join(
        f"{v:g}" for v in cfg["sigma0_deg"])
    assert rows["process noise Q [deg per update]"][1].startswith(f"({cfg['process_noise_deg']:g})")
    assert cfg["process_noise_deg"] == 1e-7 and cfg["meas_noise_m_s"] == 0.07
    assert rows["k0 (eq. 55)"][1] == f"{cfg['k0']:g}"
    assert rows["gamma_min, gamma_max (eq. 55-56) [deg]"][1] == (
        f"{cfg['gamma_min_deg']:g}, {cfg['gamma_max_deg']:g}")
    assert rows["adaptive R bounds R_min, R_max (eq. 44) [m/s]"][1].startswith(
        f"{cfg['r_min_m_s']:g}, {cfg['r_max_m_s']:g}")
    assert rows["fading factor c (eq. 43)"][1] == f"{cfg['fading_factor']:g}"
    # the scenarios the runs simulate
    sc1, sc2 = r._scenario(1), r._scenario(2)
    assert rows["latitude [deg]"][1] == f"{sc1.start.lat_deg:g}"
    assert rows["start heading, Tables 1-2 [deg]"][1].startswith(
        f"{sc1.start.heading_deg:g} (test 1), {sc2.start.heading_deg:g} (test 2)")
    assert f"white {sc2.sensors.ldv.noise_m_s:g} m/s" in rows["LDV disturbance, test 2"][1]
    assert r._scenario(2, 170.0).start.heading_deg == 170.0
    circle = rows["start heading, whole circle [deg]"][1]
    assert circle.startswith(", ".join(f"{h:g}" for h in r.CIRCLE_HEADINGS_DEG))
    assert f"{r.PAPER_START_DEG:g}" in circle


def _fake_circle(fail_key="usque/paper"):
    out = []
    for h, run, _ in r.circle_tasks(0, runs=2):
        yaw = {k: np.full(N_GRID, 0.1) for k in r.CIRCLE_KEYS}
        yaw[fail_key] = np.full(N_GRID, 20.0)
        out.append({"heading_deg": h, "run": run, "yaw": yaw,
                    "sigma_u_2s_deg": {k: 1.0 for k in r.CIRCLE_KEYS if "oba" not in k}})
    return out


def test_circle_summary_and_rows():
    from inmotion.evaluate.stats import compare_rows
    from inmotion.reproductions import suite
    C = r._summarize_circle(_fake_circle())
    n = 2 * len(r.CIRCLE_HEADINGS_DEG)
    assert C["circle"]["ausquhe/paper"]["successes"] == n
    assert C["circle"]["usque/paper"]["successes"] == 0
    assert C["paper_start"]["ausquhe/paper"]["n"] == 2
    S = r._summarize(_fake_results())
    S.update(runs=3, whole_circle=C)
    rows = {x["quantity"]: x for x in compare_rows(suite._rows_001(S))}
    q = "001 test 2 1 ausquhe (paper): success rate from the whole circle"
    assert rows[q]["kind"] == "paper" and rows[q]["verdict"] == "same"    # n of n: 1 inside
    q = "001 test 2 3 usque (paper): success rate from the whole circle"
    assert rows[q]["kind"] == "ablation"
    # the paper's one run of usque failed (14.5 deg); ours fail too
    q = f"001 test 2 3 usque (paper): success from the paper's start ({r.PAPER_START_DEG:g} deg)"
    assert rows[q]["paper"] == 0.0 and rows[q]["verdict"] == "same"
    # Table rows carry the single-run interval and are paper rows for the paper's schemes
    t = rows["001 test 2 ausquhe (paper states): heading mean 181-300 s"]
    assert t["kind"] == "paper" and len(t["measured_interval"]) == 2 and t["paper_n"] == 1
    assert rows["001 test 2 ausquhe (extended states): heading STD 181-300 s"]["kind"] == "ablation"
    assert rows["001 test 1 oba (centred): heading mean 91-180 s"]["kind"] == "ablation"
    assert rows["001 test 1 oba (paper form): heading mean 91-180 s"]["kind"] == "paper"
    assert all(x["verdict"] != "undecided" for x in rows.values() if x["kind"] == "paper")
    # the report opens with the conditions table and has the circle section
    keys = r._keys()
    S["time_s"] = {t: {k: 0.5 for k in keys} for t in ("1", "2")}
    S["time_cpu_s"] = S["time_s"]
    S.update(elapsed_s=1.0, seed=0, workers=1)
    text = r._report(S)
    assert text.split("\n## ")[1].startswith("Conditions")
    sec = text.split("## Alignment from an unknown heading")[1].split("\n## ")[0]
    assert f"| 1 `ausquhe` (paper) | {n} / {n} |" in sec
    assert "| 3 `usque` (paper) | 0 / " in sec


def test_circle_bins_wrap_the_start_heading():
    rows = [[-180.0, 0, 0.5], [170.0, 0, 20.0], [150.0, 1, 0.2], [30.0, 0, 2.0],
            [-60.0, 0, 0.1], [90.0, 0, 0.1]]
    b = r.circle_bins(rows)
    # near: 30 and -60 (one success); far: -180, 170, 150 (two successes, one gross)
    assert b["near"] == (1, 2, 0)
    assert b["far"] == (2, 3, 1)
    assert r._agree({"final_deg": {"a": rows, "oba/paper-form": rows}}, "a") == "6 of 6"


# ----------------------------------------------------------------------------- k0 sweep
def test_v0_heading_error_against_a_least_squares_fit():
    # dv0 is a constant in every pair; the heading's signal is s(t) = g Omega cos L t^2 / 2:
    # fit psi s(t) to the constant on a dense grid, equal weights, and compare
    from inmotion.core import earth
    lat, dv0, T = 28.2, 0.3, 300.0
    t = np.linspace(0.0, T, 30001)
    s = 9.79 * earth.OMEGA_IE * np.cos(np.radians(lat)) * t ** 2 / 2.0
    psi = np.sum(s * dv0) / np.sum(s * s)
    assert r.v0_heading_sigma_deg(T, lat, dv0, "uniform") == pytest.approx(np.degrees(psi),
                                                                          rel=1e-3)
    assert r.v0_heading_sigma_deg(T, lat, dv0, "last") == pytest.approx(
        np.degrees(dv0 / s[-1]), rel=1e-9)
    # the module's figure for 0.3 m/s at 200 s (inmotion.align.usque_model): 1.4 deg
    assert r.v0_heading_sigma_deg(200.0, lat, dv0) == pytest.approx(1.4, abs=0.05)


def test_success_ceiling_is_the_normal_probability():
    # P(|Z| < 1) = 0.6827, P(|Z| < 2) = 0.9545 (normal tables)
    assert r.success_ceiling(1.0, 1.0) == pytest.approx(0.6827, abs=1e-4)
    assert r.success_ceiling(0.5, 1.0) == pytest.approx(0.9545, abs=1e-4)


def test_k0_summary_of_a_known_table():
    # k0 = 1 succeeds from every start; k0 = 3 only within 60 deg; the rest fail by 10 deg
    recs = []
    for h, run, _ in r.k0_tasks(0, runs=1):
        near = abs(((h + 180.0) % 360.0) - 180.0) <= 60.0
        fin = {}
        for state in r.K0_STATE_SETS:
            for k0 in r.K0_SWEEP:
                ok = k0 == 1.0 or (k0 == 3.0 and near)
                fin[f"{state}/k0={k0:g}"] = 0.3 if ok else -10.0
        recs.append({"heading_deg": h, "run": run, "final_deg": fin})
    K = r._summarize_k0(recs)
    n = len(r.CIRCLE_HEADINGS_DEG) + 1
    assert K["runs_per_heading"] == 1 and len(K["headings_deg"]) == n
    st = K["stats"]["paper/k0=1"]
    assert st["successes"] == n and st["interval"] == r.binomial_interval(n, n)
    # near: -60, -30, 0, 30, 60 (5); far: -180, -150, -120, 120, 150, 170 (6)
    assert tuple(K["stats"]["extended/k0=3"]["near"]) == (5, 5, 0)
    assert tuple(K["stats"]["extended/k0=3"]["far"]) == (0, 6, 6)
    assert K["stats"]["paper/k0=30"]["successes"] == 0
    assert K["stats"]["paper/k0=30"]["max_abs_deg"] == 10.0
    # and the report renders the sweep with these counts
    S = r._summarize(_fake_results())
    keys = r._keys()
    S["time_s"] = {t: {k: 0.5 for k in keys} for t in ("1", "2")}
    S["time_cpu_s"] = S["time_s"]
    S.update(elapsed_s=1.0, runs=3, seed=0, workers=1, k0_sweep=K,
             whole_circle=r._summarize_circle(_fake_circle()))
    text = r._report(S)
    sec = text.split("### Can `ausquhe` be made robust?")[1].split("\n## ")[0]
    assert f"| extended | 3 | 5 / {n} |" in sec and "| 5 / 5, 0 | 0 / 6, 6 |" in sec
    assert "best k0 on the tuning drives: 1" in sec



def test_near_far_p_value_of_known_tables():
    # Fisher's exact test, two-sided, by hand: [[8, 2], [1, 5]], margins 10, 6 / 9, 7; the
    # hypergeometric tables no more likely than the observed one (C(10,8) C(6,1) = 270) are
    # a = 8, 9, 3: (270 + 10 + 120) / C(16, 9) = 400 / 11440; equal rates give p = 1
    assert r.near_far_p_value((8, 10), (1, 6)) == pytest.approx(400 / 11440, rel=1e-9)
    assert r.near_far_p_value((5, 10), (5, 10)) == pytest.approx(1.0)


# ----------------------------------------------------------------------------- campaign form
def test_campaign_files_are_the_experiment_and_keep_the_streams(monkeypatch):
    # the sweep files hold the grid and the runs the module uses
    from inmotion.evaluate.campaign import run_seed_sequence
    from inmotion.evaluate.sweep import load_sweep
    from inmotion.reproductions.common import campaign_file, unpack_record
    circle = load_sweep(campaign_file("paper001_circle"))
    heads = [p.params["heading_deg"] for p in circle.points]
    assert heads == list(r.CIRCLE_HEADINGS_DEG) + [r.PAPER_START_DEG]
    assert circle.runs == r.CIRCLE_RUNS >= 10
    assert [p.params["test"] for p in load_sweep(campaign_file("paper001")).points] == list(
        r.TESTS)
    # the run functions pass (point, engine run k, seed) to the task functions unchanged,
    # so a campaign run draws the stream of the former task loop
    monkeypatch.setattr(r, "run_circle_one", lambda task: {"task": list(task)})
    monkeypatch.setattr(r, "run_one", lambda task: {"task": list(task)})
    monkeypatch.setattr(r, "run_k0_one", lambda task: {"task": list(task)})
    rng = np.random.default_rng(run_seed_sequence(7, 4))
    rec = lambda out: unpack_record(out["record"], out.get("arrays", {}))   # noqa: E731
    assert rec(r.run_circle({"heading_deg": 170.0}, rng))["task"] == [170.0, 4, 7]
    assert rec(r.run({"test": 2}, rng))["task"] == [2, 4, 7]
    assert rec(r.run_k0({"heading_deg": -90.0}, rng))["task"] == [-90.0, 4, 7]
    from inmotion.errors import BadInput
    with pytest.raises(BadInput, match="test must be one of"):
        r.run.validate_spec({"test": 4})
    with pytest.raises(BadInput, match="heading_deg"):
        r.run_circle.validate_spec({"heading_deg": "north"})
