"""Rauch-Tung-Striebel smoothing over the error-state engine's forward pass.

The forward pass (:class:`inmotion.estimation.engine.ErrorStateFilter` with ``record=True``)
stores, for every recorded epoch ``k`` (one that applied measurements, an output epoch, the
last one): the transition ``Phi_k`` since the previous record (the product of the epochs'
transitions between them: with no update in between, the smoother needs nothing else), the
predicted covariance ``P_k|k-1``, the updated estimate and covariance ``x_k|k``, ``P_k|k``
*after* the epoch's feedback (the error relative to the corrected navigation state), the
vector fed back at the epoch ``fb_k``, the accumulated feedback and the corrected navigation
state itself. Closed-loop feedback is a reset: it moves ``fb_k`` from the error estimate into
the navigation state and leaves ``P`` as it is, so before the reset the estimate is
``x_k|k + fb_k`` relative to the uncorrected state, which is what the predict of epoch ``k``
(``x_k|k-1 = Phi_k x_k-1|k-1``) refers to. The backward pass (Rauch, Tung, Striebel 1965;
Gelb 1974 sec. 5.3), in that frame::

    A_k-1   = P_k-1|k-1 Phi_k^T P_k|k-1^-1
    x_k-1|N = x_k-1|k-1 + A_k-1 (x_k|N + fb_k - Phi_k x_k-1|k-1)
    P_k-1|N = P_k-1|k-1 + A_k-1 (P_k|N - P_k|k-1) A_k-1^T

from ``x_N|N``, ``P_N|N``. The smoothed navigation state of epoch ``k`` is the corrected
forward state with ``x_k|N`` applied as the filter's feedback would apply it; the smoothed
sensor states are the accumulated feedback plus ``x_k|N``.

The pass needs one filter's transition and covariances, so the engine records for a single
local filter only. A bank of local filters (paper 003's federated filter, a channel with its
NHC fallback) is smoothed through a central filter over the measurements the bank accepted
(:func:`inmotion.align.aided_kf._smooth_bank`, where the design is written down).

:func:`rts_backward` is the numerical core (numba); a test checks it on a linear Gaussian
system against the batch least-squares solution over all states at once. The records of a
long drive go to a file (:class:`ForwardRecord`, ``numpy.memmap``) when they would not fit
the memory budget.
"""
from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numba
import numpy as np

from ..core import _kernels as K
from .layout import DP, DV, PHI
from .nav_ops import correct_nav

__all__ = ["rts_backward", "ForwardRecord", "RECORD_FIELDS", "smooth_record",
           "smooth_at_outputs"]

#: relative eigenvalue below which a direction of the (correlation form of) P_k|k-1 counts as
#: singular in the smoother gain (machine precision times the states' dynamic range)
PINV_RCOND = 1e-12
#: per-epoch records of the forward pass: name -> shape after the epoch axis (n: states)
RECORD_FIELDS = ("t", "phi", "p_pred", "x", "p", "fb", "fed", "xs", "epoch")


@numba.njit(cache=True)
def _pinv_times(Pp, B):
    """``Pp^+ B`` for the symmetric positive semi-definite ``Pp``: eigenvalues below
    :data:`PINV_RCOND` of the largest dropped. By ``eigh`` (LAPACK ``dsyevd``); where that
    fails to converge, which it does on rare well-conditioned matrices (a 27-state central
    filter of paper 003's drive, eigenvalues 1.5e-4 .. 4.4, ``tests/data``), by the SVD
    (``Pp = U S V^T``, ``Pp^+ = V S^+ U^T``)."""
    n = Pp.shape[0]
    ok = True
    try:
        w, V = np.linalg.eigh(Pp)
    except Exception:
        ok = False
    if ok:
        cut = PINV_RCOND * w[-1]
        VtB = V.T @ B
        for i in range(n):
            inv = 1.0 / w[i] if w[i] > cut else 0.0
            for j in range(n):
                VtB[i, j] *= inv
        return V @ VtB
    U, sv, Vt = np.linalg.svd(Pp)
    cut = PINV_RCOND * sv[0]
    UtB = U.T @ B
    for i in range(n):
        inv = 1.0 / sv[i] if sv[i] > cut else 0.0
        for j in range(n):
            UtB[i, j] *= inv
    return Vt.T @ UtB


