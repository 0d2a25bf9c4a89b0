"""H-infinity covariance update with a fixed or adaptive bound gamma (paper 001 eq. 46-56).

The extended / unscented H-infinity filter (paper 001 after refs. 26-27) keeps the Kalman state
update ``x+ = x- + P_xy P_y^-1 e`` (eq. 50) but updates the covariance as

    P+ = P- - [P_xy  P-] R_e^-1 [P_xy  P-]^T,    R_e = [[P_y, P_xy^T], [P_xy, P- - gamma^2 I]]
                                                                              (eq. 51-52)

which, by the matrix inversion lemma, is (eq. 53)

    P+^-1 = P-^-1 + P-^-1 P_xy R^-1 P_xy^T P-^-1 - gamma^-2 I.

``gamma`` bounds the energy gain from disturbances to estimation error (eq. 46-47): the smaller
it is, the more ``P+`` is inflated (robust, less accurate); ``gamma -> inf`` gives the Kalman
update. ``P+`` stays positive definite only if ``gamma^2 > max eig(M^-1)`` with
``M = P-^-1 + P-^-1 P_xy R^-1 P_xy^T P-^-1`` (eq. 54); :func:`gamma_floor` returns
``gamma_a = sqrt(max eig(M^-1))``.

Reading of eq. 54-55: the printed definition of ``gamma_a`` lost its inverse and square root in
extraction; we take ``gamma_a = sqrt(max eig(M^-1))`` so that ``gamma > gamma_a`` is exactly the
existence condition (54) and ``gamma`` has the unit of the state (rad for attitude), with
``M = P_KF^-1`` (see :func:`gamma_floor`).

Update rate: eq. 53 removes ``gamma^-2`` of information at every update, so a gamma given per
update means a rate-dependent bound; a filter updating at a high rate should state gamma per
unit time and use ``gamma_c / sqrt(dt)`` per update (the discretization of
``int |S - S_hat|^2 dt``), and pick ``gamma_c`` so that the existence condition holds over the
run, not only at each step (:mod:`inmotion.align.usque`, ``usque-hinf``).

Adaptive gamma (eq. 55-56): ``gamma = (1 + k0 sqrt(trace(P_y) / e^T e)) gamma_a``, floored at
``gamma_min``; above ``gamma_max`` the Kalman covariance update is used instead. A large
innovation (an outlier) brings ``gamma`` down towards ``gamma_a`` (more robust, larger ``P+``);
a small one raises it (more accurate).

All functions use only ``numpy`` operations that ``numba`` also compiles; the filter kernel
compiles the ones that call no other function (:func:`kalman_covariance`,
:func:`hinf_from_kalman`, :func:`floor_from_kalman`, :func:`adaptive_gamma`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["hinf_covariance", "hinf_covariance_block", "kalman_covariance", "gamma_floor",
           "gamma_floor_paper", "adaptive_gamma", "hinf_update", "hinf_from_kalman",
           "floor_from_kalman"]


def kalman_covariance(P_pred, P_xy, P_y):
    """Kalman covariance update ``P- - K P_y K^T`` with ``K = P_xy P_y^-1`` (eq. 56, lower)."""
    K = np.linalg.solve(P_y.T, P_xy.T).T
    P = P_pred - K @ P_y @ K.T
    return 0.5 * (P + P.T)


def hinf_covariance(P_pred, P_xy, P_y, gamma, weights=None):
    """H-infinity covariance update of eq. 51-52, evaluated in its information form.

    Eq. 51-52 equal, exactly (block elimination of ``R_e``; a test checks it against the block
    form :func:`hinf_covariance_block`),

        P+ = (P_KF^-1 - gamma^-2 I)^-1 = (I - gamma^-2 P_KF)^-1 P_KF,
        P_KF = P- - P_xy P_y^-1 P_xy^T   (the Kalman posterior),

    which is what is computed: it needs no inverse of ``P-`` and no difference of large
    numbers, so it stays positive definite when the states have very different scales
    (attitude in rad beside accelerometer bias in m/s^2).

    Parameters
    ----------
    P_pred : (n, n) array
        Predicted state covariance ``P_{x,k+1|k}``.
    P_xy : (n, m) array
        State-measurement cross covariance (eq. 37).
    P_y : (m, m) array
        Innovation covariance including ``R`` (eq. 36).
    gamma : float
        The H-infinity bound, in the unit of the state; must exceed :func:`gamma_floor`.
    weights : (n,) array or None
        Diagonal of ``L^T L`` for the estimated combination ``S = L x`` of eq. 46 (None: all
        ones, ``S = x`` as in the paper). A filter whose state mixes units (attitude in rad,
        bias in m/s^2, speed in m/s) bounds the attitude only: weights 1 there, 0 elsewhere,
        so ``P+^-1 = P_KF^-1 - gamma^-2 L^T L``.

    Returns
    -------
    (n, n) array, the updated covariance ``P_{x,k+1}`` (symmetrized).
    """
    P_kf = kalman_covariance(P_pred, P_xy, P_y)
    w = np.ones(P_kf.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    return hinf_from_kalman(P_kf, gamma, w)


def hinf_from_kalman(P_kf, gamma, weights):
    """``(I - gamma^-2 P_KF L^T L)^-1 P_KF`` (symmetrized): eq. 51-52 from the Kalman posterior,
    ``weights`` the diagonal of ``L^T L``."""
    n = P_kf.shape[0]
    P = np.linalg.solve(np.eye(n) - (P_kf * weights.reshape(1, -1)) / (gamma * gamma), P_kf)
    return 0.5 * (P + P.T)


def hinf_covariance_block(P_pred, P_xy, P_y, gamma):
    """Eq. 51-52 literally: ``P- - [P_xy P-] R_e^-1 [P_xy P-]^T`` (reference for the tests)."""
    n = P_pred.shape[0]
    m = P_y.shape[0]
    Re = np.empty((m + n, m + n))
    Re[:m, :m] = P_y
    Re[:m, m:] = P_xy.T
    Re[m:, :m] = P_xy
    Re[m:, m:] = P_pred - gamma * gamma * np.eye(n)
    A = np.empty((n, m + n))
    A[:, :m] = P_xy
    A[:, m:] = P_pred
    P = P_pred - A @ np.linalg.solve(Re, A.T)
    return 0.5 * (P + P.T)


def gamma_floor(P_pred, P_xy, P_y, weights=None):
    """``gamma_a = sqrt(max eig(M^-1))``, the smallest admissible gamma (eq. 53-54).

    With ``M = P_KF^-1`` (the information of the Kalman posterior), ``P+^-1 = M - gamma^-2 I``
    is positive definite exactly when ``gamma^2 > max eig(P_KF)``. The paper writes
    ``M = P-^-1 + P-^-1 P_xy R^-1 (P-^-1 P_xy)^T``, which equals ``P_KF^-1`` when eq. 48-49
    hold (:func:`gamma_floor_paper`; a test shows the two agree for a linear measurement);
    for the unscented filter, where eq. 48 holds only approximately, ``P_KF`` makes the floor
    match the covariance actually formed by :func:`hinf_covariance`.
    """
    P_kf = kalman_covariance(P_pred, P_xy, P_y)
    w = np.ones(P_kf.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    return floor_from_kalman(P_kf, w)


def floor_from_kalman(P_kf, weights):
    """``sqrt(max eig(W^1/2 P_KF W^1/2))``, ``W = L^T L = diag(weights)``: :func:`gamma_floor`
    from the Kalman posterior (``P_KF^-1 - gamma^-2 W > 0`` exactly above it)."""
    s = np.sqrt(weights)
    A = P_kf * s.reshape(-1, 1) * s.reshape(1, -1)
    return np.sqrt(np.linalg.eigvalsh(A)[-1])


def gamma_floor_paper(P_pred, P_xy, R):
    """Eq. 53-54 as printed: ``sqrt(max eig(M^-1))``, ``M = P-^-1 + P-^-1 P_xy R^-1 P_xy^T P-^-1``."""
    Pinv = np.linalg.inv(P_pred)
    G = Pinv @ P_xy
    M = Pinv + G @ np.linalg.solve(R, G.T)
    M = 0.5 * (M + M.T)
    return 1.0 / np.sqrt(np.linalg.eigvalsh(M)[0])


def adaptive_gamma(gamma_a, P_y, e, k0, gamma_min):
    """Adaptive bound of eq. 55: ``(1 + k0 sqrt(trace(P_y) / e^T e)) gamma_a``, >= ``gamma_min``.

    Parameters
    ----------
    gamma_a : float
        :func:`gamma_floor` of this update.
    P_y : (m, m) array
        Innovation covariance.
    e : (m,) array
        Innovation (eq. 38).
    k0 : float
        The paper's correlation coefficient ``k0 > 0``.
    gamma_min : float
        Lower bound (same unit as the state).
    """
    ee = float(np.sum(e * e))
    ratio = np.trace(P_y) / max(ee, 1e-300)
    gamma = (1.0 + k0 * np.sqrt(ratio)) * gamma_a
    return max(gamma, gamma_min)


def hinf_update(P_pred, P_xy, P_y, gamma, gamma_max=np.inf, weights=None):
    """Covariance update of eq. 56: H-infinity (eq. 51) below ``gamma_max``, Kalman above."""
    if gamma > gamma_max:
        return kalman_covariance(P_pred, P_xy, P_y)
    return hinf_covariance(P_pred, P_xy, P_y, gamma, weights)
