"""HTML reports: content against constructed truth, paper verdicts, self-containedness, and the
page opened in a real (headless Chromium) browser."""
from __future__ import annotations

import base64
import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.core.bundle import Truth
from inmotion.core.earth import radii
from inmotion.core.solution import Solution, StateUnit
from inmotion.errors import BadInput
from inmotion.evaluate.montecarlo import run_campaign
from inmotion.evaluate.report import build_report, detect_kind, load_paper
from inmotion.evaluate.stats import compare_rows, count_verdicts, point_statistics, statistic, verdict
from inmotion.evaluate.sweep import load_sweep

ARCMIN = np.pi / 10800.0
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


# ----------------------------------------------------------------------------- fixtures
def straight_drive(n=601, dt=0.1, speed=10.0):
    """Truth: heading north at ``speed`` m/s from 45 deg N; returns (truth, north_m of truth)."""
    t = np.arange(n) * dt
    lat0, h = np.radians(45.0), 100.0
    r_m, _ = radii(lat0)
    north = speed * t
    lat = lat0 + north / (r_m + h)
    euler = np.tile([0.0, 0.0, 0.0], (n, 1))
    vel = np.tile([0.0, speed, 0.0], (n, 1))
    return Truth(t, lat, np.full(n, np.radians(10.0)), np.full(n, h), vel, euler), north


@pytest.fixture(scope="module")
def result_dir(tmp_path_factory):
    """A result folder whose errors are known: yaw +2 arcmin, 5 m north, sigmas constant."""
    from inmotion.io.result import write_result
    truth, _ = straight_drive()
    r_m, _ = radii(truth.lat[0])
    n = len(truth.t)
    euler = truth.euler.copy()
    euler[:, 2] += 2.0 * ARCMIN
    sol = Solution(truth.t, truth.lat + 5.0 / (r_m + truth.h), truth.lon, truth.h, truth.vel_n,
                   euler, sigma={"phi_U": np.full(n, 1.0 * ARCMIN), "north": np.full(n, 2.0)},
                   states={"dk": np.full(n, 150e-6)}, state_units={"dk": StateUnit("ppm", 1e6)},
                   info={"method": "constructed", "config": {"gain_per_s": 0.5}})
    path = tmp_path_factory.mktemp("result") / "run"
    write_result(sol, path, truth)
    return path


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory):
    doc = {"name": "synth", "run": "inmotion.evaluate.runs:synthetic_run", "runs": 12,
           "seed": 5, "fail_value": 1.8, "save_arrays": True,
           "grid": {"scale": [1.0, 2.0]},
           "paper": {"title": "a made-up table", "rows": [
               {"quantity": "spread at scale 2", "unit": "-", "paper": 2.5, "column": "std",
                "stat": "mean", "where": {"param.scale": 2.0}},
               {"quantity": "given figure", "unit": "m", "paper": 1.0, "measured": 3.0}]}}
    path = tmp_path_factory.mktemp("campaign") / "c"
    run_campaign(load_sweep(doc), path, workers=1, quiet=True)
    return path


def images(page: str) -> list:
    return re.findall(r'<img [^>]*src="data:image/png;base64,([^"]+)"', page)


def assert_self_contained(page: str):
    assert not re.search(r"""(src|href)=["'](?!data:)""", page), "a reference outside the page"
    assert "http://" not in page and "https://" not in page and "<script" not in page


# ----------------------------------------------------------------------------- result folder
def test_result_report_shows_the_constructed_errors(result_dir, tmp_path):
    out = build_report(result_dir, tmp_path / "r.html")
    page = out.read_text()
    assert_self_contained(page)
    imgs = images(page)
    assert len(imgs) == 4          # |errors| log scale, converged errors, position error, states
    for b64 in imgs:
        assert base64.b64decode(b64).startswith(PNG_MAGIC)
    saved = sorted((tmp_path / "r_figures").glob("*.png"))
    assert {base64.b64encode(p.read_bytes()).decode() for p in saved} == set(imgs)
    row = re.search(r"<td class=\"l\">yaw_arcmin</td><td class=\"l\">arcmin</td>"
                    r"<td class=\"\">([^<]+)</td>", page)
    assert abs(float(row.group(1)) - 2.0) < 1e-3
    row = re.search(r"<td class=\"l\">horizontal_m</td><td class=\"l\">m</td>"
                    r"<td class=\"\">([^<]+)</td>", page)
    assert abs(float(row.group(1)) - 5.0) < 1e-3
    # headers and rows in words, the final error in % of distance, every state panel explained
    assert "RMS, last 100 s" in page and "heading (yaw) error" in page
    assert "% of distance travelled" in page
    from inmotion.evaluate.plots import state_words
    assert state_words("dk_ppm") == ("dk", "ppm", "velocity sensor scale-factor error")
    assert "gain_per_s" in page and "constructed" in page and "dk_ppm" in page


