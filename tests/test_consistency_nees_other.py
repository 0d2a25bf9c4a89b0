"""Issue 15: NEES in band for the Kalman-type methods outside paper 003's sensor filters
(``parked-kf``, ``nhc-kf`` parked, ``sins-dr``, ``dr-kf``, ``od-velocity-kf``) over a small Monte Carlo
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


def test_nhc_kf_parked_takes_its_still_start_as_a_stop(parked):
    """nhc-kf has no speed sensor: on a standing vehicle its along-track velocity is measured
    by nothing, ran (standard and invariant feedback alike) to 2-11 m/s in 120 s, and the NHC
    rows linearized at that velocity took the tilt for known (issue 15, session 24: NEES 684
    over 10 runs, band 1.68-4.70). With ``detect_start_stop`` (default) the IMU's stillness
    test finds the parked start and the window is a stop: in band (measured 3.22 over 10
    runs; the first 6, these: 3.91); without it far above (471)."""
    m, (lo, hi), v = final_nees("nhc-kf", {"init_heading_sigma_deg": 2.0}, parked, RUNS,
                                (0.5, 0.5, 2.0))
    assert lo <= m <= hi, (m, (lo, hi), v)
    m, (lo, hi), v = final_nees("nhc-kf", {"init_heading_sigma_deg": 2.0,
                                           "detect_start_stop": False}, parked, RUNS,
                                (0.5, 0.5, 2.0))
    assert m > 10.0 * hi, (m, (lo, hi), v)


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


# ------------------------------------------------------------------ a phone-grade IMU
@pytest.fixture(scope="module")
def phone_drive():
    """A comma2k19-like 60 s drive, phone IMU with a 110 deg/h constant and a 50 deg/h, 30 s
    Gauss-Markov gyro bias (``reproductions.real.comma_like_scenario``)."""
    from inmotion.reproductions.real import comma_like_scenario
    from inmotion.sim.scenario import load_scenario
    return load_scenario(comma_like_scenario())


def test_markov_as_random_walk_closed_form():
    from inmotion.align.dr_kalman import OdVelocityKfConfig, config_with_spec
    from inmotion.align.meta_spec import markov_as_random_walk
    meta = {"imu": {"source": "assumed",
                    "gyro": {"drift_deg_h": 110.0, "drift_markov_deg_h": 50.0,
                             "drift_markov_tau_s": 30.0},
                    "accel": {"bias_ug": 8000.0, "bias_markov_ug": 2000.0,
                              "bias_markov_tau_s": 120.0}}}
    rw, origin = markov_as_random_walk(meta)
    # 50 deg/h sqrt(2 / 30 s) = 12.91 deg/h/sqrt(s) = 774.6 deg/h/sqrt(h); 2000 ug sqrt(2/120) 60
    assert rw["gyro_bias_rw_deg_h_sqrt_h"] == pytest.approx(774.597, abs=1e-3)
    assert rw["accel_bias_rw_ug_sqrt_h"] == pytest.approx(15491.93, abs=1e-2)
    assert origin == "meta.imu (assumed): Gauss-Markov part as a random walk"
    assert markov_as_random_walk({"imu": {"gyro": {"drift_deg_h": 1.0}}})[0] == {}
    cfg, src = config_with_spec(OdVelocityKfConfig(), meta, "odometer")
    assert cfg.gyro_bias_rw_deg_h_sqrt_h == pytest.approx(774.597, abs=1e-3)
    assert src["gyro_bias_rw_deg_h_sqrt_h"] == origin
    mine = OdVelocityKfConfig(gyro_bias_rw_deg_h_sqrt_h=1.0)     # the user's setting wins
    cfg, src = config_with_spec(mine, meta, "odometer")
    assert cfg.gyro_bias_rw_deg_h_sqrt_h == 1.0 and src["gyro_bias_rw_deg_h_sqrt_h"] == "config"


def test_velocity_matching_on_a_phone_imu_takes_its_wander(phone_drive):
    """Session 18: od-velocity-kf / dr-kf / sins-dr took the Gauss-Markov wander for a constant
    and were overconfident on this drive (20 runs from the truth: 21.39, 23.63, 26.39, band
    2.02-4.16); with the wander as the bias random walk 3.19, 6.87, 1.80 (dr-kf: its mounting
    prior, the next test)."""
    m, (lo, hi), v = final_nees("od-velocity-kf", {}, phone_drive, 20, (0.0, 0.0, 0.0))
    assert lo <= m <= hi, (m, (lo, hi), v)
    m, (lo, hi), v = final_nees("sins-dr", {}, phone_drive, 20, (0.0, 0.0, 0.0))
    assert m <= hi, (m, (lo, hi), v)
    # the constant alone (the walk set to zero): the overconfidence it had
    m, (lo, hi), v = final_nees("od-velocity-kf", {"gyro_bias_rw_deg_h_sqrt_h": 0.0},
                                phone_drive, 10, (0.0, 0.0, 0.0))
    assert m > hi, (m, (lo, hi), v)


def test_dr_kf_on_a_phone_imu_with_a_prior_that_covers_its_mounting(phone_drive):
    """Session 19: dr-kf's 6.87 on this drive (20 runs) was its mounting prior, not its NHC
    rows: the simulated phone sits 3.8 deg pitched in the car (``SIM_MOUNT_ARCMIN``), 11 times
    the paper's 20 arcmin, and the East tilt ended -28 arcmin off on average (10 runs, seeds
    100-109: 7.02). With the prior a bundle without a mounting gets
    (``meta_spec.UNKNOWN_MOUNTING_SIGMA_ARCMIN``, as the real comma2k19 does) it is in band
    (``benchmarks/nees_phone.py``: 20 runs 2.65; od-velocity-kf 2.12). Since session 20 the
    default prior covers the mounting ``meta.yaml`` gives and dr-kf estimates from zero
    (``meta_spec.unknown_installation_priors``: 228 arcmin here); the paper's 20 arcmin, set,
    with the first-order rows is still above the band. Since session 21 the NHC and DR
    velocity rows are taken at the mounting estimate (``second_order_rows``), and then the
    paper's 20 arcmin is in band as well (10 runs: 3.37; first-order rows 7.02): the 3.8 deg
    was the rows' linearization at the nominal mounting as much as the prior. The default:
    10 runs 2.16."""
    m, (lo, hi), v = final_nees("dr-kf", {}, phone_drive, 10, (0.0, 0.0, 0.0))
    assert lo <= m <= hi, (m, (lo, hi), v)
    m, (lo, hi), v = final_nees("dr-kf", {"mount_sigma_arcmin": 20.0,
                                          "second_order_rows": False}, phone_drive, 10,
                                (0.0, 0.0, 0.0))
    assert m > hi, (m, (lo, hi), v)
    m, (lo, hi), v = final_nees("dr-kf", {"mount_sigma_arcmin": 20.0}, phone_drive, 10,
                                (0.0, 0.0, 0.0))
    assert m <= hi, (m, (lo, hi), v)
