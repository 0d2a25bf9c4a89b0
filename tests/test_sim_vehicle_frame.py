"""One vehicle frame v in the simulator (docs/ARCHITECTURE.md, "Vehicle frame and mounting").

The profile moves v; the IMU frame b is turned from it by ``vehicle_mounting_arcmin = A``,
``C_v^b = exp([A x])``. Checked against closed forms:

- truth attitude ``C_b^n = C_v^n C_b^v`` with ``C_v^n`` from the profile's Euler angles;
- the increments of a mounted IMU are those of an aligned one rotated by ``C_v^b`` (a constant
  rotation commutes with the time integral), to round-off;
- NHC holds in v (truth velocity resolved in v has zero x and z outside disturbance windows,
  and exactly the slip / jump bumps inside them), and not in b (``-gamma v``, ``alpha v``);
- a velocity sensor reads the vehicle's speed whatever the IMU mounting (its lever arm given in
  b turns with the IMU); its own beam misalignment acts only to second order;
- error-free increments through the mechanization still reproduce the truth;
- bad mounting input raises BadInput naming the field.
"""
import numpy as np
import pytest

from inmotion.core import earth, rotations
from inmotion.core.bundle import BaroData, ImuData
from inmotion.core.mechanization import strapdown
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.sim import load_scenario, simulate, simulate_truth
from inmotion.sim.profile import _bump
from inmotion.sim.sensors import vehicle_C_vb

ARCMIN = np.pi / 180 / 60
ARCSEC = ARCMIN / 60
MOUNT_ARCMIN = [3.0, 10.0, 5.0]            # paper 000's figures
BIG_MOUNT_ARCMIN = [60.0, -120.0, 90.0]    # large enough that second-order terms would show

SLIP = {"t_s": 40.0, "duration_s": 1.5, "speed_m_s": 0.5}
JUMP = {"t_s": 70.0, "duration_s": 1.5, "height_m": 0.05}


def _drive(mount=None, sensors=None, disturbances=None):
    """A 150 s drive with a turn, a climb and a descent (and optional disturbances)."""
    d = {"name": "vf", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380.0,
                                 "heading_deg": 30.0},
         "segments": [{"kind": "rest", "duration_s": 5},
                      {"kind": "accelerate", "to_speed_m_s": 12, "accel_m_s2": 1},
                      {"kind": "turn", "angle_deg": 90, "rate_deg_s": 6},
                      {"kind": "climb", "pitch_deg": 3, "duration_s": 30},
                      {"kind": "turn", "angle_deg": -60, "rate_deg_s": 4},
                      {"kind": "descend", "pitch_deg": 2, "duration_s": 30},
                      {"kind": "cruise", "duration_s": 35},
                      {"kind": "stop", "decel_m_s2": 1}],
         "sensors": sensors or {}}
    if mount is not None:
        d["vehicle_mounting_arcmin"] = mount
    if disturbances:
        d["disturbances"] = disturbances
    return d


@pytest.fixture(scope="module")
def aligned_and_mounted():
    _, prof, tr0 = simulate_truth(_drive())
    _, _, tr1 = simulate_truth(_drive(BIG_MOUNT_ARCMIN))
    return prof, tr0, tr1


def _in_v(C_nb, C_vb, vec_n):
    """``C_b^v C_n^b vec_n``: an n-frame vector resolved in the vehicle frame."""
    vec_b = np.einsum("kji,kj->ki", C_nb, vec_n)
    return vec_b @ C_vb                       # rows: (C_b^v vec_b)^T = vec_b^T C_v^b


