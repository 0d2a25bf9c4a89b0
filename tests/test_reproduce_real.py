"""The real-drive pieces: the reference calibration and the still-period gyro bias against
closed forms on synthetic bundles; the whole run on the real drives (skipped without data)."""
import json

import numpy as np
import pytest

from inmotion.core import earth, rotations
from inmotion.core.bundle import Bundle, ImuData, SpeedData, Truth
from inmotion.errors import BadInput
from inmotion.reproductions import real as rr
from inmotion.navigate.pure import mounting_matrix

D = np.pi / 180.0
LAT = 43.6 * D


def synthetic_bundle(mount_rad, scale, n=50, yaw=30 * D, pitch=2 * D, roll=-1 * D):
    """Constant attitude; the vehicle moves along the sensor's forward axis
    ``C_b^n C_m^b [0, v, 0]`` and the odometer reads ``scale * v``."""
    t = np.arange(n) * 0.05
    euler = np.tile([pitch, roll, yaw], (n, 1))
    C_nb = rotations.dcm_from_euler(euler[0])
    v = 5.0 + 0.1 * t
    vel_n = (C_nb @ mounting_matrix(mount_rad) @ [0.0, 1.0, 0.0])[None, :] * v[:, None]
    truth = Truth(t, np.full(n, LAT), np.full(n, -1.38), np.full(n, 100.0), vel_n, euler)
    imu = ImuData(t, np.zeros((n, 3)), np.zeros((n, 3)))
    return Bundle(imu=imu, truth=truth, odometer=SpeedData(t, v=scale * v))


@pytest.mark.parametrize("mount_deg", [(3.8, 0.0, 0.0), (0.0, 0.0, -0.8), (-2.0, 0.0, 1.5)])
def test_reference_calibration_recovers_mounting_and_scale(mount_deg):
    mount = np.asarray(mount_deg) * D
    cal = rr.reference_calibration(synthetic_bundle(mount, 0.994))
    assert cal["scale"] == pytest.approx(0.994, abs=1e-12)
    single_axis = np.count_nonzero(mount) == 1
    tol = 1e-10 if single_axis else 2e-3          # two angles: exp([A x]) couples them (2nd order)
    assert cal["pitch_mount_deg"] == pytest.approx(mount_deg[0], abs=tol)
    assert cal["yaw_mount_deg"] == pytest.approx(mount_deg[2], abs=tol)


def test_still_gyro_bias_is_mean_rate_minus_earth_rate():
    b = synthetic_bundle(np.zeros(3), 1.0)
    bias = np.array([371.0, -486.0, -1165.0]) * D / 3600
    C_nb = b.truth.C_nb[0]
    w_b = C_nb.T @ earth.omega_ie_n(LAT) + bias
    dt = 0.05
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 1e-4, (len(b.imu.t), 3))
    noise -= noise.mean(axis=0)                    # zero-mean noise: the mean is exact
    b.imu = ImuData(b.imu.t, (w_b + noise) * dt, b.imu.dvel)
    b.truth.vel_n[:] = 0.0
    b.truth.vel_n[30:] = [1.0, 0.0, 0.0]
    t_end = rr.still_period_end(b)
    assert t_end == pytest.approx(b.truth.t[30])
    np.testing.assert_allclose(rr.still_gyro_bias(b, b.imu.t[-1]), bias, atol=1e-15)


def test_rolling_window_is_where_the_roll_leaves_its_start():
    """``rolling_window``: the span where the reference roll is more than 2 deg off its first
    value, padded by 1 s; None on a drive that does not roll."""
    b = synthetic_bundle(np.zeros(3), 1.0, n=200)          # 0.05 s steps, roll -1 deg
    assert rr.rolling_window(b) is None
    t = b.truth.t
    b.truth.euler[:, 1] += np.where((t > 3.0) & (t < 6.0), 30 * D * np.sin(np.pi * (t - 3) / 3),
                                    0.0)
    roll = b.truth.euler[:, 1] / D + 1.0                    # away from the start value
    away = np.flatnonzero(np.abs(roll) > 2.0)
    assert rr.rolling_window(b) == pytest.approx((t[away[0]] - 1.0, t[away[-1]] + 1.0))
    assert 3.0 - 1.0 < rr.rolling_window(b)[0] < 3.1 - 1.0 + 0.05