def test_result_sigma_and_tracks_in_the_error_units(result_dir):
    from inmotion.evaluate.report import _result_tracks, _sigma_on
    from inmotion.io.result import read_result
    sol = read_result(result_dir)
    t = sol.t[::7]
    sigma = _sigma_on(sol, t)
    assert np.allclose(sigma["phi_U_arcmin"], 1.0) and np.allclose(sigma["north_m"], 2.0)
    (_, e_est, n_est), (_, e_true, n_true) = _result_tracks(sol, result_dir)
    _, north = straight_drive()
    assert np.allclose(n_true - n_true[0], north, atol=1e-3) and np.allclose(e_true, 0.0, atol=1e-6)
    assert np.allclose(n_est - n_true, 5.0, atol=1e-3)


# ----------------------------------------------------------------------------- campaign
def test_campaign_report_tables_verdicts_and_failures(campaign_dir, tmp_path):
    from inmotion.evaluate.montecarlo import read_results
    df = read_results(campaign_dir)
    page = build_report(campaign_dir, tmp_path / "c.html").read_text()
    assert_self_contained(page)
    assert len(images(page)) == 1 + 2                   # distributions, an envelope per point
    # the paper rows: measured from the table, the verdict follows "lower is better"
    ok2 = df[(df.status == "ok") & (df["param.scale"] == 2.0)]["std"]
    rows = compare_rows([{"quantity": "x", "paper": 2.5, "column": "std", "stat": "mean",
                          "where": {"param.scale": 2.0}}], df)
    assert rows[0]["measured"] == pytest.approx(ok2.mean())
    # better / worse only beyond two Monte Carlo standard errors of the mean
    se = ok2.std(ddof=1) / np.sqrt(len(ok2))
    assert rows[0]["measured_se"] == pytest.approx(se) and rows[0]["n_runs"] == len(ok2)
    expected = ("same" if abs(ok2.mean() - 2.5) <= 2 * se
                else "better" if ok2.mean() < 2.5 else "worse")
    assert re.search(rf"spread at scale 2</td>.*?>{expected}</td>", page)
    # a figure given without its uncertainty gets no verdict
    assert re.search(r"given figure</td>.*?>undecided</td>", page)
    # every failed run is listed with its seed and error
    failed = df[df.status == "error"]
    assert len(failed) > 0
    assert f"Failed runs ({len(failed)})" in page
    assert page.count("RuntimeError: synthetic failure") == len(failed)


def test_saved_paper_figures_are_found_beside_the_results(result_dir, tmp_path):
    from inmotion.evaluate.report import save_paper
    run = tmp_path / "run"
    shutil.copytree(result_dir, run)
    save_paper(run, {"title": "Table 9", "rows": [
        {"quantity": "heading", "unit": "arcmin", "paper": 1.5, "measured": 2.0,
         "measured_se": 0.2}]})
    page = build_report(run).read_text()
    assert "Against the paper: Table 9" in page
    assert re.search(r"heading</td>.*?>worse</td>", page)


def test_collection_report_summarises_every_paper_row(campaign_dir, result_dir, tmp_path):
    root = tmp_path / "all"
    root.mkdir()
    shutil.copytree(campaign_dir, root / "p004", ignore=shutil.ignore_patterns("report*"))
    shutil.copytree(result_dir, root / "p000")
    (root / "p000" / "paper.yaml").write_text(
        "title: t\nrows:\n- {quantity: yaw, unit: arcmin, paper: 1.0, measured: 0.5, tolerance: 0.1}\n")
    assert detect_kind(root) == "collection"
    page = build_report(root).read_text()
    start = page.index("Summary: paper against measured")
    summary = page[start:page.index("<h2>", start)]
    assert summary.count("<tr>") == 3 + 1           # header + the 3 paper rows
    df = pd.read_parquet(campaign_dir / "table.parquet")
    ok2 = df[(df.status == "ok") & (df["param.scale"] == 2.0)]["std"]
    se = ok2.std(ddof=1) / np.sqrt(len(ok2))
    third = ("same" if abs(ok2.mean() - 2.5) <= 2 * se
             else "better" if ok2.mean() < 2.5 else "worse")
    verdicts = ["better", "undecided", third]
    for v in ("better", "same", "worse", "undecided"):
        if verdicts.count(v):
            assert f"{verdicts.count(v)} {v}" in summary


