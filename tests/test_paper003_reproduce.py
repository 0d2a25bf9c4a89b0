"""reproduce_003 smoke test: one run, one window; the report carries every table and figure."""
import json

from inmotion.reproductions.paper003 import FAULTS, reproduce


def test_reproduce_003_one_run(tmp_path):
    res = reproduce(tmp_path, runs=1, workers=1, progress=False, windows=1)
    report = (tmp_path / "report.md").read_text()
    for heading in ("Table 2 analogue", "Table 3 analogue", "detection", "False-alarm",
                    "heading error at 600 s", "adaptive"):
        assert heading in report
    for fig in ("fig08_multiplexing.png", "fig11_fdi_tests.png", "fig13_fkf_fdi.png"):
        assert (tmp_path / fig).stat().st_size > 1000
    assert json.loads((tmp_path / "results.json").read_text())["runs"] == 1
    assert len(res["detection"]) == len(FAULTS)
    for d in res["detection"]:
        assert d["detected"] == 1 and d["max_delay_s"] <= 1.0
    assert abs(res["table3"]["heading"]["mean"]) < 10.0
    assert 175.0 < res["adaptive"]["switch_time_s"]["mean"] < 185.0
