"""Issue 15: the paper 003 sensor filters' sigma covers their error. Over a small Monte Carlo
(6 runs of an 85 s drive, :mod:`consistency_mc`) with the noise settings matched to the
simulated sensors (the defaults: ``noise_preset: matched`` reads them from meta.yaml; the
start-attitude prior set to the drawn start error), the mean final-attitude NEES lies in the
95 % band of its chi-square; an overconfident setting falls above it. The paper 003 sensor
filters under their defaults run on a truth drawn from their priors (the vehicle mounting, the
lever arms, the scale spreads: :func:`consistency_mc.drawn_truth`), 20 runs."""
import pytest

from consistency_mc import drive_003, final_nees
from inmotion.sim.scenario import load_scenario

RUNS = 6
START_SIGMA_DEG = (0.1, 0.1, 0.5)
PRIOR = {"init_tilt_sigma_deg": 0.1, "init_heading_sigma_deg": 0.5}


@pytest.fixture(scope="module")
def drive():
    return drive_003()


#: fkf (issue 15), on the fixed truth's 6 runs this file ran before
#: :func:`test_drawn_truth_nees_in_band`: with the vehicle's constraint violation in paper
#: 003's scenarios and the residual test calibrated (false alarms at the set 1e-3), fkf's
#: mean NEES over those 6 runs was 6.03 (band 1.37-5.25; per run 11.7, 12.6, 1.0, 3.3, 6.1, 1.4). The displacement rows'
#: along-sensor row is now a length (``aided_kf._length_fill``: the first-order rows left the
#: second-order ``c^2 d / 2`` and the violation's ``c int u dt`` in the one precise row, the
#: LDV's forward one): 5.20 (per run 9.2, 11.5, 0.8, 3.5, 5.2, 1.0), 3.77 with detection off;
#: over 24 runs (seeds 100-123) 3.98 (band 2.10-4.06). Run 2 still loses 6' of heading to two
#: false isolations (odometer at 47 s, LDV at 57 s; 6.0 with detection off): Table 1's switch
#: to the other channel alone and back, not the lost samples (measured: with the isolated
#: channel's prediction kept in the fusion the run ends at 5.4), see aided_kf's docstring.
#: Now fkf's default (``isolated_in_fusion``; engine docstring):
#: 4.19 (per run 9.2, 5.4, 0.8, 3.5, 5.2, 1.0; run 2 5.96 with the detection off). Run 1
#: (seed 100) has no isolation and the same 9.17 with the detection off: east tilt
#: (phi/sigma)^2 5.2 (-0.11' against a 0.05' sigma), heading 3.4 (32' against 17.6'),
#: the filter's own, not the FDI's.


#: paper 003's displacement rows as printed (its reproduction's, ``paper003.PAPER_ROWS_FORM``),
#: the default before issue 15 made the exact attitude columns and the length row's second
#: order the default: consistent on paper 003's own sensors (fkf 2.94 over 20 runs, band
#: 2.02-4.16, ``benchmarks/nees_methods.py``), overconfident on a fine odometer
#: (:func:`test_paper_rows_are_overconfident_with_a_fine_odometer`)
PAPER_FORM = dict(PRIOR, exact_attitude_columns=False, second_order_length=False,
                  linearization_floor=False)


#: runs of :func:`test_drawn_truth_nees_in_band`
DRAWN_RUNS = 20


