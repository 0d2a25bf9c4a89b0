"""Observation vectors of attitude-determination alignment, integrated in discrete form.

The attitude is decomposed (paper 004 eq. 1-4; paper 001 eq. 6-10)

    C_b^n(t) = C_{n(0)}^{n(t)} C_b^n(0) C_{b(t)}^{b(0)}

with ``b(0)``, ``n(0)`` the body and navigation frames frozen in inertial space at the start
``t0``. ``C_{b(t)}^{b(0)}`` follows the gyros, ``C_{n(t)}^{n(0)}`` the navigation-frame rate
``omega_in^n = omega_ie^n + omega_en^n``, and the constant ``C_b^n(0)`` satisfies
``C_b^n(0) alpha(t) = beta(t)`` for vectors built from these integrals (all in m/s):

==========  ====================================================  =======================
name        integral                                              discrete form
==========  ====================================================  =======================
``I_f``     ``int C_{b(t)}^{b(0)} f^b dt``           (frame b0)   paper 001 eq. 17-18
``I_g``     ``int C_{n(t)}^{n(0)} g^n dt``           (frame n0)   paper 001 eq. 19 (beta)
``I_wv_n``  ``int C_{n(t)}^{n(0)} (omega_ie^n x v^n) dt`` (n0)    paper 001 eq. 16
``I_wv_b``  ``int C_{b(t)}^{b(0)} (omega_ie^b x v^b) dt`` (b0)    paper 001 eq. 15-16
``vb_b0``   ``C_{b(t)}^{b(0)} v^b(t)``                    (b0)
``vn_n0``   ``C_{n(t)}^{n(0)} v^n(t)``                    (n0)
==========  ====================================================  =======================

The vector models (one constant ``C = C_b^n(0)``, ``C alpha = beta``):

* :data:`MODEL_VB` (paper 004 eq. 9, traditional ``V^b`` IMADA, ``omega_ie^b x V^b`` dropped):
  ``alpha = vb_b0 - v^b(0) - I_f``, ``beta = I_g``.
* :data:`MODEL_VB_EARTH` (paper 001 eq. 13 and 19, OBA; paper 003 eq. 7 and 10): as
  ``MODEL_VB`` plus ``I_wv_b`` on ``alpha``. ``I_wv_b`` needs ``C_n^b``; it is accumulated with
  the attitude known at each step, ``C_{b(t)}^{b(0)} C_n^b(t) = C_hat^T C_{n(t)}^{n(0)}``.
* :data:`MODEL_DUAL` (paper 004 eq. 19): ``alpha = vb_b0 - v^b(0) - I_f``,
  ``beta = I_g - I_wv_n``.
* :data:`MODEL_VN` (paper 004 eq. 10): ``alpha = I_f``,
  ``beta = vn_n0 - v^n(0) + I_wv_n - I_g``, computed as ``C_hat (vb_b0 - v^b(0)) + I_wv_n - I_g``
  (identical for a fixed ``C_hat``, since ``v^n = C_{n(0)}^{n(t)} C_hat C_{b(t)}^{b(0)} v^b``).

Discretization: the IMU rows are taken two at a time (interval ``T`` = two sample periods),
the body rotation with the two-sample coning correction ``phi = dth1 + dth2 + 2/3 dth1 x dth2``
and the velocity increment with paper 001 eq. 18 (rotation plus two-sample sculling). A final
unpaired row uses the one-sample forms. ``C_{n(t)}^{n(0)}`` is propagated with ``omega_in^n`` at
the start of each interval (:data:`NAV_INTEGRATED`, paper 004 eq. 3) or taken in closed form
from the position, ``C_n^{i0}(t) = R_z(omega_ie (t - t0)) C_n^e(L, lambda)`` (:data:`NAV_CLOSED`,
paper 003 eq. 2-3, which includes the vehicle's displacement).

The navigation-frame velocity ``v^n = C_hat_b^n(t) v^b`` and the position (trapezoidal dead
reckoning from ``v^n``, paper 003 sec. 2.2) need an attitude: either a fixed ``C_hat`` for
``C_b^n(0)`` (a previous alignment level: multistage, paper 004 sec. 2.2 and 3) or the running
q-method answer, re-solved every ``update_every`` intervals (the "process value" of paper 004
sec. 2.1, whose errors are the "calculation errors" of the traditional IMADA).

``v^b`` is the forward-velocity sensor's speed on the body y axis (non-holonomic: no lateral
or vertical body velocity), sensor frame equal to b, no lever arm.

Every vector pair is added to Davenport's ``K`` (weight 1, optional fading per interval, and an
optional first-order low-pass applied identically to ``alpha`` and ``beta``: a linear
time-invariant filter of both sequences keeps ``C alpha = beta`` exact while it attenuates
vibration in ``alpha``, paper 003 sec. 2.1). This module is the engine; the methods live in
:mod:`inmotion.align.imada` and :mod:`inmotion.align.coarse_inertial`.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numba
import numpy as np

from ..core import _kernels as kn
from ..core import earth
from ..core.bundle import regroup
from ..estimation.qmethod import k_centered, k_increment

__all__ = ["MODEL_VB", "MODEL_VB_EARTH", "MODEL_DUAL", "MODEL_VN", "NAV_INTEGRATED",
           "NAV_CLOSED", "VectorRun", "integrate_vectors", "integrate_vector_blocks",
           "vector_rows"]

MODEL_VB = 0        #: paper 004 eq. 9 (omega_ie^b x V^b dropped)
MODEL_VB_EARTH = 1  #: paper 001 eq. 13 / paper 003 eq. 7 (Earth-rate term kept, on alpha)
MODEL_DUAL = 2      #: paper 004 eq. 19 (dual velocity modelling)
MODEL_VN = 3        #: paper 004 eq. 10 (navigation-frame velocity)

NAV_INTEGRATED = 0  #: C_{n(t)}^{n(0)} integrated from omega_in^n (paper 004 eq. 3)
NAV_CLOSED = 1      #: closed form from the position (paper 003 eq. 2-3)

#: output columns of the per-epoch record, by name
OUT_T, OUT_LAT, OUT_LON, OUT_H = 0, 1, 2, 3
OUT_VN = slice(4, 7)          #: ENU velocity [m/s] (with the attitude in use)
OUT_QB = slice(7, 11)         #: q of C_{b(t)}^{b(0)}
OUT_QN = slice(11, 15)        #: q of C_{n(t)}^{n(0)}
OUT_K = slice(15, 31)         #: Davenport K, row-major
OUT_SA = slice(31, 34)        #: weighted sum of alpha (for the centred q-method)
OUT_SB = slice(34, 37)        #: weighted sum of beta
OUT_W = 37                    #: sum of weights
OUT_ALPHA = slice(38, 41)     #: alpha of the model at the epoch (before any low-pass) [m/s]
OUT_BETA = slice(41, 44)      #: beta of the model at the epoch [m/s]
N_OUT = 44


@dataclass
class VectorRun:
    """What :func:`integrate_vectors` returns, at the output epochs (M of them).

    Attributes
    ----------
    t : (M,) s.   lat, lon : (M,) rad.   h : (M,) m.
    vel_n : (M, 3) ENU velocity [m/s] computed with the attitude in use at that epoch.
    q_b0b : (M, 4) quaternion of ``C_{b(t)}^{b(0)}``.   q_n0n : (M, 4) of ``C_{n(t)}^{n(0)}``.
    K : (M, 4, 4) Davenport matrix accumulated up to each epoch.
    S_alpha, S_beta : (M, 3) weighted sums of the vectors; W : (M,) sum of the weights
        (with fading), for :func:`inmotion.estimation.qmethod.k_centered`.
    alpha, beta : (M, 3) the model's vector pair at each epoch [m/s], ``C_b^n(0) alpha = beta``
        (before any low-pass; zero at the first epoch). For paper 001's filter, whose
        measurement is ``alpha = C_{n(t)}^{b(0)} beta_001`` with ``beta_001 =
        C_{n(0)}^{n(t)} beta``: use :data:`MODEL_VB_EARTH` and ``q_n0n``.
    n_vectors : number of vector pairs added in all.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    vel_n: np.ndarray
    q_b0b: np.ndarray
    q_n0n: np.ndarray
    K: np.ndarray
    S_alpha: np.ndarray
    S_beta: np.ndarray
    W: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    n_vectors: int

    def K_used(self, centered: bool) -> np.ndarray:
        """``K`` (plain) or the centred ``K`` of the constant-offset-free problem."""
        return k_centered(self.K, self.S_alpha, self.S_beta, self.W) if centered else self.K


