"""The USQUE filter cycle of :mod:`inmotion.align.usque`, compiled with numba.

At the paper's 100 Hz update rate a 300 s run has 30,000 filter cycles; small-array numpy
costs ~0.6 ms per cycle, so the sequential loop over epochs (accumulate IMU rows, predict,
update, record) runs here in one ``numba.njit`` function. It performs, step for step, the
cycle that :class:`inmotion.align.usque._Filter` writes in readable numpy (the tests run both
and require identical results), and it calls the same building blocks, compiled from their
single source: :func:`inmotion.estimation.quat_average.quat_average`,
:mod:`inmotion.estimation.hinf`, :func:`inmotion.estimation.adaptive_noise.adapt_noise`.

The GRP conversions (paper 001 eq. 20-21) are re-written here on single rows because
:func:`inmotion.core.rotations.grp_from_quat` / ``quat_from_grp`` are vectorized numpy with
shape checks that numba cannot compile; a test checks they agree to 1e-15.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..core import _kernels as kn
from ..estimation import adaptive_noise, hinf, quat_average as qa
from . import usque_model as model

__all__ = ["run_epochs", "HINF_NONE", "HINF_FIXED", "HINF_ADAPTIVE"]

HINF_NONE, HINF_FIXED, HINF_ADAPTIVE = 0, 1, 2

_quat_average = numba.njit(cache=True)(qa.quat_average)
_quat_average_matrix = numba.njit(cache=True)(qa.quat_average_matrix)
_adapt_noise = numba.njit(cache=True)(adaptive_noise.adapt_noise)
_fading_weight = numba.njit(cache=True)(adaptive_noise.fading_weight)
_kalman_cov = numba.njit(cache=True)(hinf.kalman_covariance)
_hinf_from_kalman = numba.njit(cache=True)(hinf.hinf_from_kalman)
_floor_from_kalman = numba.njit(cache=True)(hinf.floor_from_kalman)
_adaptive_gamma = numba.njit(cache=True)(hinf.adaptive_gamma)


@numba.njit(cache=True)
def _qmul(p, q):
    """``p (x) q`` as a new array (:func:`inmotion.core._kernels.qmul`)."""
    r = kn.qmul(p, q)
    out = np.empty(4)
    out[0], out[1], out[2], out[3] = r[0], r[1], r[2], r[3]
    return out


@numba.njit(cache=True)
def _qconj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


@numba.njit(cache=True)
def _qcanon(q):
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    s = -1.0 / n if q[0] < 0.0 else 1.0 / n
    return q * s


@numba.njit(cache=True)
def grp_to_quat(p, a, f):
    """Quaternion of the GRP ``p`` (eq. 21 with ``1 - a^2``, Crassidis & Markley 2003)."""
    n2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    q0 = (-a * n2 + f * math.sqrt(f * f + (1.0 - a * a) * n2)) / (f * f + n2)
    k = (a + q0) / f
    return np.array([q0, k * p[0], k * p[1], k * p[2]])


@numba.njit(cache=True)
def quat_to_grp(q, a, f):
    """GRP ``f q_vec / (a + q0)`` of the canonical-sign quaternion (eq. 20)."""
    qc = _qcanon(q)
    k = f / (a + qc[0])
    return np.array([k * qc[1], k * qc[2], k * qc[3]])


@numba.njit(cache=True)
def _sigma(x, P, scale):
    """Rows ``x``, ``x + L_i``, ``x - L_i`` with ``L L^T = scale P`` (eq. 24)."""
    n = len(x)
    L = np.linalg.cholesky(scale * P)
    chi = np.empty((2 * n + 1, n))
    chi[0] = x
    for i in range(n):
        chi[1 + i] = x + L[:, i]
        chi[1 + n + i] = x - L[:, i]
    return chi


@numba.njit(cache=True)
def _quats(chi, q_ref, a, f):
    m = chi.shape[0]
    out = np.empty((m, 4))
    for i in range(m):
        out[i] = _qmul(grp_to_quat(chi[i, :3], a, f), q_ref)
    return out


@numba.njit(cache=True)
def _cov(dev_a, dev_b, Wc):
    return (dev_a * Wc.reshape(-1, 1)).T @ dev_b


@numba.njit(cache=True)
def _predict(x, P, q, dq_n, Wm, Wc, scale, Q, a, f):
    """Time update (eq. 24-33) through eq. 9; returns ``x, P, q`` with the mean GRP folded."""
    chi = _sigma(x, P, scale)
    chi_q = _quats(chi, q, a, f)
    for i in range(chi.shape[0]):
        chi_q[i] = _qmul(chi_q[i], dq_n)
    q_bar = _quat_average(chi_q, Wm)
    q_bar_c = _qconj(q_bar)
    for i in range(chi.shape[0]):
        chi[i, :3] = quat_to_grp(_qmul(chi_q[i], q_bar_c), a, f)
    x_new = Wm @ chi
    dev = chi - x_new
    P_new = _cov(dev, dev, Wc) + Q
    q_new = _qcanon(_qmul(grp_to_quat(x_new[:3], a, f), q_bar))
    x_new[:3] = 0.0
    return x_new, P_new, q_new


@numba.njit(cache=True)
def _h(chi_q, chi, beta_n, wie_n, D_i, S):
    """Measurement model of :func:`inmotion.align.usque_model.predict_measurement`."""
    m = chi_q.shape[0]
    Z = np.empty((m, 3))
    for i in range(m):
        C = kn.dcm_from_quat(chi_q[i])
        Z[i] = C @ beta_n - np.cross(C @ wie_n, D_i) + S @ chi[i, 3:]
    return Z


@numba.njit(cache=True)
def _observation(acc, has_dk, has_nabla, has_eps, has_dv0, has_w):
    """Per-epoch quantities of :func:`inmotion.align.usque_model.observation` and
    :func:`~inmotion.align.usque_model.sensitivity` (columns dk, nabla, eps, dv0, w as
    present)."""
    q_ib = acc[model.Q_IB:model.Q_IB + 4].copy()
    q_n0n = acc[model.Q_N0N:model.Q_N0N + 4].copy()
    e_s = acc[model.E_S:model.E_S + 3].copy()
    u_i = kn.dcm_from_quat(q_ib) @ (acc[model.V_PREV] * e_s)
    V_i = u_i - acc[model.V0] * e_s
    beta_n = kn.dcm_from_quat(q_n0n).T @ acc[model.BETA_N0:model.BETA_N0 + 3]
    lat = acc[model.LAT]
    wie_n = np.array([0.0, model.kn.OMEGA_IE * math.cos(lat), model.kn.OMEGA_IE * math.sin(lat)])
    y = V_i - acc[model.ALPHA_F:model.ALPHA_F + 3]
    D_i = acc[model.D_I:model.D_I + 3].copy()
    n_e = int(has_dk) + 3 * int(has_nabla) + 3 * int(has_eps) + int(has_dv0) + 3 * int(has_w)
    S = np.zeros((3, n_e))
    c = 0
    if has_dk:
        S[:, 0] = model.dk_column(acc, kn.dcm_from_quat(q_ib))
        c = 1
    B = acc[model.B_I:model.B_I + 9].reshape(3, 3).copy()
    if has_nabla:
        S[:, c:c + 3] = -B
        c += 3
    if has_eps:
        J = acc[model.JF_I:model.JF_I + 9].reshape(3, 3).copy()
        for r in range(3):
            J[:, r] -= np.cross(u_i, B[:, r])
        S[:, c:c + 3] = J
        c += 3
    if has_dv0:
        for r in range(3):
            S[r, c] = -e_s[r]
        c += 1
    if has_w:
        for r in range(3):
            S[r, c + r] = 1.0
    return y, beta_n, wie_n, D_i, S, q_ib, q_n0n


@numba.njit(cache=True)
def _update(x, P, q, obs_y, beta_n, wie_n, D_i, S, Wm, Wc, scale, a, f, R, eta,
            adaptive_r, c_fade, R_min, R_max, hinf_mode, gamma_fixed, k0, gamma_min,
            gamma_max, margin, hinf_w, cv2, q_ib):
    """Measurement update (eq. 34-38, 42-45, 50-59). Also returns the innovation ``e`` and
    its NIS ``e^T Py^-1 e`` (``Py`` with the R the update used). ``cv2`` (2,): the variances
    of the vehicle's lateral and vertical velocity (``UsqueConfig.constraint_noise_m_s``,
    zeros: none), added to ``R`` along the body's x and z axes resolved in i by ``q_ib``."""
    chi = _sigma(x, P, scale)
    chi_q = _quats(chi, q, a, f)
    Z = _h(chi_q, chi, beta_n, wie_n, D_i, S)
    Y = Wm @ Z
    dZ = Z - Y
    dX = chi - x
    Py0 = _cov(dZ, dZ, Wc)
    Pxy = _cov(dX, dZ, Wc)
    e = obs_y - Y
    if adaptive_r:
        R, eta = _adapt_noise(R, eta, e, np.diag(Py0) + R, c_fade, R_min, R_max)
    Rm = np.diag(R)
    if cv2[0] > 0.0 or cv2[1] > 0.0:
        ux = kn.qrotate((q_ib[0], q_ib[1], q_ib[2], q_ib[3]), (1.0, 0.0, 0.0))
        uz = kn.qrotate((q_ib[0], q_ib[1], q_ib[2], q_ib[3]), (0.0, 0.0, 1.0))
        for r in range(3):
            for c in range(3):
                Rm[r, c] += cv2[0] * ux[r] * ux[c] + cv2[1] * uz[r] * uz[c]
    Py = Py0 + Rm
    n = Pxy.shape[0]
    rhs = np.empty((Py.shape[0], n + 1))          # one solve for the gain and the NIS
    rhs[:, :n] = Pxy.T
    rhs[:, n] = e
    sol = np.linalg.solve(Py, rhs)
    K = sol[:, :n].T.copy()
    nis = e @ sol[:, n]
    x_new = x + K @ e
    gamma = np.inf
    floor_hit = 0
    P_kf = _kalman_cov(P, Pxy, Py)
    P_new = P_kf
    if hinf_mode != HINF_NONE:
        g_a = _floor_from_kalman(P_kf, hinf_w)
        if hinf_mode == HINF_FIXED:
            if gamma_fixed < margin * g_a:
                floor_hit = 1
            else:
                gamma = gamma_fixed
                P_new = _hinf_from_kalman(P_kf, gamma, hinf_w)
        else:
            gamma = _adaptive_gamma(g_a, Py, e, k0, gamma_min)
            if gamma < margin * g_a:
                gamma = margin * g_a
                floor_hit = 1
            if gamma <= gamma_max:
                P_new = _hinf_from_kalman(P_kf, gamma, hinf_w)
    q_star = _quat_average(chi_q, Wm)
    q_new = _qcanon(_qmul(grp_to_quat(x_new[:3], a, f), q_star))
    x_new[:3] = 0.0
    return x_new, P_new, q_new, R, eta, gamma, floor_hit, e, nis


