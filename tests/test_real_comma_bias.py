"""Issue 15 on comma2k19: the phone's gyro bias as a constant plus a Gauss-Markov part
(``od_kf_single_pass``: two bias states per axis in one filter), dead reckoning with the estimated calibration (scale, mounting,
constant gyro bias), and the diagnostics behind the report (speed lag, IMU / reference yaw).
The synthetic tests inject a known lag / rotation / bias; the real-data ones compare with the
drive's reference and are skipped without the data."""
import numpy as np
import pytest

from inmotion.core.bundle import Bundle, ImuData, SpeedData, Truth
from inmotion.reproductions import real as rr

D = np.pi / 180.0
COMMA = rr.default_data_root() / "comma2k19_rav4_60s"
needs_comma = pytest.mark.skipif(not COMMA.is_dir(), reason=f"comma2k19 not found at {COMMA}")


def _straight_drive(n=1200, dt=0.05, heading=30 * D):
    """Level drive along ``heading`` with a speed 15 + 3 sin(0.7 t) m/s: truth at 20 Hz."""
    t = np.arange(n) * dt
    speed = 15.0 + 3.0 * np.sin(0.7 * t)
    vel = np.column_stack([speed * np.sin(heading), speed * np.cos(heading), np.zeros(n)])
    lat = 37.0 * D + np.cumsum(vel[:, 1]) * dt / 6.37e6
    lon = -122.0 * D + np.cumsum(vel[:, 0]) * dt / (6.37e6 * np.cos(37.0 * D))
    euler = np.tile([0.0, 0.0, heading], (n, 1))
    return Truth(t, lat, lon, np.full(n, 10.0), vel, euler)


def test_speed_lag_recovers_an_injected_odometer_delay():
    tr = _straight_drive()
    speed = np.linalg.norm(tr.vel_n, axis=1)
    for lag in (-0.12, 0.0, 0.08):
        odo = SpeedData(tr.t, v=0.99 * np.interp(tr.t - lag, tr.t, speed) + 0.01)
        b = Bundle(imu=ImuData(tr.t, np.zeros((len(tr.t), 3)), np.zeros((len(tr.t), 3))),
                   meta={}, odometer=odo, truth=tr)
        assert rr.speed_lag_s(b) == pytest.approx(lag, abs=0.011)


def test_imu_reference_yaw_recovers_an_injected_rotation_of_the_accelerometer_axes():
    """The IMU's specific force is the reference's turned by ``delta`` about z plus a bias;
    the regression on the forward specific force gives ``delta`` back."""
    tr = _straight_drive()
    ref = Bundle(imu=ImuData(tr.t, np.zeros((len(tr.t), 3)), np.zeros((len(tr.t), 3))),
                 meta={}, truth=tr)
    _, f_ref, _, _ = rr._specific_forces(ref)
    delta = 0.3 * D
    c, s = np.cos(delta), np.sin(delta)
    f_imu = f_ref @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) \
        + np.array([0.07, -0.05, 0.1])
    dvel = np.vstack([np.zeros(3), f_imu * np.diff(tr.t)[:, None]])
    b = Bundle(imu=ImuData(tr.t, np.zeros_like(dvel), dvel), meta={}, truth=tr)
    got = rr.imu_reference_yaw_from_accel(b, lags_s=(0.0,))
    assert got[0.0] == pytest.approx(0.3, abs=0.01)


def test_turning_the_imu_by_the_measured_yaw_puts_it_into_the_references_axes():
    """``turned_imu`` turned by ``imu_reference_yaw_from_accel``'s slope: the slope of the
    turned IMU against the reference is 0 (the convention ``turned_imu_yaw``'s report line
    relies on: "turned into the camera's axes")."""
    tr = _straight_drive()
    ref = Bundle(imu=ImuData(tr.t, np.zeros((len(tr.t), 3)), np.zeros((len(tr.t), 3))),
                 meta={}, truth=tr)
    _, f_ref, _, _ = rr._specific_forces(ref)
    c, s = np.cos(-0.4 * D), np.sin(-0.4 * D)
    f_imu = f_ref @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    dvel = np.vstack([np.zeros(3), f_imu * np.diff(tr.t)[:, None]])
    b = Bundle(imu=ImuData(tr.t, np.zeros_like(dvel), dvel), meta={}, truth=tr)
    slope = rr.imu_reference_yaw_from_accel(b, lags_s=(0.0,))[0.0]
    assert slope == pytest.approx(-0.4, abs=0.01)
    back = rr.imu_reference_yaw_from_accel(rr.turned_imu(b, slope), lags_s=(0.0,))[0.0]
    assert abs(back) < 0.01


