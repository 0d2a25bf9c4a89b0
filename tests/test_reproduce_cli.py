"""``inmotion reproduce``: one paper end to end, bad names, and the aggregation of ``all``.

The end-to-end run is paper 004 with 2 runs (the cheapest Monte Carlo): its summary rows must
carry the paper's own table values (read from the per-paper module) beside the measured figures
of its ``results.json``, with verdicts in the row's sense. The ``all`` tests replace the
registry with two cheap reproductions, one raising, to check the aggregation (both recorded,
the error on the page), not the science.
"""
import json
import sys
import types

import numpy as np
import pytest
from click.testing import CliRunner

from inmotion.cli.main import cli
from inmotion.errors import BadInput
from inmotion.reproductions import suite as rp
from inmotion.reproductions.page import markdown_to_html

ROW_KEYS = {"quantity", "unit", "paper", "measured", "better", "verdict", "note"}
PNG = (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x06\x00\x00"
       b"\x00\x1f\x15\xc4\x89\x00\x00\x00\rIDATx\x9cc\xf8\x0f\x00\x00\x01\x01\x00\x05\x18\xd8N"
       b"\x00\x00\x00\x00IEND\xaeB`\x82")


def invoke(*args):
    return CliRunner().invoke(cli, [*map(str, args)], catch_exceptions=False)


def _expected_verdict(row):
    p, m = row["paper"], row["measured"]
    if row.get("comparable") is False:
        return "not comparable"
    if "measured_interval" in row:
        band = None
        if row["measured_interval"][0] <= p <= row["measured_interval"][1]:
            return "same"
    elif "measured_se" in row or "paper_se" in row:
        band = 2 * np.hypot(row.get("measured_se") or 0.0, row.get("paper_se") or 0.0)
    elif row.get("tolerance", 0.0) > 0.0:
        band = row["tolerance"]
    else:
        return "undecided"
    if band is not None and abs(m - p) <= band:
        return "same"
    if row["better"] == "closer":
        return "better" if abs(m) < abs(p) else "worse"
    return "better" if m < p else "worse"


@pytest.fixture(scope="module")
def run_004(tmp_path_factory):
    out = tmp_path_factory.mktemp("r004")
    res = invoke("--quiet", "reproduce", "004", "--runs", 2, "--workers", 1, "--seed", 5,
                 "--json", "-o", out)
    return out, res


def test_004_end_to_end_rows_have_the_paper_beside_the_measured(run_004):
    from inmotion.reproductions import paper004 as r4
    out, res = run_004
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output)
    (one,) = summary["papers"]
    assert one["paper"] == "004" and one["status"] == "ok" and one["runs"] == 2
    rows = one["rows"]
    assert rows and all(ROW_KEYS <= set(r) for r in rows)
    results = json.loads((out / "results.json").read_text())
    n_table = 0
    for r in rows:
        assert r["verdict"] in ("better", "worse", "same", "not comparable", "undecided")
        assert r["verdict"] == _expected_verdict(r)
        if r["quantity"].endswith("heading mean"):   # 2 Monte Carlo standard errors
            speed, label = int(r["quantity"].split()[4]), r["quantity"].split()[3]
            std = results["stats"][str(speed)][label]["STD"]
            assert r["tolerance"] == pytest.approx(2 * std / 2 ** 0.5)
        if r["quantity"].startswith("004 Table 2 imada-vb"):
            speed = int(r["quantity"].split()[4])
            stat = r["quantity"].rsplit(" ", 1)[1]
            i = r4.STAT_NAMES.index(stat)
            assert r["paper"] == r4.PAPER_TABLE2[speed][i]
            assert r["measured"] == results["stats"][str(speed)]["imada-vb"][stat]
            n_table += 1
    assert n_table == 4 * len(r4.SPEEDS_M_S)
    # the rows are also beside the results, and the page is self-contained
    assert json.loads((out / rp.ROWS_FILE).read_text())["rows"] == rows
    page = (out / "report.html").read_text()
    assert "Paper 004" in page and "data:image/png;base64," in page
    assert "src=\"http" not in page and "<script" not in page


def test_reuse_rereads_without_running(run_004, monkeypatch):
    out, first = run_004
    monkeypatch.setattr(rp.Reproduction, "load", lambda self: pytest.fail("ran again"))
    res = invoke("--quiet", "reproduce", "004", "--reuse", "--json", "-o", out)
    assert res.exit_code == 0, res.output
    (one,) = json.loads(res.output)["papers"]
    assert one["reused"] is True
    before = json.loads(first.output)["papers"][0]
    assert one["rows"] == before["rows"]
    assert (one["wall_s"], one["runs"], one["seed"]) == (before["wall_s"], 2, 5)   # the run's