def test_gyro_minus_reference_recovers_a_bias_per_window():
    """Constant attitude, gyro = Earth rate in b + a bias that steps after 1 s (row k holds the
    interval ending at t_k): the window means are the bias of each window (the transport rate
    is zero at rest)."""
    b = synthetic_bundle(np.zeros(3), 1.0)
    b.truth.vel_n[:] = 0.0
    C_nb = b.truth.C_nb[0]
    bias = np.where(b.imu.t[:, None] <= 1.0 + 1e-9, [100.0, -200.0, 300.0], [-50.0, 0.0, 20.0])
    w_b = C_nb.T @ earth.omega_ie_n(LAT) + bias * D / 3600
    b.imu = ImuData(b.imu.t, w_b * 0.05, b.imu.dvel)
    g = rr.gyro_minus_reference(b, window_s=1.0)
    assert g["t_start_s"] == [0.0, 1.0, 2.0]
    np.testing.assert_allclose(g["mean_deg_h"], [[100.0, -200.0, 300.0], [-50.0, 0.0, 20.0],
                                                  [-50.0, 0.0, 20.0]], atol=1e-6)


def test_accel_minus_reference_at_rest_is_the_bias_and_its_tilt():
    """At rest with a tilted attitude the accelerometer reads ``C_n^b [0, 0, g] + b``; the
    function returns ``b`` and the tilt ``atan(hypot(b_x, b_y) / g)``."""
    b = synthetic_bundle(np.zeros(3), 1.0)
    b.truth.vel_n[:] = 0.0
    C_nb = b.truth.C_nb[0]
    g = earth.gravity(LAT, 100.0)
    bias = np.array([0.05, -0.02, 0.1])
    f_b = C_nb.T @ np.array([0.0, 0.0, g]) + bias
    b.imu = ImuData(b.imu.t, b.imu.dtheta, np.tile(f_b * 0.05, (len(b.imu.t), 1)))
    a = rr.accel_minus_reference(b)
    np.testing.assert_allclose(a["bias_m_s2"], bias, atol=1e-9)
    assert a["level_error_arcmin"] == pytest.approx(
        np.degrees(np.arctan(np.hypot(0.05, 0.02) / g)) * 60, rel=1e-6)


def test_no_still_period_is_bad_input():
    b = synthetic_bundle(np.zeros(3), 1.0)
    with pytest.raises(BadInput, match="no still period"):
        rr.still_period_end(b)
    with pytest.raises(BadInput, match="real data folder not found"):
        rr.reproduce_real("/tmp/unused", data_root="/nonexistent/real")


def test_level_error_is_the_tilt_whatever_the_heading():
    C_ref = rotations.dcm_from_euler([2 * D, -1 * D, 30 * D])
    tilted = rotations.dcm_from_euler([2.5 * D, -1 * D, 30 * D])       # 0.5 deg pitch
    assert rr.level_error(tilted, C_ref) == pytest.approx(0.5 * D, rel=1e-6)
    turned = rotations.dcm_from_euler([2 * D, -1 * D, 170 * D])        # heading only
    assert rr.level_error(turned, C_ref) == pytest.approx(0.0, abs=1e-12)


def _mounted_drive(mount_arcmin, scale_ppm, seed=3):
    """98 s simulated drive (accelerations, a 90 deg turn), navigation-grade IMU, odometer
    with a constant scale error and no lever arm, IMU mounted ``mount_arcmin`` in the car."""
    import yaml
    from inmotion.sim.scenario import find_scenario, load_scenario
    from inmotion.sim.simulate import simulate
    d = yaml.safe_load(open(find_scenario("paper003_drive")))
    d["vehicle_mounting_arcmin"] = list(mount_arcmin)
    d["sensors"] = {"odometer": {**d["sensors"]["odometer"], "scale_factor_sigma_ppm": 0.0,
                                 "scale_factor_ppm": scale_ppm, "lever_arm_m": [0.0, 0.0, 0.0]}}
    d["segments"] = [{"kind": "cruise", "duration_s": 10},
                     {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 0.5},
                     {"kind": "turn", "angle_deg": 90, "rate_deg_s": 3},
                     {"kind": "decelerate", "to_speed_m_s": 8, "decel_m_s2": 0.7},
                     {"kind": "accelerate", "to_speed_m_s": 14, "accel_m_s2": 0.6},
                     {"kind": "cruise", "duration_s": 20}]
    return simulate(load_scenario(d), np.random.default_rng(seed))


