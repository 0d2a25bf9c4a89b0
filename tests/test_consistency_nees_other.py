"""Issue 15: NEES in band for the Kalman-type methods outside paper 003's sensor filters
(``parked-kf``, ``sins-dr``, ``dr-kf``, ``od-velocity-kf``) over a small Monte Carlo
(:mod:`consistency_mc`), with noise settings matched to the simulated sensors, and an
overconfident setting that fails."""
import pytest

from consistency_mc import IMU_003, drive_003, final_nees, parked_003

RUNS = 6


@pytest.fixture(scope="module")
def drive():
    return drive_003()


@pytest.fixture(scope="module")
def parked():
    return parked_003()


def test_parked_kf_nees_in_band(parked):
    # parked-kf reads the IMU figures from meta.yaml; the start 0.5 / 0.5 / 2 deg off
    m, (lo, hi), v = final_nees("parked-kf", {"init_heading_sigma_deg": 2.0}, parked, RUNS,
                                (0.5, 0.5, 2.0))
    assert lo <= m <= hi, (m, (lo, hi), v)


def test_parked_kf_overconfident_zero_velocity_fails(parked):
    """Zero-velocity noise 1e-4 m/s on a vibrating, rocking parked vehicle: far above."""
    m, (lo, hi), v = final_nees("parked-kf", {"init_heading_sigma_deg": 2.0,
                                              "zero_velocity_noise_m_s": 1e-4},
                                parked, RUNS, (0.5, 0.5, 2.0))
    assert m > hi, (m, (lo, hi), v)


#: sins-dr: the IMU figures and the LDV's white noise set (as paper 003 states them), the rest
#: from meta.yaml (``noise_preset: matched``: the LDV's 500 ppm constant scale factor).
#: Measured (issue 15, ``benchmarks/nees_methods.py 20 sins-dr``): 2.95 over 20 runs (per axis
#: E / N / U 1.58 / 0.71 / 0.66; 2.64 with the field defaults for the rest; seeds 200-219:
#: 2.24), band 2.02-4.16
def test_sins_dr_nees_in_band(drive):
    cfg = dict(IMU_003, velocity_sensor="ldv", init_tilt_sigma_arcmin=6.0,
               init_heading_sigma_arcmin=30.0, speed_noise_m_s=0.01)
    m, (lo, hi), v = final_nees("sins-dr", cfg, drive, RUNS, (0.1, 0.1, 0.5))
    assert lo <= m <= hi, (m, (lo, hi), v)


#: dr-kf / od-velocity-kf: everything else from meta.yaml (``noise_preset: matched``: the IMU
#: figures, the LDV's forward noise at the measurement epochs and its constant scale factor,
#: and the cross rows' noise from the vehicle's constraint violation that paper 003's drive now
#: carries, ``dr_kalman.constraint_noise_from_meta``). The start velocity error is drawn from
#: the prior the configuration states (0.1 m/s), since velocity matching sees it together with
#: the heading (started at the true velocity, a 0.1 m/s prior leaves every sigma large).
#: Measured (issue 15, ``benchmarks/nees_methods.py 20 dr-kf,od-velocity-kf``): over 20 runs
#: 2.46 (dr-kf) and 2.62 (od-velocity-kf) against the 20-run band 2.02-4.16; paper preset
#: 1.63; the fixed floor of 3e-3 m/s the test used before the simulated vehicle broke its
#: constraint gave 45 / 58 over these 6 runs once it did (overconfident).
VELOCITY_MATCHING = dict(velocity_sensor="ldv", init_tilt_sigma_deg=0.1, init_heading_sigma_deg=0.5,
                         init_velocity_sigma_m_s=0.1)


@pytest.mark.parametrize("method", ["dr-kf", "od-velocity-kf"])
def test_velocity_matching_filters_nees_in_band(drive, method):
    m, (lo, hi), v = final_nees(method, VELOCITY_MATCHING, drive, RUNS, (0.1, 0.1, 0.5),
                                velocity_sigma_m_s=0.1)
    assert lo <= m <= hi, (m, (lo, hi), v)


def test_velocity_matching_overconfident_speed_noise_fails(drive):
    """The LDV's speed at the epochs taken as ten times better than it is (7e-4 against
    0.0071 m/s)."""
    m, (lo, hi), v = final_nees("od-velocity-kf", dict(VELOCITY_MATCHING, velocity_noise_m_s=7e-4),
                                drive, RUNS, (0.1, 0.1, 0.5), velocity_sigma_m_s=0.1)
    assert m > hi, (m, (lo, hi), v)
