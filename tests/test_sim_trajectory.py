"""The simulated truth is consistent with the navigation equations.

- error-free increments through the mechanization reproduce the truth (the acceptance of
  issue 2 on a 600 s drive, bounds scaled from the 3600 s ones);
- the pure vertical channel diverges as theory says (cosh of sqrt(2 g / R) t);
- increments match finite differences of the truth; at rest they are the closed forms;
- the Euler-rate formula matches a finite difference of the DCM.
"""
import numpy as np
import pytest

from inmotion.core import earth, rotations
from inmotion.core.bundle import BaroData, ImuData
from inmotion.core.solution import NavState
from inmotion.sim import simulate_truth
from inmotion.sim.trajectory import omega_nb_b_from_euler

ARCSEC = np.pi / 180 / 3600

VARIED_600S = {
    "name": "varied600",
    "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "segments": [
        {"kind": "rest", "duration_s": 20},
        {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 1},
        {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
        {"kind": "climb", "pitch_deg": 3, "duration_s": 60},
        {"kind": "accelerate", "to_speed_m_s": 22, "accel_m_s2": 0.5},
        {"kind": "turn", "angle_deg": -120, "rate_deg_s": 3},
        {"kind": "descend", "pitch_deg": 4, "duration_s": 50},
        {"kind": "cruise", "duration_s": 60},
        {"kind": "stop", "decel_m_s2": 1},
        {"kind": "rest", "duration_s": 30},
        {"kind": "accelerate", "to_speed_m_s": 12, "accel_m_s2": 1},
        {"kind": "turn", "angle_deg": 180, "rate_deg_s": 6},
        {"kind": "cruise", "duration_s": 150},
        {"kind": "stop", "decel_m_s2": 0.8},
        {"kind": "rest", "duration_s": 48},
    ],
}


@pytest.fixture(scope="module")
def varied():
    return simulate_truth(VARIED_600S)


def _init(tr, dh=0.0):
    return NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0] + dh, tr.vel_n[0],
                               tr.euler[0])


def _errors(sol, tr):
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, tr.lat, tr.lon)
    att = rotations.misalignment(sol.C_nb, rotations.dcm_from_euler(tr.euler))
    return np.hypot(dn, de), np.abs(sol.vel_n - tr.vel_n), np.abs(att)


def test_drive_is_varied(varied):
    sc, prof, tr = varied
    assert prof.duration_s == pytest.approx(600.0)
    speed = np.linalg.norm(tr.vel_n, axis=1)
    assert speed.max() == pytest.approx(22.0, abs=1e-9)
    assert np.ptp(tr.h) > 10.0                        # climbs and descents
    assert (speed < 1e-12).sum() > 90 * 100           # stops


def test_error_free_mechanization_reproduces_truth(varied):
    """Issue 2 acceptance on 600 s: 1 m * 600/3600, 5 mm/s, 1 arcsec; perfect barometer."""
    from inmotion.core.mechanization import strapdown
    _, _, tr = varied
    imu = ImuData(tr.t, tr.dtheta, tr.dvel)
    sol = strapdown(imu, _init(tr), BaroData(tr.t, tr.h), damping="baro")
    hor, vel, att = _errors(sol, tr)
    assert hor.max() < 1.0 * 600 / 3600
    assert vel.max() < 5e-3
    assert att.max() < 1.0 * ARCSEC


def test_pure_vertical_channel_diverges_as_theory(varied):
    """Without damping, an initial height error grows as cosh(w t), w = sqrt(2 g / R)."""
    from inmotion.core.mechanization import strapdown
    _, _, tr = varied
    imu = ImuData(tr.t, tr.dtheta, tr.dvel)
    ref = strapdown(imu, _init(tr))
    off = strapdown(imu, _init(tr, dh=1.0))
    dh = off.h - ref.h                 # the error an initial 1 m error alone causes
    lat0 = tr.lat[0]
    r_m, r_n = earth.radii(lat0)
    w = np.sqrt(2 * earth.gravity(lat0, tr.h[0]) / np.sqrt(r_m * r_n))
    expected = np.cosh(w * (off.t - off.t[0]))
    assert expected[-1] > 1.5          # the divergence is visible over 600 s
    np.testing.assert_allclose(dh, expected, rtol=0.02)
    # and the error-free run itself stays on the truth without any damping
    assert np.abs(ref.h - tr.h).max() < 1e-3


