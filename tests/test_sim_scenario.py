"""Scenario files: every shipped one loads and matches its paper; bad input says where."""
import numpy as np
import pytest
import yaml

from inmotion.errors import BadInput
from inmotion.sim import find_scenario, load_scenario, simulate
from inmotion.sim.profile import build_profile
from inmotion.sim.scenario import shipped_scenarios

GOOD = {"name": "g", "start": {"lat_deg": 30, "lon_deg": 110, "h_m": 0},
        "segments": [{"kind": "rest", "duration_s": 1}]}


def _with(**kw):
    d = yaml.safe_load(yaml.safe_dump(GOOD))
    d.update(kw)
    return d


def _distance_and_top_speed(prof):
    t = np.linspace(0, prof.duration_s, 400_001)
    v = prof.speed(t)
    return np.trapezoid(v, t), v.max()


def test_all_shipped_scenarios_load():
    names = shipped_scenarios()
    for n in ["paper000_traj1", "paper000_traj2", "paper000_traj1_slip", "paper002_hour",
              "paper004_v20", "paper004_v60", "paper004_v80", "paper001_urban",
              "paper003_drive", "paper003_parked_then_drive", "demo"]:
        assert n in names
    for n in names:
        sc = load_scenario(find_scenario(n))
        assert sc.name == n


def test_paper002_hour_matches_the_paper():
    sc = load_scenario("paper002_hour")
    prof = build_profile(sc)
    dist, vmax = _distance_and_top_speed(prof)
    assert prof.duration_s == pytest.approx(3600.0)
    assert dist == pytest.approx(50_600, abs=100)
    assert vmax == pytest.approx(22.0)
    assert sc.start.lat_deg == pytest.approx(34 + 14.763 / 60)
    assert sc.start.lon_deg == pytest.approx(108 + 54.579 / 60)
    kinds = {s.kind for s in sc.segments}
    assert {"accelerate", "decelerate", "turn", "climb", "descend", "stop"} <= kinds


@pytest.mark.parametrize("v", [20, 60, 80])
def test_paper004_drives(v):
    sc = load_scenario(f"paper004_v{v}")
    prof = build_profile(sc)
    assert prof.duration_s == 120.0 and sc.start.heading_deg == 30.0
    assert np.all(prof.speed(np.linspace(0, 120, 101)) == v)


def test_paper000_traj1_timing_and_slips():
    prof = build_profile(load_scenario("paper000_traj1"))
    assert prof.segments[0][2] == pytest.approx(60.0)
    assert prof.speed(60.0) == pytest.approx(15.0) and prof.duration_s == pytest.approx(600.0)
    sc = load_scenario("paper000_traj1_slip")
    assert [s.t_s for s in sc.disturbances.side_slips] == [120, 270, 450]
    assert [j.t_s for j in sc.disturbances.jumps] == [190, 380, 540]
    assert all(s.duration_s == 1.5 for s in sc.disturbances.side_slips + sc.disturbances.jumps)


def test_other_paper_durations():
    for name, dur in [("paper001_urban", 300.0), ("paper003_drive", 600.0),
                      ("paper003_parked_then_drive", 600.0), ("paper000_traj2", 600.0)]:
        assert build_profile(load_scenario(name)).duration_s == pytest.approx(dur), name
    prof = build_profile(load_scenario("paper003_parked_then_drive"))
    assert prof.speed(179.9) == 0.0 and prof.speed(185.0) > 0
    assert 500 < build_profile(load_scenario("demo")).duration_s < 720


def test_parked_vibration_moves_the_imu_but_not_the_vehicle():
    sc = load_scenario("paper003_parked_then_drive")
    d = sc.model_dump()
    d["segments"] = [{"kind": "rest", "duration_s": 20}]
    d["disturbances"]["vibration"] = [dict(v, end_s=20.0) for v in d["disturbances"]["vibration"]]
    d["sensors"] = {}
    b = simulate(d, np.random.default_rng(0))
    gyro = np.abs(b.imu.dtheta / 0.01).max()
    assert gyro > 1e-4                                            # it shakes
    assert np.abs(np.diff(b.truth.h)).max() < 1e-3                # mm-level motion only
    assert abs(b.truth.h[-1] - b.truth.h[0]) < 1e-4


