"""The fixed cost of a command-line run, measured as a real run, and what it is made of.

Issue 13: "a CLI run's fixed cost (imports, start-up) <= 0.4 s". ``inmotion --help`` imports
almost nothing, so it is not the figure: the fixed cost is the wall time of a real
``inmotion navigate`` on a bundle of a few seconds (7 s of a 100 Hz IMU, 10 Hz radar and
barometer, truth), where reading, filtering and writing take milliseconds and the rest is
start-up. Beside it, each in a bare interpreter (``python -c``), the floors it stands on:

* ``python``: the interpreter alone;
* ``numpy``, ``pandas``, ``pydantic``, ``pyarrow.parquet``, ``scipy.linalg``: ``import X``;
* ``numba floor``: ``import numba`` and the first call of one trivial ``@njit(cache=True)``
  function loaded from numba's cache: numba builds its CPU target on the first call, which
  imports ``scipy.linalg`` for its BLAS (``numba.np.linalg.ensure_blas``) whatever the
  function does. No run that calls a numba kernel can start faster than this;
* ``numba floor as the command line runs it``: the same, ending with ``os._exit`` as
  :func:`inmotion.cli.main.fast_exit` does (the plain floor above includes Python's teardown
  of numba's modules, about 0.2 s);
* ``run-path imports``: importing what ``navigate --method sins-dr`` imports before it calls
  a kernel (the command line, the method, the result writer, the chunked Parquet reader).

Beside the real run, the same run with
``INMOTION_FAST_EXIT=0`` (Python's own exit, tearing down every module) what
:func:`inmotion.cli.main.fast_exit` saves.

Best of ``--repeat`` wall times of each, and best CPU time (user + system of the child: on a
shared machine the wall time waits for a core, the CPU time hardly moves), after one warm-up
(file caches, numba's cache).

Then what the command is made of: whether the package's modules have byte-code (``.pyc``;
without it, as under ``PYTHONDONTWRITEBYTECODE=1`` before ``python -m inmotion.warmup`` wrote
it, every command compiles their source: 0.10 s CPU measured), and the CPU time of each part
of one ``navigate --method sins-dr`` run inside the process (timers around the command line's
own steps: imports, configuration, opening the bundle, the initial state, the filter's
construction with numba's first call, the IMU rows read and checked, the filter's kernel, the
truth rows kept for the errors, the result written), with the numba functions loaded from
numba's cache (``Dispatcher.stats.cache_hits``). ``--parts BUNDLE`` gives the same for a
bundle of yours (e.g. an hour: ``benchmarks/bench_engine.py``'s workload with ``--set
mode=velocity-position --set filter_rate_hz=100 --set output_rate_hz=1``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_startup.py [--repeat N]
        [--parts BUNDLE [--set KEY=VALUE ...]]

Ahead-of-time kernels (issue 13, branch h13aot). With numba on the run path 0.4 s was out
of reach (``import numba`` ~0.24 s, its first cached call ~0.15 s). ``numba.pycc`` (numba
0.68.1, deprecated but shipped) compiles the run path of ``navigate --method sins`` and
``sins-dr`` into one C extension (:mod:`inmotion._aot_build`, built by ``python -m
inmotion.warmup``): the engine loop ``_advance`` with the case's fill functions bound as
constant first-class function values (an intrinsic builds the ``FunctionType`` struct from
the compiled functions' addresses; the JIT path unboxes the same two addresses), ``_mode``,
``_write_output``, ``_fill_F``, ``sins_run``, ``time_steps``, the input checks, and the
predict kernel. What did not work at first: the predict kernel linked from numba's JIT module
(already optimized) was optimized again in the extension and some sums' first two products
fused into an FMA the other way (last-bit differences, e.g. 5e-21 on a state of 380);
lowered into the extension from its source (optimized once, as the JIT does) it is
bit-identical. The kernels' modules now import numba at first use (:mod:`inmotion._jit`), so
the run never imports it (``--parts`` says which path ran).

Measured (this file and an A/B script alternating 7 rounds on the 7 s bundle, CPU best of 7;
machine load 4.3-6: every figure inflated alike): ``navigate sins-dr`` main (7fb9668) 1.065 s
CPU, this branch with ``INMOTION_AOT=0`` (JIT) 1.064 s, ahead of time 0.367 s; ``sins``
0.796 / 0.836 / 0.342 s. This file, ahead of time, load 4.3-5.6: sins-dr 0.591 s wall, 0.382 s
CPU; sins 0.547 s wall, 0.364 s CPU; parts: imports 0.246 s (numpy, pyarrow, pydantic, click:
no numba), open the bundle 0.052 s, filter built 0.006 s (was 0.240 s at load ~1 with
numba), kernel 0.001 s, result 0.010 s, total in the process 0.344 s. The loop itself
(``benchmarks/bench_aot.py``, 16,380 rows, load ~4.4): JIT entry point 14.96 ms a call,
extension 13.79 ms (the difference is about the JIT's unboxing of its 16 first-class
functions, ~0.85 ms), outputs bit-identical.

Branch h13cli6: the truth rows for the errors are read in a thread during the run
(``TruthReducer``): ``--parts`` times that thread's CPU and the main thread's wait for it after
the run (``TruthStream.reduced`` only when the reducer falls back).

Branch h13cli5 (issue 13, the CLI hour): ``--parts`` on paper 002's hour showed numba
imported after all ("filter built" 0.56-0.65 s): the hour's radar states a Markov scale
factor, whose predict kernel (16 active rows) the extension did not hold (its recorded 7 s
drive has a constant one: 15 rows); ``_aot_build.RUNS`` now records it (``sins-dr --set
noise_preset=paper``). And ``mode=velocity-position`` imported scipy.linalg (0.17 s) at the
loop's first BLAS call (a 3x3 matrix product in the velocity rows, now formed only with a
mount block). The run path of ``sins-dr`` in either mode, with either scale-factor model,
imports neither (``tests/test_run_path_imports.py``, ``tests/test_aot.py``). Measured here
(alternating runs, best of 10, load 5-7, so inflated alike): the 7 s bundle with the hour's
configuration 0.96 s -> 0.40 s wall; with the defaults ``sins-dr`` 0.38 / 0.45 s and
``sins`` 0.37 / 0.40 s (unchanged code paths: the spread is the load's); at load 3-4 this file
gave sins-dr 0.26 s (before) and 0.30 s (after), sins 0.29 / 0.34 s. ``sins-dr``'s own
imports beyond ``sins``'s (its configuration's pydantic models, the engine, the
measurements) cost 0.01-0.03 s of CPU; the 0.46 s recorded before was not reproduced at
any load here.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

import inmotion
from inmotion.io.bundle import write_bundle
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

TINY = {
    "name": "tiny", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "segments": [{"kind": "rest", "duration_s": 1},
                 {"kind": "accelerate", "to_speed_m_s": 3.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 3}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
            "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}

NJIT = textwrap.dedent("""\
    import numba
    @numba.njit(cache=True)
    def f(x):
        s = 0.0
        for i in range(x.shape[0]):
            s += x[i]
        return s
    """)


#: one command-line run in a child, with CPU timers around its steps (wrappers put around the
#: package's own functions in that child only); prints one JSON line
PARTS = textwrap.dedent("""\
    import json, os, sys, time
    parts = {}
    # the CPU time of the thread that runs each part (sins-dr reads its IMU rows in a reader
    # thread while the filter runs in the main one: process time would count both in each)
    def timed(owner, name, label):
        f = getattr(owner, name)
        def w(*a, **k):
            c = time.thread_time()
            try:
                return f(*a, **k)
            finally:
                parts[label] = parts.get(label, 0.0) + time.thread_time() - c
        setattr(owner, name, w)
    def timed_gen(owner, name, label):
        f = getattr(owner, name)
        def w(*a, **k):
            g = f(*a, **k)
            while True:
                c = time.thread_time()
                try:
                    x = next(g)
                except StopIteration:
                    return
                finally:
                    parts[label] = parts.get(label, 0.0) + time.thread_time() - c
                yield x
        setattr(owner, name, w)
    c0 = time.process_time()
    import inmotion.cli.main as M
    import inmotion.io.result as R
    import inmotion.io.bundle_stream as S
    import inmotion.navigate.sins_dr
    import inmotion.estimation.engine as E
    parts["imports (interpreter start not counted)"] = time.process_time() - c0
    timed(M, "build_config", "configuration")
    timed(M, "_read_bundle", "open the bundle (meta, time columns, sensor tables)")
    timed(M, "_initial_state", "initial state")
    timed(E.ErrorStateFilter, "__init__", "filter built (numba's first call, kernel loads; "
          "or the ahead-of-time extension's load)")
    timed_gen(S._ImuTable, "chunks", "IMU rows read and checked (sins-dr: in a reader thread)")
    timed(E.ErrorStateFilter, "add_imu", "filter kernel (add_imu)")
    timed(M, "run_method", "method run (the main thread: the above but a reader thread's, "
          "and the wrapper)")
    timed(S.TruthStream, "reduced", "truth rows kept for the errors (after the run)")
    timed(S.TruthReducer, "_run", "truth rows kept for the errors (in a thread during the run)")
    timed(S.TruthReducer, "result", "truth rows: the main thread's wait after the run")
    timed(R, "write_result", "result written (errors against truth)")
    sys.argv = ["inmotion", "-q"] + sys.argv[1:]
    try:
        M.main()
    except SystemExit as e:
        if e.code:
            raise
    parts["total in the process"] = time.process_time() - c0
    numba_used = "numba" in sys.modules
    aot_used = [m for m in sys.modules if m.startswith("inmotion_aot_")]
    from numba.core.dispatcher import Dispatcher
    def dispatchers(m):      # numba functions, also behind measurements.Compiled
        for v in list(vars(m).values()):
            d = v if isinstance(v, Dispatcher) else getattr(v, "_dispatcher", None)
            if isinstance(d, Dispatcher):
                yield d
    loaded = sorted({f"{d.py_func.__module__}.{d.py_func.__name__}"
                     for n, m in list(sys.modules.items()) if n.startswith("inmotion")
                     for d in dispatchers(m) if sum(d.stats.cache_hits.values())})
    print("PARTS " + json.dumps({"parts": parts, "loaded": loaded, "numba": numba_used,
                                 "aot": aot_used}), flush=True)
    os._exit(0)
    """)


def parts(bundle, sets, out, env, repeat):
    """Per-part CPU [s] of one ``navigate --method sins-dr`` (best of ``repeat`` per part)
    and the numba functions it loaded from the cache."""
    cmd = [sys.executable, "-c", PARTS, "navigate", str(bundle), "--method", "sins-dr",
           "--init", "truth", "-o", str(out)] + [a for kv in sets for a in ("--set", kv)]
    best, loaded, got = {}, [], {}
    for i in range(repeat + 1):
        p = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
        got = json.loads(p.stdout.rsplit("PARTS ", 1)[1])
        if i:                                               # the first warms the caches
            for k, v in got["parts"].items():
                best[k] = min(best.get(k, np.inf), v)
        loaded = got["loaded"]
    return best, loaded, got


def _paths(got):
    """How the run's kernels ran: numba imported or not, the ahead-of-time extension."""
    return (f"numba imported: {'yes' if got.get('numba') else 'no'}; ahead-of-time extension "
            f"(inmotion._aot): {', '.join(got.get('aot') or []) or 'not used'}")