def test_od_kf_mounting_leaves_no_scale_bias():
    """Simulated truth: mounting of the comma2k19 size (3.8 deg pitch, -0.85 deg yaw) and a
    -0.5 % odometer scale. A first-order mounting model in the forward row would bias the
    scale by ``(alpha^2 + gamma^2) / 2`` (2300 ppm; measured +2309 ppm before issue 15); the
    displacement rows' forward row is now a length (``aided_kf._length_fill``), which has no
    such term: one pass finds the scale within 3 sigma and a fifth of that bias (measured
    -389 ppm, sigma 185), the second pass (first pass's mounting as the exact nominal
    rotation) as well (-80 ppm), and both find the mounting to a few arcmin."""
    mount = np.array([228.0, 0.0, -51.0])
    b = _mounted_drive(mount, -5000.0)
    init = rr._init_from_truth(b, b.imu.t[0])
    cfg = dict(measurement="displacement", fdi=False, use_baro=False,
               mount_sigma_arcmin=300.0, od_scale_sigma_ppm=10000.0)
    A = mount * D / 60
    bias = (A[0] ** 2 + A[2] ** 2) / 2
    for passes in (1, 2):
        _, _, _, r = rr.od_kf_iterated(b, cfg, init, passes=passes)
        err = r["scale"] - 1 + 5000e-6
        assert abs(err) < min(3 * r["scale_sigma"], 0.2 * bias), (passes, err, r["scale_sigma"])
        assert r["pitch_mount_deg"] * 60 == pytest.approx(mount[0], abs=3.0)
        assert r["yaw_mount_deg"] * 60 == pytest.approx(mount[2], abs=3.0)
    with pytest.raises(BadInput, match="passes"):
        rr.od_kf_iterated(b, cfg, init, passes=0)


DATA = rr.default_data_root()
needs_data = pytest.mark.skipif(not (DATA / "comma2k19_rav4_60s").is_dir()
                                or not (DATA / "ems_toronto_511s").is_dir(),
                                reason=f"real drives not found under {DATA}")


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    out = tmp_path_factory.mktemp("real")
    res = rr.reproduce(out)
    return out, res


@needs_data
def test_real_writes_report_rows_and_figures(real):
    out, res = real
    assert {"report.md", "results.json", "real_results.json", "real_position_error.png",
            "real_attitude_error.png", "real_mounting.png"} <= {p.name for p in out.iterdir()}
    rows = json.loads((out / "results.json").read_text())
    assert all(set(r) == {"quantity", "reference", "measured", "unit", "note"} for r in rows)
    text = (out / "report.md").read_text()
    assert "not an independent sensor" in text and "mounting roll" in text


@needs_data
def test_comma2k19_od_kf_mounting_against_the_reference(real):
    """Mounting estimated by od-kf (CAN speed + phone IMU, 60 s) against the angles measured
    from the reference pose (``reference_calibration``, 3.81 and -0.81 deg).

    Pitch within 0.5 deg: the vertical velocity ``v alpha`` (1.2 m/s for 3.8 deg at 18 m/s,
    0.16 m/s per 0.5 deg) stands far above the vertical NHC noise and is independent of the
    heading; the residual comes from the accelerometer z bias and the tilt (0.15 m/s^2 ~ 0.9
    deg if unestimated, mostly estimated). Yaw within 1.0 deg: the lateral velocity ``v gamma``
    is matched by a heading error or, at nearly constant speed, by a lateral accelerometer
    bias (0.07 m/s^2 measured against the reference) or z-gyro drift; the phone's z error
    against the reference is 100-150 deg/h and changes by ~100 deg/h within the minute
    (``gyro_minus_reference``), which a constant drift state cannot follow, so the heading
    drift not followed (up to ~1 deg over 60 s) goes partly into the yaw mount: 1 deg.
    """
    _, res = real
    c = res["drives"]["comma2k19_rav4_60s"]
    cal, est = c["reference_calibration"], c["estimated"]
    assert est["pitch_mount_deg"] == pytest.approx(cal["pitch_mount_deg"], abs=0.5)
    assert est["yaw_mount_deg"] == pytest.approx(cal["yaw_mount_deg"], abs=1.0)