@pytest.mark.parametrize("data, where", [
    (_with(start={"lat_deg": 30, "lon_deg": 110}), "start.h_m"),
    (_with(segments=[{"kind": "fly", "duration_s": 1}]), "segments.0"),
    (_with(segments=[{"kind": "turn", "angle_deg": 90, "rate_deg_s": 3}]), "accelerate first"),
    (_with(segments=[{"kind": "accelerate", "to_speed_m_s": 5, "accel_m_s2": 1},
                     {"kind": "rest", "duration_s": 3}]), "must be stopped"),
    (_with(segments=[{"kind": "accelerate", "to_speed_m_s": 5, "accel_m_s2": 1},
                     {"kind": "accelerate", "to_speed_m_s": 4, "accel_m_s2": 1}]), "not above"),
    (_with(segments=[{"kind": "rest", "duration_s": -1}]), "segments.0.rest.duration_s"),
    (_with(segments=[{"kind": "accelerate", "to_speed_m_s": 5, "accel_m_s2": 1},
                     {"kind": "decelerate", "to_speed_m_s": 6, "decel_m_s2": 1}]), "not below"),
    (_with(segments=[{"kind": "accelerate", "to_speed_m_s": 5, "accel_m_s2": 1},
                     {"kind": "turn", "angle_deg": 0, "rate_deg_s": 1}]), "non-zero angle_deg"),
    (_with(start={"lat_deg": 95, "lon_deg": 110, "h_m": 0}), "start.lat_deg"),
    (_with(segments=[]), "segments"),
    (_with(disturbances={"vibration": [{"start_s": 0, "end_s": 1.5, "frequency_hz": 20}]}),
     "2 * fade_s"),
    (_with(sensors={"odometer": {"rate_hz": 10}}), "sensors.odometer.pulses_per_m"),
    (_with(sensors={"baro": {"rate_hz": 10}},
           faults=[{"sensor": "baro", "kind": "outliers", "start_s": 0, "end_s": 1,
                    "probability": 0.5}]), "needs magnitude_m"),
    (_with(colour="red"), "colour"),
    (_with(sensors={"radar": {"rate_hz": 30}}), "sensors.radar.rate_hz"),
    (_with(sensors={"radar": {"rate_hz": 10}},
           faults=[{"sensor": "ldv", "kind": "dropout", "start_s": 0, "end_s": 1}]), "faults.0"),
    (_with(sensors={"radar": {"rate_hz": 10}},
           faults=[{"sensor": "radar", "kind": "offset", "start_s": 0, "end_s": 1}]),
     "needs offset_m_s"),
    (_with(sensors={"radar": {"rate_hz": 10}},
           faults=[{"sensor": "radar", "kind": "slip", "start_s": 0, "end_s": 1,
                    "slip_ratio": 0.1}]), "only for the odometer"),
    (_with(sensors={"radar": {"rate_hz": 10}},
           faults=[{"sensor": "radar", "kind": "stuck", "start_s": 2, "end_s": 1}]), "end_s"),
    (_with(imu={"accel": {"vrw_ug_sqrt_hz": 1, "vrw_m_s_sqrt_h": 1}}), "once"),
    (_with(imu={"gyro": {"misalignment_arcsec": [1, 2]}}), "misalignment_arcsec"),
])
def test_bad_scenarios_name_the_field(tmp_path, data, where):
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(BadInput) as e:
        load_scenario(p)
    msg = str(e.value)
    assert str(p) in msg and where in msg, msg
    assert "\n" not in msg


def test_bad_files(tmp_path):
    with pytest.raises(BadInput, match="not found"):
        load_scenario(tmp_path / "missing.yaml")
    p = tmp_path / "x.yaml"
    p.write_text("name: [unclosed")
    with pytest.raises(BadInput, match="not valid YAML"):
        load_scenario(p)
    p.write_text("- a\n- b\n")
    with pytest.raises(BadInput, match="mapping"):
        load_scenario(p)
    with pytest.raises(BadInput, match="no shipped scenario 'nope'"):
        find_scenario("nope")


def test_docs_example_is_a_valid_scenario():
    """The schema example in docs/scenarios.md loads and simulates."""
    from pathlib import Path
    text = (Path(__file__).resolve().parent.parent / "docs" / "scenarios.md").read_text()
    block = text.split("```yaml\n", 1)[1].split("```", 1)[0]
    sc = load_scenario(yaml.safe_load(block))
    assert sc.name == "my_drive" and len(sc.faults) == 8
    assert set(sc.present_sensors) == {"radar", "ldv", "odometer", "baro"}


def test_imu_grade_presets_fill_what_the_scenario_leaves_out():
    """``imu.grade`` fills the gyro and accelerometer figures of its preset; a value the
    scenario gives wins; the simulated errors follow (fixed constant errors)."""
    import numpy as np

    from inmotion.sim import simulate
    from inmotion.sim.scenario import IMU_GRADES, load_scenario
    base = dict(name="grade", start=dict(lat_deg=34.0, lon_deg=108.0, h_m=400.0,
                                         heading_deg=30.0),
                segments=[dict(kind="rest", duration_s=5.0)])
    for grade, preset in IMU_GRADES.items():
        sc = load_scenario({**base, "imu": {"grade": grade}})
        assert sc.imu.gyro.arw_deg_sqrt_h == preset["gyro"]["arw_deg_sqrt_h"]
        assert sc.imu.accel.bias_ug == preset["accel"]["bias_ug"]
    sc = load_scenario({**base, "imu": {"grade": "tactical", "gyro": {"drift_deg_h": 3.0},
                                        "accel": {"vrw_m_s_sqrt_h": 0.1}}})
    assert sc.imu.gyro.drift_deg_h == 3.0 and sc.imu.gyro.arw_deg_sqrt_h == 0.05
    assert sc.imu.accel.vrw_m_s_sqrt_h == 0.1 and sc.imu.accel.vrw_ug_sqrt_hz is None
    b = simulate({**base, "imu": {"grade": "navigation"}}, np.random.default_rng(0))
    assert b.meta["simulated_errors"]["imu"]["gyro_drift_deg_h"] == [0.01, 0.01, 0.01]
    with pytest.raises(BadInput, match="grade"):
        load_scenario({**base, "imu": {"grade": "automotive"}})
