"""Paper 000 / 002 reproductions (issue 17): the new statistics on known tables, the Z2
algebra against eq. 36, and the conditions tables against the values the runs use."""
import numpy as np
import pytest

from inmotion.reproductions import paper000 as p0
from inmotion.reproductions import paper002 as p2


# ----------------------------------------------------------------------------- statistics
def test_one_run_interval_is_the_2_5_and_97_5_percentiles():
    x = np.arange(101.0)                    # 0 .. 100: percentile q is q itself
    assert p0.one_run_interval(x) == pytest.approx([2.5, 97.5])
    two = np.stack([x, 2 * x], axis=1)      # per axis
    assert p0.one_run_interval(two) == [pytest.approx([2.5, 97.5]), pytest.approx([5.0, 195.0])]


def test_gain_of_paired_runs_on_a_known_table():
    g = p0._gain([1.0, 2.0, 4.0, 5.0], [2.0, 4.0, 8.0, 15.0])
    assert g["ratio_median"] == pytest.approx(2.0)             # ratios 2, 2, 2, 3
    assert g["ratio_of_medians"] == pytest.approx(6.0 / 3.0)
    d = np.array([1.0, 2.0, 4.0, 10.0])
    assert g["difference_mean"] == pytest.approx(d.mean())
    assert g["difference_se"] == pytest.approx(d.std(ddof=1) / 2.0)
    assert g["ratio_interval"][0] == pytest.approx(2.0)
    assert g["ratio_interval"][1] == pytest.approx(np.percentile([2, 2, 2, 3], 97.5))


def test_crossover_log_linear_on_a_known_table():
    xs = (0.01, 0.1, 1.0)
    # every run: velocity/position 1 better at 0.01, 1 worse at 0.1: the crossing is at the
    # geometric mean of 0.01 and 0.1
    c = p2.crossover(np.tile([-1.0, 1.0, 2.0], (6, 1)), xs)
    assert c["crossing_m_s"] == pytest.approx(np.sqrt(0.01 * 0.1))
    assert c["mean"] == pytest.approx([-1.0, 1.0, 2.0]) and c["se"] == pytest.approx([0, 0, 0])
    assert c["fraction_crossing"] == 1.0
    assert c["crossing_interval_m_s"] == pytest.approx([np.sqrt(1e-3)] * 2)
    # a 3:1 split of the distance in log x
    assert p2._crossing(xs, [-3.0, 1.0, 1.0]) == pytest.approx(10 ** (-2 + 0.75))
    none = p2.crossover(np.tile([1.0, 2.0, 3.0], (4, 1)), xs)
    assert none["crossing_m_s"] is None and none["fraction_crossing"] == 0.0


# ----------------------------------------------------------------------------- Z2 algebra
@pytest.mark.parametrize("pitch_deg", [0.0, 5.0])
def test_vehicle_frame_z2_is_z1_lateral_velocity_minus_v_times_heading_row(pitch_deg):
    """Eq. 36 with Z1's velocity row dv - [V x] phi_D and attitude row phi - phi_D: the lateral
    NHC row is Z1's lateral velocity row minus V (the speed along the body's forward axis
    projected: 15 cos(pitch) on the heading row) times Z1's heading row, exactly."""
    r = p0.z2_redundancy(speed_m_s=15.0, heading_deg=30.0, pitch_deg=pitch_deg)
    assert r["residual"] < 1e-12
    assert r["rank_z1_z2"] == r["rank_z1"] == 6
    coef = np.array(r["coef"])
    assert coef[0, 0] == pytest.approx(-15.0 * np.cos(np.deg2rad(pitch_deg)), rel=1e-9)
    assert coef[0, 3] == pytest.approx(1.0)         # lateral velocity row
    assert coef[1, 5] == pytest.approx(1.0)         # vertical velocity row
    assert coef[1, 1] == pytest.approx(-15.0)       # the pitch row


def test_printed_eq37_is_outside_z1s_span():
    r = p0.z2_redundancy(nhc_mount_terms=False)
    assert r["residual"] > 0.1 and r["rank_z1_z2"] == r["rank_z1"] + 2


# ----------------------------------------------------------------------------- conditions
def _ours(table, name):
    return {p: o for p, _, o, _ in table}[name]