@numba.njit(cache=True)
def run_epochs(acc, dtheta, dvel, dt_rows, speed, epochs, slot, x, P, q, Q, Wm, Wc, scale, a,
               f, R, eta, adaptive_r, c_fade, R_min, R_max, hinf_mode, gamma_fixed, k0,
               gamma_min, gamma_max, margin, hinf_w, has_dk, has_nabla, has_eps, has_dv0,
               has_w, arw2_dt, vrw2_dt, out_q_in, out_q_ib, out_lla, out_P, out_R, out_gamma,
               out_x, cv2):
    """The filter epochs of one block of IMU rows. ``epochs[j]`` is the row (in the block)
    of update ``j``; row 0 is the block's start (the run's start, or the previous block's last
    epoch: ``acc`` holds the accumulator there, updated in place). Epoch ``j`` is written to
    output row ``slot[j]`` (none when negative; row 0 of the run is filled by the caller):
    quaternions of ``C_n^i`` and ``C_b^i``, DR position, covariance, sqrt(R), gamma, state.
    With ``has_w`` the integrated-noise state ``w`` is the last block and each update's
    process noise is :func:`inmotion.align.usque_model.add_integrated_noise` of ``Q``.
    Returns ``(floor hits, NIS sum, x, P, q, R, eta)``: the hits, the sum of the updates'
    NIS (3 degrees of freedom each) and the filter after the last epoch, from which the next
    block goes on (the same operations as one block of all rows).
    """
    k_prev = 0
    i_w = x.shape[0] - 3
    q_n0n_prev = acc[model.Q_N0N:model.Q_N0N + 4].copy()
    hits = 0
    nis_sum = 0.0
    for j in range(len(epochs)):
        k = epochs[j]
        q_bn = _qmul(_qconj(q), acc[model.Q_IB:model.Q_IB + 4])
        model.accumulate(acc, dtheta[k_prev + 1:k + 1], dvel[k_prev + 1:k + 1],
                         dt_rows[k_prev:k], speed[k_prev + 1:k + 1], q_bn)
        y, beta_n, wie_n, D_i, S, q_ib, q_n0n = _observation(acc, has_dk, has_nabla, has_eps,
                                                             has_dv0, has_w)
        dq_n = _qmul(_qconj(q_n0n_prev), q_n0n)
        Qk = model.add_integrated_noise(Q, acc, i_w, arw2_dt, vrw2_dt) if has_w else Q
        x, P, q = _predict(x, P, q, dq_n, Wm, Wc, scale, Qk, a, f)
        x, P, q, R, eta, gamma, hit, e, nis = _update(
            x, P, q, y, beta_n, wie_n, D_i, S, Wm, Wc, scale, a, f, R, eta, adaptive_r,
            c_fade, R_min, R_max, hinf_mode, gamma_fixed, k0, gamma_min, gamma_max, margin, hinf_w,
            cv2, q_ib)
        hits += hit
        nis_sum += nis
        r = slot[j]
        if r >= 0:
            out_q_in[r] = q
            out_q_ib[r] = q_ib
            out_lla[r, 0] = acc[model.LAT]
            out_lla[r, 1] = acc[model.LON]
            out_lla[r, 2] = acc[model.H]
            out_P[r] = P
            out_R[r] = np.sqrt(R)
            out_gamma[r] = gamma
            out_x[r] = x
        q_n0n_prev = q_n0n
        k_prev = k
    return hits, nis_sum, x, P, q, R, eta