def print_parts(bundle, sets, out, env, repeat):
    best, loaded, got = parts(bundle, sets, out, env, repeat)
    print(f"parts of navigate --method sins-dr on {Path(bundle).name} (CPU, best of {repeat}):")
    print(f"  {_paths(got)}")
    for k, v in best.items():
        print(f"  {k}: {v:.3f} s")
    print(f"  numba functions loaded from the cache ({len(loaded)}): {', '.join(loaded)}")


def bytecode_status():
    """``(modules of the run path, those without up-to-date byte-code)``."""
    import inmotion.cli.main  # noqa: F401  (the run path's modules)
    import inmotion.io.bundle_stream  # noqa: F401
    import inmotion.io.result  # noqa: F401
    import inmotion.navigate.sins_dr  # noqa: F401
    from inmotion.warmup import _bytecode_current
    files = [Path(m.__file__) for n, m in list(sys.modules.items())
             if n.startswith("inmotion") and getattr(m, "__file__", None)]
    return len(files), [f for f in files if not _bytecode_current(f)]


def _run(cmd, env, cwd):
    """``(wall, cpu)`` [s] of one child: its wall time and its user + system CPU time (the
    latter barely moves when the machine is shared)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(p.pid, 0)
    if status:
        raise SystemExit(f"failed: {' '.join(cmd)}")
    return time.perf_counter() - t0, ru.ru_utime + ru.ru_stime


def best_wall(cmd, repeat, env, cwd=None):
    """``(best wall, best CPU)`` [s] of ``repeat`` runs after a warm-up."""
    _run(cmd, env, cwd)                                                  # warm-up
    runs = [_run(cmd, env, cwd) for _ in range(repeat)]
    return min(r[0] for r in runs), min(r[1] for r in runs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--parts", metavar="BUNDLE", help="only the parts of a run on BUNDLE")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="configuration of sins-dr for --parts (repeatable)")
    args = ap.parse_args()
    here = str(Path(inmotion.__file__).resolve().parents[1])     # children run in a tmp dir
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(p for p in (here, os.environ.get("PYTHONPATH")) if p))
    py = sys.executable
    n_mod, stale = bytecode_status()
    print(f"byte-code: {n_mod - len(stale)} of the run path's {n_mod} modules have up-to-date "
          f".pyc" + (f" (missing: {', '.join(f.name for f in stale[:5])}"
                     f"{' ...' if len(stale) > 5 else ''}; python -m inmotion.warmup writes "
                     "them)" if stale else ""))
    if args.parts:
        with tempfile.TemporaryDirectory() as tmp:
            print_parts(args.parts, args.sets, Path(tmp) / "out", env, args.repeat)
        return
    with tempfile.TemporaryDirectory() as tmp:
        bundle = Path(tmp) / "tiny"
        write_bundle(simulate(load_scenario(TINY), np.random.default_rng(0)), bundle,
                     fmt="parquet")
        for method in ("sins-dr", "sins"):
            cmd = [py, "-m", "inmotion.cli.main", "-q", "navigate", str(bundle), "--method",
                   method, "-o", str(Path(tmp) / f"out-{method}")]
            wall, cpu = best_wall(cmd, args.repeat, env)
            print(f"CLI fixed cost (navigate {method}, 7 s bundle): {wall:.3f} s wall "
                  f"(target 0.4 s), {cpu:.3f} s CPU")
            if method == "sins-dr":
                wall, cpu = best_wall(cmd, args.repeat, dict(env, INMOTION_FAST_EXIT="0"))
                print(f"CLI fixed cost (navigate {method}) with Python's own exit: {wall:.3f} s "
                      f"wall, {cpu:.3f} s CPU")
        wall, cpu = best_wall([py, "-m", "inmotion.cli.main", "--help"], args.repeat, env)
        print(f"CLI --help: {wall:.3f} s wall, {cpu:.3f} s CPU")
        (Path(tmp) / "k.py").write_text(NJIT)
        floors = {"python": "pass"}
        for mod in ("numpy", "pandas", "pydantic", "pyarrow.parquet", "scipy.linalg",
                    "scipy.special", "numba"):
            floors[f"import {mod}"] = f"import {mod}"
        floors["numba floor"] = "import numpy as np, k; k.f(np.ones(3))"
        floors["numba floor as the command line runs it (fast exit)"] = (
            "import os, numpy as np, k; k.f(np.ones(3)); os._exit(0)")
        floors["run-path imports (navigate sins-dr, before a kernel runs)"] = (
            "import inmotion.cli.main, inmotion.navigate.sins_dr, inmotion.io.result, "
            "inmotion.io.bundle_stream, pyarrow.parquet")
        for name, code in floors.items():
            wall, cpu = best_wall([py, "-c", code], args.repeat, env, cwd=tmp)
            print(f"  bare interpreter, {name}: {wall:.3f} s wall, {cpu:.3f} s CPU")
        print_parts(bundle, (), Path(tmp) / "out-parts", env, args.repeat)


if __name__ == "__main__":
    main()