@pytest.mark.parametrize("method", ["fkf", "od-kf", "ldv-kf"])
def test_drawn_truth_nees_in_band(drive, method):
    """The paper 003 sensor filters under their defaults with the truth drawn from their
    priors as the start error is (issue 15, session 17; :func:`consistency_mc.drawn_truth`:
    the vehicle mounting's pitch and yaw from the 30' prior, the lever arms in ``meta`` off the
    true ones by the 5 cm prior, the scale priors at the simulated spreads). Before, these
    filters ran 6 runs on the scenario's fixed 10' / 15' mounting with exact lever arms.
    Measured (``benchmarks/nees_methods.py 20 fkf,od-kf,ldv-kf 0 1``, seeds 100-119, band
    2.02-4.16): fkf 2.85, od-kf 3.08, ldv-kf 3.50; on the same random streams with nothing
    drawn (``... 0 control``) 3.28, 3.38, 4.05 (``ldv_scale_sigma_ppm`` 1000: 3.84), the
    fixed truth's own streams 2.38, 2.87, 2.64. So on this 85 s drive the draws move nothing
    beyond the Monte Carlo's spread (20 runs of a heavy-tailed NEES: ldv-kf's seed 104 is 13-16
    under every mode); on the 194 s drive after the 90 deg turn they do
    (``benchmarks/nees_drive_start.py``). 6 runs did not hold ldv-kf here (seeds 100-105: 5.37
    drawn, 6.7 control, band 1.37-5.25, the one heavy run), hence 20."""
    m, (lo, hi), per_run = final_nees(method, PRIOR, drive, DRAWN_RUNS, START_SIGMA_DEG,
                                      prior_drawn=True)
    assert lo <= m <= hi, (method, m, (lo, hi), per_run)


@pytest.mark.parametrize("method, config", [
    ("fkf", PAPER_FORM),
    # the vehicle-constraint filter alone, its rows' noise from the drive's constraint
    # violation (aided_kf.nhc_noise_from_meta: 0.0217 m/s; the fixed 0.01 m/s set here before
    # gave 6.18 over 20 runs, band 2.02-4.16: overconfident)
    ("nhc-kf", PRIOR),
])
def test_final_attitude_nees_in_band(drive, method, config):
    m, (lo, hi), per_run = final_nees(method, config, drive, RUNS, START_SIGMA_DEG)
    assert lo <= m <= hi, (method, m, (lo, hi), per_run)


#: the exact attitude columns with the length row's second order (issue 15: the exact
#: columns alone gave fkf 6.23, ldv-kf 5.37 over 20 runs, band 2.02-4.16; with
#: ``second_order_length`` 2.82 and 3.89, od-kf 2.85; ``aided_kf._length_second_order``;
#: with its variance taken ``aided_kf.LENGTH_VAR_SCALE`` = 4 times, helper h15nees5: 2.44,
#: 2.65, od-kf 2.88). The defaults since (helper h15def); set explicitly here so that these
#: tests keep checking this form whatever the defaults become
SECOND_ORDER = dict(PRIOR, exact_attitude_columns=True, second_order_length=True,
                    linearization_floor=False)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["fkf", "ldv-kf"])
def test_second_order_length_rows_in_band(drive, method):
    m, (lo, hi), per_run = final_nees(method, SECOND_ORDER, drive, RUNS, START_SIGMA_DEG)
    assert lo <= m <= hi, (method, m, (lo, hi), per_run)


@pytest.mark.slow
def test_fine_odometer_with_second_order_length_in_band():
    """Issue 15: od-kf with the 20,000 pulses/m odometer under ``second_order_length`` (and
    the exact columns): the length row's second-order error repeats over successive
    intervals, so its variance is taken ``aided_kf.LENGTH_VAR_SCALE`` (4) times; with it
    taken once (as independent per row) seeds 100-109 gave 6.85 (band 1.68-4.70), seeds
    100-105 10.4, 0.3, 17.5, 3.3, 4.7, 0.5 (mean 6.12, band 1.37-5.25). On the scenario's
    fixed truth: with the truth drawn from the priors these defaults are overconfident on
    this sensor (4.23 over 40 runs, band 2.29-3.80); the floor fixes it
    (:func:`test_od_kf_with_a_fine_odometer_stays_consistent`, its figures)."""
    m, (lo, hi), per_run = final_nees("od-kf", SECOND_ORDER, fine_odometer_drive(), RUNS,
                                      START_SIGMA_DEG)
    assert lo <= m <= hi, (m, (lo, hi), per_run)


