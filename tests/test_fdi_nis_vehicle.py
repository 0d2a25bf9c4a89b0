"""Issue 15: the residual statistic of fkf's sub-filters on a vehicle that breaks its
constraint as real ones do (the simulator's ``vehicle.constraint_violation``, paper 003's
measured figures). The matched noise takes the lateral and vertical rows from that vehicle
spec; the pooled NIS per degree of freedom must then be what Gauss-Markov theory predicts for
those rows, and a filter told its sensors are three times better than they are must fail that
band. The false-alarm calibration itself is ``benchmarks/fdi_calibration.py``.

The theory below takes each row's noise as the sensor's (and the vehicle's) alone, which is
paper 003's rows (``exact_attitude_columns`` and ``second_order_length`` false,
:data:`PAPER_FORM`), so the first test runs that form. Under the defaults since issue 15
(helper h15def: both on) the length row's variance also carries
``aided_kf.LENGTH_VAR_SCALE`` (4) times its second-order term; since helper h15split the
residual test takes the row's single-interval variance instead (``Measurement.test_variance``:
the sensor's plus the second order's own). That was not yet the theory's on this drive's
start as the first test runs it (the true velocity under fkf's 0.2 m/s velocity prior): the
gain's inflated row and the sub-filters' federated ``1 / beta`` keep the along-track ``P``
wide for the first minute, and the pooled NIS per degree of freedom (2 runs) was 0.423
odometer, 0.344 LDV (0.343, 0.233 with the test on the inflated row, before h15split; the
paper's form 0.464, 0.546). Since fkf's ``test_covariance`` (the engine's "Test covariance")
the test takes the sub-filter's error covariance under its own gains, the last test."""
import numpy as np
import pytest

from consistency_mc import pooled_fkf_nis
from inmotion.align import aided_kf as ak
from inmotion.core.solution import NavState

RUNS = 2
T = 0.5          # the measurement interval (AidedKfConfig.measurement_period_s default)


def _expected_nis_per_dof(cv, beta):
    """Per row, the residual's variance over the row noise, the state part neglected: 1 for
    the forward row (the sensor's own noise, matched), and for the lateral / vertical rows
    the variance of an interval mean of a Gauss-Markov process, ``sigma^2 2 (x - 1 + e^-x) /
    x^2`` with ``x = T / tau``, over the white-equivalent noise the filter carries, ``2
    sigma^2 tau / T``, shared out by ``1 / beta`` (derived here from the process,
    independently of the library)."""
    r = []
    for a in ("lateral", "vertical"):
        x = T / cv[f"{a}_tau_s"]
        r.append(beta * (2 * (x - 1 + np.exp(-x)) / x ** 2) / (2 / x))
    return (1.0 + sum(r)) / 3.0


#: paper 003's rows as printed (its reproduction's ``paper003.PAPER_ROWS_FORM``)
PAPER_FORM = {"exact_attitude_columns": False, "second_order_length": False}


def _pooled(cfg):
    return pooled_fkf_nis({**PAPER_FORM, **cfg}, RUNS, 500)


#: fkf's information sharing and the beta its sub-filters' rows carry (the sharing in the
#: sub-filters, paper 003's: 1/2; at the fusion, the default since session 25: none)
SHARINGS = [("fusion", 1.0), ("sub-filters", 0.5)]


@pytest.mark.parametrize("sharing, beta", SHARINGS)
def test_sub_filter_nis_follows_the_vehicle_spec_and_an_overconfident_setting_fails(sharing,
                                                                                     beta):
    """Measured (2 runs, odometer / LDV): fusion 0.630 / 0.717 against the theory's 0.667;
    sub-filters 0.464 / 0.546 against 0.500."""
    share = {"information_sharing": sharing}
    matched, b = _pooled(share)
    cv = b.meta["vehicle"]["constraint_violation"]
    expect = _expected_nis_per_dof(cv, beta)
    if beta == 0.5:                             # 0.5 for paper 003's figures, beta 1/2
        assert expect == pytest.approx(0.5, abs=0.01)
    src = ak.run_fkf(b, {"fdi": False, **PAPER_FORM, **share},
                     NavState.from_truth(b.truth)).info["config_source"]
    assert "meta.vehicle.constraint_violation" in src["od_noise_m_s"]
    # band: +-30 % (a few hundred correlated rows; the state part adds a little)
    for ch, m in matched.items():
        assert 0.7 * expect < m < 1.3 * expect, (ch, m, expect)
    fwd_od, lat_od, _ = ak.sensor_noise_from_meta(b.meta, "odometer", T, "displacement")
    fwd_ldv, lat_ldv, _ = ak.sensor_noise_from_meta(b.meta, "ldv", T, "displacement")
    over, _ = _pooled({"od_noise_m_s": [lat_od[0] / 3, fwd_od / 3, lat_od[1] / 3],
                       "ldv_noise_m_s": [lat_ldv[0] / 3, fwd_ldv / 3, lat_ldv[1] / 3],
                       **share})
    for ch, m in over.items():
        assert m > 1.3 * expect, (ch, m)