def integrate_vectors(t, dtheta, dvel, speed_fwd, speed0, lat0, lon0, h0, *, model,
                      nav=NAV_INTEGRATED, C_fixed=None, update_every=5, out_every=50,
                      fading=1.0, lowpass_a=0.0, centered=False, skip=0) -> VectorRun:
    """Integrate the observation vectors over IMU rows ``1..N-1`` and accumulate ``K``.

    Parameters
    ----------
    t : (N,) s.  IMU row ``k`` holds increments over ``(t[k-1], t[k]]``; ``t[0]`` is ``t0``.
    dtheta, dvel : (N, 3) rad, m/s.  Angle and velocity increments in b.
    speed_fwd : (N,) m/s.  Forward speed at the IMU times (0 for a parked vehicle).
    speed0 : float m/s.  Forward speed taken for ``v^b(0)`` (possibly smoothed).
    lat0, lon0, h0 : rad, rad, m.  Position at ``t0``.
    model : one of :data:`MODEL_VB`, :data:`MODEL_VB_EARTH`, :data:`MODEL_DUAL`, :data:`MODEL_VN`.
    nav : :data:`NAV_INTEGRATED` or :data:`NAV_CLOSED`.
    C_fixed : (3, 3) or None.  Attitude ``C_b^n(0)`` used for ``v^n`` and ``I_wv_b``; None: the
        running q-method answer, re-solved every ``update_every`` intervals.
    out_every : int.  Record an epoch every ``out_every`` intervals (and at the last one).
    fading : float in (0, 1].  ``K <- fading K`` before each interval's pair.
    lowpass_a : float in [0, 1).  First-order low-pass ``x_f += (1 - lowpass_a) (x - x_f)`` on
        both ``alpha`` and ``beta`` (0: none).
    centered : bool.  The running answer solves the centred problem (a constant offset in
        ``alpha``, e.g. the error of ``v^b(0)``, is estimated away; see
        :func:`inmotion.estimation.qmethod.k_centered`).
    skip : int.  Intervals whose pairs are not added to ``K`` (the low-pass's settling time:
        its start-up transient on vibration is not a constant offset, so the centred problem
        would see it as a slowly decaying error).
    """
    return integrate_vector_blocks([(t, dtheta, dvel, speed_fwd)], speed0, lat0, lon0, h0,
                                   model=model, nav=nav, C_fixed=C_fixed,
                                   update_every=update_every, out_every=out_every,
                                   fading=fading, lowpass_a=lowpass_a, centered=centered,
                                   skip=skip)


