"""Davenport's q-method: the rotation that best maps one set of vectors onto another.

Wahba's problem here is written in the form the alignment papers use: find the constant
rotation ``C`` with ``C @ alpha_i ~= beta_i`` (paper 004 eq. 6-8; paper 001 eq. 14), i.e.
maximise the gain ``sum_i w_i beta_i . (C alpha_i)``.

Convention (derived here, because paper 004 eq. 7 prints the cross-product term for a
scalar-last, passive quaternion): with the package's scalar-first Hamilton quaternion ``q``
and ``C = dcm_from_quat(q)`` (so ``C = (q0^2 - |v|^2) I + 2 v v^T + 2 q0 [v x]``), the gain is
``q^T K q`` with

    B = sum_i w_i beta_i alpha_i^T,   sigma = tr(B),   z = sum_i w_i alpha_i x beta_i,
    K = [[sigma, z^T], [z, B + B^T - sigma I3]]                       (4 x 4, symmetric)

(paper 004 eq. 7-8 up to that ordering). The optimal ``q`` is the eigenvector of the largest
eigenvalue ``lambda_1`` of ``K``. The gap ``lambda_1 - lambda_2`` measures how well the
vectors determine the rotation (it vanishes when they are all parallel, where the rotation
about them is unobservable); :func:`solve` reports it, absolute and relative to ``lambda_1``.

``K`` is linear in the vector pairs, so it can be accumulated over time (paper 004 eq. 7-8,
the recursive q-method): ``K_k = lambda K_{k-1} + dK_k`` with an optional fading factor
``0 < lambda <= 1`` (:class:`RecursiveQMethod`, and :func:`k_increment` for kernels).

Centred form (:func:`k_centered`): when ``alpha_i`` carry an unknown constant offset ``c``
(``C (alpha_i - c) = beta_i``), minimising ``sum w_i |beta_i - C alpha_i + d|^2`` over ``C`` and
``d = C c`` gives ``d = mean_w(C alpha_i - beta_i)`` and leaves Wahba's problem for the centred
vectors ``alpha_i - mean_w(alpha)``, ``beta_i - mean_w(beta)``, whose ``K`` is, by bilinearity,
``K - K(S_alpha, S_beta) / W`` with ``S_alpha = sum w_i alpha_i``, ``S_beta = sum w_i beta_i``,
``W = sum w_i``: three running sums, no stored vectors.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from ..core import rotations

__all__ = ["k_matrix", "k_pairs", "k_centered", "k_increment", "solve", "QSolution",
           "RecursiveQMethod", "triad"]


def k_matrix(alpha, beta, weights=None):
    """Davenport's ``K`` (4, 4) of the pairs ``C alpha_i = beta_i`` (paper 004 eq. 7-8).

    Parameters
    ----------
    alpha, beta : (M, 3) or (3,)
        Vector pairs, any consistent unit (m/s for the alignment vectors).
    weights : (M,), optional
        Non-negative weights ``w_i`` (default 1).

    Returns
    -------
    (4, 4) ndarray, scalar-first ordering (see the module docstring).
    """
    alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
    beta = np.atleast_2d(np.asarray(beta, dtype=float))
    if alpha.shape != beta.shape or alpha.shape[-1] != 3:
        raise ValueError(f"alpha and beta must both be (M, 3), got {alpha.shape}, {beta.shape}")
    w = np.ones(len(alpha)) if weights is None else np.asarray(weights, dtype=float)
    B = np.einsum("i,ij,ik->jk", w, beta, alpha)
    z = np.einsum("i,ij->j", w, np.cross(alpha, beta))
    return _k_from_bz(B, z)


def k_pairs(alpha, beta):
    """``K`` of each single pair, vectorized: (M, 3), (M, 3) -> (M, 4, 4)."""
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    B = beta[..., :, None] * alpha[..., None, :]
    z = np.cross(alpha, beta)
    sigma = np.einsum("...ii->...", B)
    K = np.empty(alpha.shape[:-1] + (4, 4))
    K[..., 0, 0] = sigma
    K[..., 0, 1:] = z
    K[..., 1:, 0] = z
    K[..., 1:, 1:] = B + np.swapaxes(B, -1, -2) - sigma[..., None, None] * np.eye(3)
    return K


def k_centered(K, S_alpha, S_beta, W):
    """``K`` of the centred vectors: ``K - K(S_alpha, S_beta) / W`` (see the module docstring).

    Broadcasts over leading axes; where ``W == 0`` the input ``K`` is returned.
    """
    W = np.asarray(W, dtype=float)
    safe = np.where(W > 0, W, 1.0)
    return np.asarray(K) - k_pairs(S_alpha, S_beta) / safe[..., None, None] * (W > 0)[..., None, None]


def _k_from_bz(B, z):
    sigma = np.trace(B)
    K = np.empty((4, 4))
    K[0, 0] = sigma
    K[0, 1:] = z
    K[1:, 0] = z
    K[1:, 1:] = B + B.T - sigma * np.eye(3)
    return K


@numba.njit(cache=True)
def k_increment(K, alpha, beta, w):
    """Add ``w K(alpha, beta)`` of one pair to ``K`` in place (numba; paper 004 eq. 7-8).

    ``K`` is (4, 4) float64; ``alpha``, ``beta`` are (3,) float64; ``w`` a weight.
    """
    a0, a1, a2 = alpha[0], alpha[1], alpha[2]
    b0, b1, b2 = beta[0], beta[1], beta[2]
    sigma = b0 * a0 + b1 * a1 + b2 * a2
    z0 = a1 * b2 - a2 * b1
    z1 = a2 * b0 - a0 * b2
    z2 = a0 * b1 - a1 * b0
    K[0, 0] += w * sigma
    K[0, 1] += w * z0
    K[0, 2] += w * z1
    K[0, 3] += w * z2
    K[1, 0] += w * z0
    K[2, 0] += w * z1
    K[3, 0] += w * z2
    # B + B^T - sigma I with B = beta alpha^T
    K[1, 1] += w * (2.0 * b0 * a0 - sigma)
    K[2, 2] += w * (2.0 * b1 * a1 - sigma)
    K[3, 3] += w * (2.0 * b2 * a2 - sigma)
    s01 = w * (b0 * a1 + b1 * a0)
    s02 = w * (b0 * a2 + b2 * a0)
    s12 = w * (b1 * a2 + b2 * a1)
    K[1, 2] += s01
    K[2, 1] += s01
    K[1, 3] += s02
    K[3, 1] += s02
    K[2, 3] += s12
    K[3, 2] += s12


@dataclass
class QSolution:
    """The q-method's answer for one or many ``K``.

    Attributes
    ----------
    q : (..., 4) scalar-first unit quaternion of ``C`` (canonical sign ``q0 >= 0``).
    C : (..., 3, 3) the rotation, ``C alpha ~= beta``.
    eigval_max : (...,) the largest eigenvalue ``lambda_1`` (the optimal gain).
    gap : (...,) ``lambda_1 - lambda_2``.
    gap_rel : (...,) ``(lambda_1 - lambda_2) / |lambda_1|`` (0 where ``lambda_1 = 0``).
    """

    q: np.ndarray
    C: np.ndarray
    eigval_max: np.ndarray
    gap: np.ndarray
    gap_rel: np.ndarray


def solve(K) -> QSolution:
    """Largest-eigenvalue eigenvector of ``K`` (..., 4, 4) (Davenport's q-method).

    Vectorized over leading axes (one ``eigh`` call). Returns a :class:`QSolution`.
    """
    K = np.asarray(K, dtype=float)
    if K.shape[-2:] != (4, 4):
        raise ValueError(f"K must have shape (..., 4, 4), got {K.shape}")
    vals, vecs = np.linalg.eigh(0.5 * (K + np.swapaxes(K, -1, -2)))
    q = rotations.quat_normalize(vecs[..., :, 3])
    lam1, lam2 = vals[..., 3], vals[..., 2]
    gap = lam1 - lam2
    with np.errstate(divide="ignore", invalid="ignore"):
        gap_rel = np.where(np.abs(lam1) > 0, gap / np.abs(lam1), 0.0)
    return QSolution(q, rotations.dcm_from_quat(q), lam1, gap, gap_rel)


class RecursiveQMethod:
    """Recursive q-method (paper 004 eq. 7-8): ``K_k = fading * K_{k-1} + dK_k``.

    Parameters
    ----------
    fading : float in (0, 1]
        Multiplies the accumulated ``K`` before each :meth:`update` (1: no fading, all
        vectors since the start count alike).
    """

    def __init__(self, fading: float = 1.0):
        if not 0.0 < fading <= 1.0:
            raise ValueError(f"fading must be in (0, 1], got {fading}")
        self.fading = float(fading)
        self.K = np.zeros((4, 4))

    def update(self, alpha, beta, weights=None) -> None:
        """Fade, then add the pairs ``C alpha_i = beta_i`` ((3,) or (M, 3))."""
        self.K *= self.fading
        self.K += k_matrix(alpha, beta, weights)

    def solution(self) -> QSolution:
        return solve(self.K)


def triad(alpha1, alpha2, beta1, beta2):
    """Dual-vector attitude determination (TRIAD; paper 003 eq. 9): ``C`` with
    ``C alpha1 = beta1`` exactly and ``C alpha2 ~= beta2`` in direction.

    Each pair builds an orthonormal triad ``[u, u x v / |u x v|, u x (u x v) / |..|]``
    (``u = x1 / |x1|``, ``v = x2``); ``C = T_beta T_alpha^T``. The two vectors must not be
    parallel. This is the two-vector special case of Davenport's q-method (which weighs
    both vectors, where TRIAD trusts the first one fully).
    """
    def frame(x1, x2):
        u = np.asarray(x1, float) / np.linalg.norm(x1)
        w = np.cross(u, x2)
        n = np.linalg.norm(w)
        if n < 1e-12 * np.linalg.norm(x2):
            raise ValueError("triad: the two vectors are parallel")
        w = w / n
        return np.column_stack([u, w, np.cross(u, w)])
    return frame(beta1, beta2) @ frame(alpha1, alpha2).T
