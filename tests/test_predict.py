"""The allocation-free F builder and the sparse covariance predict (issue 13).

* ``_fill_F`` assigns exactly the entries of ``F_pattern`` (so an F zeroed once can be
  refilled every epoch without clearing) and ``F_pattern`` holds every nonzero of F;
* ``predict_sparse`` (a kernel generated for each pattern) equals the dense
  ``kalman._predict_kernel`` to rounding (1e-13 of the size of the terms) for F of every
  layout the methods use (sins-dr with and without the DR drift term, dr-kf and od-kf /
  od-velocity-kf with ``dk`` Markov or constant, aided_kf's sub-filter and its 15-state
  vehicle-constraint filter, parked-kf, the 22-state benchmark) and for a pattern with a
  Gauss-Markov gyro bias (``-1/tau`` on the ``eps`` diagonal), at random states, random F on
  the same patterns, random SPD ``P``, dt from 0.005 to 1 s; ``P`` comes out exactly symmetric;
* the same over 200 chained steps inside a numba loop (the engine's use);
* ``borrowed`` views share the data and hold no reference; ``predict_kernel_call`` (the
  engine's call) gives ``predict_sparse``'s results bit for bit;
* the generated kernel is cached on disk and loaded, not compiled, by a second process; a
  pickled workspace is rebuilt in the process that unpickles it.
"""
import os
import pickle
import subprocess
import sys
from collections import namedtuple
from pathlib import Path

import numba
import numpy as np
import pytest
from llvmlite import ir as llvm_ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from inmotion.align.dr_kalman import LAYOUT_DR_KF, LAYOUT_OD_KF
from inmotion.align.parked_kf import ENGINE_LAYOUT as PARKED_LAYOUT
from inmotion.core.rotations import dcm_from_euler
from inmotion.estimation import error_model as em
from inmotion.estimation.aiding_rows import NHC_LAYOUT, SUB_LAYOUT
from inmotion.estimation.kalman import _predict_kernel
from inmotion.estimation.layout import Layout
from inmotion.estimation.predict import (borrowed, kernel_source, make_workspace,
                                         predict_kernel_call, predict_sparse)
from inmotion.navigate.sins_dr import LAYOUT_SINS_DR

LAYOUTS = {
    "sins15": Layout(["phi", "dv", "dp", "eps", "nabla"]),
    "sins15+mount,dk": Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk"]),
    "sins15+dr": Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D"]),
    "sins-dr": LAYOUT_SINS_DR,
    "dr-kf": LAYOUT_DR_KF,
    "od-kf": LAYOUT_OD_KF,
    "aided sub-filter": SUB_LAYOUT,
    "bench 22 (lever)": Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk", "lever"]),
}
DTS = (0.005, 0.01, 0.1, 1.0)
#: (layout, 1/tau of dk, DR sees the gyro drift, 1/tau of a Gauss-Markov gyro bias): the
#: filters the methods build (sins-dr; dr-kf, od-velocity-kf; od-kf; aided_kf's sub-filters
#: and vehicle-constraint filter; parked-kf) and the benchmark's, plus a Markov gyro bias
CASES = {
    "sins-dr": (LAYOUT_SINS_DR, 1.0 / 300.0, True, 0.0),
    "sins-dr printed F": (LAYOUT_SINS_DR, 1.0 / 300.0, False, 0.0),
    "dr-kf": (LAYOUT_DR_KF, 1.0 / 300.0, True, 0.0),
    "dr-kf dk constant": (LAYOUT_DR_KF, 0.0, True, 0.0),
    "od-kf": (LAYOUT_OD_KF, 1.0 / 300.0, True, 0.0),
    "aided sub-filter": (SUB_LAYOUT, 0.0, True, 0.0),
    "aided nhc / parked": (NHC_LAYOUT, 0.0, True, 0.0),
    "bench 22 (lever)": (LAYOUTS["bench 22 (lever)"], 0.0, True, 0.0),
    "sins15 Markov gyro bias": (NHC_LAYOUT, 0.0, True, 1.0 / 600.0),
    "sins-dr Markov gyro bias": (LAYOUT_SINS_DR, 1.0 / 300.0, True, 1.0 / 600.0),
}
assert tuple(PARKED_LAYOUT.names) == tuple(NHC_LAYOUT.names)


