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

from ``x_N|N``, ``P_N|N``. With the engine's invariant velocity feedback (issue 15, session
23; :mod:`inmotion.estimation.engine`, "Invariant velocity error") the reset is ``x <- J (x -
fb_k)``, ``P <- J P J^T`` with ``J`` known from the recorded velocity change, and the backward
pass takes ``x_k|N``, ``P_k|N`` through ``J^-1`` before adding ``fb_k`` (:func:`rts_backward`).
The smoothed navigation state of epoch ``k`` is the corrected
forward state with ``x_k|N`` applied as the filter's feedback would apply it; the smoothed
sensor states are the accumulated feedback plus ``x_k|N``.

The pass needs one filter's transition and covariances, so the engine records for a single
local filter only. A bank of local filters (paper 003's federated filter, a channel with its
NHC fallback) is smoothed through a central filter over the measurements the bank accepted
(:func:`inmotion.align.aided_kf._smooth_bank`, where the design is written down).

:func:`rts_backward` is the numerical core (numba); a test checks it on a linear Gaussian
system against the batch least-squares solution over all states at once. The records of a
long drive go to files (:class:`ForwardRecord`) beyond a memory budget, and the backward
pass reads them back block by block (:func:`smooth_record`): the memory of a smoothed run
does not grow with the log's length.
"""
from __future__ import annotations

import math
import os
import tempfile
import weakref

import numpy as np

from .._jit import njit
from ..core import _kernels as K
from .layout import DP, DV, PHI
from .nav_ops import correct_nav, velocity_shear

__all__ = ["rts_backward", "ForwardRecord", "RECORD_FIELDS", "MEMORY_BUDGET_BYTES",
           "smooth_record", "smooth_at_outputs"]

#: relative eigenvalue below which a direction of the (correlation form of) P_k|k-1 counts as
#: singular in the smoother gain (machine precision times the states' dynamic range)
PINV_RCOND = 1e-12
#: per-epoch records of the forward pass: name -> shape after the epoch axis (n: states)
RECORD_FIELDS = ("t", "phi", "p_pred", "x", "p", "fb", "fed", "xs", "epoch")
#: records a forward pass keeps in memory before it writes them to files [bytes] (about 8000
#: epochs of 22 states: a 10 Hz hour of them is 440 MB)
MEMORY_BUDGET_BYTES = 1e8


@njit(cache=True)
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


@njit(cache=True)
def _undo_invariant_reset(x, P, o_phi, o_dv, a, b, c):
    """``x <- J^-1 x``, ``P <- J^-1 P J^-T`` in place, ``J^-1 = I - E``, ``E[dv, phi] = [dV
    x]``, ``dV = (a, b, c)`` (:func:`rts_backward`); nothing for ``dV = 0``."""
    velocity_shear(P, x, o_phi, o_dv, (a, b, c), -1.0)


@njit(cache=True)
def rts_backward(x, P, Phi, P_pred, fb, xs_out, Ps_out, o_phi=-1, o_dv=-1):
    """The backward pass of the module docstring over epochs ``0 .. N-1``.

    Parameters
    ----------
    x, P : (N, n), (N, n, n) ``x_k|k``, ``P_k|k`` after each epoch's feedback
    Phi, P_pred : (N, n, n) the transition into epoch ``k`` and ``P_k|k-1`` (entry 0 unused)
    fb : (N, n) the feedback applied at epoch ``k`` (zeros without feedback)
    xs_out, Ps_out : (N, n), (N, n, n) written with ``x_k|N``, ``P_k|N``
    o_phi, o_dv : with the engine's invariant velocity feedback, the offsets of ``phi`` and
        ``dv`` (-1: the standard feedback). Its reset is ``x <- J (x - fb)``, ``P <- J P
        J^T`` with ``J = I + E``, ``E[dv, phi] = [dV x]``, ``dV = -fb[dv]`` (the velocity
        change the feedback made; :func:`inmotion.estimation.engine._invariant_velocity_reset`):
        the smoothed ``x_k|N``, ``P_k|N`` go back through ``J^-1 = I - E`` before the
        feedback is added back, as the shift alone does for the standard feedback

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
        xk = xs_out[k].copy()
        Psk = np.ascontiguousarray(Ps_out[k]).copy()
        if o_phi >= 0:
            _undo_invariant_reset(xk, Psk, o_phi, o_dv, -fb[k, o_dv], -fb[k, o_dv + 1],
                                  -fb[k, o_dv + 2])
        innov = xk + fb[k] - Ph @ np.ascontiguousarray(x[k - 1])
        xs_out[k - 1] = x[k - 1] + A @ innov
        dP = Psk - np.ascontiguousarray(P_pred[k])
        Pn = Pk + A @ dP @ AT
        Ps_out[k - 1] = 0.5 * (Pn + Pn.T)