def test_increments_match_finite_differences_of_truth(varied):
    """dtheta_k against the truth attitude change plus the n-frame rate; dvel_k against the
    truth velocity change with gravity and Coriolis removed (one interval, second order)."""
    _, _, tr = varied
    dt = tr.t[1] - tr.t[0]
    C = rotations.dcm_from_euler(tr.euler)
    k = np.arange(1, len(tr.t))
    # body rotation relative to n over the interval, plus n's rotation seen in b
    d_nb = rotations.rotvec_from_dcm(np.swapaxes(C[k - 1], -1, -2) @ C[k])
    lat_m, h_m = 0.5 * (tr.lat[k] + tr.lat[k - 1]), 0.5 * (tr.h[k] + tr.h[k - 1])
    v_m = 0.5 * (tr.vel_n[k] + tr.vel_n[k - 1])
    w_in = earth.omega_ie_n(lat_m) + earth.omega_en_n(lat_m, h_m, v_m)
    C_m = C[k - 1] @ rotations.dcm_from_rotvec(0.5 * d_nb)
    dth_fd = d_nb + np.einsum("kji,kj->ki", C_m, w_in) * dt
    assert np.abs(tr.dtheta[k] - dth_fd).max() < 1e-9          # rad; |dtheta| up to 1e-3
    # velocity: v_k - v_{k-1} = C_m (dvel) - (2 w_ie + w_en) x v dt + g dt (midpoint rule)
    w_c = 2 * earth.omega_ie_n(lat_m) + earth.omega_en_n(lat_m, h_m, v_m)
    dv_n = (np.einsum("kij,kj->ki", C_m, tr.dvel[k]) - np.cross(w_c, v_m) * dt
            + earth.gravity_n(lat_m, h_m) * dt)
    assert np.abs(dv_n - (tr.vel_n[k] - tr.vel_n[k - 1])).max() < 1e-6   # m/s per 0.01 s


def test_increments_at_rest_are_closed_form(varied):
    """Level, at rest: dtheta = C_n^b omega_ie_n dt, dvel = C_n^b [0, 0, g] dt."""
    _, _, tr = varied
    dt = tr.t[1] - tr.t[0]
    rows = tr.t <= 19.0
    C = rotations.dcm_from_euler(tr.euler[rows])
    lat, h = tr.lat[rows], tr.h[rows]
    w = np.einsum("kji,kj->ki", C, earth.omega_ie_n(lat)) * dt
    f = np.einsum("kji,kj->ki", C, -earth.gravity_n(lat, h)) * dt
    np.testing.assert_allclose(tr.dtheta[rows], w, atol=1e-18)
    np.testing.assert_allclose(tr.dvel[rows], f, atol=1e-14)
    assert tr.lat[0] == np.radians(34.2) and tr.h[0] == 380.0
    np.testing.assert_allclose(np.degrees(tr.euler[0]), [0, 0, 30], atol=1e-12)


def test_omega_nb_matches_finite_difference_of_dcm():
    rng = np.random.default_rng(3)
    e0, ed = rng.uniform(-1, 1, (50, 3)), rng.uniform(-0.5, 0.5, (50, 3))
    h = 1e-6
    Cp = rotations.dcm_from_euler(e0 + h * ed)
    Cm = rotations.dcm_from_euler(e0 - h * ed)
    C = rotations.dcm_from_euler(e0)
    w_fd = rotations.vee(np.swapaxes(C, -1, -2) @ (Cp - Cm) / (2 * h))
    np.testing.assert_allclose(omega_nb_b_from_euler(e0, ed), w_fd, atol=1e-8)


def test_turn_heading_roll_and_speed_follow_the_segments(varied):
    sc, prof, tr = varied
    kinds = [s[0] for s in prof.segments]
    i = kinds.index("turn")
    _, a, b = prof.segments[i]
    yaw = np.unwrap(tr.euler[:, 2])
    ia, ib = np.searchsorted(tr.t, [a, b])
    assert np.degrees(yaw[ib] - yaw[ia]) == pytest.approx(90.0, abs=1e-9)
    mid = (ia + ib) // 2
    assert tr.euler[mid, 1] < 0            # right turn rolls the body left (roll < 0)
    k = np.radians(sc.vehicle.roll_per_lateral_accel_deg_per_m_s2)
    v = np.linalg.norm(tr.vel_n[mid])
    assert tr.euler[mid, 1] == pytest.approx(-k * v * np.radians(5.0), rel=1e-9)
    # accelerate segment ends exactly at its target speed
    j = kinds.index("accelerate")
    ie = np.searchsorted(tr.t, prof.segments[j][2])
    assert np.linalg.norm(tr.vel_n[ie]) == pytest.approx(15.0, abs=1e-9)


def test_motion_is_smooth_across_segment_joins(varied):
    """Acceleration (from the truth velocity) has no jumps: C1 velocity at every join."""
    _, prof, _ = varied
    for _, a, _ in prof.segments[1:]:
        for eps in (1e-7,):
            lo, hi = prof.kinematics(np.array([a - eps, a + eps]))[3]
            np.testing.assert_allclose(lo, hi, atol=1e-5)


