"""Issue 15: the isolation cascade at the paper's false-alarm rate 0.05. A channel isolated
early (its sub-filter still far from converged) is tested for its return, with
``return_test: masked``, against its masked sub-filter, whose error is frozen from the
isolation on (no update; the feedback shifts every local filter alike) while its covariance
grows by the prediction: the statistic stays far above its model after the fault has ended
and the channel keeps being isolated. With ``return_test: conditioned`` (fkf's default since h15retdef) the
test is of a copy conditioned on the healthy sub-filter's common estimate, and after a
return the sub-filter is on probation (:mod:`inmotion.estimation.engine`'s docstring).

The judgement is the statistic's model, not the code's output: the LDV's statistic has the
model mean ``sum(weights)`` (``info["residual_test_weights"]``, 1.50 here), and a channel
whose tests follow it exceeds the 0.05 threshold about 5 % of the time. The drive: paper
003's 85 s drive (``consistency_mc.drive_003``) with a +0.5 m/s LDV step fault over 1-4 s,
the start 0.15 / 0.15 / 1.5 deg off (1-sigma, drawn), three seeds. Measured (seeds 300-302,
tests after 7 s): masked, mean statistic 16.4, 12.8, 5.5 and exceedances 0.98, 0.88, 0.41;
conditioned 2.5, 2.7, 2.7 and 0.18, 0.16, 0.18; the same drives without the fault and with
the detection off 1.68, 1.72, 1.50 and 0.075, 0.069, 0.056. What is left above the
fault-free figures is the returned sub-filter's state: the test does include ``H P H^T``
(h15fdi4, ``benchmarks/fdi_state_probe.py``: the exact law of the statistic moves the rate by
less than 1e-3); what the conditioned copy exposes is the channel's own states' lag, e.g. the
odometer's scale factor (:mod:`inmotion.estimation.engine`'s "Isolate and return").

The filters run paper 003's rows (:data:`PAPER_FORM`), on which the figures above were
measured and the statistic's model holds. Under the defaults since issue 15 (helper h15def:
``exact_attitude_columns`` and ``second_order_length`` on) the length row's variance carries
``aided_kf.LENGTH_VAR_SCALE`` times its second-order term, which the statistic's model does
not, and the masked test's statistic after the fault is 0.39, 0.38, 0.36 times its model
(seeds 300-302): no cascade, but a deflated test (``tests/test_fdi_nis_vehicle.py``).
Since helper h15split the test takes that row's single-interval variance
(``Measurement.test_variance``); the default's test is then as paper 003's rows' when the
start's prior is honest, and deflated for the first minute or two after a start whose prior
is wider than its error (``benchmarks/fdi_calibration.py``'s docstring), so these filters
still run paper 003's rows, on which the figures above were measured.
"""
import numpy as np
import pytest

from consistency_mc import drive_003
from inmotion.align import aided_kf as ak
from inmotion.core.solution import NavState
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

SEEDS = (300, 301, 302)
FAULT = (1.0, 4.0)          # LDV +0.5 m/s over these seconds
AFTER = FAULT[1] + 3.0      # tests from here on are of a healthy sensor
#: paper 003's rows as printed (its reproduction's ``paper003.PAPER_ROWS_FORM``)
PAPER_FORM = {"exact_attitude_columns": False, "second_order_length": False}


def _scenario():
    d = drive_003().model_dump(mode="json", exclude_none=True)
    d["faults"] = [{"sensor": "ldv", "kind": "offset", "start_s": FAULT[0], "end_s": FAULT[1],
                    "offset_m_s": 0.5}]
    return load_scenario(d)


@pytest.fixture(scope="module")
def after_fault():
    """Per return test: per seed the LDV's statistics after the fault, its model mean, its
    0.05 threshold and its detection times."""
    sc = _scenario()
    # without the return span (fkf's default since h15retdef), as the figures above were
    # measured; the checks pass with it too (h15retdef, 2026-12-02)
    out = {"masked": [], "conditioned": []}
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        b = simulate(sc, rng)
        init = NavState.from_truth(b.truth, euler_error=np.radians([0.15, 0.15, 1.5])
                                   * rng.standard_normal(3))
        for mode in out:
            sol = ak.run_fkf(b, {"init_tilt_sigma_deg": 0.15, "init_heading_sigma_deg": 1.5,
                                 "false_alarm_rate": 0.05, "keep_test_statistics": True,
                                 "return_test": mode, "return_span": False, **PAPER_FORM},
                               init)
            ts = sol.info["test_statistics"]
            c = list(ts["channels"]).index("ldv")
            lam = ts["lambda"][ts["t"] > AFTER, c]
            out[mode].append({
                "lam": lam[np.isfinite(lam)],
                "model": float(sum(sol.info["residual_test_weights"]["ldv"]["weights"])),
                "thr": sol.info["fdi_thresholds"]["ldv"],
                "detected": [e["t_s"] for e in sol.info["events"]
                             if e.get("channel") == "ldv" and e["event"] == "detected"]})
    return out


def test_the_fault_is_detected_at_its_first_sample(after_fault):
    for mode, runs in after_fault.items():
        for r in runs:
            assert FAULT[0] <= r["detected"][0] <= FAULT[0] + 0.5, (mode, r["detected"])


def test_the_masked_return_test_latches(after_fault):
    """The scenario shows the cascade: with the masked sub-filter the statistic of a healthy
    sensor stays several times its model (measured 5.5-16 against 1.5)."""
    means = [r["lam"].mean() / r["model"] for r in after_fault["masked"]]
    assert np.mean(means) > 4.0, means


def test_the_conditioned_return_test_follows_the_model(after_fault):
    """After the fault the returned channel's statistic stays near its model: mean within
    twice the model's (measured 1.7-1.8 times; masked 3.7-11), exceedances of the 0.05
    threshold below 0.25 per test pooled (measured 0.17; masked 0.75)."""
    runs = after_fault["conditioned"]
    for r in runs:
        assert r["lam"].size > 100
        assert r["lam"].mean() < 2.0 * r["model"], (r["lam"].mean(), r["model"])
    exc = np.concatenate([r["lam"] > r["thr"] for r in runs])
    assert exc.mean() < 0.25, exc.mean()