class ForwardRecord:
    """The forward pass's per-epoch records, appended chunk by chunk.

    Kept in memory up to ``memory_budget_bytes`` of records; beyond it every field goes to a
    file of its own in ``folder`` (a temporary folder by default, under ``TMPDIR``, removed by
    :meth:`close`), written by plain appends and read back block by block by
    :func:`smooth_record`, so a drive of hours is smoothed with memory of the budget's size
    whatever its length. (Not a ``numpy.memmap``: the pages of a mapped file count in the
    process's resident set as they are touched, so a mapped record grows the peak RSS with
    the log as the arrays in memory did.)

    Parameters
    ----------
    n : states;  capacity : epochs that may be recorded at most (known from the log's length)
    memory_budget_bytes : records kept in memory up to this size [bytes]; also the size of
        the blocks the backward pass reads back (None: :data:`MEMORY_BUDGET_BYTES`)
    folder : where the files go (None: a new temporary folder)
    """

    def __init__(self, n: int, capacity: int, memory_budget_bytes: float | None = None,
                 folder=None):
        self.n = int(n)
        self.capacity = int(capacity)
        self.size = 0
        self.shapes = {"t": (), "phi": (n, n), "p_pred": (n, n), "x": (n,), "p": (n, n),
                       "fb": (n,), "fed": (n,), "xs": (10,), "epoch": ()}
        self.record_bytes = 8 * sum(int(np.prod(s)) for s in self.shapes.values())
        self.budget = float(MEMORY_BUDGET_BYTES if memory_budget_bytes is None
                            else memory_budget_bytes)
        self._folder = folder
        self._tmp = None
        self._files = None                  # field -> open file, once on disk
        self.paths = {}
        self._parts = []                    # in memory: the appended chunks
        self.invariant = (-1, -1)           # see for_filter

    @property
    def on_disk(self) -> bool:
        """Whether the records went to files (the budget was exceeded)."""
        return self._files is not None

    @classmethod
    def for_filter(cls, filt, epochs: int, **kw) -> "ForwardRecord":
        """A record for ``epochs`` more epochs of the engine filter ``filt`` (made with
        ``record=True``), holding the start as record 0: ``x = 0`` (nothing estimated yet)
        with ``P0``, the start state, epoch 0. ``kw``: the constructor's."""
        n = filt.layout.n
        rec = cls(n, int(epochs) + 1, **kw)
        #: (o_phi, o_dv) when the filter feeds back in the invariant velocity error, else
        #: (-1, -1) (:func:`rts_backward`)
        rec.invariant = ((int(filt.layout["phi"].start), int(filt.layout["dv"].start))
                         if filt.invariant_velocity else (-1, -1))
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
        part = {name: np.ascontiguousarray(rec[name], dtype=np.float64).reshape(
            (k,) + self.shapes[name]) for name in RECORD_FIELDS}
        if self._files is None and (self.size + k) * self.record_bytes > self.budget:
            self._spill()
        if self._files is None:
            self._parts.append({name: a.copy() for name, a in part.items()})
        else:
            for name in RECORD_FIELDS:
                self._files[name].write(part[name].tobytes())
        self.size += k

    def _spill(self):
        """Move the records kept so far to files; later appends go there too. The files (and
        the temporary folder) are removed by :meth:`close`, or when the record is dropped or
        the interpreter exits (``weakref.finalize``: a run that fails midway leaves none)."""
        folder = self._folder
        if folder is None:
            self._tmp = tempfile.mkdtemp(prefix="inmotion-smoother-")
            folder = self._tmp
        self._files = {}
        self._finalizer = weakref.finalize(self, _remove_files, self._files, self._tmp)
        for name in RECORD_FIELDS:
            self.paths[name] = os.path.join(folder, f"{name}.f64")
            self._files[name] = open(self.paths[name], "w+b")
            for part in self._parts:
                self._files[name].write(part[name].tobytes())
        self._parts = []

    def block(self, a: int, b: int, fields=RECORD_FIELDS, out: dict | None = None) -> dict:
        """The records ``a .. b - 1`` of ``fields``: views of memory, or read from the files
        (into ``out[field][:b - a]`` when given: buffers reused from block to block, so the
        backward pass over many blocks does not leave the allocator's heap fragmented)."""
        a, b = max(0, int(a)), min(self.size, int(b))
        if self._files is None:
            if len(self._parts) > 1:               # one array per field from here on
                self._parts = [{k: np.concatenate([p[k] for p in self._parts])
                                for k in RECORD_FIELDS}]
            if not self._parts:
                return {k: np.empty((0,) + self.shapes[k]) for k in fields}
            return {k: self._parts[0][k][a:b] for k in fields}
        res = {}
        for k in fields:
            f = self._files[k]
            f.flush()
            width = int(np.prod(self.shapes[k]))
            f.seek(8 * width * a)
            if out is not None:
                dst = out[k][:b - a]
                if f.readinto(memoryview(dst).cast("B")) != dst.nbytes:
                    raise RuntimeError(f"smoother record {k}: short read")
                res[k] = dst
                continue
            res[k] = np.fromfile(f, dtype=np.float64, count=width * (b - a)).reshape(
                (b - a,) + self.shapes[k])
        return res

    def __getitem__(self, name):
        return self.block(0, self.size, (name,))[name]

    def close(self):
        """Drop the records (and the files, and the temporary folder)."""
        self._parts = []
        if self._files is not None:
            self._finalizer()
            self._files = None
            self.paths = {}
            self._tmp = None


