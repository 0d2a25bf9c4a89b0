"""Sensor error models: statistics recovered from long series, closed forms for geometry."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.sim import load_scenario, simulate, simulate_truth
from inmotion.sim.imu_errors import DEG_H, DEG_SQRT_H, UG, apply_imu_errors, draw_imu_errors
from inmotion.sim.scenario import Imu
from inmotion.sim.random_processes import markov
from inmotion.sim.sensors import mounting_C_mb

ARCMIN = np.pi / 180 / 60


def _drive(sensors, segments=None, disturbances=None, speed=0.0):
    d = {"name": "s", "start": {"lat_deg": 30.0, "lon_deg": 110.0, "h_m": 100.0,
                                "heading_deg": 10.0, "speed_m_s": speed},
         "segments": segments or [{"kind": "rest", "duration_s": 5},
                                  {"kind": "accelerate", "to_speed_m_s": 10, "accel_m_s2": 1},
                                  {"kind": "turn", "angle_deg": 90, "rate_deg_s": 6},
                                  {"kind": "cruise", "duration_s": 20},
                                  {"kind": "stop", "decel_m_s2": 1}],
         "sensors": sensors}
    if disturbances:
        d["disturbances"] = disturbances
    return d


def test_imu_noise_and_bias_statistics():
    """Drift and bias are the means, ARW sqrt(dt) and VRW sqrt(dt) the standard deviations
    of the increment errors, within Monte Carlo tolerance (N = 400 000 per axis)."""
    spec = Imu.model_validate({"rate_hz": 100, "gyro": {"drift_deg_h": [0.01, -0.02, 0.03],
                                                        "arw_deg_sqrt_h": 0.003},
                               "accel": {"bias_ug": [100, -50, 20], "vrw_ug_sqrt_hz": 10}})
    rng = np.random.default_rng(11)
    err = draw_imu_errors(spec, rng)
    n, dt = 400_000, 0.01
    z = np.zeros((n, 3))
    g, a = apply_imu_errors(z, z, dt, err, rng)
    s_g, s_a = 0.003 * DEG_SQRT_H * np.sqrt(dt), 10 * UG * np.sqrt(dt)
    np.testing.assert_allclose(g.std(axis=0), s_g, rtol=4 / np.sqrt(2 * n))
    np.testing.assert_allclose(a.std(axis=0), s_a, rtol=4 / np.sqrt(2 * n))
    np.testing.assert_allclose(g.mean(axis=0) / dt, np.array([0.01, -0.02, 0.03]) * DEG_H,
                               atol=4 * s_g / np.sqrt(n) / dt)
    np.testing.assert_allclose(a.mean(axis=0) / dt, np.array([100, -50, 20]) * UG,
                               atol=4 * s_a / np.sqrt(n) / dt)


def test_vrw_units_agree():
    """1 m/s/sqrt(h) = 1/60 m/s/sqrt(s) = (1/60 / 9.80665e-6) ug/sqrt(Hz)."""
    a = draw_imu_errors(Imu.model_validate({"accel": {"vrw_m_s_sqrt_h": 0.06}}), None)
    b = draw_imu_errors(Imu.model_validate({"accel": {"vrw_ug_sqrt_hz": 1e-3 / UG}}), None)
    assert a.vrw == pytest.approx(1e-3) and b.vrw == pytest.approx(1e-3)


def test_scale_factor_and_misalignment_matrix():
    spec = Imu.model_validate({"gyro": {"scale_factor_ppm": [100, 200, 300],
                                        "misalignment_arcsec": [10, 20, 30]},
                               "accel": {"misalignment_arcsec": [1, 2, 3, 4, 5, 6]}})
    err = draw_imu_errors(spec, None)
    x = np.array([[1e-3, -2e-3, 5e-4]])
    g, a = apply_imu_errors(x, x, 0.01, err, np.random.default_rng(0))
    a_rot = np.radians(np.array([10, 20, 30]) / 3600)
    expected = x[0] * (1 + np.array([100, 200, 300]) * 1e-6) - np.cross(a_rot, x[0])
    np.testing.assert_allclose(g[0], expected, rtol=0, atol=1e-15)
    M = np.radians(np.array([[0, 1, 2], [3, 0, 4], [5, 6, 0]]) / 3600)
    np.testing.assert_allclose(a[0], x[0] + M @ x[0], atol=1e-15)


def test_random_constants_have_the_given_sigma():
    spec = Imu.model_validate({"constant_errors": "random", "gyro": {"drift_deg_h": 0.01}})
    rng = np.random.default_rng(5)
    eps = np.array([draw_imu_errors(spec, rng).eps for _ in range(3000)]) / DEG_H
    assert eps.std() == pytest.approx(0.01, rel=0.05) and abs(eps.mean()) < 0.001


def test_markov_recovers_sigma_and_correlation_time():
    """Lag-1 regression gives phi = exp(-T/tau); the variance is the stationary one."""
    rng = np.random.default_rng(2)
    n, T, tau, sigma = 200_000, 10.0, 300.0, 1e-3
    x = markov(n, T, sigma, tau, rng)
    phi = np.dot(x[:-1], x[1:]) / np.dot(x[:-1], x[:-1])
    tau_hat = -T / np.log(phi)
    # sd(phi) ~ sqrt((1 - phi^2) / n) -> sd(tau) ~ 5 s here; allow 4 sigma
    assert tau_hat == pytest.approx(tau, abs=25.0)
    n_eff = n * T / (2 * tau)
    assert x.std() == pytest.approx(sigma, rel=4 / np.sqrt(n_eff))
    # started stationary: the first samples of many runs have the stationary spread
    x0 = [markov(2, T, sigma, tau, rng)[0] for _ in range(4000)]
    assert np.std(x0) == pytest.approx(sigma, rel=0.05)


def test_radar_lever_arm_in_a_steady_turn():
    """Forward speed of a point at lever arm l: v + (omega x l)_y = v + omega_z l_x."""
    b = simulate(_drive({"radar": {"rate_hz": 100, "lever_arm_m": [1.5, 0.0, 0.0]}}),
                 np.random.default_rng(0))
    sc, prof, tr = simulate_truth(_drive({}))
    _, a, e = [s for s in prof.segments if s[0] == "turn"][0]
    m = (b.radar.t > a + 3) & (b.radar.t < e - 3)            # steady part of the turn
    v = np.linalg.norm(tr.vel_n[m], axis=1)
    w_z = -np.radians(6.0) * np.cos(tr.euler[m, 0]) * np.cos(tr.euler[m, 1])  # roll is small
    np.testing.assert_allclose(b.radar.v[m], v + w_z * 1.5, atol=2e-6)  # Earth/transport rate ~1e-4 * 1.5


def test_mounting_angles_first_order_effect_on_side_slip():
    """With a side slip v_x, a radar mounted with yaw offset gamma reads v_y - gamma v_x
    (beam misalignment C_v^s = exp(-[A x]) = I - [A x] to first order, paper 000 eq. 9: first
    order in the slip, while with no slip the beam acts to second order)."""
    gamma_arcmin = 60.0
    dist = {"side_slips": [{"t_s": 20.0, "duration_s": 2.0, "speed_m_s": 0.5}]}
    seg = [{"kind": "cruise", "duration_s": 30}]
    b0 = simulate(_drive({"radar": {"rate_hz": 100}}, seg, dist, speed=10.0),
                  np.random.default_rng(0))
    b1 = simulate(_drive({"radar": {"rate_hz": 100, "mounting_arcmin": [0, 0, gamma_arcmin]}},
                         seg, dist, speed=10.0), np.random.default_rng(0))
    i = np.searchsorted(b0.radar.t, 21.0)                    # slip peak: v_x = 0.5 m/s
    diff = b1.radar.v[i] - b0.radar.v[i]
    g = gamma_arcmin * ARCMIN
    assert diff == pytest.approx(-g * 0.5 - 0.5 * g * g * 10.0, rel=1e-3)


def test_mounting_matrix_is_first_order_i_plus_skew():
    A = np.array([3.0, 10.0, 5.0])
    C_mb = mounting_C_mb(A)
    np.testing.assert_allclose(C_mb @ C_mb.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(C_mb, np.eye(3) - rotations.skew(A * ARCMIN), atol=1e-5)


def test_odometer_quantization_and_scale():
    ppm = 20.0
    b = simulate(_drive({"odometer": {"rate_hz": 10, "pulses_per_m": ppm,
                                      "scale_factor_ppm": 5000}}), np.random.default_rng(0))
    _, _, tr = simulate_truth(_drive({"odometer": {"rate_hz": 10, "pulses_per_m": ppm}}))
    pulses = b.odometer.ds * ppm
    np.testing.assert_allclose(pulses, np.round(pulses), atol=1e-9)   # whole pulses
    true_total = tr.sensor_distance["odometer"][1:].sum()             # rows after t = 0
    assert b.odometer.ds.sum() == pytest.approx(1.005 * true_total, abs=1.0 / ppm)
    assert b.odometer.t[0] == pytest.approx(0.1)                      # first ds over (0, 0.1]


def test_ldv_distance_and_baro_statistics():
    rng = np.random.default_rng(4)
    sensors = {"ldv": {"rate_hz": 50, "output": "distance", "scale_factor_ppm": -500},
               "baro": {"rate_hz": 100, "bias_m": 3.0, "noise_m": 2.0}}
    b = simulate(_drive(sensors), rng)
    _, _, tr = simulate_truth(_drive(sensors))
    assert b.ldv.v is None
    assert b.ldv.ds.sum() == pytest.approx(0.9995 * tr.sensor_distance["ldv"][1:].sum(),
                                           abs=1e-9)
    e = b.baro.h - tr.h
    n = len(e)
    assert e.mean() == pytest.approx(3.0, abs=4 * 2.0 / np.sqrt(n))
    assert e.std() == pytest.approx(2.0, rel=4 / np.sqrt(2 * n))


def test_imu_markov_bias_has_its_sigma_and_correlation():
    """Bias instability: per-row bias recovered from the increments of a still IMU."""
    spec = Imu.model_validate({"gyro": {"drift_markov_deg_h": 0.01, "drift_markov_tau_s": 100.0},
                               "accel": {"bias_markov_ug": 30.0, "bias_markov_tau_s": 50.0}})
    rng = np.random.default_rng(9)
    err = draw_imu_errors(spec, rng)
    n, dt = 400_000, 0.01
    z = np.zeros((n, 3))
    g, a = apply_imu_errors(z, z, dt, err, rng)
    for x, sigma, tau in ((g / dt / DEG_H, 0.01, 100.0), (a / dt / UG, 30.0, 50.0)):
        n_eff = n * dt / (2 * tau) * 3                     # three independent axes
        assert x.std() == pytest.approx(sigma, rel=4 / np.sqrt(n_eff))
        lag = int(tau / dt)
        rho = np.mean(x[:-lag] * x[lag:]) / x.var()
        assert rho == pytest.approx(np.exp(-1.0), abs=4 / np.sqrt(n_eff))


def test_quadrature_converged_with_disturbances():
    """Default nodes against 8 nodes on a drive with slips, jumps and fast vibration."""
    d = _drive({}, disturbances={
        "side_slips": [{"t_s": 8.0, "duration_s": 1.5, "speed_m_s": 0.5}],
        "jumps": [{"t_s": 12.0, "duration_s": 1.5, "height_m": 0.05}],
        "vibration": [{"start_s": 0.0, "end_s": 6.0, "frequency_hz": 25.0,
                       "angular_amplitude_arcsec": 10.0, "linear_amplitude_mm": 0.02}]})
    _, _, a = simulate_truth(d)
    _, _, b = simulate_truth(dict(d, quadrature_nodes=8))
    assert np.abs(a.dtheta - b.dtheta).max() < 1e-15
    assert np.abs(a.dvel - b.dvel).max() < 1e-13
    d["disturbances"]["vibration"] = []                    # driving alone: 3 nodes
    assert load_scenario(d).nodes == 3
    _, _, a = simulate_truth(d)
    _, _, b = simulate_truth(dict(d, quadrature_nodes=8))
    assert np.abs(a.dtheta - b.dtheta).max() < 1e-16
    assert np.abs(a.dvel - b.dvel).max() < 1e-14
