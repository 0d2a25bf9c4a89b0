"""The simulator's vehicle constraint violation (issue 15): side slip and bounce as a
Gauss-Markov velocity in the vehicle frame, consistent with the IMU increments, with the set
1-sigma and correlation time, zero at rest, written to meta, and off unless the scenario asks."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.core.bundle import BaroData, ImuData
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.sim import simulate, simulate_truth
from inmotion.sim.scenario import load_scenario
from inmotion.sim.sensors import vehicle_C_vb

CV = {"lateral_sigma_m_s": 0.05, "lateral_tau_s": 0.5, "vertical_sigma_m_s": 0.03,
      "vertical_tau_s": 0.2}
DRIVE = {
    "name": "cv", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "vehicle_mounting_arcmin": [10.0, 0.0, 15.0],
    "vehicle": {"constraint_violation": CV},
    "segments": [{"kind": "rest", "duration_s": 5},
                 {"kind": "accelerate", "to_speed_m_s": 12, "accel_m_s2": 1},
                 {"kind": "turn", "angle_deg": 60, "rate_deg_s": 5},
                 {"kind": "cruise", "duration_s": 60}],
}


def _vehicle_velocity(tr, mounting):
    vb = np.einsum("nji,nj->ni", rotations.dcm_from_euler(tr.euler), tr.vel_n)
    return vb @ vehicle_C_vb(mounting)          # v_v = C_b^v v_b


@pytest.fixture(scope="module")
def drive():
    return simulate_truth(DRIVE, np.random.default_rng(7))


def test_increments_reproduce_the_truth_with_the_violation(drive):
    """Error-free increments through the mechanization follow the truth, whose lateral and
    vertical velocity now move: the IMU senses the violation (the bounds of
    test_sim_trajectory's 600 s check)."""
    from inmotion.core.mechanization import strapdown
    _, _, tr = drive
    vv = _vehicle_velocity(tr, DRIVE["vehicle_mounting_arcmin"])
    assert vv[:, 0].std() > 0.02 and vv[:, 2].std() > 0.01
    init = NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0], tr.euler[0])
    sol = strapdown(ImuData(tr.t, tr.dtheta, tr.dvel), init, BaroData(tr.t, tr.h),
                    damping="baro")
    assert np.abs(sol.vel_n - tr.vel_n).max() < 5e-3
    att = rotations.misalignment(sol.C_nb, rotations.dcm_from_euler(tr.euler))
    assert np.abs(att).max() < 1.0 * np.pi / 180 / 3600


def test_violation_has_the_set_sigma_and_correlation_time_and_is_zero_at_rest(drive):
    d = dict(DRIVE)
    d["start"] = dict(DRIVE["start"], speed_m_s=20.0)
    d["segments"] = [{"kind": "cruise", "duration_s": 400}]
    _, _, tr = simulate_truth(d, np.random.default_rng(3))
    vv = _vehicle_velocity(tr, d["vehicle_mounting_arcmin"])
    g = 400.0 / 401.0                                    # the standstill fade at 20 m/s
    for col, axis in ((0, "lateral"), (2, "vertical")):
        x = vv[:, col] / g
        sigma, tau = CV[f"{axis}_sigma_m_s"], CV[f"{axis}_tau_s"]
        # 400 s / tau independent stretches: the sample sigma within about 3 / sqrt(800)
        assert x.std() == pytest.approx(sigma, rel=0.15)
        lag = int(round(tau * 100))
        xc = x - x.mean()
        rho = float(np.mean(xc[lag:] * xc[:-lag]) / xc.var())
        assert rho == pytest.approx(np.exp(-1.0), abs=0.1)
    _, _, tr = drive
    rest = tr.t < 4.9
    assert np.abs(tr.vel_n[rest]).max() == 0.0


def test_off_by_default_and_in_meta():
    d = {k: v for k, v in DRIVE.items() if k != "vehicle"}
    a = simulate(d, np.random.default_rng(5))
    b = simulate(dict(d, vehicle={"constraint_violation": {}}), np.random.default_rng(5))
    np.testing.assert_array_equal(a.imu.dvel, b.imu.dvel)     # zero sigma: nothing drawn
    assert "constraint_violation" not in a.meta["vehicle"]
    c = simulate(DRIVE, np.random.default_rng(5))
    assert c.meta["vehicle"]["constraint_violation"]["lateral_sigma_m_s"] == 0.05
    assert c.meta["vehicle"]["constraint_violation"]["vertical_tau_s"] == 0.2
    with pytest.raises(BadInput, match="lateral_tau_s"):
        load_scenario(dict(DRIVE, vehicle={"constraint_violation": {"lateral_tau_s": 0}}))


def test_paper_003_scenarios_carry_the_measured_violation():
    for name in ("paper003_drive", "paper003_faults", "paper003_parked_then_drive"):
        cv = load_scenario(name).vehicle.constraint_violation
        assert (cv.lateral_sigma_m_s, cv.lateral_tau_s) == (0.010, 0.5)
        assert (cv.vertical_sigma_m_s, cv.vertical_tau_s) == (0.020, 0.2)
