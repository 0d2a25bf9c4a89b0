"""The documentation is part of the package (issue 18): the worked examples run, the methods
page is current, the built site has no warnings, and nothing points outside the repository."""
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def run_example(name, *args, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep
               + os.environ.get("PYTHONPATH", ""), OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, str(DOCS / "examples" / name), *map(str, args)],
                       capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout, time.perf_counter() - t0


def test_example_simulate_align_navigate(tmp_path):
    import json
    out, wall = run_example("simulate_align_navigate.py", tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert list(s) == ["coarse", "fine", "navigate"]
    # fine alignment improves on the coarse heading, down to the gyrocompassing limit
    assert abs(s["fine"]["heading_arcmin"]) < abs(s["coarse"]["heading_arcmin"])
    assert abs(s["fine"]["heading_arcmin"]) < 20.0
    assert all(v["level_arcmin"] < 1.0 for v in s.values())
    assert s["navigate"]["horizontal_m"] < 0.02 * s["navigate"]["distance_m"]
    assert (tmp_path / "errors.png").stat().st_size > 10_000
    assert (tmp_path / "navigate-sins-dr" / "summary.json").is_file()
    assert wall < 60, f"the example took {wall:.1f} s (target < 20 s)"


def test_example_real_log(tmp_path):
    from inmotion.reproductions.real import default_data_root
    data = default_data_root()
    if not (data / "comma2k19_rav4_60s").is_dir():
        pytest.skip(f"no real data at {data}")
    out, wall = run_example("real_log.py", tmp_path, "--data", data)
    assert "dead reckoning ends" in out
    assert (tmp_path / "dr" / "summary.json").is_file() and (tmp_path / "dr.geojson").is_file()
    assert wall < 60, f"the example took {wall:.1f} s (target < 20 s)"


def test_methods_page_is_current():
    from inmotion.cli.method_docs import methods_markdown
    assert (DOCS / "methods.md").read_text() == methods_markdown(), (
        "docs/methods.md is stale: python -c 'from inmotion.cli.method_docs import "
        "methods_markdown; open(\"docs/methods.md\", \"w\").write(methods_markdown())'")


def test_nothing_points_outside_the_repository():
    pages = [ROOT / "README.md", *DOCS.glob("*.md"), *DOCS.glob("guide/*.md")]
    for p in pages:
        text = p.read_text()
        assert "../shared" not in text and "shared/DESIGN.md" not in text, p
    # the README is the wheel's long description: no relative links
    links = re.findall(r"\]\(([^)]+)\)", (ROOT / "README.md").read_text())
    assert all(x.startswith(("https://", "#")) for x in links), links


def test_docs_build_without_warnings(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings_handlers.python")
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-d",
                        str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "site" / "api" / "index.html").is_file()
