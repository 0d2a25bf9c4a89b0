"""Profile of the engine's per-row path at issue 13's equal workload, part by part.

Times, each the minimum over ``--repeat`` runs of this process's CPU time
(``time.process_time``) for one hour of 100 Hz rows (360,000 calls):

(a) the predict kernel alone (``predict_sparse``, the equal workload's layout, ``P`` and ``F``
    taken from the filter after 10 min of the hour: a realistic covariance);
(b) the mechanization alone (``_kernels.sins_run`` over the hour's IMU rows);
(c) ``error_model._fill_F`` alone (at the same state);
(d) the whole filter (``bench_engine.engine_run``: ``_advance`` over the hour, chunked);
(e) the same without the 10 Hz samples (mechanization, ``_fill_F``, predict, the loop);
(f) a bare loop of (b), (c) and (a) per row (mechanization, ``C_b^n``, ``_fill_F``, predict)
    with nothing else: what (e) would cost if the engine's loop added nothing.

    OPENBLAS_NUM_THREADS=1 python benchmarks/profile_engine.py [--repeat 5]

The machine may be shared: the load average is printed before and after.

Issue 13, the last few percent (what each change saved; CPU time, best of 5 runs of
``bench_engine.engine_run`` a process, the two versions run alternately; this 2-core machine
gives ~1.8x the load-1 figures at load > 2). Where the time went: ``perf record`` of eight
runs of the hour with a symbol map of the JIT code (``/tmp/perf-PID.map`` written from each
compiled library's object-code symbols; numba writes none): the predict kernel 56 % of the
compiled code's samples, the SINS step, its attitude update and libm's sin / cos / tan 20 %,
the scalar updates 10 %, ``_fill_F`` 5 %, the rest of ``_advance`` 5 %; inside the kernel
(samples by instruction address against its disassembly): forming ``Phi_a`` 27 % (spills: the
stack frame was 2 KB), the ``A`` pass 36 %, ``R`` 22 %, the scalar stores of ``P'`` 17 %.

* predict kernel: each row of ``Phi_a`` formed right before its row of ``A`` (no spilled
  ``Phi_a``): (a) 0.626 -> 0.564 us a call; the hour 0.478, 0.484 -> 0.438, 0.442 s (load
  3.5-4.7);
* ``sins_step`` and ``_fill_F`` inlined into ``_advance`` (``inline="always"``; no call, no
  NULL-meminfo reference-count calls for their arrays): 0.453, 0.448, 0.458 -> 0.423, 0.425,
  0.421 s (load ~5);
* together, the hour about -12 %; results bit-identical (the hour's filter state and
  ``sins-dr``'s hour, plain and smoothed, ``np.array_equal``). ``bench_engine.py --repeat 2
  --no-cli``, before and after alternating at load 1.8-2.9: equal workload 0.479, 0.530 ->
  0.418, 0.418 s per hour; ``sins-dr`` at 100 Hz 0.889, 0.929 -> 0.891, 0.891 s (even).
  ``python -m inmotion.warmup`` from empty caches: 102 -> 105 s CPU (load ~3; the inlined
  code is compiled into each caller).

Tried, not kept: ``attitude_update`` inlined too (0.414, 0.433 -> 0.416, 0.424: noise);
two or three rows of ``A`` per loop in the kernel (engine workload 0.56 -> 0.61-0.68 us;
``sins-dr``'s kernel 1.38 -> 1.24); the stores of ``P'`` after loads into locals (numba runs
no SLP vectorizer, so straight-line copies stay scalar: no change). After them the kernel's
samples: ``Phi_a`` and ``A`` 57 %, ``R`` 21 %, the stores of ``P'`` 20 % (~315 scalar
stores a call: a loop of fewer than 16 trips that needs a run-time alias check is not
vectorized, and ``P`` and the buffer are raw pointers to LLVM).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_engine import engine_run  # noqa: E402

from inmotion.core import _kernels as K  # noqa: E402
from inmotion.core.solution import NavState  # noqa: E402
from inmotion.estimation import error_model as em  # noqa: E402
from inmotion.estimation.predict import predict_sparse  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import find_scenario, load_scenario  # noqa: E402

ROWS = 360_000


@numba.njit(cache=True)
def _loop_predict(calls, x, P, F, Qc, dt, ws):
    for _ in range(calls):
        predict_sparse(x, P, F, Qc, dt, ws)


@numba.njit(cache=True)
def _loop_fill(calls, F, offs, lat, h, v, C, f_n, itau, dr_eps, gg, itg, ita):
    for _ in range(calls):
        em._fill_F(F, offs, lat, h, v, C, f_n, itau, dr_eps, gg, itg, ita)


@numba.njit(cache=True)
def _loop_bare(xs, mem, dtheta, dvel, dt, x, P, F, Qc, ws, offs9, itau, dr_eps, gg, itg, ita):
    C_S = np.empty((3, 3))
    f_n = np.empty(3)
    vel = np.empty(3)
    for k in range(dt.shape[0]):
        dth = (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2])
        dvl = (dvel[k, 0], dvel[k, 1], dvel[k, 2])
        K.sins_step(xs, mem, dth, dvl, dt[k], np.nan, 0.0, 0.0)
        K.dcm_from_quat_into((xs[K.Q0], xs[K.Q0 + 1], xs[K.Q0 + 2], xs[K.Q3]), C_S)
        for i in range(3):
            vel[i] = xs[K.VE + i]
        for i in range(3):
            f_n[i] = (C_S[i, 0] * dvl[0] + C_S[i, 1] * dvl[1] + C_S[i, 2] * dvl[2]) / dt[k]
        em._fill_F(F, offs9, xs[K.LAT], xs[K.H], vel, C_S, f_n, itau, dr_eps, gg, itg, ita)
        predict_sparse(x, P, F, Qc, dt[k], ws)


def best(fn, repeat):
    fn()
    out = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        fn()
        out = min(out, time.process_time() - c0)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--parts", default="abcdef")
    args = ap.parse_args(argv)
    print(f"load average before {os.getloadavg()}")
    bundle = simulate(load_scenario(find_scenario("paper002_hour")), np.random.default_rng(0))
    init = NavState.from_truth(bundle.truth)
    imu = bundle.imu
    # a realistic P, F: the filter after the first 10 minutes
    n10 = 60_000
    f = engine_run(_head(bundle, n10), init)
    S, C = f._S, f._C
    P = S.P[0].copy()
    x = S.X[0].copy()
    n = P.shape[0]
    xs = S.xs
    C_S = np.empty((3, 3))
    K.dcm_from_quat_into((xs[K.Q0], xs[K.Q0 + 1], xs[K.Q0 + 2], xs[K.Q3]), C_S)
    f_n = np.array([0.1, -0.2, 9.81])
    vel = xs[K.VE:K.VE + 3].copy()
    F = np.zeros((n, n))
    fill_args = (C.offs9, xs[K.LAT], xs[K.H], vel, C_S, f_n, C.inv_tau_dk, C.dr_eps,
                 C.grav_grad, C.inv_tau_b[0], C.inv_tau_b[1])
    em._fill_F(F, *fill_args)
    dt = 0.01
    res = {}
    if "a" in args.parts:
        res["a predict_sparse"] = best(
            lambda: _loop_predict(ROWS, x.copy(), P.copy(), F, C.Qc[0], dt, C.ws), args.repeat)
    if "b" in args.parts:
        def mech():
            x0 = np.asarray(_state(init))
            mem = np.zeros(K.NMEM)
            K.sins_run(x0, mem, imu.dtheta[1:], imu.dvel[1:], np.diff(imu.t),
                       np.full(len(imu.t) - 1, np.nan), 0.0, 0.0, 1 << 40,
                       np.zeros(1, np.int64), np.zeros((1, K.NX)))
        res["b mechanization (sins_run)"] = best(mech, args.repeat)
    if "c" in args.parts:
        res["c _fill_F"] = best(lambda: _loop_fill(ROWS, F, *fill_args), args.repeat)
    if "d" in args.parts:
        res["d whole filter (engine_run)"] = best(lambda: engine_run(bundle, init), args.repeat)
    if "e" in args.parts:
        res["e filter without samples"] = best(lambda: engine_run(bundle, init, False),
                                               args.repeat)
    if "f" in args.parts:
        def bare():
            x0 = np.asarray(_state(init))
            _loop_bare(x0, np.zeros(K.NMEM), imu.dtheta[1:], imu.dvel[1:], np.diff(imu.t),
                       x.copy(), P.copy(), np.zeros((n, n)), C.Qc[0], C.ws, C.offs9,
                       C.inv_tau_dk, C.dr_eps, C.grav_grad, C.inv_tau_b[0], C.inv_tau_b[1])
        res["f bare loop b+c+a"] = best(bare, args.repeat)
    for k, v in res.items():
        print(f"{k:32s} {v:.4f} s per hour ({v / ROWS * 1e6:.3f} us a row)")
    print(f"load average after {os.getloadavg()}")


def _state(init):
    from inmotion.core.mechanization import _state_vector
    return _state_vector(init)


def _head(bundle, rows):
    """The bundle's first ``rows`` IMU rows (and its radar up to then)."""
    import copy
    b = copy.copy(bundle)
    b.imu = copy.copy(bundle.imu)
    for k in ("t", "dtheta", "dvel"):
        setattr(b.imu, k, getattr(bundle.imu, k)[:rows + 1])
    return b


if __name__ == "__main__":
    main()