@numba.njit(cache=True)
def rts_backward(x, P, Phi, P_pred, fb, xs_out, Ps_out):
    """The backward pass of the module docstring over epochs ``0 .. N-1``.

    Parameters
    ----------
    x, P : (N, n), (N, n, n) ``x_k|k``, ``P_k|k`` after each epoch's feedback
    Phi, P_pred : (N, n, n) the transition into epoch ``k`` and ``P_k|k-1`` (entry 0 unused)
    fb : (N, n) the feedback applied at epoch ``k`` (zeros without feedback)
    xs_out, Ps_out : (N, n), (N, n, n) written with ``x_k|N``, ``P_k|N``

    The gain is ``A^T = P_k|k-1^+ Phi_k P_k-1|k-1`` with the pseudo-inverse of the
    correlation form of ``P_k|k-1`` (eigenvalues below :data:`PINV_RCOND` of the largest
    dropped; with ``P_k|k-1`` regular it is the inverse); the smoothed covariance is
    symmetrized.
    """
    N, n = x.shape
    xs_out[N - 1] = x[N - 1]
    Ps_out[N - 1] = P[N - 1]
    d = np.empty(n)
    Pp = np.empty((n, n))
    for k in range(N - 1, 0, -1):
        Pk = np.ascontiguousarray(P[k - 1])
        Ph = np.ascontiguousarray(Phi[k])
        # the solve on the correlation form of P_k|k-1: its entries span 1e-14 (rad^2 of
        # latitude) to 1e2, which LU pivoting alone does not survive
        for i in range(n):
            v = P_pred[k, i, i]
            d[i] = math.sqrt(v) if v > 0.0 else 1.0
        for i in range(n):
            for j in range(n):
                Pp[i, j] = P_pred[k, i, j] / (d[i] * d[j])
        B = Ph @ Pk
        for i in range(n):
            for j in range(n):
                B[i, j] /= d[i]
        # pseudo-inverse: P_k|k-1 is singular where two states' difference has neither
        # prior nor process noise (dr-kf: the SINS and DR attitude errors start equal and
        # share the gyro noise); those directions carry no information to smooth
        AT = _pinv_times(Pp, B)
        for i in range(n):
            for j in range(n):
                AT[i, j] /= d[i]
        A = np.ascontiguousarray(AT.T)
        innov = xs_out[k] + fb[k] - Ph @ np.ascontiguousarray(x[k - 1])
        xs_out[k - 1] = x[k - 1] + A @ innov
        dP = np.ascontiguousarray(Ps_out[k]) - np.ascontiguousarray(P_pred[k])
        Pn = Pk + A @ dP @ AT
        Ps_out[k - 1] = 0.5 * (Pn + Pn.T)


class ForwardRecord:
    """The forward pass's per-epoch records, appended chunk by chunk.

    Kept in memory up to ``memory_budget_bytes``; beyond it every field is a
    ``numpy.memmap`` in ``folder`` (a temporary folder by default, removed by :meth:`close`),
    so a drive of hours can be smoothed with memory of the budget's size (plus the page
    cache the operating system grants).

    Parameters
    ----------
    n : states;  capacity : epochs that will be recorded (known from the log's length)
    """

    def __init__(self, n: int, capacity: int, memory_budget_bytes: float = 5e8,
                 folder=None):
        self.n = int(n)
        self.capacity = int(capacity)
        self.size = 0
        shapes = {"t": (), "phi": (n, n), "p_pred": (n, n), "x": (n,), "p": (n, n),
                  "fb": (n,), "fed": (n,), "xs": (10,), "epoch": ()}
        need = 8 * self.capacity * sum(int(np.prod(s)) for s in shapes.values())
        self._tmp = None
        self.on_disk = need > memory_budget_bytes
        self.arrays = {}
        if self.on_disk:
            if folder is None:
                self._tmp = tempfile.mkdtemp(prefix="inmotion-smoother-")
                folder = self._tmp
            for name, s in shapes.items():
                self.arrays[name] = np.lib.format.open_memmap(
                    os.path.join(folder, f"{name}.npy"), mode="w+", dtype=np.float64,
                    shape=(self.capacity,) + s)
        else:
            for name, s in shapes.items():
                self.arrays[name] = np.empty((self.capacity,) + s)

    @classmethod
    def for_filter(cls, filt, epochs: int) -> "ForwardRecord":
        """A record for ``epochs`` more epochs of the engine filter ``filt`` (made with
        ``record=True``), holding the start as record 0: ``x = 0`` (nothing estimated yet)
        with ``P0``, the start state, epoch 0."""
        n = filt.layout.n
        rec = cls(n, int(epochs) + 1)
        P0 = filt.covariance()
        rec.append({"t": [filt.t], "phi": np.eye(n)[None], "p_pred": P0[None], "x": filt.x[None],
                    "p": P0[None], "fb": np.zeros((1, n)), "fed": np.zeros((1, n)),
                    "xs": filt.kernel_states()[0][None], "epoch": [0.0]})
        return rec

    def append(self, rec: dict):
        """Append the records of one ``add_imu`` call (``rec[field]`` (k, ...))."""
        k = len(rec["t"])
        if self.size + k > self.capacity:
            raise ValueError(f"ForwardRecord holds {self.capacity} epochs; got "
                             f"{self.size + k}")
        for name in RECORD_FIELDS:
            self.arrays[name][self.size:self.size + k] = rec[name]
        self.size += k

    def __getitem__(self, name):
        return self.arrays[name][:self.size]

    def close(self):
        """Drop the arrays (and the temporary folder of the file-backed ones)."""
        self.arrays = {}
        if self._tmp is not None:
            for p in Path(self._tmp).glob("*.npy"):
                p.unlink()
            os.rmdir(self._tmp)
            self._tmp = None


