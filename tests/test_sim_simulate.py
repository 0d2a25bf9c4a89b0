"""simulate(): reproducible by seed, noisy by seed, complete meta, one time base."""
import numpy as np
import pytest
import yaml

from inmotion.sim import simulate

SC = {"name": "det", "start": {"lat_deg": 30, "lon_deg": 110, "h_m": 10},
      "segments": [{"kind": "rest", "duration_s": 2},
                   {"kind": "accelerate", "to_speed_m_s": 8, "accel_m_s2": 2},
                   {"kind": "cruise", "duration_s": 5}],
      "imu": {"gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.01},
              "accel": {"bias_ug": 50, "vrw_ug_sqrt_hz": 20}, "constant_errors": "random"},
      "sensors": {"radar": {"rate_hz": 10, "noise_m_s": 0.1, "scale_markov_sigma_ppm": 1000,
                            "lever_arm_m": [0, 1, -0.5]},
                  "ldv": {"rate_hz": 50, "output": "distance", "noise_m_s": 0.01,
                          "scale_factor_sigma_ppm": 500},
                  "odometer": {"rate_hz": 10, "pulses_per_m": 100, "noise_m_s": 0.05},
                  "baro": {"rate_hz": 5, "noise_m": 1, "bias_sigma_m": 3}},
      "faults": [{"sensor": "ldv", "kind": "outliers", "start_s": 3, "end_s": 6,
                  "probability": 0.5, "magnitude_m_s": 1}]}


def _arrays(b):
    return [b.imu.t, b.imu.dtheta, b.imu.dvel, b.radar.v, b.ldv.ds, b.odometer.ds, b.baro.h,
            b.truth.lat, b.truth.euler]


def test_same_seed_identical_bundle():
    a, b = simulate(SC, np.random.default_rng(7)), simulate(SC, np.random.default_rng(7))
    for x, y in zip(_arrays(a), _arrays(b)):
        np.testing.assert_array_equal(x, y)
    assert a.meta == b.meta


def test_different_seed_different_noise_same_truth():
    a, b = simulate(SC, np.random.default_rng(1)), simulate(SC, np.random.default_rng(2))
    for x, y in zip([a.imu.dtheta, a.imu.dvel, a.radar.v, a.ldv.ds, a.baro.h],
                    [b.imu.dtheta, b.imu.dvel, b.radar.v, b.ldv.ds, b.baro.h]):
        assert not np.array_equal(x, y)
    np.testing.assert_array_equal(a.truth.lat, b.truth.lat)
    assert a.meta["simulated_errors"] != b.meta["simulated_errors"]


def test_time_base_and_meta():
    b = simulate(SC, np.random.default_rng(0))
    np.testing.assert_array_equal(b.imu.t, b.truth.t)
    assert b.imu.t[0] == 0.0 and b.imu.t[-1] == pytest.approx(2 + (8 / 2 + 2) + 5)   # accelerate: dv / a + transition
    m = b.meta
    assert m["name"] == "det" and m["files"] == ["imu", "truth", "radar", "ldv", "odometer", "baro"]
    assert m["lat_deg"] == 30 and m["sensors"]["radar"]["lever_arm_m"] == [0, 1, -0.5]
    assert m["lever_arms_m"]["radar"] == [0, 1, -0.5]
    assert m["sensors"]["ldv"]["output"] == "distance"
    assert m["imu"]["gyro"]["arw_deg_sqrt_h"] == 0.01
    assert m["faults"][0]["kind"] == "outliers"
    assert set(m["simulated_errors"]) == {"imu", "radar", "ldv", "odometer", "baro"}
    assert yaml.safe_load(yaml.safe_dump(m)) == m          # plain YAML, no numpy objects


def test_needs_a_generator():
    with pytest.raises(TypeError, match="Generator"):
        simulate(SC, 7)
