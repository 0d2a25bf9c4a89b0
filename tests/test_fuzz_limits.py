"""Issue 16: the inputs that used to exhaust memory or hang, run in a child process with its
peak memory and wall time measured, and Ctrl-C during a campaign.

Before issue 16 a YAML alias bomb in ``meta.yaml`` took 4 GB and was killed, as did
``montecarlo --runs 1000000000`` and a sweep grid of 10^10 points; a scenario 31 years long
raised MemoryError; ``--scheduler`` pointing at nothing waited 30 s; Ctrl-C during a campaign
printed the workers' tracebacks.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from fuzz_common import SCENARIO, SRC, run_bounded  # noqa: E402
from test_fuzz_kinds import BOMB  # noqa: E402

#: a child that refuses its input may use this much memory beyond a child that reads a valid
#: bundle (interpreter, numpy, pandas, numba ...); the inputs used to take 4 GB
EXTRA_MIB = 300.0
WALL_S = 15.0


@pytest.fixture(scope="module")
def baseline_mib(tmp_path_factory):
    """Peak memory of a child running ``inmotion info`` on a valid bundle."""
    d = tmp_path_factory.mktemp("base")
    b = _bundle(d)
    code, err, secs, peak = run_bounded(["info", b], d)
    assert code == 0, err
    return peak


def _bundle(tmp_path):
    from fuzz_common import expect_ok
    (tmp_path / "s.yaml").write_text(SCENARIO)
    expect_ok(["simulate", tmp_path / "s.yaml", "-o", tmp_path / "b"])
    return tmp_path / "b"


def _check(baseline, code, err, secs, peak, *fragments):
    lines = err.strip().splitlines()
    assert code == 2, (code, err)
    assert len(lines) == 1 and lines[0].startswith("inmotion: error: "), err
    assert "Traceback" not in err
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    assert secs < WALL_S, secs
    assert peak < baseline + EXTRA_MIB, (peak, baseline)


def test_meta_alias_bomb_bounded(tmp_path, baseline_mib):
    b = _bundle(tmp_path)
    (b / "meta.yaml").write_text(BOMB)
    _check(baseline_mib, *run_bounded(["info", b], tmp_path), "meta.yaml", "aliases")


def test_runs_1e9_and_grid_1e10_bounded(tmp_path, baseline_mib):
    (tmp_path / "s.yaml").write_text(SCENARIO)
    _check(baseline_mib, *run_bounded(["montecarlo", tmp_path / "s.yaml", "--method", "dr", "--runs",
                         1000000000, "-o", tmp_path / "mc"], tmp_path), "runs")
    grid = "".join(f"  k{i}: [1,2,3,4,5,6,7,8,9,10]\n" for i in range(10))
    (tmp_path / "sw.yaml").write_text(f"name: sw\nscenario: s.yaml\nmethod: dr\ngrid:\n{grid}")
    _check(baseline_mib, *run_bounded(["montecarlo", tmp_path / "sw.yaml", "-o", tmp_path / "mc2"], tmp_path),
           "sw.yaml", "points")
    assert not (tmp_path / "mc").exists() and not (tmp_path / "mc2").exists()


def test_scenario_31_years_bounded(tmp_path, baseline_mib):
    p = tmp_path / "long.yaml"
    p.write_text(SCENARIO.replace("duration_s: 6", "duration_s: 978000000"))
    _check(baseline_mib, *run_bounded(["simulate", p, "-o", tmp_path / "b"], tmp_path), "long.yaml", "rows")


def test_scheduler_nobody_answers_is_quick(tmp_path):
    (tmp_path / "s.yaml").write_text(SCENARIO)
    code, err, secs, peak = run_bounded(
        ["montecarlo", tmp_path / "s.yaml", "--method", "dr", "--runs", 1, "-o", tmp_path / "mc",
         "--scheduler", "tcp://127.0.0.1:9"], tmp_path)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "--scheduler tcp://127.0.0.1:9" in err and "Traceback" not in err
    assert secs < 15.0


def test_ctrl_c_during_montecarlo_stops_cleanly(tmp_path):
    """SIGINT to the whole process group (what a terminal's Ctrl-C does) while runs are
    landing: exit 130, one line saying how many runs are saved and the command to resume, no
    traceback from the client or the workers."""
    (tmp_path / "s.yaml").write_text(SCENARIO)
    out = tmp_path / "mc"
    launcher = ("import os, signal, sys\n"
                "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
                "sys.argv[0] = 'inmotion'\n"
                "from inmotion.cli.main import main\n"
                "main()\n")
    env = dict(os.environ, PYTHONPATH=SRC)
    args = ["--quiet", "montecarlo", tmp_path / "s.yaml", "--method", "sins", "--runs", 100000,
            "--workers", 1, "-o", out, "--no-report"]
    p = subprocess.Popen([sys.executable, "-c", launcher, *map(str, args)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                         start_new_session=True)
    try:
        t0 = time.monotonic()
        while not list((out / "results").glob("journal-*.jsonl")) or \
                os.path.getsize(next((out / "results").glob("journal-*.jsonl"))) == 0:
            assert p.poll() is None, p.communicate()
            assert time.monotonic() - t0 < 60, "no run finished"
            time.sleep(0.1)
        time.sleep(0.5)
        os.killpg(p.pid, signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    err = err.decode()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert p.returncode == 130, err
    assert "Traceback" not in err and "Error" not in err, err
    assert len(lines) == 1 and "runs are saved in" in lines[0] and "--resume" in lines[0], err
    saved = int(lines[0].split("interrupted; ")[1].split(" of ")[0])
    assert saved >= 1
    from inmotion.evaluate.store import ResultStore
    assert len(ResultStore(out).done()) == saved
