"""``dr`` (navigate.pure) against simulated truth with the IMU mounted in the vehicle.

Error-free IMU and an error-free LDV giving the exact distance over every IMU interval (100 Hz,
no lever arm), so the only model question left is the mounting:

- told the true vehicle mounting (from meta.yaml) the dead reckoner reproduces the truth. Bound:
  its attitude is the SINS's gyro update, error-free below 1 arcsec (tests/test_sim_trajectory),
  so the position error is below ``d * 1 arcsec`` (1.2 cm over the 2.5 km drive); resolving each
  0.01 s distance with the midpoint attitude leaves ``ds (omega dt)^2 / 24`` per row
  (< 1e-8 m). Bound used: 2 cm horizontal and vertical.
- assuming ``C_v^b = I`` it puts the speed along b's forward axis instead of
  ``C_v^b [0, 1, 0] = [-gamma, 1, alpha]``: first order, the track drifts right by
  ``gamma * d`` and down by ``alpha * d`` (straight road), in general by
  ``sum C_b^n [gamma, 0, -alpha] ds`` (second-order rest ``|A|^2 / 2 * d``).
"""
import numpy as np
import pytest

from inmotion.core import earth
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.navigate.pure import DrConfig, mounting_from_meta, run_dr
from inmotion.sim import simulate

ARCMIN = np.pi / 180 / 60
MOUNT_ARCMIN = [3.0, 10.0, 5.0]
LDV_EXACT = {"ldv": {"rate_hz": 100, "output": "distance"}}


def _scenario(segments, mount=MOUNT_ARCMIN, heading_deg=30.0):
    return {"name": "dr", "vehicle_mounting_arcmin": mount,
            "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380.0,
                      "heading_deg": heading_deg},
            "segments": segments, "sensors": LDV_EXACT}


STRAIGHT = [{"kind": "rest", "duration_s": 2},
            {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 1},
            {"kind": "cruise", "duration_s": 150}]
TURNING = [{"kind": "rest", "duration_s": 2},
           {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 1},
           {"kind": "turn", "angle_deg": 90, "rate_deg_s": 6},
           {"kind": "climb", "pitch_deg": 3, "duration_s": 30},
           {"kind": "turn", "angle_deg": -120, "rate_deg_s": 4},
           {"kind": "descend", "pitch_deg": 2, "duration_s": 30},
           {"kind": "cruise", "duration_s": 60}]


@pytest.fixture(scope="module")
def straight():
    return simulate(_scenario(STRAIGHT), np.random.default_rng(1))


@pytest.fixture(scope="module")
def turning():
    return simulate(_scenario(TURNING), np.random.default_rng(2))


def _init(b):
    tr = b.truth
    return NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0], tr.euler[0])


def _enu_error(sol, tr):
    """East, North, Up position error [m] of a solution at the truth times (estimate - truth)."""
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, tr.lat, tr.lon)
    return np.stack([de, dn, sol.h - tr.h], -1)


def _distance(b):
    return float(np.sum(b.ldv.ds))


def test_dr_with_the_meta_mounting_reproduces_truth(turning):
    sol = run_dr(turning, DrConfig(), _init(turning))
    assert sol.info["mounting_arcmin"] == MOUNT_ARCMIN
    err = _enu_error(sol, turning.truth)
    d = _distance(turning)
    assert d > 2000.0
    assert np.hypot(err[:, 0], err[:, 1]).max() < 0.02
    assert np.abs(err[:, 2]).max() < 0.02


def test_dr_without_the_mounting_drifts_gamma_d_right_and_alpha_d_down(straight):
    alpha, _, gamma = np.array(MOUNT_ARCMIN) * ARCMIN
    sol = run_dr(straight, DrConfig(mounting_arcmin=(0.0, 0.0, 0.0)), _init(straight))
    assert sol.info["mounting_arcmin"] == [0.0, 0.0, 0.0]          # the config overrides meta
    e = _enu_error(sol, straight.truth)[-1]
    psi = np.radians(30.0)
    right = e[0] * np.cos(psi) - e[1] * np.sin(psi)                 # body x of heading psi
    along = e[0] * np.sin(psi) + e[1] * np.cos(psi)
    d = _distance(straight)
    second = (alpha ** 2 + gamma ** 2) / 2 * d + 0.02
    assert right == pytest.approx(gamma * d, abs=second)
    assert e[2] == pytest.approx(-alpha * d, abs=second)
    assert abs(along) < second
    assert gamma * d > 10 * second                                  # the effect is metres


