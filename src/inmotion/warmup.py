"""Compile the numba kernels the demo uses, once, at install time (``make install``).

::

    python -m inmotion.warmup [--seconds S] [--verbose]

Numba compiles each kernel at its first call and caches it on disk beside the source
(``cache=True``, ``__pycache__/*.nbi, *.nbc``); a fresh clone's first ``make demo`` would
otherwise spend minutes compiling. This runs the demo's own code path quietly on a short
stretch of the built-in ``demo`` drive: the simulation, the bundle written and read back,
every ``navigate`` method from the first truth row, the main job (``process``: alignment
and navigation stages) on a window of the drive, the result files with their errors. The kernels are
compiled for the same argument types the demo uses, so the demo then only loads them.
It prints one line (what it compiled, how long it took) and exits 0 even if a method fails
(numba then compiles that method's kernels at its first use instead).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["warm_up", "main"]


def warm_up(seconds: float = 30.0, verbose: bool = False) -> dict:
    """Run the demo's code path on ``seconds`` [s] of moving drive per stage.

    Parameters
    ----------
    seconds : float
        Length [s] of each method's window (the drive starts moving at 30 s).
    verbose : bool
        Print each step's time on stderr.

    Returns
    -------
    dict
        ``steps`` (label -> seconds), ``failed`` (labels whose run raised), ``total_s`` [s].
    """
    import click
    import numpy as np

    from . import registry
    from .cli import main as cli
    from .io.bundle import write_bundle
    from .io.result import write_result
    from .sim import simulate

    ctx = click.Context(cli.cli, obj=cli._Opts(quiet=True))
    steps, failed = {}, []
    t_all = time.perf_counter()

    def step(label, fn):
        t0 = time.perf_counter()
        try:
            out = fn()
        except Exception as e:               # a failed step must not stop the others
            failed.append(label)
            if verbose:
                print(f"warm-up: {label}: {type(e).__name__}: {e}", file=sys.stderr)
            out = None
        steps[label] = time.perf_counter() - t0
        if verbose:
            print(f"warm-up: {label} {steps[label]:.1f} s", file=sys.stderr)
        return out

    with tempfile.TemporaryDirectory(prefix="inmotion-warmup-") as tmp, ctx:
        root = Path(tmp)
        scen = cli._load_scenario(cli.DEMO_SCENARIO)
        bundle = step("simulate", lambda: simulate(scen, np.random.default_rng(0)))
        if bundle is None:
            return {"steps": steps, "failed": failed, "total_s": time.perf_counter() - t_all}
        step("write bundle", lambda: write_bundle(bundle, root / "bundle"))
        bundle = step("read bundle", lambda: cli._read_bundle(ctx, root / "bundle")) or bundle
        t_move = 30.0
        for spec in registry.methods("navigate"):
            def nav(spec=spec):
                state, _ = cli._initial_state(ctx, bundle, "truth", None, spec.needs_attitude)
                sol, b = cli.run_method(ctx, bundle, spec, cli.build_config(spec), state,
                                        (None, t_move + seconds))
                write_result(sol, root / spec.name, truth=b.truth)
            step(spec.name, nav)
        def process():                   # the demo's main job, on a window of the drive
            from .process import ProcessConfig
            cli.run_process_to(ctx, bundle.window(None, t_move + 4 * seconds),
                               root / "process", ProcessConfig(), init="truth", report=False)
        step("process", process)
    return {"steps": steps, "failed": failed, "total_s": time.perf_counter() - t_all}


def main(argv=None) -> int:
    """Command-line entry point: ``python -m inmotion.warmup``."""
    p = argparse.ArgumentParser(prog="python -m inmotion.warmup", description=__doc__.split(
        "\n\n")[0])
    p.add_argument("--seconds", type=float, default=30.0,
                   help="window of each method [s] (default 30)")
    p.add_argument("--verbose", action="store_true", help="time each step on stderr")
    a = p.parse_args(argv)
    print("inmotion: compiling the numba kernels (once; cached on disk) ...", flush=True)
    res = warm_up(a.seconds, a.verbose)
    note = f"; not warmed: {', '.join(res['failed'])}" if res["failed"] else ""
    print(f"inmotion: kernels ready in {res['total_s']:.0f} s ({len(res['steps'])} steps{note})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