@needs_data
def test_comma2k19_gauss_markov_gyro_bias_improves_the_calibration(real):
    """Issue 15: with the phone's gyro bias a Gauss-Markov process (the importer's assumed
    spec, 150 deg/h, 30 s) the yaw mounting moves towards the reference-derived value, its
    sigma covers its error (the constant-bias model's did not: 0.7 deg off, sigma 0.17), and
    dead reckoning with the estimated scale and mounting ends closer than with the constant
    model's. (The yaw target, 0.2 deg, is not met; the 20 m dead-reckoning target is met on
    this segment only with the constant + Gauss-Markov calibration, not robustly on simulated
    drives of its kind: report.md and tests/test_real_comma_bias.py say why.)"""
    _, res = real
    c = res["drives"]["comma2k19_rav4_60s"]
    cal, gm, const = c["reference_calibration"], c["estimated"], c["estimated_constant_bias"]
    err_gm = abs(gm["yaw_mount_deg"] - cal["yaw_mount_deg"])
    err_const = abs(const["yaw_mount_deg"] - cal["yaw_mount_deg"])
    assert err_gm < 0.6 * err_const
    assert err_gm <= 2.0 * gm["yaw_mount_sigma_deg"]
    assert err_const > 3.0 * const["yaw_mount_sigma_deg"]      # the former overconfidence
    runs = {r["run"]: r["final_horizontal_m"] for r in c["runs"]}
    assert runs["dr scale + mounting (od-kf)"] < runs["dr scale + mounting (od-kf constant bias)"]
    for g in c["gm_sensitivity"]:                                # every setting of the table
        assert abs(g["yaw_mount_deg"] - cal["yaw_mount_deg"]) < err_const, g


@needs_data
def test_comma2k19_level_attitude_and_position(real):
    """Level attitude: the coarse alignment's ``C_b^n(0)`` within 1 deg of the reference (the
    accelerometer biases of the phone, 0.07 / 0.15 m/s^2, allow ~0.5-1 deg); od-kf within
    1 deg over the whole run (started from the reference: it must hold the level the gyro
    biases of ~110 deg/h would lose, 2.5 deg in DR after 60 s). Aiding beats pure inertial,
    and the NHC needs the vehicle frame: with the estimated mounting it beats the IMU frame."""
    _, res = real
    c = res["drives"]["comma2k19_rav4_60s"]
    for r in c["coarse"]:
        assert r["start_level_arcmin"] < 60.0, r["run"]
    runs = {r["run"]: r for r in c["runs"]}
    assert runs["od-kf"]["max_level_arcmin"] < 60.0
    assert runs["od-kf"]["max_level_arcmin"] < runs["dr raw"]["max_level_arcmin"]
    assert runs["od-kf"]["final_horizontal_m"] < runs["sins"]["final_horizontal_m"]
    assert runs["dr raw"]["final_horizontal_m"] < runs["sins"]["final_horizontal_m"]
    assert (runs["nhc-kf (od-kf mounting)"]["final_horizontal_m"]
            < runs["nhc-kf (no mounting)"]["final_horizontal_m"])
    assert (runs["dr scale + mounting (from reference)"]["final_horizontal_m"]
            < runs["dr raw"]["final_horizontal_m"])
    assert c["reference_calibration"]["pitch_mount_deg"] == pytest.approx(3.8, abs=0.5)
    assert c["reference_calibration"]["yaw_mount_deg"] == pytest.approx(-0.8, abs=0.5)


@needs_data
def test_ems_nhc_bounds_the_inertial_error(real):
    """INS + NHC only against pure INS over the 511 s drive (both with the still-period gyro
    bias removed): pure INS is tens of km off (accelerometer biases integrate twice); the NHC
    bounds the velocity across and along-track errors grow with heading only, so the error
    stays within 10 % of the 2.1 km travelled."""
    _, res = real
    runs = {r["run"]: r for r in res["drives"]["ems_toronto_511s"]["runs"]}
    nhc, sins = runs["nhc-kf"], runs["sins"]
    assert sins["final_horizontal_m"] > 1000.0
    assert nhc["final_horizontal_pct_distance"] < 10.0
    assert nhc["max_horizontal_m"] < 0.05 * sins["max_horizontal_m"]
    assert (runs["dr pseudo-odometer + still gyro bias"]["final_horizontal_m"]
            < runs["dr pseudo-odometer"]["final_horizontal_m"])