def test_dr_without_the_mounting_follows_first_order_theory_in_turns(turning):
    """Naive minus told DR against ``sum C_b^n [gamma, 0, -alpha] ds`` over the rows."""
    alpha, _, gamma = np.array(MOUNT_ARCMIN) * ARCMIN
    told = run_dr(turning, DrConfig(), _init(turning))
    naive = run_dr(turning, DrConfig(mounting_arcmin=(0.0, 0.0, 0.0)), _init(turning))
    diff = _enu_error(naive, turning.truth) - _enu_error(told, turning.truth)
    ds = np.concatenate([[0.0], turning.ldv.ds])                  # one ds per IMU row
    theory = np.cumsum(turning.truth.C_nb @ np.array([gamma, 0.0, -alpha]) * ds[:, None], axis=0)
    d = _distance(turning)
    second = (alpha ** 2 + gamma ** 2) / 2 * d + 0.01
    np.testing.assert_allclose(diff, theory, atol=second)
    assert np.linalg.norm(theory[-1]) > 100 * second


def test_mounting_and_lever_arm_come_from_meta():
    meta = {"vehicle_mounting_arcmin": [1, 2, 3],
            "sensors": {"radar": {"mounting_arcmin": [9, 9, 9], "lever_arm_m": [0, 1.5, -0.4]}}}
    mount, lever = mounting_from_meta(meta, "radar")
    np.testing.assert_array_equal(mount, [1, 2, 3])                 # not the beam's [9, 9, 9]
    np.testing.assert_array_equal(lever, [0, 1.5, -0.4])
    assert mounting_from_meta({}, "radar") == (None, None)


@pytest.mark.parametrize("meta, words", [
    ({"vehicle_mounting_arcmin": [1, 2]}, "meta.yaml vehicle_mounting_arcmin must be 3 numbers"),
    ({"vehicle_mounting_arcmin": "abc"}, "meta.yaml vehicle_mounting_arcmin must be 3 numbers"),
    ({"sensors": {"ldv": {"lever_arm_m": [1, "x", 2]}}},
     "meta.yaml sensors.ldv.lever_arm_m must be 3 numbers"),
])
def test_bad_mounting_in_meta(straight, meta, words):
    b = straight.window()
    b.meta = meta
    with pytest.raises(BadInput) as e:
        run_dr(b, DrConfig(), _init(straight))
    assert words in str(e.value)


def test_dr_with_the_meta_lever_arm_reproduces_truth_in_turns():
    """A sensor 0.4 m right, 1.8 m ahead, 0.6 m below the IMU reads the forward part of
    ``omega x l``, ``omega_z l_x``, on top of the vehicle's speed (less on the inside of a
    turn): ``l_x`` times the heading change of distance, ``0.4 * pi/2 = 0.63 m`` over the
    first (90 deg) turn. Told the lever arm (from meta) the DR removes it (same bound as without
    a lever arm); ignoring it errs by about that much."""
    sc = _scenario(TURNING)
    sc["sensors"] = {"ldv": {**LDV_EXACT["ldv"], "lever_arm_m": [0.4, 1.8, -0.6]}}
    b = simulate(sc, np.random.default_rng(3))
    told = run_dr(b, DrConfig(), _init(b))
    assert told.info["lever_arm_m"] == [0.4, 1.8, -0.6]
    err = _enu_error(told, b.truth)
    assert np.hypot(err[:, 0], err[:, 1]).max() < 0.02 and np.abs(err[:, 2]).max() < 0.02
    naive = _enu_error(run_dr(b, DrConfig(lever_arm_m=(0, 0, 0)), _init(b)), b.truth)
    assert np.hypot(naive[:, 0], naive[:, 1]).max() > 0.8 * 0.4 * np.pi / 2
