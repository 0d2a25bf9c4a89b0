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


def test_sins_dr_nees_in_band(drive):
    cfg = dict(IMU_003, velocity_sensor="ldv", init_tilt_sigma_arcmin=6.0,
               init_heading_sigma_arcmin=30.0, speed_noise_m_s=0.01)
    m, (lo, hi), v = final_nees("sins-dr", cfg, drive, RUNS, (0.1, 0.1, 0.5))
    assert lo <= m <= hi, (m, (lo, hi), v)


@pytest.mark.xfail(strict=True, reason="issue 15, open: over these 6 runs od-velocity-kf's "
                   "mean NEES is 7.3 (band 1.4-5.3; a level error about East of -0.1 to -0.26 "
                   "arcmin in most runs against a sigma of 0.08 arcmin), dr-kf's 0.87 (below "
                   "the band since its DR takes the sensor lever arm, merged from main)")
@pytest.mark.parametrize("method", ["dr-kf", "od-velocity-kf"])
def test_velocity_matching_filters_nees_in_band(drive, method):
    cfg = dict(IMU_003, velocity_sensor="ldv", init_tilt_sigma_deg=0.1,
               init_heading_sigma_deg=0.5, velocity_noise_m_s=0.01, nhc_noise_m_s=3e-3,
               lateral_noise_m_s=3e-3)
    m, (lo, hi), v = final_nees(method, cfg, drive, RUNS, (0.1, 0.1, 0.5))
    assert lo <= m <= hi, (m, (lo, hi), v)
