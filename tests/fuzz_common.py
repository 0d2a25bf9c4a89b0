"""Shared pieces of the fuzz suite (``tests/test_fuzz_*.py``, issue 16).

The suite's contract for bad input: exit status 2, exactly one line on stderr starting with
``inmotion: error:``, naming the thing at fault (file, row, time, option or field), no
traceback, within a time and memory bound. For valid input: exit 0 and finite, plausible
output.
"""
from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from inmotion.cli.main import cli

SRC = str(Path(__file__).resolve().parents[1] / "src")

#: a 16 s drive with a 10 deg/s turn, 50 Hz IMU: small and fast, but turning (so increments in
#: degrees are detectable)
SCENARIO = """\
name: fuzz_small
start: {lat_deg: 34.0, lon_deg: 108.0, h_m: 400.0, heading_deg: 20.0, speed_m_s: 8.0}
segments:
  - {kind: cruise, duration_s: 4}
  - {kind: turn, angle_deg: 60, rate_deg_s: 10}
  - {kind: cruise, duration_s: 6}
imu: {rate_hz: 50.0}
sensors:
  radar: {rate_hz: 10}
  odometer: {rate_hz: 10, pulses_per_m: 1000}
  baro: {rate_hz: 10}
"""

#: seconds one bad input may take in process, and resident memory it may add [MiB]
TIME_BOUND_S = 20.0
MEMORY_BOUND_MIB = 600.0


def _maxrss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def invoke(args):
    """Run the CLI in this process: ``(exit code, stdout, stderr, seconds, MiB added)``."""
    rss0, t0 = _maxrss_mib(), time.perf_counter()
    r = CliRunner().invoke(cli, ["--quiet", *map(str, args)])
    return (r.exit_code, r.stdout, r.stderr, time.perf_counter() - t0, _maxrss_mib() - rss0,
            r.exception)


def expect_bad(args, *fragments) -> str:
    """The contract for bad input; returns the message line."""
    code, out, err, secs, mib, exc = invoke(args)
    lines = err.strip().splitlines()
    assert code == 2, (code, out, err, exc)
    assert len(lines) == 1, err
    assert lines[0].startswith("inmotion: error: "), err
    assert "Traceback" not in err and "None" not in lines[0], err
    for f in fragments:
        assert str(f) in lines[0], (f, lines[0])
    assert secs < TIME_BOUND_S, secs
    assert mib < MEMORY_BOUND_MIB, mib
    return lines[0]


def expect_ok(args) -> str:
    code, out, err, secs, mib, exc = invoke(args)
    assert code == 0, (code, out, err, exc)
    return out


def run_bounded(args, tmp_path, timeout_s=60.0):
    """Run the CLI in a child process: ``(exit code, stderr, seconds, peak MiB of the child)``,
    for the inputs that used to exhaust memory; the child records its own peak resident
    memory at exit (none recorded: it did not exit by itself)."""
    peak_file = Path(tmp_path) / f"peak-{time.monotonic_ns()}.txt"
    code = ("import atexit, resource, sys\n"
            f"atexit.register(lambda: open({str(peak_file)!r}, 'w').write("
            "str(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)))\n"
            "sys.argv[0] = 'inmotion'\n"
            "from inmotion.cli.main import main\n"
            "main()\n")
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-c", code, "--quiet", *map(str, args)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        out, err = p.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        raise AssertionError(f"{args}: still running after {timeout_s} s")
    secs = time.perf_counter() - t0
    peak = float(peak_file.read_text()) / 1024.0 if peak_file.exists() else float("inf")
    return p.returncode, err.decode(errors="replace"), secs, peak


def finite_solution(result_dir: Path) -> None:
    """A result folder's solution: finite, latitude and pitch within +-90 deg, time rising."""
    import pandas as pd
    df = pd.read_csv(result_dir / "solution.csv")
    v = df[["t", "lat", "lon", "h", "vE", "vN", "vU", "pitch", "roll", "yaw"]].to_numpy(float)
    assert np.isfinite(v).all()
    assert (np.abs(v[:, 1]) <= 90).all() and (np.abs(v[:, 7]) <= 90).all()
    assert (np.diff(v[:, 0]) > 0).all()
