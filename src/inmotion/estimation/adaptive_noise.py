"""Adaptive measurement-noise covariance with a fading factor and bounds (paper 001 eq. 38-45).

From the innovation ``e = y - Y_hat`` (eq. 38) and its predicted covariance
``P_y = H P H^T + R_k`` (eq. 36), ``E[e e^T] - P_y + R_k`` is a one-sample estimate of ``R``
(eq. 39-40). The paper averages these estimates with a fading memory (eq. 42-43):

    R_{k+1} = (1 - eta_{k+1}) R_k + eta_{k+1} (e e^T - P_y + R_k),
    eta_{k+1} = eta_k / (eta_k + c),   eta_0 = 1,

with the fading factor ``c`` in (0.9, 0.999): ``eta`` falls from 1 to the steady value
``1 - c``, i.e. a memory of about ``1 / (1 - c)`` updates. Per diagonal element ``i`` (the paper
updates the measurement components sequentially) the estimate is bounded (eq. 44-45):

    p_i = e_i^2 - P_y,ii + R_k,i
    R_{k+1},i = (1 - eta) R_k,i + eta R_min,i    if p_i < R_min,i
              = R_max,i                          if p_i > R_max,i
              = (1 - eta) R_k,i + eta p_i        otherwise.

So an innovation larger than the upper bound sets the element straight to ``R_max`` (an outlier
is de-weighted at once), while decreases are gradual.

Timing choice (the paper does not say which update uses ``R_{k+1}``): the new ``R`` is used in
the same update that produced it, i.e. ``P_y`` is recomputed with ``R_{k+1}`` before the gain is
formed. Otherwise the first sample of an outlier burst would be taken at full weight. The
tests show ``R`` stays within its bounds and follows a step change of the true noise.

The function uses only ``numpy`` operations that ``numba`` also compiles.
"""
from __future__ import annotations

import numpy as np

__all__ = ["adapt_noise", "fading_weight"]


def fading_weight(eta, c):
    """``eta_{k+1} = eta_k / (eta_k + c)`` (eq. 43); start from ``eta_0 = 1``."""
    return eta / (eta + c)


def adapt_noise(R_diag, eta, e, Py_diag, c, R_min, R_max):
    """One step of the bounded fading-memory noise estimate (eq. 43-45).

    Parameters
    ----------
    R_diag : (m,) array
        Current diagonal of ``R_k`` [measurement unit^2].
    eta : float
        Current fading weight ``eta_k`` (1 at the first update).
    e : (m,) array
        Innovation ``e_{k+1}``.
    Py_diag : (m,) array
        Diagonal of the innovation covariance ``P_{y,k+1}`` computed with ``R_k``.
    c : float
        Fading factor, 0 < c < 1 (paper: 0.9 to 0.999).
    R_min, R_max : (m,) arrays
        Per-element bounds of ``R``.

    Returns
    -------
    R_new : (m,) array, the diagonal of ``R_{k+1}``
    eta_new : float, ``eta_{k+1}``
    """
    eta_new = eta / (eta + c)             # fading_weight, inlined for numba
    p = e * e - Py_diag + R_diag
    R_new = (1.0 - eta_new) * R_diag + eta_new * p
    for i in range(len(R_new)):
        if p[i] < R_min[i]:
            R_new[i] = (1.0 - eta_new) * R_diag[i] + eta_new * R_min[i]
        elif p[i] > R_max[i]:
            R_new[i] = R_max[i]
    return R_new, eta_new