def _state(rng):
    """A random linearization point: lat, h, vel_n, C, f_n."""
    return (rng.uniform(-1.4, 1.4), rng.uniform(-300.0, 5000.0),
            rng.normal(0.0, 15.0, 3) * rng.choice([0.0, 1e-3, 1.0]),
            dcm_from_euler(rng.uniform(-np.pi, np.pi, 3)),
            rng.normal(0.0, 2.0, 3) + np.array([0.0, 0.0, 9.8]))


def _fill(n, offs, st, itau=1.0 / 300.0, dr_eps=True, F=None):
    F = np.zeros((n, n)) if F is None else F
    em._fill_F(F, offs, st[0], st[1], st[2], st[3], st[4], itau, dr_eps, True)
    return F


def _model_Qc(layout, rng):
    noise = em.ProcessNoise(gyro_arw=5e-5, accel_vrw=1e-3, gyro_bias_rw=1e-7,
                            accel_bias_rw=1e-5, dk_sigma=1e-3, dk_tau=300.0, mount_rw=1e-6)
    Qc = em.ErrorModel(layout, noise).Qc().copy()
    if "dp_D" in layout:                            # the driver's DR position random walk
        s = layout["dp_D"]
        Qc[s, s] += np.diag([1e-15, 1e-15, 1e-2])
    return Qc


def _spd(rng, n, spread):
    L = rng.standard_normal((n, n))
    s = 10.0 ** rng.uniform(-spread, spread, n)
    return (L @ L.T / n + 0.1 * np.eye(n)) * np.outer(s, s)


def _assert_close(x1, P1, x0, P0, x, P, F, Qc, dt, tol=1e-13):
    """``x1, P1`` (sparse) against ``x0, P0`` (dense) to ``tol`` of the size of the terms."""
    n = len(x)
    Fdt = F * dt
    Phi = np.abs(np.eye(n) + Fdt + 0.5 * Fdt @ Fdt)
    size_P = Phi @ (np.abs(P) + dt * np.abs(Qc)) @ Phi.T + dt * np.abs(Qc)
    size_x = Phi @ np.abs(x)
    assert np.all(np.abs(P1 - P0) <= tol * size_P)
    assert np.all(np.abs(x1 - x0) <= tol * size_x)


# -- the F builder ----------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(LAYOUTS))
def test_fill_F_assigns_exactly_its_pattern_and_needs_no_clearing(name):
    lay = LAYOUTS[name]
    offs = em._offsets(lay)
    rng = np.random.default_rng(1)
    for extra in (0, 6):                    # F wider than the layout (aided_engine: 21 on 15)
        n = lay.n + extra
        for itau, dr_eps in ((1.0 / 300.0, True), (0.0, False)):
            pat = em.F_pattern(n, offs, itau, dr_eps)
            F_reused = np.zeros((n, n))
            for _ in range(20):
                st = _state(rng)
                F = _fill(n, offs, st, itau, dr_eps)
                assert not np.any(F[~pat])
                marked = np.full((n, n), np.nan)
                _fill(n, offs, st, itau, dr_eps, marked)
                assert np.array_equal(~np.isnan(marked), pat)          # writes = pattern
                _fill(n, offs, st, itau, dr_eps, F_reused)             # never cleared
                assert np.array_equal(F_reused, F)
            dk = lay["dk"].start if "dk" in lay else None
            if dk is not None:
                assert pat[dk, dk] == (itau != 0.0)