def test_oracle_calibration_carries_the_mean_gyro_error():
    """A constant gyro bias on a level, straight drive: the oracle's bias is that constant
    (plus nothing else: the increments are the Earth rate seen in b)."""
    from inmotion.core import earth
    tr = _straight_drive()
    bias = np.array([-100.0, 50.0, 107.0]) * D / 3600.0
    w = tr.C_nb[0].T @ earth.omega_ie_n(tr.lat[0]) + bias
    dtheta = np.vstack([np.zeros(3), np.tile(w, (len(tr.t) - 1, 1)) * np.diff(tr.t)[:, None]])
    b = Bundle(imu=ImuData(tr.t, dtheta, np.zeros_like(dtheta)), meta={},
               odometer=SpeedData(tr.t, v=np.linalg.norm(tr.vel_n, axis=1)), truth=tr)
    orc = rr.oracle_calibration(b)
    assert np.allclose(orc["gyro_bias_deg_h"], [-100.0, 50.0, 107.0], atol=2.0)
    assert orc["scale"] == pytest.approx(1.0, abs=1e-9)
    assert orc["yaw_mount_deg"] == pytest.approx(0.0, abs=1e-6)


@pytest.fixture(scope="module")
def comma():
    from inmotion.io.importers import import_log
    b = import_log("comma2k19", COMMA)
    init = rr._init_from_truth(b, b.imu.t[0])
    row, _, sol, est = rr.od_kf_single_pass(b, init)
    return b, init, row, est, sol


@needs_comma
def test_single_pass_models_the_phone_spec_with_two_bias_states(comma):
    """The importer's spec has a constant and a Gauss-Markov gyro bias: od-kf carries both
    (``eps``, ``eps_gm``) and says so; the constant it ends with is the one the calibration
    hands to the dead reckoning."""
    _, _, _, est, sol = comma
    assert sol.info["gyro_bias_model"] == "constant + gauss-markov"
    assert sol.info["config_source"]["gyro_drift_deg_h"].startswith("meta.imu")
    assert {"eps_gm_x", "eps_gm_y", "eps_gm_z", "sigma_eps_gm_z"} <= set(sol.states)
    eps = np.array([sol.states[f"eps_{a}"][-1] for a in "xyz"])
    np.testing.assert_array_equal(est["gyro_bias_rad_s"], eps)


@needs_comma
def test_single_pass_calibration_against_the_reference(comma):
    """Issue 15 targets on the segment, as measured: the yaw mounting misses its 0.2 deg
    target (-0.48 against -0.81 deg, report.md says why) but its sigma covers its error; the
    pitch is within 0.3 deg; the dead reckoning with the estimated scale and mounting beats
    the raw one (26.5 against 36.5 m); the 20 m target with the constant gyro bias is missed
    (29.6 m: the constant z bias from 60 s of a straight drive is not determined, report.md)."""
    b, init, _, est, _ = comma
    cal = rr.reference_calibration(b)
    assert abs(est["yaw_mount_deg"] - cal["yaw_mount_deg"]) <= 2.0 * est["yaw_mount_sigma_deg"]
    assert est["pitch_mount_deg"] == pytest.approx(cal["pitch_mount_deg"], abs=0.3)
    no_bias = {k: v for k, v in est.items() if k != "gyro_bias_rad_s"}
    row, _, _ = rr.calibrated_dr(b, no_bias, init)
    raw, _, _ = rr._run("dr", "dr", b, rr.DrConfig(sensor="odometer"), init)
    assert row["distance_m"] > 1000.0
    assert row["final_horizontal_m"] < raw["final_horizontal_m"]


