"""Benchmark: the per-epoch covariance predict, dense (before) against sparse (issue 13).

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_predict.py [--calls N] [--batches B]``.

For the ``sins-dr`` layout (n = 22, 16 active rows), the ``dr-kf`` layout (n = 25, 16 active)
and the layout of ``bench_engine.py``'s equal workload (``engine``: n = 22, ``dk`` a random
constant, 9 active rows) it times, per call, in a numba loop (no Python between calls; the
first batch compiles / loads and is not timed):

* before: ``F = np.zeros((n, n))``, the array form of ``_fill_F`` (a frozen copy of the
  pre-issue-13 builder, :func:`_fill_F_before`, here for timing only) and the dense
  ``kalman._predict_kernel``: what ``sins_dr_driver._run_epochs`` did every epoch;
* after: ``error_model._fill_F`` into an ``F`` zeroed once, and ``predict.predict_sparse`` (the
  kernel generated for the layout's F pattern, :func:`inmotion.estimation.predict.make_workspace`;
  the time to generate and compile it, or to load it from numba's cache, is printed);
* each part alone.

Per call: the median (and the minimum) over ``B`` batches of ``N`` calls of this thread's CPU
time (``time.thread_time``: on a shared machine the wall time also counts the time other
processes hold the core); per hour: the median times 360,000 (one predict per 100 Hz IMU
epoch). Reference (issue 13): the dense 22-state
predict costs 4.3 us a call; the predict should reach about 0.3 us a call (0.1 s per hour).
The outputs of both paths are compared once (F bitwise; x and P to rounding).
"""
from __future__ import annotations

import argparse
import os
import time

import numba
import numpy as np

from inmotion.align.dr_kalman import LAYOUT_DR_KF
from inmotion.core.rotations import dcm_from_euler
from inmotion.estimation import error_model as em
from inmotion.estimation.kalman import _predict_kernel
from inmotion.estimation.layout import Layout
from inmotion.estimation.predict import make_workspace, predict_sparse
from inmotion.navigate.sins_dr import LAYOUT_SINS_DR

CALLS_PER_HOUR = 360_000
#: bench_engine.py's 22-state layout (its dk a random constant: default ProcessNoise)
ENGINE_LAYOUT = Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk", "lever"])


@numba.njit(cache=True)
def _fill_F_before(F, offs, lat, h, vel_n, C, f_n, inv_tau_dk, dr_eps, grav_grad):
    """Frozen copy of ``error_model._fill_F`` before issue 13 (array form), for timing only."""
    K = em.K
    skew = em.skew
    _put = em._put
    o_phi, o_dv, o_dp, o_eps, o_nabla, o_phiD, o_dpD, o_mount, o_dk = offs[:9]   # (eps_gm: none here)
    w_ie, w_en, Wie_p, Wen_v, Wen_p, Mpv, Mpp = em.transport_jacobians(lat, h, vel_n)
    V = skew(vel_n)
    _put(F, o_phi, o_phi, -skew(w_ie + w_en))
    _put(F, o_phi, o_dv, Wen_v)
    _put(F, o_phi, o_dp, Wie_p + Wen_p)
    _put(F, o_dv, o_phi, skew(f_n))
    _put(F, o_dv, o_dv, V @ Wen_v - skew(2.0 * w_ie + w_en))
    _put(F, o_dv, o_dp, V @ (2.0 * Wie_p + Wen_p))
    if grav_grad:
        r_m, r_n = K.radii(lat)
        F[o_dv + 2, o_dp + 2] += 2.0 * K.gravity(lat, h) / (np.sqrt(r_m * r_n) + h)
    _put(F, o_dp, o_dv, Mpv)
    _put(F, o_dp, o_dp, Mpp)
    if o_eps >= 0:
        _put(F, o_phi, o_eps, -C)
    if o_nabla >= 0:
        _put(F, o_dv, o_nabla, C)
    if o_phiD >= 0:
        D = np.zeros((3, F.shape[1]))
        em._dr_velocity_kernel(D, o_phiD, o_mount, o_dk, vel_n, C)
        A = Wen_v @ D
        B = Mpv @ D
        for i in range(3):
            for j in range(F.shape[1]):
                F[o_phiD + i, j] += A[i, j]
                F[o_dpD + i, j] += B[i, j]
        W = -skew(w_ie + w_en)
        Pj = Wie_p + Wen_p
        for i in range(3):
            for j in range(3):
                F[o_phiD + i, o_phiD + j] += W[i, j]
                F[o_phiD + i, o_dpD + j] += Pj[i, j]
                F[o_dpD + i, o_dpD + j] += Mpp[i, j]
        if o_eps >= 0 and dr_eps:
            _put(F, o_phiD, o_eps, -C)
    if o_dk >= 0:
        F[o_dk, o_dk] = -inv_tau_dk