# ----------------------------------------------------------------------------- statistics
def test_statistics_are_the_textbook_ones():
    x = np.array([1.0, -2.0, 3.0, np.nan])
    f = x[:3]
    assert statistic(x, "mean") == pytest.approx(f.mean())
    assert statistic(x, "std") == pytest.approx(np.std(f, ddof=1))
    assert statistic(x, "rms") == pytest.approx(np.sqrt(14.0 / 3.0))
    assert statistic(x, "max_abs") == 3.0 and statistic(x, "mean_abs") == 2.0
    assert np.isnan(statistic([np.nan], "mean"))
    with pytest.raises(BadInput, match="unknown statistic 'avg'"):
        statistic(x, "avg")


@pytest.mark.parametrize("paper, measured, better, kw, expected", [
    (2.0, 1.0, "lower", {"tolerance": 0.1}, "better"), (2.0, 3.0, "lower", {"tolerance": 0.1}, "worse"),
    (2.0, 3.0, "higher", {"tolerance": 0.1}, "better"), (2.0, 2.05, "lower", {"tolerance": 0.1}, "same"),
    (2.0, -1.0, "closer", {"tolerance": 0.1}, "better"),
    (1.0, 3.0, "closer", {"target": 2.5, "tolerance": 0.1}, "better"),
    (2.0, 1.0, "lower", {"tolerance": 0.0}, "undecided"),   # a zero tolerance claims no uncertainty
    (None, 1.0, "lower", {}, "-"), ("n/a", 1.0, "lower", {}, "-"),
    # no uncertainty given: no verdict
    (2.0, 1.0, "lower", {}, "undecided"),
    # standard errors of both: 2 * hypot(0.3, 0.4) = 1.0
    (2.0, 1.05, "lower", {"measured_se": 0.3, "paper_se": 0.4}, "same"),
    (2.0, 0.95, "lower", {"measured_se": 0.3, "paper_se": 0.4}, "better"),
    (2.0, 3.05, "lower", {"measured_se": 0.3, "paper_se": 0.4}, "worse"),
    # the paper's one run inside / outside our spread of single runs
    (2.0, 1.0, "lower", {"measured_interval": [0.5, 2.5]}, "same"),
    (3.0, 1.0, "lower", {"measured_interval": [0.5, 2.5]}, "better"),
    (2.0, 1.0, "lower", {"measured_se": 0.01, "comparable": False}, "not comparable"),
])
def test_verdicts(paper, measured, better, kw, expected):
    assert verdict(paper, measured, better, **kw) == expected


def test_rows_compare_only_the_same_statistic_over_comparable_sample_sizes():
    rows = compare_rows([
        {"quantity": "a", "paper": 2.0, "measured": 1.0, "measured_se": 0.1,
         "statistic": "std", "n_runs": 50, "paper_n": 5},
        {"quantity": "b", "paper": 2.0, "measured": 1.0, "measured_se": 0.1,
         "statistic": "std", "n_runs": 8, "paper_n": 5},
        {"quantity": "c", "paper": 2.0, "measured": 1.0, "measured_se": 0.1,
         "statistic": "median", "paper_statistic": "max"},
        {"quantity": "d", "paper": 2.0, "measured": 1.0, "measured_se": 0.1, "kind": "ablation"},
        {"quantity": "e", "paper": 2.0, "measured": 1.0, "tolerance": 0.1, "kind": "timing",
         "comparable": False, "why": "seconds on another machine"},
    ])
    assert [r["verdict"] for r in rows] == ["not comparable", "better", "not comparable",
                                            "better", "not comparable"]
    assert "std over 50 against the paper's over 5" in rows[0]["why"]
    counts = count_verdicts(rows)
    assert counts["better"] == 1 and counts["not comparable"] == 3 and counts["ablation"] == 1
    with pytest.raises(BadInput, match=r"measured_interval must be \[lo, hi\], got \[3.0, 1.0\]"):
        compare_rows([{"quantity": "g", "paper": 1.0, "measured": 2.0,
                       "measured_interval": [3.0, 1.0]}])
    with pytest.raises(BadInput, match="kind must be paper, ablation or timing"):
        compare_rows([{"quantity": "f", "paper": 1, "measured": 1, "kind": "mine"}])


@pytest.mark.parametrize("rows, message", [
    ([{"paper": 1}], "expected a mapping with a 'quantity'"),
    ([{"quantity": "q", "paper": 1, "column": "nope"}], "no column 'nope'"),
    ([{"quantity": "q", "paper": 1, "column": "a", "where": {"zz": 1}}], "selects on 'zz'"),
    ([{"quantity": "q", "paper": 1, "measured": 2, "better": "bigger"}], "lower, higher or closer"),
])
def test_bad_paper_rows_raise_bad_input(rows, message):
    df = pd.DataFrame({"status": ["ok"], "a": [1.0], "point_id": [0], "label": ["p"]})
    with pytest.raises(BadInput, match=message):
        compare_rows(rows, df)