@numba.njit(cache=True)
def run_vector_epochs(y, beta_n, q_n0n, slot, x, P, q, Q, Wm, Wc, scale, a, f, R, eta,
                      adaptive_r, c_fade, R_min, R_max, hinf_mode, gamma_fixed, k0, gamma_min,
                      gamma_max, margin, hinf_w, out_q_in, out_P, out_R, out_gamma, out_x):
    """The filter cycle over precomputed per-epoch vectors (``y``, ``beta_n``: (M, 3), and
    ``q_n0n``: (M, 4), row 0 the start or the previous block's last epoch), attitude state
    only: the Earth-rate term is already in ``y`` (``inmotion.align.obs_vectors``, model
    ``MODEL_VB_EARTH``). Epoch ``j`` (row ``j >= 1``) is written to output row
    ``slot[j - 1]`` (none when negative). Returns ``(floor hits, NIS sum, x, P, q, R,
    eta)``: as :func:`run_epochs`."""
    zero3 = np.zeros(3)
    no_cv = np.zeros(2)                  # the paper's model: no constraint noise term
    unit_q = np.array([1.0, 0.0, 0.0, 0.0])
    S = np.zeros((3, 0))
    hits = 0
    nis_sum = 0.0
    for j in range(1, y.shape[0]):
        dq_n = _qmul(_qconj(q_n0n[j - 1]), q_n0n[j])
        x, P, q = _predict(x, P, q, dq_n, Wm, Wc, scale, Q, a, f)
        x, P, q, R, eta, gamma, hit, e, nis = _update(
            x, P, q, y[j], beta_n[j], zero3, zero3, S, Wm, Wc, scale, a, f, R, eta, adaptive_r,
            c_fade, R_min, R_max, hinf_mode, gamma_fixed, k0, gamma_min, gamma_max, margin, hinf_w,
            no_cv, unit_q)
        hits += hit
        nis_sum += nis
        r = slot[j - 1]
        if r >= 0:
            out_q_in[r] = q
            out_P[r] = P
            out_R[r] = np.sqrt(R)
            out_gamma[r] = gamma
            out_x[r] = x
    return hits, nis_sum, x, P, q, R, eta
