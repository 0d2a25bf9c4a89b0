"""Issue 15: fkf's residual test on consistent data. Noise from the bundle's sensor specs
(``noise_preset: matched``), checked against the spec arithmetic; the pooled NIS per degree of
freedom of each channel over a few fault-free runs lies in a wide band around 1 (0.15-3; measured 0.33) that the
former fixed noise (``conservative``) fails. The false-alarm calibration itself is the Monte
Carlo of ``benchmarks/fdi_calibration.py``."""
import numpy as np
import pytest

from consistency_mc import drive_003, pooled_fkf_nis
from inmotion.align import aided_kf as ak
from inmotion.core.solution import NavState
from inmotion.estimation import chi2
from inmotion.sim import simulate

RUNS = 3


def test_sensor_noise_from_the_spec():
    meta = {"simulated": True, "disturbances": {"side_slips": [], "vibration": []},
            "sensors": {"odometer": {"rate_hz": 10.0, "noise_m_s": 0.0, "pulses_per_m": 200.0},
                        "ldv": {"rate_hz": 100.0, "noise_m_s": 0.01}}}
    T = 0.5
    # two 5 mm quantizations (variance q^2 / 12 each) over 0.5 s
    fwd, lat, origin = ak.sensor_noise_from_meta(meta, "odometer", T, "displacement")
    assert fwd == pytest.approx(np.sqrt(2 * 0.005 ** 2 / 12) / T)
    assert lat == pytest.approx(ak.SIM_CONSTRAINT_PER_FORWARD * fwd)
    assert origin == "meta.sensors (simulated)"
    # 50 samples of 0.01 m/s white noise (1e-4 m each) summed over 0.5 s
    fwd, _, _ = ak.sensor_noise_from_meta(meta, "ldv", T, "displacement")
    assert fwd == pytest.approx(np.sqrt(50) * 1e-4 / T)
    # the velocity form keeps the configured lateral values; a disturbed vehicle too
    assert ak.sensor_noise_from_meta(meta, "ldv", T, "velocity")[1] is None
    meta["disturbances"]["side_slips"] = [{"t_s": 1.0}]
    assert ak.sensor_noise_from_meta(meta, "ldv", T, "displacement")[1] is None
    assert ak.sensor_noise_from_meta({}, "ldv", T, "displacement") == (None, None, "")


def test_config_source_says_where_each_value_came_from():
    b = simulate(drive_003(), np.random.default_rng(1))
    init = NavState.from_truth(b.truth)
    sol = ak.run_fkf(b, {"accel_bias_ug": 80.0}, init)
    src, cfg = sol.info["config_source"], sol.info["config"]
    assert src["accel_bias_ug"] == "config" and cfg["accel_bias_ug"] == 80.0
    assert src["gyro_drift_deg_h"] == "meta.imu (simulated)"
    assert cfg["gyro_drift_deg_h"] == pytest.approx(0.005)
    assert src["od_noise_m_s"] == ("meta.sensors (simulated) + meta.vehicle.constraint_violation"
                                   " (lateral/vertical)")
    sol = ak.run_fkf(b, {"noise_preset": "conservative"}, init)
    assert sol.info["config_source"]["od_noise_m_s"] == "default"
    assert sol.info["config"]["od_noise_m_s"] == [0.05, 0.02, 0.05]


def _pooled_nis(preset):
    return pooled_fkf_nis({"noise_preset": preset}, RUNS, 300)[0]


def test_nis_per_dof_near_one_with_matched_noise_and_not_with_the_former_fixed_noise():
    matched = _pooled_nis("matched")
    for ch, m in matched.items():
        assert 0.15 < m < 3.0, (ch, m)      # measured 0.33 (odometer), 0.34 (LDV)
    conservative = _pooled_nis("conservative")
    for ch, m in conservative.items():
        assert m < 0.15, (ch, m)            # measured 0.019, 0.006


def test_nis_per_measurement_kind_in_summary_and_report(tmp_path):
    from inmotion.evaluate.report import _consistency_section
    from inmotion.io.result import read_summary, write_result
    b = simulate(drive_003(), np.random.default_rng(2))
    sol = ak.run_fkf(b, {}, NavState.from_truth(b.truth))
    write_result(sol, tmp_path / "r", truth=b.truth)
    s = read_summary(tmp_path / "r")
    assert set(s["nis"]) == {"odometer", "ldv", "nhc", "height"}
    od = s["nis"]["odometer"]
    assert od["samples"] > 100 and od["dof"] == 3 * od["samples"]
    # judged against the residual test's model (the rows weighted by the vehicle's
    # constraint violation, issue 15), not chi2's 1; the other kinds against chi2
    w = sol.info["residual_test_weights"]["odometer"]["weights"]
    assert od["model"].startswith("weighted rows")
    assert od["expected_mean_per_dof"] == pytest.approx(sum(w) / 3)
    assert od["band_95"][0] < od["expected_mean_per_dof"] < od["band_95"][1] < 1.0
    assert s["nis"]["nhc"]["model"] == "chi2"
    assert s["nis"]["nhc"]["band_95"][0] < 1.0 < s["nis"]["nhc"]["band_95"][1]
    assert "attitude" in s["errors"]["consistency"]
    # the report's table (the section _result_section adds; whole pages are test_report's)
    text = _consistency_section(s["errors"]["consistency"], s["nis"])
    assert "Consistency" in text and "NIS odometer" in text and "NEES attitude" in text


@pytest.mark.parametrize("weights, g", [([0.186, 1.0, 0.318], 0.0), ([0.184, 1.0, 0.317], 1.0)])
def test_the_nis_band_of_the_weighted_model_covers_its_mean(weights, g):
    """``residual_test_nis``'s band: over 2000 sets of 400 samples drawn from the statistic's
    model (weighted rows, the forward row Gaussian or a triangular quantization difference),
    the mean per degree of freedom falls inside in at least 95 % of the sets (the forward
    row's spread taken at the Gaussian's, wide for the quantization), and unit weights keep
    chi2's block."""
    rng = np.random.default_rng(12)
    sets, n = 2000, 400
    lat, vert = rng.standard_normal((2, sets, n))
    tri = (rng.random((sets, n)) - rng.random((sets, n))) * np.sqrt(6.0)
    fwd = np.sqrt(g) * rng.standard_normal((sets, n)) + np.sqrt(1.0 - g) * tri
    stat = weights[0] * lat ** 2 + weights[1] * fwd ** 2 + weights[2] * vert ** 2
    w = {"weights": weights, "gauss_fraction": g}
    inside = 0
    for k in range(sets):
        block = chi2.nis_summary(float(stat[k].sum()), 3 * n, n)
        out = ak.residual_test_nis(block, w)
        inside += out["in_band"]
    assert out["expected_mean_per_dof"] == pytest.approx(sum(weights) / 3)
    frac = inside / sets
    assert 0.95 <= frac <= (0.995 if g == 1.0 else 1.0), frac
    unit = chi2.nis_summary(1500.0, 1500, 500)
    assert ak.residual_test_nis(unit, {"weights": [1.0, 1.0, 1.0], "gauss_fraction": 1.0}) \
        == unit