def test_error_model_F_is_the_kernel_F():
    lay = LAYOUT_DR_KF
    rng = np.random.default_rng(2)
    model = em.ErrorModel(lay, em.ProcessNoise(dk_tau=300.0))
    st = _state(rng)
    pt = em.LinPoint(lat=st[0], h=st[1], vel_n=st[2], C_nb=st[3], f_n=st[4])
    assert np.array_equal(model.F(pt), _fill(lay.n, em._offsets(lay), st))


# -- the sparse predict ------------------------------------------------------------------------

def _case_F(lay, itau, dr_eps, itau_eps, st):
    """F of a case at state ``st`` and its pattern (a Markov gyro bias adds ``-1/tau`` on the
    ``eps`` diagonal, as a Gauss-Markov bias model would)."""
    n, offs = lay.n, em._offsets(lay)
    F = _fill(n, offs, st, itau, dr_eps)
    pat = em.F_pattern(n, offs, itau, dr_eps)
    if itau_eps:
        e = lay["eps"]
        F[e, e] = -itau_eps * np.eye(3)
        pat[e, e] |= np.eye(3, dtype=bool)
    return F, pat


@pytest.mark.parametrize("name", list(CASES))
def test_predict_sparse_equals_the_dense_kernel(name):
    lay, itau, dr_eps, itau_eps = CASES[name]
    n = lay.n
    rng = np.random.default_rng(3)
    Qc = _model_Qc(lay, rng)
    _, pat = _case_F(lay, itau, dr_eps, itau_eps, _state(rng))
    ws = make_workspace(pat, Qc)
    assert list(ws.act) == list(np.flatnonzero(pat.any(axis=1)))
    if itau_eps:
        assert set(range(lay["eps"].start, lay["eps"].stop)) <= set(ws.act)
    for trial in range(12):
        F, _ = _case_F(lay, itau, dr_eps, itau_eps, _state(rng))
        if trial % 3 == 2:                  # random values on the real pattern, larger
            F = np.where(pat, rng.normal(0.0, 0.3, (n, n)), 0.0)
        P = _spd(rng, n, 1.0 if trial % 2 else 6.0)
        x = rng.standard_normal(n)
        for dt in DTS:
            x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
            _predict_kernel(x0, P0, F, Qc, dt)
            predict_sparse(x1, P1, F, Qc, dt, ws)
            assert np.array_equal(P1, P1.T)
            _assert_close(x1, P1, x0, P0, x, P, F, Qc, dt)
            # the workspace's Phi_a^T is the dense Phi's active rows (the smoother reads it)
            Fdt = F * dt
            Phi = np.eye(n) + Fdt + 0.5 * Fdt @ Fdt
            size = np.eye(n) + np.abs(Fdt) + 0.5 * np.abs(Fdt) @ np.abs(Fdt)
            na = len(ws.act)
            assert np.all(np.abs(ws.PhiT[:, :na] - Phi[ws.act].T) <= 1e-13 * size[ws.act].T)
            assert not ws.PhiT[:, na:].any()


def test_predict_sparse_plain_relative_error_on_a_unit_covariance():
    """Well-scaled P: every entry within 1e-13 of the dense kernel's, relative to max |P|."""
    lay = LAYOUT_SINS_DR
    n, offs = lay.n, em._offsets(lay)
    rng = np.random.default_rng(4)
    Qc = rng.uniform(0.1, 1.0) * np.eye(n)
    ws = make_workspace(em.F_pattern(n, offs, 1.0 / 300.0, True))    # Qc: diagonal pattern
    for dt in DTS:
        F = np.where(em.F_pattern(n, offs, 1.0 / 300.0, True), rng.normal(0, 1, (n, n)), 0.0)
        P = _spd(rng, n, 0.0)
        x = rng.standard_normal(n)
        x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
        _predict_kernel(x0, P0, F, Qc, dt)
        predict_sparse(x1, P1, F, Qc, dt, ws)
        assert np.max(np.abs(P1 - P0)) <= 1e-13 * np.max(np.abs(P0))
        assert np.max(np.abs(x1 - x0)) <= 1e-13 * np.max(np.abs(x0))