def test_point_statistics_per_point_over_ok_runs_only():
    df = pd.DataFrame({"point_id": [0, 0, 0, 1], "label": ["a", "a", "a", "b"],
                       "status": ["ok", "ok", "error", "ok"], "e": [1.0, 3.0, np.nan, 5.0]})
    st = point_statistics(df, ["e"], ("mean", "rms"))
    assert st["runs"].tolist() == [3, 1] and st["failed"].tolist() == [1, 0]
    assert st["e:mean"].tolist() == [2.0, 5.0]
    assert st["e:rms"].iloc[0] == pytest.approx(np.sqrt(5.0))


# ----------------------------------------------------------------------------- bad input
def test_report_of_something_else_raises_bad_input(tmp_path):
    with pytest.raises(BadInput, match="not a directory"):
        build_report(tmp_path / "missing")
    with pytest.raises(BadInput, match="neither a campaign"):
        build_report(tmp_path)
    with pytest.raises(BadInput, match="paper figures file not found"):
        load_paper(tmp_path / "nope.yaml")
    (tmp_path / "p.yaml").write_text("rows: 3\n")
    with pytest.raises(BadInput, match="'rows' list"):
        load_paper(tmp_path / "p.yaml")
    (tmp_path / "q.yaml").write_text("rows: [1, 2\n")
    with pytest.raises(BadInput, match=r"q\.yaml: not valid YAML"):
        load_paper(tmp_path / "q.yaml")


def test_report_command(campaign_dir, tmp_path):
    from inmotion.cli.main import cli
    res = CliRunner().invoke(cli, ["report", str(campaign_dir), "-o", str(tmp_path / "x.html"),
                                   "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["report"] == str(tmp_path / "x.html") and len(out["figures"]) == 3
    res = CliRunner().invoke(cli, ["report", str(tmp_path / "missing")])
    assert res.exit_code == 2 and "not a directory" in res.output


# ----------------------------------------------------------------------------- real browser
CHECK = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || e.type)), true);
window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  const out = {images: imgs.length,
               rendered: imgs.filter(i => i.complete && i.naturalWidth > 0).length,
               widths: imgs.map(i => i.naturalWidth), errors: window.__errors,
               tables: document.querySelectorAll('table').length,
               fetched: performance.getEntriesByType('resource').map(r => r.name)};
  const p = document.createElement('pre');
  p.id = 'browser-check';
  p.textContent = JSON.stringify(out);
  document.body.appendChild(p);
});
</script>"""


def open_in_chromium(page: Path, tmp_path: Path) -> dict:
    """Load ``page`` (with a check script injected) in headless Chromium; the script's findings."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no chromium: `apt-get install -y chromium` (.ci/run installs it)")
    probe = tmp_path / f"browser-{page.stem}.html"
    probe.write_text(page.read_text().replace("<head>", "<head>" + CHECK, 1))
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run",
           f"--user-data-dir={tmp_path / 'chromium-profile'}", "--virtual-time-budget=10000",
           "--dump-dom", probe.as_uri()]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="browser-check">(.*?)</pre>', res.stdout, re.S)
    assert m, f"the page did not finish loading in chromium: {res.stderr[-2000:]}"
    return json.loads(html.unescape(m.group(1)))


def test_reports_load_and_render_in_a_real_browser(campaign_dir, result_dir, tmp_path):
    for src in (campaign_dir, result_dir):
        page = build_report(src, tmp_path / f"{src.name}.html")
        found = open_in_chromium(page, tmp_path)
        pngs = [base64.b64decode(b) for b in images(page.read_text())]
        assert found["errors"] == []
        assert found["images"] == len(pngs) > 0 and found["rendered"] == len(pngs)
        # the browser decoded each PNG to its own width (IHDR bytes 16-19)
        assert found["widths"] == [int.from_bytes(p[16:20], "big") for p in pngs]
        assert found["tables"] >= 2
        assert found["fetched"] == []                   # nothing loaded from anywhere


def test_result_page_screenshot_in_a_real_browser(result_dir, tmp_path):
    """The single-result page as an engineer sees it: headless Chromium renders it to a PNG
    that is not blank (figures and tables drawn)."""
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no chromium: `apt-get install -y chromium` (.ci/run installs it)")
    from matplotlib.image import imread
    page = build_report(result_dir, tmp_path / "shot.html")
    shot = tmp_path / "shot.png"
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--no-first-run", f"--user-data-dir={tmp_path / 'chromium-profile'}",
           "--window-size=1280,3000", f"--screenshot={shot}", page.as_uri()]
    subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert shot.is_file() and shot.read_bytes().startswith(PNG_MAGIC)
    img = imread(shot)
    assert img.shape[0] >= 2000 and img.shape[1] >= 1200
    gray = img[..., :3].mean(axis=2)
    assert gray.std() > 0.05                             # not a blank page
    assert (gray < 0.5).mean() > 0.005                   # text and lines drawn
