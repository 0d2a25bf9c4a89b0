"""Sparse covariance predict: the math of :func:`kalman._predict_kernel`, F's zero rows skipped.

One filter epoch predicts ``x`` and ``P`` over ``dt`` with (:mod:`inmotion.estimation.kalman`)::

    Phi = I + F dt + (F dt)^2 / 2
    x  <- Phi x
    P  <- Phi P Phi^T + dt / 2 (Phi Qc Phi^T + Qc)      (symmetric, diagonal floored at 0)

The error model's ``F`` (:func:`error_model._fill_F`) is sparse: 60-115 nonzeros of
n^2 = 484-625, all in the rows of the dynamic blocks (``phi, dv, dp, phi_D, dp_D``, and ``dk``
when it is a Markov state); the random-constant states (``eps, nabla, mount``) have zero rows,
i.e. identity rows of ``Phi``. :func:`predict_sparse` works on the ``na`` "active" rows only
(16 of 22 or 25 in the package's layouts):

* ``Phi_a`` (the active rows of ``Phi``) ``= I_a + dt F_a + dt^2/2 F_aa F_a``, ``F_a`` the
  active rows of F and ``F_aa`` their active columns (F's other rows are zero); it is built
  transposed, ``Phi_a^T`` (n x na), the one form both products below take without a copy;
* ``Phi P Phi^T + dt/2 Phi Qc Phi^T = Phi Pt Phi^T`` with ``Pt = P + dt/2 Qc`` (Qc's few
  entries added before, and once more after: the trapezoid's ``+ dt/2 Qc``);
* ``A = Phi_a Pt`` (na x n), the only rows of ``Phi Pt`` that differ from ``Pt``;
* ``P' = (Phi Pt) Phi^T``: between two active indices ``R = A Phi_a^T`` (na x na), averaged
  with its transpose (as the dense kernel symmetrizes); between an active ``i`` and an
  inactive ``j`` it is ``A[i, j]``; between two inactive indices ``Pt`` (+ dt/2 Qc).

The three products (``F_a^T F_aa^T``, ``Phi_a Pt``, ``A Phi_a^T``) are dense BLAS calls on the
compact blocks (``np.dot`` with ``out``; 19,000 multiplications for n = 22, against 53,000 in
the dense kernel, and no allocation per call). Measured (``benchmarks/bench_predict.py``), at
these sizes BLAS beats numba loops over E's ~170 nonzeros, a sparse product list for
``F_aa F_a``, and row-blocked loops; FMA contraction (``fastmath={'contract'}``) changes
nothing measurable (the arithmetic is in BLAS).

Where the time goes (issue 13's engine workload: n = 22, ``phi, dv, dp`` active, na = 9;
CPU time per call, minimum of 15 batches of 20,000, a loaded 2-core machine): 1.07 us a
call, of which the call itself 0.13 us (numba increfs and decrefs each of the 13 arrays
passed, ``ws`` included, ~10 ns a pair), gathering ``F_a^T``, ``F_aa^T`` 0.1 us, the three
BLAS products 0.18 + 0.19 + 0.16 us (``np.dot``'s own overhead is 0.04 us a call: the rest is
OpenBLAS's small-matrix kernel, ~23 multiply-adds per ns), the ``Phi`` scaling, ``x`` and
``Qc`` loops 0.15 us, the write-back of ``P`` 0.14 us. In the engine's loop it costs about
1.25 us a row, 0.45 s per hour at 100 Hz: 60 % of the engine's 0.74 s. Tried for issue 13
and rejected, each slower at these sizes: numba loops over F's active rows and nonzero
columns only (``A = Pt[act] + M Pt[cols]``, one triangle of ``R``; 1.4-1.6 us, also with
``fastmath={'contract', 'reassoc'}``; presumably the 14- and 22-long inner loops spend their
time in scalar remainders), the same with BLAS on the compacted blocks (1.4 us; the gathers
seem to cost more than the smaller products save), ``Phi_a`` built untransposed from row gathers (1.1 us), and
``Phi_a Pt`` over F's nonzero column span only (1.18 us: OpenBLAS's time does not shrink with
the inner dimension at this size). ``_nrt=False`` (no reference counting) is not available:
numba types ``np.dot(a, b, out)`` only with NRT. Reaching ~0.3 us would, we expect, need code
generated per pattern (straight-line products over the ~60 nonzeros of ``F_a``, fixed ``n``).

The results equal the dense kernel's to rounding (a test checks 1e-13 relative to the size of
the terms, random SPD ``P``, dt from 0.005 to 1 s, F of every layout of the package).

The sparsity patterns (F's, from :func:`error_model.F_pattern`, and Qc's) are taken once by
:func:`make_workspace`, which allocates the buffers. Rows of ``F`` outside the pattern's
nonzero rows, and entries of ``Qc`` outside its pattern, are ignored (taken as zero); ``Qc``'s
diagonal is always in its pattern. ``P`` and ``F`` must be C-contiguous float64.

Usage (engine)::

    F = np.zeros((n, n))                                  # zeroed once (_fill_F assigns)
    ws = make_workspace(em.F_pattern(n, offs, inv_tau_dk, dr_eps), Qc != 0)
    ...                                                   # every epoch, in numba code:
    em._fill_F(F, offs, lat, h, vel_n, C, f_n, inv_tau_dk, dr_eps, grav_grad)
    predict_sparse(x, P, F, Qc, dt, ws)                   # x, P in place
"""
from __future__ import annotations

from collections import namedtuple

import numba
import numpy as np

__all__ = ["PredictWorkspace", "make_workspace", "predict_sparse"]