def test_unknown_paper_exits_2_naming_the_valid_ones(tmp_path):
    res = CliRunner().invoke(cli, ["reproduce", "005", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2
    assert "unknown paper '005'" in res.output
    for name in rp.names() + ["all"]:
        assert name in res.output
    assert not (tmp_path / "x").exists()


def test_summary_rows_bad_input(tmp_path):
    with pytest.raises(BadInput, match="no results of paper 002"):
        rp.summary_rows("002", tmp_path)
    (tmp_path / "summary.json").write_text("{not json")
    with pytest.raises(BadInput, match="not valid JSON"):
        rp.summary_rows("002", tmp_path)


def test_runs_for_a_function_without_runs_is_bad_input(tmp_path, fake_registry):
    with pytest.raises(BadInput, match="takes no --runs"):
        rp.run_reproduction("fixed", tmp_path, runs=3)


# ----------------------------------------------------------------------------- all, faked
@pytest.fixture
def fake_registry(monkeypatch):
    """Three cheap reproductions: 'bad' raises, 'good' writes results and a report with an
    image, 'fixed' takes no runs."""
    mod = types.ModuleType("fake_reproductions")
    calls = []

    def good(out, runs=4, seed=0):
        calls.append({"runs": runs, "seed": seed})
        (out / "res.json").write_text(json.dumps({"value": 1.5, "other": 7.0}))
        (out / "fig.png").write_bytes(PNG)
        (out / "report.md").write_text("# Good\n\n| a | b |\n|---|---|\n| 1 | <2> |\n\n"
                                       "![the figure](fig.png)\n")

    def bad(out, runs=4, workers=2, seed=0, progress=True):
        raise RuntimeError("boom: solver diverged")

    def fixed(out):
        (out / "res.json").write_text(json.dumps({"value": 3.0, "other": 1.0}))

    mod.good, mod.bad, mod.fixed = good, bad, fixed
    monkeypatch.setitem(sys.modules, "fake_reproductions", mod)

    def rows(res):
        return [rp._row("value", "m", 2.0, res["value"], measured_se=0.1),
                rp._row("other", "m", 5.0, res["other"], better="closer", measured_se=0.1)]

    fake = {n: rp.Reproduction(n, f"paper {n}", "fake_reproductions", n, "res.json", rows, k)
            for n, k in (("bad", 4), ("good", 4), ("fixed", None))}
    monkeypatch.setattr(rp, "REPRODUCTIONS", fake)
    return calls


def test_all_records_the_failure_and_runs_the_others(tmp_path, fake_registry):
    summary = rp.reproduce_all(tmp_path, runs=3, workers=1, seed=9, progress=False)
    by = {p["paper"]: p for p in summary["papers"]}
    assert [p["paper"] for p in summary["papers"]] == ["bad", "good", "fixed"]
    assert by["bad"]["status"] == "failed" and "boom: solver diverged" in by["bad"]["error"]
    assert by["good"]["status"] == by["fixed"]["status"] == "ok"
    assert fake_registry == [{"runs": 3, "seed": 9}]      # only the arguments it takes
    good = {r["quantity"]: r for r in by["good"]["rows"]}
    assert good["value"]["verdict"] == "better" and good["other"]["verdict"] == "worse"
    fixed = {r["quantity"]: r for r in by["fixed"]["rows"]}
    assert fixed["value"]["verdict"] == "worse" and fixed["other"]["verdict"] == "better"
    page = (tmp_path / "report.html").read_text()
    for text in ("Paper bad", "Paper good", "Paper fixed", "boom: solver diverged",
                 "RuntimeError", "&lt;2&gt;", "data:image/png;base64,"):
        assert text in page
    assert page.count("<tr>") >= 3 + 4          # summary rows + every paper figure
    on_disk = json.loads((tmp_path / rp.ALL_SUMMARY_FILE).read_text())
    assert [p["status"] for p in on_disk["papers"]] == ["failed", "ok", "ok"]


def test_cli_all_exits_1_when_one_fails_and_prints_rows(tmp_path, fake_registry):
    res = CliRunner().invoke(cli, ["reproduce", "all", "--runs", "2", "-o",
                                                   str(tmp_path)])
    assert res.exit_code == 1
    assert "paper bad: failed (RuntimeError: boom: solver diverged)" in res.stdout
    assert "value" in res.stdout and "better" in res.stdout
    assert "failed: bad" in res.stderr
    assert "paper bad (1 of 3)" in res.stderr and "paper good: ok" in res.stderr
    assert (tmp_path / "report.html").is_file()


def test_markdown_subset_to_html(tmp_path):
    (tmp_path / "f.png").write_bytes(PNG)
    used = set()
    h = markdown_to_html("## T <x>\n\ntext `code` and\nmore\n\n| a | b |\n| --- | ---: |\n"
                         "| 1 | 2 |\n\n- item\n\n![cap](f.png)\n![gone](missing.png)\n",
                         tmp_path, used)
    assert "<h4>T &lt;x&gt;</h4>" in h
    assert "<p>text <code>code</code> and more</p>" in h
    assert h.count("<tr>") == 2 and "---" not in h
    assert "<li>item</li>" in h
    assert h.count("<img") == 1 and used == {"f.png"}
