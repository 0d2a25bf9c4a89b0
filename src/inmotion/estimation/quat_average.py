"""Weighted quaternion averaging (Markley, Cheng, Crassidis & Oshman 2007; paper 001 ref. 24).

The average of unit quaternions ``q_i`` with weights ``w_i`` is the unit quaternion that
maximizes ``sum_i w_i (q_i . q)^2``, i.e. minimizes the weighted sum of squared Frobenius
distances between the attitude matrices. It is the eigenvector of

    M = sum_i w_i q_i q_i^T          (4 x 4, symmetric)

belonging to its largest eigenvalue (Markley et al. 2007, eq. 12-13). Because ``q q^T`` is the
same for ``q`` and ``-q``, the result does not depend on the sign of each input quaternion,
unlike the naive normalized arithmetic mean.

Unscented filters use this average as the mean of propagated quaternion sigma points
(paper 001 eq. 30 and 59). Their zeroth weight may be negative (``lambda < 0``); the
eigenvector is still well defined as long as ``M`` has a single largest eigenvalue, which
holds whenever the sigma points are clustered (the usual case: spreads of a few degrees).

The functions use only ``numpy`` operations that ``numba`` also compiles and call no other
Python function, so a filter kernel can use ``numba.njit(quat_average)`` on the same source.
"""
from __future__ import annotations

import numpy as np

__all__ = ["quat_average", "quat_average_matrix"]


def quat_average_matrix(q, w):
    """The 4x4 matrix ``M = sum_i w_i q_i q_i^T`` (Markley et al. 2007, eq. 12).

    Parameters
    ----------
    q : (m, 4) array
        Scalar-first unit quaternions.
    w : (m,) array
        Weights (need not sum to one; may include a negative zeroth weight).

    Returns
    -------
    (4, 4) array
    """
    return (q * w.reshape(-1, 1)).T @ q


def quat_average(q, w):
    """Weighted average of unit quaternions (Markley et al. 2007, eq. 13).

    Parameters
    ----------
    q : (m, 4) array
        Scalar-first unit quaternions (either sign of each is fine).
    w : (m,) array
        Weights.

    Returns
    -------
    (4,) array
        The unit eigenvector of ``sum w q q^T`` with the largest eigenvalue, sign chosen so that
        its scalar part is non-negative (the package's canonical sign).
    """
    M = (q * w.reshape(-1, 1)).T @ q      # = quat_average_matrix(q, w), inlined for numba
    _, vecs = np.linalg.eigh(M)
    q_avg = vecs[:, 3].copy()             # eigh sorts eigenvalues ascending
    if q_avg[0] < 0.0:
        q_avg = -q_avg
    return q_avg / np.sqrt(np.sum(q_avg * q_avg))