@pytest.mark.slow
def test_paper_rows_are_overconfident_with_a_fine_odometer():
    """Issue 15: paper 003's rows as printed (:data:`PAPER_FORM`, its reproduction's setting)
    with the 20,000 pulses/m odometer are overconfident, which is why they are not the
    default: seeds 100-109 50.6 (band 1.68-4.70) against 3.20 under the defaults
    (:func:`test_fine_odometer_with_second_order_length_in_band`)."""
    m, (lo, hi), per_run = final_nees("od-kf", PAPER_FORM, fine_odometer_drive(), RUNS,
                                      START_SIGMA_DEG)
    assert m > hi, (m, (lo, hi), per_run)


def test_an_overconfident_setting_fails_the_band(drive):
    """The same check fails a filter told its sensors are 30 times better than they are
    (detection off: with it, the residual test isolates such channels at once, the vehicle
    constraint's violation alone exceeding their noise, and the fallback filter carries the
    estimate: NEES 2.7 on these runs, issue 15)."""
    cfg = dict(PRIOR, od_noise_m_s=[3e-5, 1e-4, 3e-5], ldv_noise_m_s=[3e-5, 5e-5, 3e-5],
               gyro_drift_deg_h=0.0005, accel_bias_ug=5.0, fdi=False)
    m, (lo, hi), per_run = final_nees("fkf", cfg, drive, RUNS, START_SIGMA_DEG)
    assert m > hi, (m, (lo, hi), per_run)


def fine_odometer_drive(pulses_per_m=20000.0):
    """:func:`consistency_mc.drive_003` with its odometer at ``pulses_per_m`` (20,000: a 0.05
    mm pulse, forward row 4.1e-5 m/s over 0.5 s where the usual 200 give 4.1e-3)."""
    d = drive_003().model_dump(mode="json", exclude_none=True)
    d["sensors"]["odometer"]["pulses_per_m"] = pulses_per_m
    return load_scenario(d)


def test_od_kf_with_a_fine_odometer_stays_consistent():
    """Issue 15: od-kf with a very fine odometer (20,000 pulses/m). The first-order
    displacement rows' own error (``d c^2 / 2`` for the unresolved heading ``c``), which the
    coarse odometer's quantization hides, is the forward row's noise floor
    (:func:`inmotion.align.aided_kf.linearization_floor_per_m`). Without it the mean NEES
    over these 6 runs was 74.2 (one run at 393; heading sigma 1-2
    arcmin at errors of 5-18 arcmin); with it 4.50 (band 1.37-5.25; over seeds 100-109
    4.44, band 1.68-4.70). The floor is a named setting, ``linearization_floor``, off by
    default (its cost where the heading prior is large: the function's docstring), so
    under the then default (paper 003's rows) this case stayed overconfident. With the rows in the
    frame of the sensor's displacement (``aided_kf._rows_to_displacement_frame``: the turn's
    heading bias from the lateral slip gone) these 6 runs give 4.15 with the floor and, under
    the default, seeds 100-109 still 50.6 (what is left: ``linearization_floor_per_m``).
    With the exact columns and the length row's second order from the filter's own
    covariance instead of this floor (``second_order_length``), seeds 100-109 give 6.85,
    with that second order's variance taken 4 times (``aided_kf.LENGTH_VAR_SCALE``) 3.20
    (``test_fine_odometer_with_second_order_length_in_band``), formerly
    still above the band (``benchmarks/heading_symmetry.py``, issue 15). Those two settings
    are the defaults since (helper h15def), so this case runs the floor on top of them:
    both widen the rows' variance for the same second-order error, and the check is that
    their sum stays in the band.

    Since session 17 on the truth drawn from the priors (:func:`test_drawn_truth_nees_in_band`),
    20 runs: measured 3.22 (seeds 100-119; 120-139: 2.28; band 2.02-4.16) where the defaults
    alone give 4.94 and 3.52 (4.23 over the 40, band 2.29-3.80: overconfident, so the summary
    warns when the floor is set false, :func:`test_fine_odometer_gets_the_floor_or_a_warning`;
    the floor is the default for this sensor since: ``linearization_floor: auto``)."""
    m, (lo, hi), per_run = final_nees("od-kf", dict(PRIOR, linearization_floor=True),
                                      fine_odometer_drive(), DRAWN_RUNS, START_SIGMA_DEG,
                                      prior_drawn=True)
    assert lo <= m <= hi, (m, (lo, hi), per_run)