#: index arrays and buffers of :func:`predict_sparse` (numba takes the namedtuple as is)
PredictWorkspace = namedtuple("PredictWorkspace", [
    "act",      # (na,) int64: active indices (rows where F may be nonzero), ascending
    "inact",    # (n - na,) int64: the other indices (identity rows of Phi)
    "q",        # (2, nnz Qc) int64: Qc's pattern (symmetric, with its diagonal): rows, columns
    "FaT",      # (n, na) float64: F's active rows, transposed
    "FaaT",     # (na, na) float64: their active columns
    "PhiT",     # (n, na) float64: Phi's active rows, transposed
    "A",        # (na, n) float64: the active rows of Phi (P + dt/2 Qc)
    "R",        # (na, na) float64: A Phi_a^T
    "xa",       # (na,) float64: the active entries of Phi x
])


def make_workspace(F_pattern, Qc_pattern=None) -> PredictWorkspace:
    """Index arrays and buffers of :func:`predict_sparse`, allocated once per filter.

    Parameters
    ----------
    F_pattern : (n, n) array, nonzero where F may be nonzero (e.g.
        :func:`inmotion.estimation.error_model.F_pattern`, or ``F != 0`` of F at a generic
        state); its zero rows are the identity rows of ``Phi``
    Qc_pattern : (n, n) array, nonzero where Qc may be nonzero (default: the diagonal only);
        the diagonal is always included, and the pattern is symmetrized

    Returns
    -------
    PredictWorkspace : a namedtuple of arrays, passed as is to :func:`predict_sparse`
        (also from numba code); one per filter (its buffers are overwritten by each call)
    """
    Fm = np.asarray(F_pattern) != 0
    n = Fm.shape[0]
    if Fm.shape != (n, n):
        raise ValueError(f"F_pattern must be square, got {Fm.shape}")
    Qm = np.eye(n, dtype=bool)
    if Qc_pattern is not None:
        q = np.asarray(Qc_pattern) != 0
        if q.shape != (n, n):
            raise ValueError(f"Qc_pattern must be ({n}, {n}), got {q.shape}")
        Qm |= q | q.T
    rows = Fm.any(axis=1)
    act = np.flatnonzero(rows).astype(np.int64)
    inact = np.flatnonzero(~rows).astype(np.int64)
    na = len(act)
    q = np.array(np.nonzero(Qm), dtype=np.int64).reshape(2, -1)
    return PredictWorkspace(act, inact, q, np.zeros((n, na)), np.zeros((na, na)),
                            np.zeros((n, na)), np.zeros((na, n)), np.zeros((na, na)),
                            np.zeros(na))


@numba.njit(cache=True)
def predict_sparse(x, P, F, Qc, dt, ws):
    """In place, ``x <- Phi x``, ``P <- Phi P Phi^T + dt/2 (Phi Qc Phi^T + Qc)``, symmetric.

    The same math as :func:`inmotion.estimation.kalman._predict_kernel` (second-order
    ``Phi = I + F dt + (F dt)^2 / 2``, trapezoid ``Qd``, ``P`` symmetrized, its diagonal
    floored at 0), on the active rows of ``ws`` only (module docstring); no allocation.

    Parameters
    ----------
    x : (n,) float64 error state, updated in place
    P : (n, n) float64, C-contiguous, symmetric covariance, updated in place
    F : (n, n) float64 continuous system matrix (rows outside ``ws``'s active rows ignored)
    Qc : (n, n) float64 continuous process-noise density (entries outside ``ws``'s Qc
        pattern ignored)
    dt : float, step [s]
    ws : :class:`PredictWorkspace` from :func:`make_workspace` for this ``n`` and pattern
    """
    n = x.shape[0]
    act, inact, q = ws.act, ws.inact, ws.q
    FaT, FaaT, PhiT, A, R, xa = ws.FaT, ws.FaaT, ws.PhiT, ws.A, ws.R, ws.xa
    na = act.shape[0]
    hdt = 0.5 * dt
    hdt2 = 0.5 * dt * dt
    if na > 0:
        # Phi_a^T = I_a + dt F_a^T + dt^2/2 F_a^T F_aa^T  (F's other rows are zero)
        for c in range(n):
            for a in range(na):
                FaT[c, a] = F[act[a], c]
        for b in range(na):
            k = act[b]
            for a in range(na):
                FaaT[b, a] = FaT[k, a]
        np.dot(FaT, FaaT, PhiT)
        for c in range(n):
            for a in range(na):
                PhiT[c, a] = dt * FaT[c, a] + hdt2 * PhiT[c, a]
        for a in range(na):
            PhiT[act[a], a] += 1.0
        # x <- Phi x (rows of PhiT: contiguous over the active rows)
        for a in range(na):
            xa[a] = 0.0
        for c in range(n):
            xc = x[c]
            for a in range(na):
                xa[a] += PhiT[c, a] * xc
        for a in range(na):
            x[act[a]] = xa[a]
    # Pt = P + dt/2 Qc
    for p in range(q.shape[1]):
        P[q[0, p], q[1, p]] += hdt * Qc[q[0, p], q[1, p]]
    if na > 0:
        # A = Phi_a Pt;  R = A Phi_a^T
        np.dot(PhiT.T, P, A)
        np.dot(A, PhiT, R)
        for b in range(na):
            j = act[b]
            for a in range(b + 1):
                i = act[a]
                s = 0.5 * (R[a, b] + R[b, a])
                P[i, j] = s
                P[j, i] = s
            for m in range(inact.shape[0]):
                c = inact[m]
                s = A[b, c]
                P[j, c] = s
                P[c, j] = s
    # + dt/2 Qc; diagonal floored at 0
    for p in range(q.shape[1]):
        P[q[0, p], q[1, p]] += hdt * Qc[q[0, p], q[1, p]]
    for i in range(n):
        if P[i, i] < 0.0:
            P[i, i] = 0.0