def test_increments_match_ecef_kinematics_of_truth(varied):
    """An independent check in the Earth-fixed frame, from the truth positions and attitudes
    alone (no transport rate, no Euler-rate formula): ``f = a_e + 2 w_ie x v_e - g`` and
    ``w_ib = w_eb + w_ie``, with ``a_e`` and ``dC_b^e/dt`` from sixth-order central differences
    (steps 0.05 s for positions, 0.02 s for the DCM; stencils inside one polynomial piece of the motion: the blends are C3 only at
    their joins) and the IMU's rates at ``t_k`` from the increments around it."""
    _, prof, tr = varied
    dt = tr.t[1] - tr.t[0]
    s, h = 5, 5 * dt
    joins = np.unique(np.concatenate([prof.accel.x, prof.yaw_rate.x, prof.pitch.x]))
    k = np.arange(3 * s + 5, len(tr.t) - 3 * s - 5, 7)
    near = np.abs(tr.t[k][:, None] - joins[None, :]).min(axis=1) < 3 * h + 2 * dt
    k = k[~near]
    r_e = earth.lla_to_ecef(tr.lat, tr.lon, tr.h)
    C_en = np.swapaxes(earth.enu_from_ecef_matrix(tr.lat, tr.lon), -1, -2)   # C_n^e
    C_eb = C_en @ rotations.dcm_from_euler(tr.euler)                         # C_b^e
    c1 = np.array([-1 / 60, 3 / 20, -3 / 4, 0.0, 3 / 4, -3 / 20, 1 / 60])
    c2 = np.array([1 / 90, -3 / 20, 3 / 2, -49 / 18, 3 / 2, -3 / 20, 1 / 90])

    def diff(x, c, p, step=s):   # differences from x[k]: the weights' sum is not exactly 0
        return sum(ci * (x[k + (i - 3) * step] - x[k]) for i, ci in enumerate(c)) / (step * dt) ** p

    w_ie_e = np.array([0.0, 0.0, earth.OMEGA_IE])
    v_e = np.einsum("kij,kj->ki", C_en[k], tr.vel_n[k])
    g_e = np.einsum("kij,kj->ki", C_en[k], earth.gravity_n(tr.lat[k], tr.h[k]))
    f_e = diff(r_e, c2, 2) + 2 * np.cross(w_ie_e, v_e) - g_e
    f_b = np.einsum("kji,kj->ki", C_eb[k], f_e)
    f_imu = _rate_at_row_ends(tr.dvel, k, dt)
    assert len(k) > 5000
    assert np.abs(f_imu - f_b).max() < 2e-5          # m/s^2 (2 ug); |f| ~ 9.8
    np.testing.assert_allclose(diff(r_e, c1, 1), v_e, atol=1e-7)
    W = np.swapaxes(C_eb[k], -1, -2) @ diff(C_eb, c1, 1, step=2)   # DCM: no large offsets
    w_ib = rotations.vee(W) + np.einsum("kji,j->ki", C_eb[k], w_ie_e)
    w_imu = _rate_at_row_ends(tr.dtheta, k, dt)
    assert np.abs(w_imu - w_ib).max() < 1.5e-8       # rad/s (0.003 deg/h): the O(dt^4) of the rate estimate in the blends


def _rate_at_row_ends(inc, k, dt):
    """Rate at t_k from increments, to O(dt^4): the means over 2 and 4 rows around t_k are
    ``x + dt^2 x''/6`` and ``x + 4 dt^2 x''/6``; Richardson removes the ``x''`` term."""
    m2 = (inc[k] + inc[k + 1]) / (2 * dt)
    m4 = (inc[k - 1] + inc[k] + inc[k + 1] + inc[k + 2]) / (4 * dt)
    return (4 * m2 - m4) / 3


def test_vibration_truth_is_consistent_at_high_rate():
    """Engine vibration (25 Hz, coning phases, linear shaking), 1000 Hz increments: the
    mechanization follows the truth (at 100 Hz its two-sample coning correction could not)."""
    from inmotion.core.mechanization import strapdown
    sc = {"name": "vib", "start": {"lat_deg": 40.0, "lon_deg": 116.0, "h_m": 50.0},
          "imu": {"rate_hz": 1000.0},
          "segments": [{"kind": "rest", "duration_s": 10.0}],
          "disturbances": {"vibration": [
              {"start_s": 0.0, "end_s": 10.0, "frequency_hz": 25.0, "fade_s": 0.5,
               "angular_amplitude_arcsec": [5.0, 8.0, 3.0], "phases_deg": [0, 120, 240],
               "linear_amplitude_mm": [0.02, 0.02, 0.05]},
              {"start_s": 0.0, "end_s": 10.0, "frequency_hz": 0.7, "fade_s": 1.0,
               "angular_amplitude_arcsec": 30.0, "linear_amplitude_mm": 1.0}]}}
    _, _, tr = simulate_truth(sc)
    assert np.abs(tr.dtheta).max() / 1e-3 > 5e-4          # it shakes: > 1e-4 rad/s
    sol = strapdown(ImuData(tr.t, tr.dtheta, tr.dvel), _init(tr))
    hor, vel, att = _errors(sol, tr)
    assert hor.max() < 1e-5 and vel.max() < 1e-6 and att.max() < 1e-3 * ARCSEC