def test_row_noise_from_the_vehicle_spec_and_the_fallback_without_it():
    cv = {"lateral_sigma_m_s": 0.01, "lateral_tau_s": 0.5, "vertical_sigma_m_s": 0.02,
          "vertical_tau_s": 0.2}
    meta = {"simulated": True, "disturbances": {}, "imu": {"gyro": {"drift_deg_h": 0.005}},
            "sensors": {"ldv": {"rate_hz": 100.0, "noise_m_s": 0.01}},
            "vehicle": {"constraint_violation": cv}}
    fwd, (lat, vert), origin = ak.sensor_noise_from_meta(meta, "ldv", T, "displacement")
    model = ak.SIM_CONSTRAINT_PER_FORWARD * fwd
    # the test's statistic model: one-interval spread over the rows' noise; LDV all Gaussian
    cfg, src = ak.config_with_spec(ak.AidedKfConfig(), meta, ("ldv",))
    tw = ak.residual_test_weights(cfg, meta, "ldv", src)
    one = 0.01 ** 2 * 2 * (1 - 1 + np.exp(-1.0))      # x = T / tau = 1
    assert tw["weights"][0] == pytest.approx((one + model ** 2) / lat ** 2)
    assert tw["gauss_fraction"] == 1.0
    # white equivalent of 0.5 s means: sqrt(2 sigma^2 tau / T), with the rows' model error
    assert lat == pytest.approx(np.hypot(0.01 * np.sqrt(2 * 0.5 / 0.5), model))
    assert vert == pytest.approx(np.hypot(0.02 * np.sqrt(2 * 0.2 / 0.5), model))
    assert "meta.vehicle.constraint_violation" in origin
    # the one-interval spread, for the record: the double integral of the autocorrelation
    t = np.linspace(0, T, 801)
    R = 0.01 ** 2 * np.exp(-np.abs(t[:, None] - t[None, :]) / 0.5)
    assert ak.markov_mean_sigma(0.01, 0.5, T) == pytest.approx(np.sqrt(R.mean()), rel=1e-3)
    # without a vehicle spec: the documented fallback, a quarter of the forward 1-sigma
    del meta["vehicle"]
    fwd, lat, origin = ak.sensor_noise_from_meta(meta, "ldv", T, "displacement")
    assert lat == pytest.approx(ak.SIM_CONSTRAINT_PER_FORWARD * fwd)
    assert "vehicle" not in origin


@pytest.mark.parametrize("weights, g", [([1.0, 1.0, 1.0], 1.0), ([0.186, 1.0, 0.318], 0.0),
                                        ([0.184, 1.0, 0.317], 1.0), ([0.3, 1.0, 0.5], 0.5)])
def test_residual_test_threshold_against_monte_carlo(weights, g):
    """The threshold of the test statistic's model (weighted chi-square rows, a forward row
    part Gaussian, part a triangular quantization difference) has the set tail probability
    in 1e6 draws of that model (binomial 1-sigma at 1e-3: 3 %)."""
    from inmotion.estimation import chi2
    rng = np.random.default_rng(11)
    n = rng.standard_normal((1_000_000, 3))
    tri = (rng.random(len(n)) - rng.random(len(n))) * np.sqrt(6.0)     # unit variance
    e = np.sqrt(g) * n[:, 1] + np.sqrt(1.0 - g) * tri
    q = weights[0] * n[:, 0] ** 2 + weights[1] * e ** 2 + weights[2] * n[:, 2] ** 2
    for rate in (0.05, 1e-3):
        x = ak.weighted_chi2_threshold(rate, weights, g)
        assert np.mean(q > x) == pytest.approx(rate, rel=0.15 if rate < 0.01 else 0.03)
        if g == 1.0 and weights == [1.0, 1.0, 1.0]:
            assert x == chi2.threshold(rate, 3)


@pytest.mark.parametrize("velocity_sigma_m_s", [0.0, 0.2])
@pytest.mark.parametrize("sharing, beta", SHARINGS)
def test_the_defaults_residual_test_follows_the_same_theory(velocity_sigma_m_s, sharing, beta):
    """The defaults (``exact_attitude_columns``, ``second_order_length``, the length row
    updated with its inflated variance; fkf's ``test_covariance``: the test on the sub-filter's
    error covariance under its own gains, with the sensor's variance): the pooled sub-filter
    NIS per degree of freedom in the same band of the same theory as paper 003's rows, from
    fkf's usual start (the true velocity under its 0.2 m/s prior) and from a start velocity
    drawn from that prior. Measured (2 runs), the sharing in the sub-filters: 0.468 / 0.538
    and 0.479 / 0.553 (odometer / LDV); without the test covariance 0.423 / 0.344 and 0.431
    / 0.360, the LDV's below the band: the inflated row and the federated 1 / beta keep ``P``
    wide for the first minute. At the fusion (the default since session 25; theory 0.667):
    0.632 / 0.713 and 0.647 / 0.733, without the test covariance 0.617 / 0.608 and 0.631 /
    0.624 (no 1 / beta, no deflation)."""
    share = {"information_sharing": sharing}
    got, b = pooled_fkf_nis(share, RUNS, 500, velocity_sigma_m_s=velocity_sigma_m_s)
    cv = b.meta["vehicle"]["constraint_violation"]
    expect = _expected_nis_per_dof(cv, beta)
    for ch, m in got.items():
        assert 0.7 * expect < m < 1.3 * expect, (ch, m, expect)
    off, _ = pooled_fkf_nis({"test_covariance": False, **share}, RUNS, 500,
                            velocity_sigma_m_s=velocity_sigma_m_s)
    if beta < 1.0:
        assert off["ldv"] < 0.75 * expect      # the deflation the test covariance removes
    else:
        assert all(0.7 * expect < m < 1.3 * expect for m in off.values()), off