def test_truth_attitude_is_the_vehicle_attitude_turned_by_the_mounting(aligned_and_mounted):
    prof, tr0, tr1 = aligned_and_mounted
    C_vb = vehicle_C_vb(BIG_MOUNT_ARCMIN)
    C_nv = rotations.dcm_from_euler(prof.kinematics(tr1.t)[0])
    np.testing.assert_allclose(rotations.dcm_from_euler(tr1.euler), C_nv @ C_vb.T, atol=1e-12)
    # the aligned IMU is the vehicle, and position / velocity are the reference point's
    np.testing.assert_allclose(rotations.dcm_from_euler(tr0.euler), C_nv, atol=1e-12)
    np.testing.assert_array_equal(tr1.vel_n, tr0.vel_n)
    np.testing.assert_array_equal(tr1.lat, tr0.lat)
    np.testing.assert_array_equal(tr1.h, tr0.h)


def test_increments_are_the_aligned_ones_rotated_by_C_vb(aligned_and_mounted):
    """omega_ib_b = C_v^b omega_iv_v and f_b = C_v^b f_v; C_v^b is constant, so the increments
    (time integrals) rotate the same way."""
    _, tr0, tr1 = aligned_and_mounted
    C_vb = vehicle_C_vb(BIG_MOUNT_ARCMIN)
    np.testing.assert_allclose(tr1.dtheta, tr0.dtheta @ C_vb.T, atol=1e-16)
    np.testing.assert_allclose(tr1.dvel, tr0.dvel @ C_vb.T, atol=1e-13)
    assert np.abs(tr1.dtheta - tr0.dtheta).max() > 1e-7       # the mounting does show


def test_nhc_holds_in_the_vehicle_frame_not_in_b():
    sc, prof, tr = simulate_truth(_drive(MOUNT_ARCMIN, disturbances={"side_slips": [SLIP],
                                                                     "jumps": [JUMP]}))
    C_vb = vehicle_C_vb(MOUNT_ARCMIN)
    C_nb = rotations.dcm_from_euler(tr.euler)
    v_v = _in_v(C_nb, C_vb, tr.vel_n)
    s_slip, s_jump = (tr.t - SLIP["t_s"]) / SLIP["duration_s"], (tr.t - JUMP["t_s"]) / JUMP["duration_s"]
    np.testing.assert_allclose(v_v[:, 0], SLIP["speed_m_s"] * _bump(s_slip, 0), atol=1e-9)
    np.testing.assert_allclose(v_v[:, 2], JUMP["height_m"] * _bump(s_jump, 1)
                               / JUMP["duration_s"], atol=1e-9)
    outside = (_bump(s_slip, 0) == 0) & (_bump(s_jump, 1) == 0)
    assert np.abs(v_v[outside][:, [0, 2]]).max() < 1e-9
    # in b the vehicle's motion is C_v^b [0, v, 0]: lateral -gamma v and vertical +alpha v to
    # first order (second-order rest below |A|^2 / 2 v)
    v_b = np.einsum("kji,kj->ki", C_nb, tr.vel_n)
    A = np.array(MOUNT_ARCMIN) * ARCMIN
    speed = v_v[:, 1]
    np.testing.assert_allclose(v_b[outside], speed[outside, None] * C_vb[:, 1], atol=1e-9)
    second = A @ A / 2 * speed.max()
    np.testing.assert_allclose(v_b[outside, 0], -A[2] * speed[outside], atol=second)
    np.testing.assert_allclose(v_b[outside, 2], A[0] * speed[outside], atol=second)
    assert np.abs(v_b[outside, 0]).max() > 0.015