def test_predict_sparse_floors_a_negative_diagonal_like_the_dense_kernel():
    lay = LAYOUTS["sins15"]
    n, offs = lay.n, em._offsets(lay)
    rng = np.random.default_rng(5)
    F = _fill(n, offs, _state(rng))
    Qc = np.zeros((n, n))
    ws = make_workspace(F != 0)
    P = _spd(rng, n, 0.0)
    P[0, 0] = -1.0                          # an active index
    P[10, 10] = -1.0                        # a random-constant one
    x = np.zeros(n)
    P0, P1 = P.copy(), P.copy()
    _predict_kernel(x.copy(), P0, F, Qc, 0.01)
    predict_sparse(x.copy(), P1, F, Qc, 0.01, ws)
    assert P0[0, 0] == P1[0, 0] == 0.0 and P0[10, 10] == P1[10, 10] == 0.0
    assert np.allclose(P1, P0, rtol=0.0, atol=1e-13)


def test_make_workspace_patterns():
    lay = LAYOUT_SINS_DR
    n, offs = lay.n, em._offsets(lay)
    ws = make_workspace(em.F_pattern(n, offs, 1.0 / 300.0, True), np.ones((n, n)))
    assert list(ws.act) == [*range(9), *range(15, 22)]        # SINS, DR and the Markov dk
    assert list(ws.inact) == list(range(9, 15))               # eps, nabla: identity rows
    assert ws.Qc_pattern.all()
    ws0 = make_workspace(em.F_pattern(n, offs, 0.0, True))
    assert 21 in ws0.inact and np.array_equal(ws0.Qc_pattern, np.eye(n, dtype=bool))  # dk
    with pytest.raises(ValueError):
        make_workspace(np.ones((3, 4)))


@numba.njit
def _run_dense(x, P, F, Qc, offs, states, dt):
    for k in range(states.shape[0]):
        F[:, :] = 0.0
        C = states[k, 5:14].reshape(3, 3).copy()
        em._fill_F(F, offs, states[k, 0], states[k, 1], states[k, 2:5], C, states[k, 14:17],
                   1.0 / 300.0, True, True)
        _predict_kernel(x, P, F, Qc, dt)


@numba.njit
def _run_sparse(x, P, F, Qc, offs, states, dt, ws):
    for k in range(states.shape[0]):
        C = states[k, 5:14].reshape(3, 3).copy()
        em._fill_F(F, offs, states[k, 0], states[k, 1], states[k, 2:5], C, states[k, 14:17],
                   1.0 / 300.0, True, True)
        predict_sparse(x, P, F, Qc, dt, ws)


@pytest.mark.parametrize("name", ["sins-dr", "dr-kf"])
def test_chained_steps_in_numba_follow_the_dense_kernel(name):
    """The engine's use: F zeroed once, refilled and predicted 200 times in compiled code."""
    lay = LAYOUTS[name]
    n, offs = lay.n, em._offsets(lay)
    rng = np.random.default_rng(6)
    Qc = _model_Qc(lay, rng)
    ws = make_workspace(em.F_pattern(n, offs, 1.0 / 300.0, True), Qc)
    st0 = _state(rng)
    states = np.array([np.concatenate([[st0[0] + 1e-6 * k, st0[1]], st0[2] + 0.01 * k,
                                       st0[3].ravel(), st0[4]]) for k in range(200)])
    P = _spd(rng, n, 3.0)
    x = rng.standard_normal(n)
    x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
    _run_dense(x0, P0, np.zeros((n, n)), Qc, offs, states, 0.01)
    _run_sparse(x1, P1, np.zeros((n, n)), Qc, offs, states, 0.01, ws)
    d = np.sqrt(np.diag(P0))
    assert np.max(np.abs(P1 - P0) / np.outer(d, d)) < 1e-12
    assert np.array_equal(P1, P1.T)
    assert np.max(np.abs(x1 - x0) / (np.abs(x0) + d)) < 1e-12