def test_fine_sensor_ratio_closed_form():
    """``aided_kf.fine_sensor_ratio``: ``sqrt(3) / 2 s^2 v / sigma_fwd`` at s = 0.5 deg, v = 14
    m/s, a 4.1e-5 m/s forward row (no accelerometer noise, so nothing is added to it): 0.5 deg
    = 8.7266e-3 rad, s^2 = 7.6154e-5, times 0.86603 * 14 / 4.1e-5 = 22.52."""
    from inmotion.align.aided_kf import AidedKfConfig, fine_sensor_ratio
    cfg = AidedKfConfig(od_noise_m_s=[0.01, 4.1e-5, 0.01], accel_vrw_ug_sqrt_hz=0.0)
    assert fine_sensor_ratio(cfg, "od", 14.0) == pytest.approx(22.52, rel=1e-3)
    # the configuration's heading prior does not enter (FINE_SENSOR_HEADING_DEG)
    cfg2 = cfg.model_copy(update={"init_heading_sigma_deg": 3.0})
    assert fine_sensor_ratio(cfg2, "od", 14.0) == fine_sensor_ratio(cfg, "od", 14.0)


@pytest.mark.parametrize("pulses_per_m, config, floor, warns", [
    (20000.0, {}, True, False), (20000.0, {"linearization_floor": False}, False, True),
    (20000.0, {"linearization_floor": True}, True, False), (200.0, {}, False, False),
    (200.0, {"linearization_floor": False}, False, False)])
def test_fine_odometer_gets_the_floor_or_a_warning(pulses_per_m, config, floor, warns):
    """A distance sensor fine enough that its rows' second order sets what they tell
    (``aided_kf.FINE_SENSOR_WARN_RATIO``: the 20,000 pulses/m odometer measured overconfident
    on the drawn truth without the floor, 4.23 over 40 runs against a band of 2.29-3.80) gets
    the floor under the default ``linearization_floor: auto``, and with the floor set false it
    is named in the summary's warnings; the usual 200 pulses/m one gets neither (measured
    consistent without it). ``info['linearization_floor']`` says per sensor which applied."""
    import numpy as np

    from inmotion.align.aided_kf import run_od_kf
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    b = simulate(fine_odometer_drive(pulses_per_m), np.random.default_rng(1))
    sol = run_od_kf(b, dict(PRIOR, **config), NavState.from_truth(b.truth))
    hit = [w for w in sol.info["warnings"] if w.startswith("odometer:") and "finer" in w]
    assert bool(hit) == warns, sol.info["warnings"]
    assert sol.info["linearization_floor"] == {"odometer": floor}


def test_usual_odometer_heading_sigma_does_not_depend_on_the_error_sign(drive):
    """A linear filter's covariance does not depend on its errors; an EKF's only through its
    linearization point (``benchmarks/heading_sign.py``, issue 15 session 17). Each run is
    drawn as :func:`test_drawn_truth_nees_in_band`'s and run again with the start heading
    error's sign flipped, everything else the same: with the usual 200 pulses/m odometer the
    two final heading sigmas agree (measured mean ``|ln(sigma+ / sigma-)|`` 0.011 over seeds
    100-109; bound 0.05 here), where the 20,000 pulses/m odometer without the floor differs by
    0.46 (the floor: 0.17; the LDV 0.093), and on these three seeds by 0.165, so the check
    fails such a filter."""
    import numpy as np

    from consistency_mc import sign_flipped_headings
    logs = []
    for seed in (100, 101, 102):
        _, ((_, s_plus), (_, s_minus)) = sign_flipped_headings("od-kf", PRIOR, drive, seed,
                                                              START_SIGMA_DEG)
        logs.append(abs(np.log(s_plus / s_minus)))
    assert np.mean(logs) < 0.05, logs