# ---------------------------------------------------------------- timed loops (numba)
@numba.njit(cache=True)
def _loop_before(calls, x, P, Qc, dt, offs, lat, h, v, C, f_n, itau):
    n = x.shape[0]
    for _ in range(calls):
        F = np.zeros((n, n))
        _fill_F_before(F, offs, lat, h, v, C, f_n, itau, True, True)
        _predict_kernel(x, P, F, Qc, dt)


@numba.njit(cache=True)
def _loop_after(calls, x, P, F, Qc, dt, ws, offs, lat, h, v, C, f_n, itau):
    for _ in range(calls):
        em._fill_F(F, offs, lat, h, v, C, f_n, itau, True, True)
        predict_sparse(x, P, F, Qc, dt, ws)


@numba.njit(cache=True)
def _loop_fill_before(calls, F, offs, lat, h, v, C, f_n, itau):
    n = F.shape[0]
    for _ in range(calls):
        F = np.zeros((n, n))
        _fill_F_before(F, offs, lat, h, v, C, f_n, itau, True, True)


@numba.njit(cache=True)
def _loop_fill(calls, F, offs, lat, h, v, C, f_n, itau):
    for _ in range(calls):
        em._fill_F(F, offs, lat, h, v, C, f_n, itau, True, True)


@numba.njit(cache=True)
def _loop_dense(calls, x, P, F, Qc, dt):
    for _ in range(calls):
        _predict_kernel(x, P, F, Qc, dt)


@numba.njit(cache=True)
def _loop_sparse(calls, x, P, F, Qc, dt, ws):
    for _ in range(calls):
        predict_sparse(x, P, F, Qc, dt, ws)


def _per_call(fn, make_args, calls, batches):
    """Median and minimum CPU seconds per call over ``batches`` batches (after a warm-up)."""
    fn(1, *make_args())
    times = []
    for _ in range(batches + 1):
        args = make_args()
        t0 = time.thread_time()
        fn(calls, *args)
        times.append((time.thread_time() - t0) / calls)
    times = np.array(times[1:])
    return float(np.median(times)), float(times.min())


def _case(layout, rng):
    """A filter's inputs at a generic state: offsets, Qc, a covariance, a state."""
    n = layout.n
    offs = em._offsets(layout)
    noise = em.ProcessNoise(gyro_arw=5e-5, accel_vrw=1e-3, gyro_bias_rw=1e-7,
                            accel_bias_rw=1e-5, dk_sigma=1e-3, dk_tau=300.0)
    Qc = em.ErrorModel(layout, noise).Qc().copy()
    o = offs[6]
    if o >= 0:
        Qc[o:o + 3, o:o + 3] += np.diag([1e-15, 1e-15, 1e-2])  # DR position random walk
    L = rng.standard_normal((n, n))
    scale = {"phi": [1e-3] * 3, "dv": [0.1] * 3, "dp": [1e-6, 1e-6, 1.0], "eps": [1e-6] * 3,
             "nabla": [1e-3] * 3, "phi_D": [1e-3] * 3, "dp_D": [1e-6, 1e-6, 1.0],
             "mount": [1e-3] * 3, "dk": [1e-3], "lever": [0.05] * 3}
    s = np.concatenate([scale[b.name] for b in layout.blocks])
    P0 = (L @ L.T / n + np.eye(n)) * np.outer(s, s)
    x0 = 0.1 * s * rng.standard_normal(n)
    nav = (0.6, 120.0, np.array([8.0, 12.0, 0.2]), dcm_from_euler(np.array([0.02, -0.01, 0.9])),
           np.array([0.3, -0.2, 9.81]), 1.0 / 300.0)
    return n, offs, Qc, P0, x0, nav