def test_000_conditions_table_states_the_draws_the_runs_use():
    table = p0.conditions()
    assert len({p for p, *_ in table}) == len(table)
    rng_a, rng_b = np.random.default_rng(7), np.random.default_rng(7)
    sc = p0._scenario("paper000_traj1", rng_a)
    assert sc["imu"]["gyro"]["drift_deg_h"] == pytest.approx(
        rng_b.normal(0.0, p0.DRIFT_SIGMA_DEG_H, 3))
    assert sc["imu"]["accel"]["bias_ug"] == pytest.approx(
        rng_b.normal(0.0, p0.ACCEL_BIAS_SIGMA_UG, 3))
    assert f"N(0, {p0.DRIFT_SIGMA_DEG_H:g} deg/h)" in _ours(table, "gyro constant drift")
    assert f"N(0, {p0.ACCEL_BIAS_SIGMA_UG:g} ug)" in _ours(table, "accelerometer bias")
    assert f"{sc['start']['heading_deg']:g} deg" in _ours(table, "heading")
    assert f"{sc['imu']['gyro']['arw_deg_sqrt_h']:g} deg/sqrt(h)" == _ours(table, "gyro random walk")
    assert ", ".join(f"{v:g}" for v in sc["vehicle_mounting_arcmin"]) in _ours(
        table, "installation angles")
    from inmotion.align.dr_kalman import DrKfConfig
    cfg = DrKfConfig()
    assert _ours(table, "Z2 noise") == f"{cfg.nhc_noise_m_s:g} m/s"
    assert f"{cfg.lateral_noise_m_s:g} m/s across" in _ours(table, "Z1 velocity noise")
    # the start errors: the same draws as _initial_state's
    from inmotion.sim import simulate
    b = simulate(sc, rng_a)
    assert b.truth.t[-1] - b.truth.t[0] == pytest.approx(p0.RUN_S, abs=0.02)
    rng_c = np.random.default_rng(3)
    init = p0._initial_state(b.truth, rng_c)
    att = np.random.default_rng(3).normal(0.0, np.deg2rad(p0.ATTITUDE_ERROR_SIGMA_DEG), 3)
    from inmotion.core.rotations import misalignment
    phi = misalignment(init.C_nb[None], b.truth.C_nb[:1])[0]
    assert phi == pytest.approx(att, abs=1e-9)


def test_000_z2_conditions_change_what_they_say():
    sc = p0._z2_scenario({"drift_deg_h": 0.03, "heading_deg": 135.0, "mount_arcmin": 0.0},
                         np.random.default_rng(1))
    assert sc["imu"]["gyro"]["drift_deg_h"] == [0.03] * 3
    assert sc["start"]["heading_deg"] == 135.0 and sc["vehicle_mounting_arcmin"] == [0.0] * 3
    drawn = p0._z2_scenario({"heading_deg": 30.0}, np.random.default_rng(1))
    assert drawn["imu"]["gyro"]["drift_deg_h"] != [0.03] * 3
    assert p0.Z2_STUDY["eq. 37 exact, drift-free DR"][2] == {"nhc_mount_terms": False,
                                                             "dr_sees_gyro_drift": False}


def test_002_conditions_table_states_the_sweep_and_settings_the_runs_use():
    table = p2.conditions()
    sweep = _ours(table, "velocity-difference noise, across and up")
    assert sweep.endswith(", ".join(f"{x:g}" for x in p2.CROSS_NOISE_M_S) + " m/s")
    for x in p2.CROSS_NOISE_M_S:
        name, cfg = p2.METHODS[p2._cross_label(x)]
        assert name == "sins-dr" and cfg["mode"] == "velocity-position"
        assert cfg.get("velocity_cross_noise_m_s", x) == x
    from inmotion.navigate.sins_dr import SinsDrConfig
    default = SinsDrConfig().velocity_cross_noise_m_s
    assert sweep.startswith(f"{default:g} m/s (default)")
    assert p2._cross_label(default) == "velocity-position"
    assert f"N(0, {p2.INIT_SIGMA_ARCMIN[2]:.2f}')" in _ours(table, "initial attitude error")
    for label in p2.DRIFT_FREE_DR:
        assert p2.METHODS[label][1]["dr_sees_gyro_drift"] is False


def test_sins_dr_dr_gyro_rows_must_be_finite():
    from inmotion.core.solution import NavState
    from inmotion.navigate.sins_dr import run_sins_dr
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario
    sc = load_scenario(find_scenario("paper000_traj1")).model_dump()
    sc["segments"][1]["duration_s"] = 10.0
    b = simulate(sc, np.random.default_rng(0))
    from inmotion.errors import BadInput
    bad = b.imu.dtheta.copy()
    bad[3, 2] = np.inf
    with pytest.raises(BadInput, match=r"dtheta_dr: row 3 \(t = "):
        run_sins_dr(b, {}, NavState.from_truth(b.truth), dtheta_dr=bad)