@numba.njit
def _fill_and_predict(calls, x, P, F, Qc, dt, ws, offs, st_f, C):
    for _ in range(calls):
        em._fill_F(F, offs, st_f[0], st_f[1], st_f[2:5], C, st_f[5:8], 1.0 / 300.0, True, True)
        predict_sparse(x, P, F, Qc, dt, ws)


def test_fill_F_and_predict_sparse_allocate_nothing_per_call():
    """NRT's allocation count of a compiled loop does not grow with its number of calls (only
    the arguments' entry into compiled code counts)."""
    try:
        from numba.core.runtime import _nrt_python, rtsys
        _nrt_python.memsys_enable_stats()
    except (ImportError, AttributeError):            # pragma: no cover - numba internals
        pytest.skip("numba's NRT statistics are not available")
    lay = LAYOUT_DR_KF
    n, offs = lay.n, em._offsets(lay)
    rng = np.random.default_rng(7)
    st = _state(rng)
    Qc = _model_Qc(lay, rng)
    ws = make_workspace(em.F_pattern(n, offs, 1.0 / 300.0, True), Qc)
    st_f = np.concatenate([[st[0], st[1]], st[2], st[4]])
    x, P, F = rng.standard_normal(n), _spd(rng, n, 1.0), np.zeros((n, n))
    counts = []
    for calls in (1, 1, 300):
        a0 = rtsys.get_allocation_stats().alloc
        _fill_and_predict(calls, x, P, F, Qc, 0.01, ws, offs, st_f, st[3])
        counts.append(rtsys.get_allocation_stats().alloc - a0)
    assert counts[1] > 0                              # the statistics are live
    assert counts[1] == counts[2]


def test_predict_sparse_with_no_dynamic_state_adds_dt_qc():
    n = 4
    rng = np.random.default_rng(8)
    P, x, Qc = _spd(rng, n, 0.0), rng.standard_normal(n), np.diag(rng.uniform(0.1, 1.0, n))
    ws = make_workspace(np.zeros((n, n)))
    x1, P1 = x.copy(), P.copy()
    predict_sparse(x1, P1, np.zeros((n, n)), Qc, 0.1, ws)
    assert np.array_equal(x1, x) and np.allclose(P1, P + 0.1 * Qc, rtol=1e-15, atol=0.0)


def test_kernel_source_follows_the_pattern():
    """Another pattern gives another kernel; the same pattern the same source (the cache key)."""
    lay = LAYOUT_SINS_DR
    n, offs = lay.n, em._offsets(lay)
    q = np.eye(n, dtype=bool)
    a = kernel_source(em.F_pattern(n, offs, 1.0 / 300.0, True), q)
    assert a == kernel_source(em.F_pattern(n, offs, 1.0 / 300.0, True), q)
    assert a != kernel_source(em.F_pattern(n, offs, 1.0 / 300.0, False), q)
    assert a != kernel_source(em.F_pattern(n, offs, 0.0, True), q)


def test_predict_sparse_refuses_arrays_of_another_size():
    n = 5
    pat = np.zeros((n, n), dtype=bool)
    pat[0, 1] = True
    ws = make_workspace(pat)
    for x, P in ((np.zeros(n + 1), np.eye(n)), (np.zeros(n), np.eye(n - 1))):
        with pytest.raises(ValueError, match="workspace's size"):
            predict_sparse(x, P, np.zeros((n, n)), np.eye(n), 0.1, ws)


def test_workspace_pickles_into_a_working_one():
    rng = np.random.default_rng(9)
    n = 5
    pat = np.zeros((n, n), dtype=bool)
    pat[0, 1] = pat[1, 0] = pat[1, 4] = True
    ws = make_workspace(pat)
    ws2 = pickle.loads(pickle.dumps(ws))
    assert ws2.kernel == ws.kernel and np.array_equal(ws2.F_pattern, ws.F_pattern)
    F = np.where(pat, rng.standard_normal((n, n)), 0.0)
    P, x, Qc = _spd(rng, n, 1.0), rng.standard_normal(n), np.diag(rng.uniform(0.1, 1.0, n))
    x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
    _predict_kernel(x0, P0, F, Qc, 0.1)
    predict_sparse(x1, P1, F, Qc, 0.1, ws2)
    _assert_close(x1, P1, x0, P0, x, P, F, Qc, 0.1)


