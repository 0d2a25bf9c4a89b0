"""The ahead-of-time loop against numba's JIT loop (issue 13): the same ``_advance`` call of
``navigate --method sins-dr``, on copies of its inputs, through the extension of
:mod:`inmotion._aot` and through the JIT overload's entry point (what
:meth:`ErrorStateFilter._call_advance` calls), CPU time per call, best of ``--repeat``
batches, alternating; and whether the outputs are bit-identical.

Needs the extension built for the current sources (``python -m inmotion._aot_build``).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_aot.py [--seconds S]
        [--repeat N] [--calls K]
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import io
import tempfile
import time
from pathlib import Path

import numpy as np

from inmotion import _aot
from inmotion._aot_build import _equal, _outputs
from inmotion.cli.main import cli
from inmotion.estimation import engine as E
from inmotion.io.bundle import write_bundle
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario


def drive(seconds):
    return {"name": "bench-aot",
            "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
            "segments": [{"kind": "rest", "duration_s": 1},
                         {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                         {"kind": "turn", "angle_deg": 90, "rate_deg_s": 3},
                         {"kind": "cruise", "duration_s": seconds}],
            "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
                    "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
            "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                        "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=120.0, help="cruise [s] (one call)")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--calls", type=int, default=10, help="calls per batch")
    a = ap.parse_args()
    got = {}
    orig = E.ErrorStateFilter._call_advance

    def call(self, *args):
        if not got:
            got.update(f=self, before=copy.deepcopy((self._S, args)))
        r = orig(self, *args)
        if "after" not in got:
            got.update(r=r, after=copy.deepcopy((self._S, args)))
        return r

    E.ErrorStateFilter._call_advance = call
    with tempfile.TemporaryDirectory() as tmp:
        b = Path(tmp) / "b"
        write_bundle(simulate(load_scenario(drive(a.seconds)), np.random.default_rng(0)), b,
                     fmt="parquet")
        with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
            cli.main(args=["-q", "navigate", str(b), "--method", "sins-dr", "-o",
                           str(Path(tmp) / "o")], prog_name="inmotion")
    E.ErrorStateFilter._call_advance = orig
    f = got["f"]
    if f._aot is None:
        raise SystemExit("no ahead-of-time case for this filter: python -m inmotion._aot_build")
    rows = len(got["before"][1][0])
    head = (f._S, f._C, f._fills, f._accs)
    tys = tuple(E._advance.typeof_pyval(x) for x in head + got["before"][1])
    S, args = copy.deepcopy(got["before"])
    E._advance(S, f._C, f._fills, f._accs, *args)         # compiled, or loaded from the cache
    jit = E._advance.overloads[tys].entry_point
    paths = {"jit": lambda S, args: jit(S, f._C, f._fills, f._accs, *args),
             "aot": lambda S, args: f._aot.advance(S, f._C, *args)}
    for name, fn in paths.items():
        S, args = copy.deepcopy(got["before"])
        r = fn(S, args)
        same = (r == got["r"] and _equal(S, got["after"][0])
                and _equal(_outputs(args[11]), _outputs(got["after"][1][11])))
        print(f"{name}: outputs bit-identical to the run's: {same}")
    best = {k: np.inf for k in paths}
    for _ in range(a.repeat):
        for name, fn in paths.items():
            ins = [copy.deepcopy(got["before"]) for _ in range(a.calls)]
            c = time.process_time()
            for S, args in ins:
                fn(S, args)
            best[name] = min(best[name], (time.process_time() - c) / a.calls)
    for name, v in best.items():
        print(f"{name}: {v * 1e3:.3f} ms CPU a call of {rows} IMU rows "
              f"({v / rows * 1e6:.3f} us a row), best of {a.repeat} batches of {a.calls}")
    print(f"extension: {_aot.module()[0].__name__}")


if __name__ == "__main__":
    main()