#: IMU rows per block fed to the kernel by :func:`integrate_vector_blocks` (even: whole
#: two-row intervals)
BLOCK_ROWS = 16384


def integrate_vector_blocks(blocks, speed0, lat0, lon0, h0, *, model, nav=NAV_INTEGRATED,
                            C_fixed=None, update_every=5, out_every=50, fading=1.0,
                            lowpass_a=0.0, centered=False, skip=0,
                            block_rows=None) -> VectorRun:
    """:func:`integrate_vectors` over rows given in consecutive blocks ``(t, dtheta, dvel,
    speed_fwd)`` of any sizes (an iterable: a bundle read in chunks yields them as it reads,
    :func:`inmotion.align.attitude_determination.prepare`), holding one block of
    ``block_rows`` rows at a time (default :data:`BLOCK_ROWS`): memory of the output epochs,
    not of the rows.

    The kernel's state (``K``, the sums, the integrals, the attitudes, the position, the
    low-pass, the step count) is carried from block to block and every interval is computed
    by the same floating-point operations as over the rows in one array, so the result is
    bit for bit that of :func:`integrate_vectors` on the rows joined, whatever the blocks.
    """
    outs, steps = [], 0
    for out, steps in vector_rows(blocks, speed0, lat0, lon0, h0, model=model, nav=nav,
                                  C_fixed=C_fixed, update_every=update_every,
                                  out_every=out_every, fading=fading, lowpass_a=lowpass_a,
                                  centered=centered, skip=skip, block_rows=block_rows):
        outs.append(out)
    out = np.concatenate(outs)
    return VectorRun(out[:, OUT_T], out[:, OUT_LAT], out[:, OUT_LON], out[:, OUT_H],
                     out[:, OUT_VN], out[:, OUT_QB], out[:, OUT_QN],
                     out[:, OUT_K].reshape(-1, 4, 4), out[:, OUT_SA], out[:, OUT_SB],
                     out[:, OUT_W], out[:, OUT_ALPHA], out[:, OUT_BETA], int(steps))