_CACHE_PROBE = """
import numpy as np
from inmotion.estimation import predict
pat = np.zeros((6, 6), dtype=bool)
pat[0, 1] = pat[1, 2] = pat[2, 0] = pat[2, 5] = True
predict.make_workspace(pat)
(fn,) = predict._KERNELS.values()
print(fn.cache_hits)
"""


def test_generated_kernel_is_cached_across_processes(tmp_path):
    """A first process compiles the kernel of a (new) pattern, a second one loads it."""
    env = dict(os.environ, INMOTION_KERNEL_DIR=str(tmp_path),
               PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    hits = [subprocess.run([sys.executable, "-c", _CACHE_PROBE], env=env, check=True,
                           capture_output=True, text=True).stdout.split()[-1]
            for _ in range(2)]
    assert hits == ["0", "1"]
    assert len(list(tmp_path.glob("predict_*.py"))) == 1


# ------------------------------------------------------------ borrowed views (issue 13)
@intrinsic
def _refcount_and_null(typingctx, arr):
    """(meminfo's reference count or -1 when NULL, meminfo is NULL) of an array."""
    sig = types.UniTuple(types.int64, 2)(arr)

    def codegen(context, builder, signature, args):
        a = context.make_array(arr)(context, builder, args[0])
        mi = a.meminfo
        is_null = cgutils.is_null(builder, mi)
        i64 = llvm_ir.IntType(64)
        cnt = cgutils.alloca_once_value(builder, i64(-1))
        with builder.if_then(builder.not_(is_null)):
            builder.store(builder.load(builder.bitcast(mi, i64.as_pointer())), cnt)
        return context.make_tuple(builder, signature.return_type,
                                  [builder.load(cnt), builder.zext(is_null, i64)])

    return sig, codegen


_Pair = namedtuple("_Pair", "a b k inner")


@numba.njit
def _borrow_probe():
    a = np.arange(5.0)
    before = _refcount_and_null(a)[0]
    v = borrowed(a)
    w = v[1:4]                       # a view of the borrowed view
    w[0] = 10.0                      # writes reach the owner's memory
    during = _refcount_and_null(a)[0]
    t = borrowed(_Pair(a, np.ones((2, 2)), 3, (a, 2.5)))
    return (before, during, _refcount_and_null(v)[1], _refcount_and_null(w)[1],
            _refcount_and_null(t.inner[0])[1], a[1], t.a[1], t.k, t.inner[1], t.b.sum())


def test_borrowed_views_share_the_data_and_hold_no_reference():
    """``borrowed`` (the engine's per-row arrays): same data (a write through a view of it
    reaches the owner), a NULL meminfo (so numba's reference counting of it is a test of
    NULL, not an atomic operation), the owner's count untouched; in a (named)tuple every
    array, also nested, is borrowed and the other members are the same."""
    before, during, v_null, w_null, t_null, a1, ta1, k, inner1, bsum = _borrow_probe()
    assert before >= 1 and during == before
    assert v_null == 1 and w_null == 1 and t_null == 1
    assert a1 == 10.0 and ta1 == 10.0
    assert k == 3 and inner1 == 2.5 and bsum == 4.0


@numba.njit
def _predict_both(x, P, F, Qc, dt, ws, x2, P2):
    predict_sparse(x, P, F, Qc, dt, ws)
    predict_kernel_call(ws.kernel, x2, P2, F, Qc, dt, ws.buf)


def test_predict_kernel_call_is_predict_sparse_without_the_check():
    """The engine's call (kernel address and buffer bound once, sizes checked once) runs the
    same kernel as ``predict_sparse``: the same results bit for bit."""
    lay = LAYOUTS["sins-dr"]
    n, offs = lay.n, em._offsets(lay)
    rng = np.random.default_rng(11)
    Qc = _model_Qc(lay, rng)
    ws = make_workspace(em.F_pattern(n, offs, 1.0 / 300.0, True), Qc)
    lat, h, v, C, f_n = _state(rng)
    F = np.zeros((n, n))
    em._fill_F(F, offs, lat, h, v, C, f_n, 1.0 / 300.0, True, True)
    P = _spd(rng, n, 1.0)
    x = rng.standard_normal(n)
    x2, P2, P_in = x.copy(), P.copy(), P.copy()
    _predict_both(x, P, F, Qc, 0.01, ws, x2, P2)
    assert np.array_equal(x, x2) and np.array_equal(P, P2)
    assert not np.array_equal(P, P_in)                                    # it did predict


# -- first order (KF-GINS's Phi = I + F dt) ----------------------------------------------------

@pytest.mark.parametrize("name", ["sins-dr", "dr-kf", "bench 22 (lever)",
                                  "sins15 Markov gyro bias"])
def test_first_order_predict_equals_the_dense_first_order_predict(name):
    """``order=1``: ``Phi = I + F dt`` (no ``F F`` term), the trapezoid ``Q_d`` with that
    ``Phi``; against the dense formula written out here, to 1e-13 of the size of the terms
    (the sums are in another order), and the workspace's ``Phi_a^T`` is its active rows."""
    lay, itau, dr_eps, itau_eps = CASES[name]
    n = lay.n
    rng = np.random.default_rng(8)
    Qc = _model_Qc(lay, rng)
    _, pat = _case_F(lay, itau, dr_eps, itau_eps, _state(rng))
    ws = make_workspace(pat, Qc, order=1)
    assert ws.order == 1
    na = len(ws.act)
    for trial in range(6):
        F, _ = _case_F(lay, itau, dr_eps, itau_eps, _state(rng))
        if trial % 3 == 2:
            F = np.where(pat, rng.normal(0.0, 0.3, (n, n)), 0.0)
        P = _spd(rng, n, 1.0 if trial % 2 else 6.0)
        x = rng.standard_normal(n)
        for dt in DTS:
            Phi = np.eye(n) + F * dt
            x0 = Phi @ x
            P0 = Phi @ P @ Phi.T + 0.5 * dt * (Phi @ Qc @ Phi.T + Qc)
            P0 = 0.5 * (P0 + P0.T)
            x1, P1 = x.copy(), P.copy()
            predict_sparse(x1, P1, F, Qc, dt, ws)
            assert np.array_equal(P1, P1.T)
            A = np.abs(Phi)
            size_P = A @ (np.abs(P) + dt * np.abs(Qc)) @ A.T + dt * np.abs(Qc)
            assert np.all(np.abs(P1 - P0) <= 1e-13 * size_P)
            assert np.all(np.abs(x1 - x0) <= 1e-13 * (A @ np.abs(x)))
            # (the diagonal's 1 + dt F_ii may be one fused multiply-add)
            assert np.all(np.abs(ws.PhiT[:, :na] - Phi[ws.act].T) <= 1e-15 * A[ws.act].T)
            assert not ws.PhiT[:, na:].any()


def test_first_order_is_its_own_kernel_and_survives_pickling():
    lay = LAYOUTS["bench 22 (lever)"]
    pat = em.F_pattern(lay.n, em._offsets(lay), 0.0, True)
    q = np.eye(lay.n, dtype=bool)
    assert kernel_source(pat, q) == kernel_source(pat, q, 2)
    assert kernel_source(pat, q, 1) != kernel_source(pat, q, 2)
    ws = pickle.loads(pickle.dumps(make_workspace(pat, order=1)))
    assert ws.order == 1 and ws.kernel == make_workspace(pat, order=1).kernel
    assert make_workspace(pat).order == 2
    for bad in (0, 3):
        with pytest.raises(ValueError, match="order must be 1 or 2"):
            make_workspace(pat, order=bad)