def bench_layout(name, layout, calls, batches, dt=0.01, itau=None):
    rng = np.random.default_rng(0)
    n, offs, Qc, P0, x0, nav = _case(layout, rng)
    lat, h, v, C, f_n, itau0 = nav
    itau = itau0 if itau is None else itau
    c0 = time.process_time()
    ws = make_workspace(em.F_pattern(n, offs, itau, True), Qc)
    print(f"{name}: predict kernel for {len(ws.act)} active rows generated / loaded in "
          f"{time.process_time() - c0:.2f} s CPU")
    F = np.zeros((n, n))
    em._fill_F(F, offs, lat, h, v, C, f_n, itau, True, True)
    # the two paths agree (F bitwise; x, P to rounding)
    Fb = np.zeros((n, n))
    _fill_F_before(Fb, offs, lat, h, v, C, f_n, itau, True, True)
    xa, Pa, xb, Pb = x0.copy(), P0.copy(), x0.copy(), P0.copy()
    _predict_kernel(xb, Pb, Fb, Qc, dt)
    predict_sparse(xa, Pa, F, Qc, dt, ws)
    dP = np.max(np.abs(Pa - Pb) / np.sqrt(np.outer(np.diag(Pb), np.diag(Pb))))
    print(f"{name} (n = {n}): F nonzeros {int(np.count_nonzero(F))}, F equal to before: "
          f"{np.array_equal(F, Fb)}; max |dP| / sqrt(P_ii P_jj) after one step {dP:.1e}")

    def st():
        return x0.copy(), P0.copy()

    rows = [
        ("before: np.zeros + _fill_F (array form) + dense _predict_kernel", _loop_before,
         lambda: (*st(), Qc, dt, offs, lat, h, v, C, f_n, itau)),
        ("after: _fill_F (scalar, F reused) + predict_sparse", _loop_after,
         lambda: (*st(), F, Qc, dt, ws, offs, lat, h, v, C, f_n, itau)),
        ("  np.zeros + _fill_F, array form (before)", _loop_fill_before,
         lambda: (np.zeros((n, n)), offs, lat, h, v, C, f_n, itau)),
        ("  _fill_F, scalar (after)", _loop_fill,
         lambda: (F, offs, lat, h, v, C, f_n, itau)),
        ("  dense _predict_kernel (before)", _loop_dense, lambda: (*st(), F, Qc, dt)),
        ("  predict_sparse (after)", _loop_sparse, lambda: (*st(), F, Qc, dt, ws)),
    ]
    out = {}
    for label, fn, make in rows:
        med, best = _per_call(fn, make, calls, batches)
        out[label] = med
        print(f"  {name:7s} {label:64s} {med * 1e6:7.3f} us/call (min {best * 1e6:.3f})   "
              f"{med * CALLS_PER_HOUR:6.3f} s per hour at 100 Hz")
    b, a = out[rows[0][0]], out[rows[1][0]]
    print(f"  {name} speed-up, fill + predict: {b / a:.1f}x")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000, help="calls per timed batch")
    ap.add_argument("--batches", type=int, default=15)
    args = ap.parse_args(argv)
    print(f"per-call CPU times: median of {args.batches} batches of {args.calls} calls, "
          f"dt = 0.01 s; per hour = {CALLS_PER_HOUR} calls (100 Hz); "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for name, lay, itau in (("sins-dr", LAYOUT_SINS_DR, None), ("dr-kf", LAYOUT_DR_KF, None),
                            ("engine", ENGINE_LAYOUT, 0.0)):
        bench_layout(name, lay, args.calls, args.batches, itau=itau)


if __name__ == "__main__":
    main()