def _remove_files(files: dict, tmp):
    """Close and delete a :class:`ForwardRecord`'s files (``{field: open file}``) and its
    temporary folder ``tmp`` (None: a folder given by the caller, kept)."""
    for f in files.values():
        f.close()
        try:
            os.unlink(f.name)
        except FileNotFoundError:
            pass
    files.clear()
    if tmp is not None:
        try:
            os.rmdir(tmp)
        except OSError:
            pass


@njit(cache=True)
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
    at the recorded epochs ``rows`` (indices, increasing; default all), in the fields of the
    engine's outputs.

    The pass runs over blocks of records from the last back to the first, each read whole
    (in memory: one block, the whole record): :func:`rts_backward` on records ``a .. b``
    with record ``b``'s ``x``, ``P`` replaced by its smoothed values from the block after
    (``rts_backward`` starts from them and reads nothing else of record ``b``'s filtered
    estimate), so the values are those of one pass over all records, bit for bit, and only
    a block's records and the outputs at ``rows`` are held.

    Returns
    -------
    dict: ``t`` (M,), ``x_sins`` (M, 10) smoothed kernel states, ``sigma`` (M, n),
    ``states`` (M, n) (accumulated feedback plus the smoothed error), ``cov_phi``
    (M, 3, 3), and the forward filter's ``sigma_forward`` (M, n) beside them.
    """
    N, n = record.size, record.n
    if N == 0:
        raise ValueError("no epochs recorded: nothing to smooth")
    rows = np.arange(N) if rows is None else np.asarray(rows, dtype=np.int64)
    M = len(rows)
    o = layout.offsets()
    ph = layout["phi"]
    out = {"t": np.empty(M), "x_sins": np.empty((M, 10)), "sigma": np.empty((M, n)),
           "states": np.empty((M, n)), "cov_phi": np.empty((M, 3, 3)),
           "sigma_forward": np.empty((M, n))}
    # records per block: the whole record in memory, else what the budget holds (with the
    # block's smoothed x, P beside it)
    per = max(2, int(record.budget // (record.record_bytes + 8 * n * (n + 1)))
              ) if record.on_disk else N
    b = N                                   # this block: records a .. b - 1
    x_next = P_next = None                  # the smoothed x, P of record b - 1
    # on disk: one set of block buffers, read into and written over block after block
    bufs = ({k: np.empty((min(per, N),) + record.shapes[k]) for k in RECORD_FIELDS}
            if record.on_disk else None)
    xs_buf, Ps_buf = np.empty((min(per, N), n)), np.empty((min(per, N), n, n))
    while b > 0:
        a = max(0, b - per)
        blk = record.block(a, b, out=bufs)
        x, P = blk["x"], blk["p"]
        p_last = None
        if x_next is not None:
            if bufs is None:                # (views of the record in memory: not written)
                x, P = x.copy(), P.copy()
            else:                           # the forward P of the last record, for its sigma
                p_last = P[-1].copy()
            x[-1], P[-1] = x_next, P_next
        xs_out, Ps_out = xs_buf[:b - a], Ps_buf[:b - a]
        rts_backward(x, P, blk["phi"], blk["p_pred"], blk["fb"], xs_out, Ps_out,
                     *record.invariant)
        if p_last is not None:
            P[-1] = p_last
        sel = np.flatnonzero((rows >= a) & (rows < b))
        r = rows[sel] - a
        x_k, P_k = xs_out[r], Ps_out[r]
        nav = np.empty((len(r), 10))
        _smoothed_nav(np.ascontiguousarray(blk["xs"][r]), np.ascontiguousarray(x_k),
                      int(o[PHI]), int(o[DV]), int(o[DP]), nav)
        out["t"][sel] = blk["t"][r]
        out["x_sins"][sel] = nav
        out["sigma"][sel] = np.sqrt(np.maximum(np.diagonal(P_k, axis1=1, axis2=2), 0.0))
        out["states"][sel] = blk["fed"][r] + x_k
        out["cov_phi"][sel] = P_k[:, ph, ph]
        out["sigma_forward"][sel] = np.sqrt(np.maximum(
            np.diagonal(blk["p"][r], axis1=1, axis2=2), 0.0))
        x_next, P_next = xs_out[0].copy(), Ps_out[0].copy()
        if a == 0:
            break
        b = a + 1                           # the next block ends with this block's first
    return out


def smooth_at_outputs(record: ForwardRecord, filt, with_last: bool = True,
                      times=None) -> dict:
    """The backward pass over ``record`` (closed afterwards), returned at the epochs of the
    engine filter's output grid (every ``filt.out_every``-th, the start included) and, with
    ``with_last``, at the last epoch (where a run writes its last row even off the grid);
    ``times`` [s] (None: all of them): only those of these epochs at these times (the forward
    rows a run kept, :meth:`VelocityAidedRun.run_stream`'s ``select``)."""
    ep = np.asarray(record["epoch"])
    keep = ep % filt.out_every == 0
    if with_last:
        keep |= ep == ep[-1]
    if times is not None:
        keep &= np.isin(np.asarray(record["t"]), np.asarray(times))
    try:
        return smooth_record(record, filt.layout, np.flatnonzero(keep))
    finally:
        record.close()
