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
    assert od["band_95"][0] < 1.0 < od["band_95"][1]
    assert "attitude" in s["errors"]["consistency"]
    # the report's table (the section _result_section adds; whole pages are test_report's)
    text = _consistency_section(s["errors"]["consistency"], s["nis"])
    assert "Consistency" in text and "NIS odometer" in text and "NEES attitude" in text