@needs_comma
def test_split_check_out_of_sample(comma):
    """Calibrated on one half, dead-reckoned on the other (about 500 m): within 2 % of the
    distance, the issue's 20 m per km (measured 4.9 and 5.2 m with the single pass)."""
    b = comma[0]
    rows = rr.split_check(b)
    assert [r["fit"] for r in rows] == ["first half", "second half"]
    for r in rows:
        assert r["distance_m"] > 400.0
        assert r["dr_m"] < 0.02 * r["distance_m"], r


def test_simulated_check_yaw_against_truth_and_the_constant_models_overconfidence():
    """Simulated truth (10 runs of the comma2k19-like drive, gyro bias constant + Gauss-Markov,
    filters with the importer's assumed spec): the single-pass yaw mounting is within the
    0.2 deg target in RMS and its sigma covers its error; the constant-bias model's sigma
    claims a fraction of its error (the overconfidence issue 15 reports on the real log); the
    oracle calibration (true scale, mounting, mean gyro bias) dead-reckons within 20 m.

    With the car slipping and bouncing as the real segment does (``COMMA_MEASURED_SLIP``,
    scale 1) the single pass's yaw error grows (measured over 100 runs: RMS 0.11 -> 0.30
    deg) while its sigma still covers it: what a correct estimator gives on such a drive."""
    sim = rr.simulated_calibration_check(runs=10, seed=7)
    two, const = sim["models"]["constant + gauss-markov"], sim["models"]["constant"]
    assert two["yaw_error_rms_deg"] < rr.TARGET_YAW_MOUNT_DEG
    assert two["yaw_error_over_sigma_rms"] < 1.5
    assert const["yaw_error_over_sigma_rms"] > 2.0
    assert sim["models"]["oracle"]["dr_within_target"] == 1.0
    scales = [r["slip_scale"] for r in sim["by_slip"]]
    assert scales == list(rr.SIM_SLIP_SCALES)
    assert sim["by_slip"][0]["models"] == sim["models"]
    slip = rr._measured_slip_point(sim)["models"]["constant + gauss-markov"]
    assert slip["yaw_error_rms_deg"] > 2.0 * two["yaw_error_rms_deg"]
    assert slip["yaw_error_over_sigma_rms"] < 1.5


def test_comma_like_scenario_slip():
    """``slip_scale`` scales the measured slip into the scenario's vehicle; 0 leaves the
    constraint exact; a negative scale is bad input."""
    from inmotion.errors import BadInput
    assert "vehicle" not in rr.comma_like_scenario()
    cv = rr.comma_like_scenario(0.5)["vehicle"]["constraint_violation"]
    assert cv["lateral_sigma_m_s"] == pytest.approx(0.5 * rr.COMMA_MEASURED_SLIP["lateral_sigma_m_s"])
    assert cv["vertical_tau_s"] == rr.COMMA_MEASURED_SLIP["vertical_tau_s"]
    for bad in (-1.0, float("nan")):
        with pytest.raises(BadInput, match="slip_scale must be a finite number >= 0"):
            rr.comma_like_scenario(bad)


@needs_comma
def test_an_imu_camera_yaw_misalignment_reaches_the_estimate_only_in_part(comma):
    """The report's claim (session 15): the start attitude (the reference's, the camera's,
    0.1 deg heading prior) anchors the single pass's frame, so turning the IMU's increments
    by +-0.16 deg (the accelerometers' IMU-camera yaw) moves the yaw mounting by a quarter of
    the turn (measured -0.52 / -0.45 against -0.48 as is: 0.24), not by the turn, which is
    why that misalignment cannot explain the 0.33 deg miss."""
    b, init, _, est, _ = comma
    (d1, y1), (d2, y2) = rr.turned_imu_yaw(b, init, (-0.16, 0.16))
    slope = (y2 - y1) / (d2 - d1)
    assert 0.0 < slope < 0.5, (y1, y2)
    assert min(y1, y2) < est["yaw_mount_deg"] < max(y1, y2)
