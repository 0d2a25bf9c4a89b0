"""reproduce_003 smoke test: one run, one window; the report carries every table and figure."""
import json

import pytest

from inmotion.reproductions import paper003 as r3
from inmotion.reproductions.paper003 import FAULTS, reproduce


def test_reproduce_003_one_run(tmp_path):
    res = reproduce(tmp_path, runs=1, workers=1, progress=False, windows=1)
    report = (tmp_path / "report.md").read_text()
    assert report.index("## Conditions") < report.index("## Pooled")
    for heading in ("Pooled over drives and windows", "gain of information multiplexing",
                    "detection", "false-alarm rate 0.05", "heading error at 600 s",
                    "Strategy 1", "Strategy 2"):
        assert heading in report
    for fig in ("fig08_multiplexing.png", "fig11_fdi_tests.png", "fig13_fkf_fdi.png"):
        assert (tmp_path / fig).stat().st_size > 1000
    assert json.loads((tmp_path / "results.json").read_text())["runs"] == 1
    assert len(res["detection"]) == len(FAULTS)
    for d in res["detection"]:
        assert d["detected"] == 1 and d["max_delay_s"] <= 1.0
    assert abs(res["table3"]["heading"]["mean"]) < 10.0
    assert 175.0 < res["adaptive"]["switch_time_s"]["mean"] < 185.0
    # the short park takes Strategy 2 (in-motion coarse + fine with multiplexing)
    assert res["adaptive_strategy2"]["strategy"][0].startswith("2:")
    assert 25.0 < res["adaptive_strategy2"]["switch_time_s"]["mean"] < 35.0
    # multiplexing from the paper's 53' coarse start: the fine alignment ends far closer
    mg = res["multiplexing_gain"]
    assert mg["start_heading"]["mean"] == pytest.approx(r3.MUX_START_ERROR_ARCMIN, abs=1e-6)
    assert abs(mg["fkf with multiplexing"]["mean"]) < 10.0
