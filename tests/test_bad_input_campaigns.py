"""Bad input added with the reproduction campaigns and the vehicle's constraint violation
(issues 15, 17): each is one BadInput whose message names what is wrong, raised before any run
starts or anything is written."""
import json

import numpy as np
import pytest

from inmotion.errors import BadInput
from inmotion.evaluate.montecarlo import run_campaign
from inmotion.evaluate.sweep import load_sweep


@pytest.mark.parametrize("run, grid, message", [
    ("paper001:run_circle", {"heading_deg": [400.0]}, r"heading_deg must be a number in \[-180, 360\)"),
    ("paper001:run", {"test": [4]}, "test must be one of"),
    ("paper003:run", {"windows": [0]}, r"windows must be an integer in 1\.\.10"),
    ("paper004:run", {"speed_m_s": [33]}, "speed_m_s must be one of"),
    ("paper004:run_car", {"effect": ["bounce"]}, "effect must be one of"),
])
def test_a_bad_campaign_point_fails_before_the_campaign(tmp_path, run, grid, message):
    doc = {"name": "t", "run": f"inmotion.reproductions.{run}", "grid": grid}
    with pytest.raises(BadInput, match=message):
        run_campaign(load_sweep(doc), tmp_path / "c", workers=1, quiet=True)
    assert not (tmp_path / "c" / "results").exists()


@pytest.mark.parametrize("module, kwargs, old, message", [
    ("paper001", {"seed": 0, "reuse_tables": True}, {"seed": 3},
     "the results to reuse were made with seed 3, not 0"),
    ("paper004", {"runs": 50, "seed": 0, "reuse_speeds": True}, {"runs": 5, "seed": 0},
     "the results to reuse are of 5 runs, seed 0, not 50 runs, seed 0"),
])
def test_reusing_results_of_another_run_is_bad_input(tmp_path, module, kwargs, old, message):
    import importlib
    (tmp_path / "results.json").write_text(json.dumps(old))
    mod = importlib.import_module(f"inmotion.reproductions.{module}")
    with pytest.raises(BadInput, match=message) as e:
        mod.reproduce(tmp_path, workers=1, progress=False, **kwargs)
    assert "results.json" in str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


def test_a_constraint_violation_that_is_not_a_number_is_bad_input():
    from inmotion.align.aided_kf import vehicle_constraint_noise
    meta = {"vehicle": {"constraint_violation": {"lateral_sigma_m_s": "fast",
                                                 "lateral_tau_s": 0.5}}}
    with pytest.raises(BadInput, match="constraint_violation: sigma and tau must be numbers"):
        vehicle_constraint_noise(meta, 0.1)
    ok = {"vehicle": {"constraint_violation": {"lateral_sigma_m_s": 0.01, "lateral_tau_s": 0.5}}}
    lat, vert = vehicle_constraint_noise(ok, 0.5)
    assert lat == pytest.approx(np.sqrt(2 * 0.01 ** 2 * 0.5 / 0.5)) and vert == 0.0


def test_an_imu_table_of_one_row_is_bad_input(tmp_path):
    from inmotion.io.bundle import check_imu
    with pytest.raises(BadInput, match="the IMU table has 1 row; it needs at least 2") as e:
        check_imu(np.array([0.0]), np.zeros((1, 3)), np.zeros((1, 3)), tmp_path / "imu.csv")
    assert "imu.csv" in str(e.value) and "row 1" in str(e.value)
