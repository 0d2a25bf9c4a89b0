"""Back-to-back A/B of command-line runs of two (or more) source trees on one bundle.

Each round runs every tree once (alternating, so the machine's load falls on all alike), the
command in a child ``python -c`` that calls :func:`inmotion.cli.main.main` and prints the
child's main-thread CPU (``time.thread_time``) and process CPU; the first round is a warm-up.
Printed per tree: wall, main-thread CPU and process CPU, min and median. On a shared machine
the wall time waits for a core; the main thread's CPU is the critical path when the other
threads (IMU reader, truth reducer, result writer) fit on the second core.

    OPENBLAS_NUM_THREADS=1 python benchmarks/ab_cli.py TREE_A,TREE_B HOUR [--runs N]
        [--method sins-dr|od-velocity-kf]

``TREE`` a checkout (its ``src`` on ``PYTHONPATH``), ``HOUR`` a Parquet bundle (``inmotion
simulate paper002_hour -o HOUR --format parquet``). ``sins-dr``: ``benchmarks/bench_engine.py``'s
CLI line; ``od-velocity-kf``: its equal-workload line. Outputs go to ``/tmp/ab_cli_<method>_<tree>``.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

COMMANDS = {
    "sins-dr": ["navigate", "--method", "sins-dr", "--init", "truth", "--set",
                "mode=velocity-position", "--set", "filter_rate_hz=100", "--set",
                "measurement_rate_hz=10", "--set", "output_rate_hz=1"],
    "od-velocity-kf": ["align", "--method", "od-velocity-kf", "--init", "truth", "--set",
                       "filter_rate_hz=100", "--set", "measurement_rate_hz=10", "--set",
                       "feedback_rate_hz=10", "--set", "use_baro=false", "--output-rate", "1"]}
CHILD = ("import sys, os, time\nimport inmotion.cli.main as M\nsys.argv = ['inmotion'] + "
         "sys.argv[1:]\ntry:\n    M.main()\nexcept SystemExit as e:\n    assert not e.code\n"
         "sys.stdout.flush()\nos.write(2, f'MAIN {time.thread_time()} PROC "
         "{time.process_time()}\\n'.encode())\nos._exit(0)\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees")
    ap.add_argument("bundle")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--method", choices=list(COMMANDS), default="sins-dr")
    args = ap.parse_args()
    trees = args.trees.split(",")
    cmd = COMMANDS[args.method]
    res = {t: [] for t in trees}
    for i in range(args.runs + 1):
        for t in trees:
            env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=f"{t}/src")
            out = f"/tmp/ab_cli_{args.method}_{os.path.basename(t.rstrip('/'))}"
            argv = ["-q", cmd[0], args.bundle, *cmd[1:], "-o", out]
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-c", CHILD, *argv], env=env, text=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            wall = time.perf_counter() - t0
            if p.returncode:
                raise SystemExit(f"{t}: failed\n{p.stderr}")
            w = p.stderr.rsplit("MAIN ", 1)[1].split()
            if i:
                res[t].append((wall, float(w[0]), float(w[2])))
    for t, r in res.items():
        cols = list(zip(*r))

        def mm(c):
            return f"min {min(c):.3f} median {sorted(c)[len(c) // 2]:.3f}"
        print(f"{args.method} {t}: wall {mm(cols[0])}; main-thread CPU {mm(cols[1])}; "
              f"process CPU {mm(cols[2])} s ({len(r)} runs)")


if __name__ == "__main__":
    main()