def vector_rows(blocks, speed0, lat0, lon0, h0, *, model, nav=NAV_INTEGRATED, C_fixed=None,
                update_every=5, out_every=50, fading=1.0, lowpass_a=0.0, centered=False,
                skip=0, block_rows=None):
    """:func:`integrate_vector_blocks`'s output rows as they are made: yields ``(rows,
    steps)``, the record rows (``N_OUT`` columns, :data:`OUT_T` ...) of each block of
    ``block_rows`` rows (the first: the start's row; the last: the last interval's row when it
    is off the grid) and the number of intervals integrated so far. For a consumer that keeps
    only what it needs of every row (the USQUE filter on these vectors, ``out_every=1``)."""
    update_every, out_every = int(max(update_every, 1)), int(max(out_every, 1))
    block_rows = max(2, 2 * (int(BLOCK_ROWS if block_rows is None else block_rows) // 2))
    running = C_fixed is None
    C_hat = np.eye(3) if running else np.array(C_fixed, dtype=float)    # (a copy: written)
    it = iter(blocks)
    first = None
    for first in it:                      # the first non-empty block
        if len(first[0]):
            break
    if first is None or not len(first[0]):
        raise ValueError("integrate_vector_blocks: no rows")
    st = np.zeros(N_STATE)
    K, C_n0n = np.zeros((4, 4)), np.eye(3)
    row0 = tuple(np.ascontiguousarray(x[:1], dtype=float) for x in first)
    yield _start(row0[0][0], float(speed0), float(lat0), float(lon0), float(h0), C_hat, st,
                 K), 0
    rest = itertools.chain([tuple(x[1:] for x in first)], it)
    prev, steps = row0, 0
    for blk in regroup(rest, block_rows):
        # the row before the block leads it (row ``i1 - 1`` of its first interval)
        rows = [np.ascontiguousarray(np.concatenate([p, np.asarray(x, dtype=float)]))
                for p, x in zip(prev, blk)]
        n_steps = len(rows[0]) // 2       # as over one array: rows 1.. two at a time
        out, count = _integrate(rows[0], rows[1], rows[2], rows[3], float(speed0),
                                float(lat0), float(lon0), int(model), int(nav), running,
                                C_hat, C_n0n, K, st, steps, update_every, out_every,
                                float(fading), float(lowpass_a), bool(centered), int(skip),
                                n_steps // out_every + 1)
        steps += n_steps
        prev = tuple(r[-1:] for r in rows)
        yield out[:count], steps
    if steps % out_every:                 # the last interval, recorded off the grid
        yield _record_last(prev[0][0], K, st), steps


# ------------------------------------------------------------------ small numba helpers
@numba.njit(cache=True)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@numba.njit(cache=True)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(cache=True)
def _scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@numba.njit(cache=True)
def _matvec(C, v):
    return (C[0, 0] * v[0] + C[0, 1] * v[1] + C[0, 2] * v[2],
            C[1, 0] * v[0] + C[1, 1] * v[1] + C[1, 2] * v[2],
            C[2, 0] * v[0] + C[2, 1] * v[1] + C[2, 2] * v[2])


@numba.njit(cache=True)
def _matTvec(C, v):
    return (C[0, 0] * v[0] + C[1, 0] * v[1] + C[2, 0] * v[2],
            C[0, 1] * v[0] + C[1, 1] * v[1] + C[2, 1] * v[2],
            C[0, 2] * v[0] + C[1, 2] * v[1] + C[2, 2] * v[2])


@numba.njit(cache=True)
def _solve_running(K, S_a, S_b, W, centered, C):
    """Largest-eigenvalue eigenvector of ``K`` (or of its centred form) into the DCM ``C``."""
    Ku = K.copy()
    if centered and W > 0.0:
        k_increment(Ku, S_a, S_b, -1.0 / W)
    vals, vecs = np.linalg.eigh(Ku)
    q = (vecs[0, 3], vecs[1, 3], vecs[2, 3], vecs[3, 3])
    kn.dcm_from_quat_into(kn.qnormalize(q), C)


@numba.njit(cache=True)
def _C_n_i0(lat, lon, dt_from_t0, C_e_n0, C):
    """``C_{n(t)}^{n(0)} = C_e^{n0} R_z(omega_ie dt) C_n^e(lat, lon)`` (paper 003 eq. 2-3)."""
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    # C_n^e: columns are E, N, U in ECEF
    Cne = np.empty((3, 3))
    Cne[0, 0], Cne[1, 0], Cne[2, 0] = -so, co, 0.0
    Cne[0, 1], Cne[1, 1], Cne[2, 1] = -sl * co, -sl * so, cl
    Cne[0, 2], Cne[1, 2], Cne[2, 2] = cl * co, cl * so, sl
    a = earth.OMEGA_IE * dt_from_t0
    ca, sa = math.cos(a), math.sin(a)
    Rz = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    M = C_e_n0 @ (Rz @ Cne)
    for i in range(3):
        for j in range(3):
            C[i, j] = M[i, j]


@numba.njit(cache=True)
def _q_of_dcm(C):
    """Scalar-first quaternion of a DCM (Shepperd), as a tuple."""
    tr = C[0, 0] + C[1, 1] + C[2, 2]
    if tr >= C[0, 0] and tr >= C[1, 1] and tr >= C[2, 2]:
        s = 2.0 * math.sqrt(1.0 + tr)
        return (0.25 * s, (C[2, 1] - C[1, 2]) / s, (C[0, 2] - C[2, 0]) / s, (C[1, 0] - C[0, 1]) / s)
    if C[0, 0] >= C[1, 1] and C[0, 0] >= C[2, 2]:
        s = 2.0 * math.sqrt(1.0 + C[0, 0] - C[1, 1] - C[2, 2])
        return ((C[2, 1] - C[1, 2]) / s, 0.25 * s, (C[0, 1] + C[1, 0]) / s, (C[0, 2] + C[2, 0]) / s)
    if C[1, 1] >= C[2, 2]:
        s = 2.0 * math.sqrt(1.0 - C[0, 0] + C[1, 1] - C[2, 2])
        return ((C[0, 2] - C[2, 0]) / s, (C[0, 1] + C[1, 0]) / s, 0.25 * s, (C[1, 2] + C[2, 1]) / s)
    s = 2.0 * math.sqrt(1.0 - C[0, 0] - C[1, 1] + C[2, 2])
    return ((C[1, 0] - C[0, 1]) / s, (C[0, 2] + C[2, 0]) / s, (C[1, 2] + C[2, 1]) / s, 0.25 * s)


# ------------------------------------------------------------------ the sequential kernel
@numba.njit(cache=True)
def _body_step(dth1, dv1, dth2, dv2, two):
    """Rotation vector and rotation/sculling-compensated velocity increment (paper 001 eq. 18).

    Two samples: ``phi = dth1 + dth2 + 2/3 dth1 x dth2``; ``dv = dv1 + dv2 + 1/2 (dth1 + dth2) x
    (dv1 + dv2) + 2/3 (dth1 x dv2 + dv1 x dth2)``, both in ``b`` at the interval's start.
    One sample: ``phi = dth1``, ``dv = dv1 + 1/2 dth1 x dv1``.
    """
    if two:
        phi = _add(_add(dth1, dth2), _scale(kn.cross(dth1, dth2), 2.0 / 3.0))
        ths = _add(dth1, dth2)
        dvs = _add(dv1, dv2)
        scul = _add(kn.cross(dth1, dv2), kn.cross(dv1, dth2))
        dv = _add(_add(dvs, _scale(kn.cross(ths, dvs), 0.5)), _scale(scul, 2.0 / 3.0))
    else:
        phi = dth1
        dv = _add(dv1, _scale(kn.cross(dth1, dv1), 0.5))
    return phi, dv


@numba.njit(cache=True)
def _nav_increments(q_n0n, w_ie, w_in, g_n, vn_a, vn_b, T):
    """``int C_{n(t)}^{n(0)} g dt`` (paper 001 eq. 19) and ``int C_{n(t)}^{n(0)} (w_ie x v^n) dt``
    (paper 001 eq. 16) over one interval, in ``n(0)``."""
    gi = _add(_scale(g_n, T), _scale(kn.cross(w_in, g_n), 0.5 * T * T))
    wa = kn.cross(w_ie, vn_a)
    wb = kn.cross(w_ie, vn_b)
    inc = _add(_add(_scale(wa, 0.5 * T), _scale(kn.cross(w_in, wa), T * T / 6.0)),
               _add(_scale(wb, 0.5 * T), _scale(kn.cross(w_in, wb), T * T / 3.0)))
    return kn.qrotate(q_n0n, gi), kn.qrotate(q_n0n, inc)


#: the kernel's state carried from block to block (:func:`integrate_vector_blocks`): where
#: each quantity starts in it (3-vectors unless said)
O_T0 = 0                      #: t0 [s], one value
O_POS = 1                     #: 10 values, the kernels' x layout: lat, lon, h, v (unused), q (unused)
O_VN = 11
O_QB = 14                     #: q_b0b, 4 values
O_QN = 18                     #: q_n0n, 4 values
O_IF, O_IG, O_IWVN, O_IWVB = 22, 25, 28, 31
O_AF, O_BF, O_SA, O_SB = 34, 37, 40, 43
O_W = 46                      #: one value
O_ALPHA, O_BETA = 47, 50      #: the last pair (before the low-pass)
N_STATE = 53


@numba.njit(cache=True)
def _v3(st, i):
    return (st[i], st[i + 1], st[i + 2])


@numba.njit(cache=True)
def _v4(st, i):
    return (st[i], st[i + 1], st[i + 2], st[i + 3])


@numba.njit(cache=True)
def _put(st, i, v):
    for k in range(len(v)):
        st[i + k] = v[k]


@numba.njit(cache=True)
def _start(t0, speed0, lat0, lon0, h0, C_hat, st, K):
    """The state at ``t0`` into ``st`` and its output row: ``v^n(t0) = C_hat v^b(0)``,
    identities, zero sums."""
    pos = np.array([lat0, lon0, h0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])   # kernels' x layout
    vb0 = (0.0, speed0, 0.0)
    vn = _matvec(C_hat, vb0)                       # v^n(t0) = C_hat v^b(0)
    st[:] = 0.0
    st[O_T0] = t0
    st[O_POS:O_POS + 10] = pos
    _put(st, O_VN, vn)
    _put(st, O_QB, (1.0, 0.0, 0.0, 0.0))
    _put(st, O_QN, (1.0, 0.0, 0.0, 0.0))
    out = np.zeros((1, N_OUT))
    zero = (0.0, 0.0, 0.0)
    _record(out, 0, t0, pos, vn, (1.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), K, zero, zero,
            0.0, zero, zero)
    return out


@numba.njit(cache=True)
def _record_last(t, K, st):
    """The output row of the state ``st`` (the last interval's, at its end ``t``)."""
    out = np.zeros((1, N_OUT))
    _record(out, 0, t, st[O_POS:O_POS + 10], _v3(st, O_VN), _v4(st, O_QB), _v4(st, O_QN), K,
            _v3(st, O_SA), _v3(st, O_SB), st[O_W], _v3(st, O_ALPHA), _v3(st, O_BETA))
    return out


@numba.njit(cache=True)
def _integrate(t, dtheta, dvel, speed, speed0, lat0, lon0, model, nav, running, C_hat, C_n0n,
               K, st, s0, update_every, out_every, fading, lowpass_a, centered, skip, n_out):
    """The intervals of one block of rows, from the state ``st``, ``K``, ``C_hat``,
    ``C_n0n`` (updated in place) after ``s0`` intervals: row 0 is the row before the block
    (its time only is used), rows ``1 + 2 j, 2 + 2 j`` make the block's interval ``j``
    (global ``s0 + j``); an odd row at the end (the last block only) is a one-row interval.
    Returns the output rows recorded on the grid (every ``out_every`` intervals)."""
    n = len(t)
    n_steps = n // 2
    out = np.zeros((n_out, N_OUT))
    t0 = st[O_T0]
    q_b0b = _v4(st, O_QB)
    q_n0n = _v4(st, O_QN)
    # C_e^{n0}: ENU at the start, for the closed form
    sl, cl, so, co = math.sin(lat0), math.cos(lat0), math.sin(lon0), math.cos(lon0)
    C_e_n0 = np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])
    pos = st[O_POS:O_POS + 10]                     # a view: updated in place
    vb0 = (0.0, speed0, 0.0)
    vn = _v3(st, O_VN)
    I_f, I_g = _v3(st, O_IF), _v3(st, O_IG)
    I_wvn, I_wvb = _v3(st, O_IWVN), _v3(st, O_IWVB)
    a_f, b_f, S_a, S_b = _v3(st, O_AF), _v3(st, O_BF), _v3(st, O_SA), _v3(st, O_SB)
    W = st[O_W]
    alpha_raw, beta_raw = _v3(st, O_ALPHA), _v3(st, O_BETA)
    gain = 1.0 - lowpass_a
    C_tmp = np.empty((3, 3))
    count = 0
    for m in range(n_steps):
        s = s0 + m
        i1 = 1 + 2 * m
        two = i1 + 1 < n
        i_end = i1 + 1 if two else i1
        T = t[i_end] - t[i1 - 1]
        d1 = (dtheta[i1, 0], dtheta[i1, 1], dtheta[i1, 2])
        v1 = (dvel[i1, 0], dvel[i1, 1], dvel[i1, 2])
        if two:
            d2 = (dtheta[i1 + 1, 0], dtheta[i1 + 1, 1], dtheta[i1 + 1, 2])
            v2 = (dvel[i1 + 1, 0], dvel[i1 + 1, 1], dvel[i1 + 1, 2])
        else:
            d2 = (0.0, 0.0, 0.0)
            v2 = (0.0, 0.0, 0.0)
        phi, dvb = _body_step(d1, v1, d2, v2, two)
        # -- body side: int C_b0b f dt, then C_b0b <- C_b0b exp(phi x)
        I_f = _add(I_f, kn.qrotate(q_b0b, dvb))
        q_b0b = kn.qnormalize(kn.qmul(q_b0b, kn.quat_from_rotvec(phi)))
        # -- navigation side, rates at the interval's start
        lat, h = pos[0], pos[2]
        w_ie = kn.omega_ie_n(lat)
        w_en = kn.omega_en_n(lat, h, vn)
        w_in = _add(w_ie, w_en)
        g_n = (0.0, 0.0, -kn.gravity(lat, h))
        q_n0n_start = q_n0n
        # C_n0n at the interval's end
        if nav == NAV_INTEGRATED:
            q_n0n = kn.qnormalize(kn.qmul(q_n0n, kn.quat_from_rotvec(_scale(w_in, T))))
        else:
            pos_pred = pos.copy()
            kn.position_update(pos_pred, vn, vn, T)
            _C_n_i0(pos_pred[0], pos_pred[1], t[i_end] - t0, C_e_n0, C_n0n)
            q_n0n = kn.qnormalize(_q_of_dcm(C_n0n))
        # velocity at the end with the attitude in use, trapezoidal position
        vb = (0.0, speed[i_end], 0.0)
        vb_b0 = kn.qrotate(q_b0b, vb)
        vn_end = kn.qrotate_inv(q_n0n, _matvec(C_hat, vb_b0))
        kn.position_update(pos, vn, vn_end, T)
        if nav == NAV_CLOSED:
            _C_n_i0(pos[0], pos[1], t[i_end] - t0, C_e_n0, C_n0n)
            q_n0n = kn.qnormalize(_q_of_dcm(C_n0n))
        dIg, dIwv = _nav_increments(q_n0n_start, w_ie, w_in, g_n, vn, vn_end, T)
        I_g = _add(I_g, dIg)
        I_wvn = _add(I_wvn, dIwv)
        I_wvb = _add(I_wvb, _matTvec(C_hat, dIwv))
        vn = vn_end
        # -- the vector pair of this model
        if model == MODEL_VN:
            # C_n0n v^n(t) - v^n(0) = C_hat (C_b0b v^b(t) - v^b(0)): exact for a fixed C_hat,
            # the process value otherwise
            alpha = I_f
            beta = _sub(_add(_matvec(C_hat, _sub(vb_b0, vb0)), I_wvn), I_g)
        else:
            alpha = _sub(_sub(vb_b0, vb0), I_f)
            beta = I_g
            if model == MODEL_VB_EARTH:
                alpha = _add(alpha, I_wvb)
            elif model == MODEL_DUAL:
                beta = _sub(beta, I_wvn)
        alpha_raw, beta_raw = alpha, beta
        if lowpass_a > 0.0:
            if s == 0:          # start the filter on the first pair: a constant passes unchanged
                a_f, b_f = alpha, beta
            a_f = _add(a_f, _scale(_sub(alpha, a_f), gain))
            b_f = _add(b_f, _scale(_sub(beta, b_f), gain))
            alpha, beta = a_f, b_f
        if fading < 1.0 and s >= skip:
            for i in range(4):
                for j in range(4):
                    K[i, j] *= fading
            S_a = _scale(S_a, fading)
            S_b = _scale(S_b, fading)
            W *= fading
        if s >= skip:
            k_increment(K, alpha, beta, 1.0)
            S_a = _add(S_a, alpha)
            S_b = _add(S_b, beta)
            W += 1.0
        if running and s >= skip and (s + 1) % update_every == 0:
            _solve_running(K, S_a, S_b, W, centered, C_tmp)
            C_hat[:, :] = C_tmp
        if (s + 1) % out_every == 0:
            _record(out, count, t[i_end], pos, vn, q_b0b, q_n0n, K, S_a, S_b, W,
                    alpha_raw, beta_raw)
            count += 1
    _put(st, O_VN, vn)
    _put(st, O_QB, q_b0b)
    _put(st, O_QN, q_n0n)
    _put(st, O_IF, I_f)
    _put(st, O_IG, I_g)
    _put(st, O_IWVN, I_wvn)
    _put(st, O_IWVB, I_wvb)
    _put(st, O_AF, a_f)
    _put(st, O_BF, b_f)
    _put(st, O_SA, S_a)
    _put(st, O_SB, S_b)
    _put(st, O_ALPHA, alpha_raw)
    _put(st, O_BETA, beta_raw)
    st[O_W] = W
    return out, count


@numba.njit(cache=True)
def _record(out, j, t, pos, vn, q_b0b, q_n0n, K, S_a, S_b, W, alpha, beta):
    out[j, OUT_T] = t
    out[j, OUT_LAT] = pos[0]
    out[j, OUT_LON] = pos[1]
    out[j, OUT_H] = pos[2]
    for i in range(3):
        out[j, 4 + i] = vn[i]
    for i in range(4):
        out[j, 7 + i] = q_b0b[i]
        out[j, 11 + i] = q_n0n[i]
    for i in range(4):
        for k in range(4):
            out[j, 15 + 4 * i + k] = K[i, k]
    for i in range(3):
        out[j, 31 + i] = S_a[i]
        out[j, 34 + i] = S_b[i]
    out[j, OUT_W] = W
    for i in range(3):
        out[j, 38 + i] = alpha[i]
        out[j, 41 + i] = beta[i]
