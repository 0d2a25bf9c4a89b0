"""``benchmarks/run_all.py``: figures read from a script's output, verdicts against targets, a
budget that stops a script, and the results file (machine, table, outputs)."""
import importlib.util
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def run_all():
    spec = importlib.util.spec_from_file_location("run_all", ROOT / "benchmarks" / "run_all.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["run_all"] = mod           # dataclasses look their module up there
    spec.loader.exec_module(mod)
    yield mod
    sys.modules.pop("run_all", None)


def test_every_bench_script_has_a_spec(run_all):
    scripts = {p.name for p in (ROOT / "benchmarks").glob("bench_*.py")}
    assert scripts <= set(run_all.BENCHES), scripts - set(run_all.BENCHES)


def test_figures_are_read_and_judged(run_all):
    out = textwrap.dedent("""\
        dr-kf, paper000_traj2, 60001 IMU rows
          filter: best wall 1.250 s, best CPU 0.629 s (target < 1 s); all walls [1.3]
        """)
    (wall, w), (cpu, c) = run_all.read_figures(run_all.BENCHES["bench_dr_kf.py"], out)
    assert (w, c) == (1.25, 0.629)
    assert wall.verdict(w) == "FAIL" and cpu.verdict(c) == "pass"
    faster = run_all.Figure("speed-up", r"x {NUM}", "x", 1.6, ">")
    assert faster.verdict(1.7) == "pass" and faster.verdict(1.5) == "FAIL"
    assert run_all.Figure("size", "", "MB").verdict(5.0) == "-"
    (_, missing), _ = run_all.read_figures(run_all.BENCHES["bench_dr_kf.py"], "nothing")
    assert missing is None


def test_budget_stops_a_script_and_the_file_says_so(run_all, tmp_path):
    slow = tmp_path / "bench_slow.py"
    slow.write_text("import time\nprint('started', flush=True)\ntime.sleep(30)\n")
    r = run_all.run_script(slow, run_all.Bench(budget_s=1.0))
    assert r["status"] == "timeout" and r["wall_s"] < 10
    fig = run_all.Figure("never", r"never {0}", "s", 1.0)
    r.update(figures=[(fig, None)], note="")
    text = run_all.results_markdown([r], {"cpu": "test", "cores": 2}, (1, 1, 1), (2, 2, 2),
                                    "2026-01-01 00:00 UTC")
    assert "| bench_slow.py | run | exit 0 within 1 s | timeout after" in text
    assert "| bench_slow.py | never | < 1 s | not printed | - |" in text
    assert "- cpu: test" in text and "started" in text and "0 pass, 1 fail." in text