def test_sensor_reads_the_vehicle_speed_whatever_the_imu_mounting():
    """With the lever arm given in b, a mounted IMU with lever l_b sees the same sensor point as
    an aligned one with lever C_b^v l_b; the reading is the same (to round-off)."""
    C_vb = vehicle_C_vb(BIG_MOUNT_ARCMIN)
    l_b = np.array([0.4, 1.8, -0.6])
    l_v = C_vb.T @ l_b
    _, _, tr1 = simulate_truth(_drive(BIG_MOUNT_ARCMIN, {"radar": {"rate_hz": 100,
                                                                   "lever_arm_m": list(l_b)}}))
    _, _, tr0 = simulate_truth(_drive(None, {"radar": {"rate_hz": 100,
                                                       "lever_arm_m": list(l_v)}}))
    np.testing.assert_allclose(tr1.sensor_speed["radar"], tr0.sensor_speed["radar"], atol=1e-12)
    # and with no lever arm it is the speed of the reference point
    _, _, tr = simulate_truth(_drive(BIG_MOUNT_ARCMIN, {"ldv": {"rate_hz": 100}}))
    np.testing.assert_allclose(tr.sensor_speed["ldv"], np.linalg.norm(tr.vel_n, axis=1),
                               atol=1e-12)


def test_beam_misalignment_acts_to_second_order():
    """A beam turned by A_s reads [C_v^s v_v]_y = (exp(-[A_s x]))_yy v = v (1 - O(A_s^2))."""
    beam = np.array([30.0, 20.0, 40.0])
    _, _, tr = simulate_truth(_drive(MOUNT_ARCMIN, {"ldv": {"rate_hz": 100,
                                                            "mounting_arcmin": list(beam)}}))
    speed = np.linalg.norm(tr.vel_n, axis=1)
    factor = rotations.mounting_dcm(beam * ARCMIN)[1, 1]        # (C_s^v)^T_yy = (C_s^v)_yy
    np.testing.assert_allclose(tr.sensor_speed["ldv"], factor * speed, atol=1e-12)
    a, _, g = beam * ARCMIN
    assert 1.0 - factor == pytest.approx((a * a + g * g) / 2, rel=1e-3)


def test_error_free_mechanization_reproduces_the_mounted_truth(aligned_and_mounted):
    """Issue 2 acceptance with a mounted IMU: bounds 1 m * 150/3600, 5 mm/s, 1 arcsec."""
    _, _, tr = aligned_and_mounted
    init = NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0],
                               tr.euler[0])
    sol = strapdown(ImuData(tr.t, tr.dtheta, tr.dvel), init, BaroData(tr.t, tr.h),
                    damping="baro")
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, tr.lat, tr.lon)
    att = rotations.misalignment(sol.C_nb, rotations.dcm_from_euler(tr.euler))
    assert np.hypot(dn, de).max() < 1.0 * 150 / 3600
    assert np.abs(sol.vel_n - tr.vel_n).max() < 5e-3
    assert np.abs(att).max() < 1.0 * ARCSEC


def test_meta_carries_the_vehicle_mounting():
    b = simulate(_drive(MOUNT_ARCMIN, {"radar": {"rate_hz": 10, "lever_arm_m": [0, 1, 0]}}),
                 np.random.default_rng(0))
    assert b.meta["vehicle_mounting_arcmin"] == MOUNT_ARCMIN
    assert b.meta["sensors"]["radar"]["mounting_arcmin"] == [0.0, 0.0, 0.0]
    assert b.meta["lever_arms_m"]["radar"] == [0, 1, 0]
    assert simulate(_drive(), np.random.default_rng(0)).meta["vehicle_mounting_arcmin"] == [0, 0, 0]


@pytest.mark.parametrize("name", ["paper000_traj1", "paper000_traj1_slip", "paper000_traj2"])
def test_paper000_mounting_is_the_vehicle_mounting(name):
    sc = load_scenario(name)
    assert sc.vehicle_mounting_arcmin == MOUNT_ARCMIN
    assert sc.sensors.radar.mounting_arcmin == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("value, words", [
    ([3.0, 10.0], "vehicle_mounting_arcmin"),
    ([0.0, 0.0, 3000.0], "vehicle_mounting_arcmin: [0.0, 0.0, 3000.0] arcmin"),
])
def test_bad_vehicle_mounting(value, words):
    with pytest.raises(BadInput) as e:
        load_scenario(_drive(value))
    assert words in str(e.value)
