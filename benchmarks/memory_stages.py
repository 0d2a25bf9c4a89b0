"""Where a command's peak memory comes from: peak resident set size per stage of one CLI run.

Runs ``inmotion ARGS...`` in this process with the stage functions of ``inmotion process``
(and the methods it chains) wrapped, while a thread samples the resident set size
(``/proc/self/statm``) every 2 ms and charges it to the innermost stage running; prints, per
stage path, the peak RSS seen while it ran. Issue 13 used it to find which stages' memory grows
with the log (run it on a 1 h and a 4 h bundle, e.g. those ``bench_memory.py`` builds).

    inmotion simulate SCENARIO.yaml -o B --seed 0 --format parquet
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/memory_stages.py process B --no-report -o OUT

Linux only (``/proc``). The figures are those of the sampling, so a peak shorter than 2 ms may
be missed; ``ru_maxrss`` at the end is the kernel's exact peak.
"""
from __future__ import annotations

import functools
import importlib
import os
import resource
import sys
import threading
import time

#: ``module:function`` wrapped as a stage
STAGES = ("inmotion.cli.main:_process_bundle", "inmotion.process:run_process",
          "inmotion.process:plan", "inmotion.process:heading_observability",
          "inmotion.process:stop_windows", "inmotion.process:_navigate",
          "inmotion.process:_concat",
          "inmotion.align.coarse_inertial:run_coarse_inertial",
          "inmotion.align.multiplex:coarse_fault_tolerant",
          "inmotion.align.parked_kf:run_parked_kf", "inmotion.align.dr_kalman:run_dr_kf",
          "inmotion.navigate.sins_dr:run_sins_dr", "inmotion.align.aided_kf:run_aided",
          "inmotion.align.aided_kf:_smooth_bank", "inmotion.align.aided_kf:_feed",
          "inmotion.estimation.smoother:smooth_at_outputs",
          "inmotion.estimation.smoother:smooth_record",
          "inmotion.io.result:thin", "inmotion.io.result:write_result")

_PAGE = os.sysconf("SC_PAGE_SIZE")


def _rss_mib() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * _PAGE / 2 ** 20


def main(argv):
    stack, peaks, order, done = ["(outside the stages)"], {}, [], threading.Event()

    def sample():
        while not done.is_set():
            r, key = _rss_mib(), " > ".join(stack)
            if key not in peaks:
                order.append(key)
            peaks[key] = max(peaks.get(key, 0.0), r)
            time.sleep(0.002)

    def wrap(spec):
        mod_name, fn_name = spec.split(":")
        mod = importlib.import_module(mod_name)
        fn = getattr(mod, fn_name)

        @functools.wraps(fn)
        def staged(*a, **k):
            stack.append(fn_name)
            try:
                return fn(*a, **k)
            finally:
                stack.pop()
        setattr(mod, fn_name, staged)

    import inmotion.cli.main as cli_main
    for spec in STAGES:
        wrap(spec)
    threading.Thread(target=sample, daemon=True).start()
    try:
        cli_main.cli.main(argv, standalone_mode=False)
    finally:
        done.set()
        time.sleep(0.01)
        print("peak RSS [MiB] while the stage ran:")
        for key in order:
            print(f"{peaks[key]:9.1f}  {key}")
        print(f"ru_maxrss {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.1f} MiB")


if __name__ == "__main__":
    main(["-q", *sys.argv[1:]])