@numba.njit(cache=True)
def _smoothed_nav(xs, x, o_phi, o_dv, o_dp, out):
    """Each forward (corrected) state ``xs[k]`` with the smoothed error ``x[k]`` applied as
    feedback would apply it (:func:`inmotion.estimation.nav_ops.correct_nav`)."""
    mem = np.zeros(K.NMEM)
    for k in range(xs.shape[0]):
        out[k] = xs[k]
        correct_nav(out[k], mem, x[k, o_phi:o_phi + 3], x[k, o_dv:o_dv + 3],
                    x[k, o_dp:o_dp + 3], True)


def smooth_record(record: ForwardRecord, layout, rows=None) -> dict:
    """Run the backward pass over a forward pass's records and return the smoothed outputs
    at the recorded epochs ``rows`` (indices; default all), in the fields of the engine's
    outputs.

    Returns
    -------
    dict: ``t`` (M,), ``x_sins`` (M, 10) smoothed kernel states, ``sigma`` (M, n),
    ``states`` (M, n) (accumulated feedback plus the smoothed error), ``cov_phi``
    (M, 3, 3), and the forward filter's ``sigma_forward`` (M, n) beside them.
    """
    N, n = record.size, record.n
    if N == 0:
        raise ValueError("no epochs recorded: nothing to smooth")
    if record.on_disk:
        folder = os.path.dirname(record.arrays["phi"].filename)
        xs_out = np.lib.format.open_memmap(os.path.join(folder, "x_smooth.npy"), mode="w+",
                                           dtype=np.float64, shape=(N, n))
        Ps_out = np.lib.format.open_memmap(os.path.join(folder, "p_smooth.npy"), mode="w+",
                                           dtype=np.float64, shape=(N, n, n))
    else:
        xs_out, Ps_out = np.empty((N, n)), np.empty((N, n, n))
    arr = {k: np.asarray(record[k]) for k in RECORD_FIELDS}
    rts_backward(arr["x"], arr["p"], arr["phi"], arr["p_pred"], arr["fb"],
                 np.asarray(xs_out), np.asarray(Ps_out))
    rows = np.arange(N) if rows is None else np.asarray(rows, dtype=np.int64)
    x_k = np.asarray(xs_out)[rows]
    P_k = np.asarray(Ps_out)[rows]
    nav = np.empty((len(rows), 10))
    o = layout.offsets()
    _smoothed_nav(np.ascontiguousarray(arr["xs"][rows]), np.ascontiguousarray(x_k),
                  int(o[PHI]), int(o[DV]), int(o[DP]), nav)
    diag = np.sqrt(np.maximum(np.diagonal(P_k, axis1=1, axis2=2), 0.0))
    ph = layout["phi"]
    return {"t": arr["t"][rows], "x_sins": nav, "sigma": diag,
            "states": arr["fed"][rows] + x_k, "cov_phi": P_k[:, ph, ph],
            "sigma_forward": np.sqrt(np.maximum(np.diagonal(arr["p"][rows], axis1=1, axis2=2),
                                                0.0))}


def smooth_at_outputs(record: ForwardRecord, filt, with_last: bool = True) -> dict:
    """The backward pass over ``record`` (closed afterwards), returned at the epochs of the
    engine filter's output grid (every ``filt.out_every``-th, the start included) and, with
    ``with_last``, at the last epoch (where a run writes its last row even off the grid)."""
    ep = np.asarray(record["epoch"])
    keep = ep % filt.out_every == 0
    if with_last:
        keep |= ep == ep[-1]
    sm = smooth_record(record, filt.layout, np.flatnonzero(keep))
    record.close()
    return sm
