"""Small numba operations on the navigation kernel state shared by the filter engines.

The kernel state is ``x = [lat, lon, h, vE, vN, vU, q0, q1, q2, q3]`` of
:mod:`inmotion.core._kernels` with its step memory; these functions read its attitude
(:func:`dcm_of_q`, :func:`euler_ypr`), compensate IMU rows by the fed-back sensor errors
(:func:`compensated_row`) and apply closed-loop corrections (:func:`correct_nav`,
:func:`corrected_sins`) with the DESIGN misalignment convention
``C_b^n(computed) = (I - [phi x]) C_b^n(true)``.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from ..core import _kernels as K

__all__ = ["dcm_of_q", "dcm_columns", "compensated_row", "euler_ypr", "wrap_pi", "correct_nav",
           "corrected_sins", "velocity_shear"]


@njit(cache=True)
def dcm_of_q(q):
    """``C_b^n`` (3, 3) of a unit quaternion ``q_nb`` (array of 4): its columns are the body
    axes in n, ``C[:, j] = q (x) e_j (x) q*`` (:func:`inmotion.core._kernels.qrotate`)."""
    qt = (q[0], q[1], q[2], q[3])
    C = np.empty((3, 3))
    for j in range(3):
        e = (1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0, 1.0 if j == 2 else 0.0)
        c = K.qrotate(qt, e)
        C[0, j], C[1, j], C[2, j] = c[0], c[1], c[2]
    return C


@njit(cache=True)
def dcm_columns(x):
    """The columns of ``C_b^n`` of the kernel state ``x``'s attitude as three 3-tuples (the
    body axes in n; :func:`dcm_of_q`'s values, with no array allocated). ``C_n^b``'s rows
    are the same tuples."""
    qt = (x[K.Q0], x[K.Q0 + 1], x[K.Q0 + 2], x[K.Q3])
    return (K.qrotate(qt, (1.0, 0.0, 0.0)), K.qrotate(qt, (0.0, 1.0, 0.0)),
            K.qrotate(qt, (0.0, 0.0, 1.0)))


@njit(cache=True)
def compensated_row(dtheta, dvel, k, dt, bias_g, bias_a):
    """IMU row ``k`` less the accumulated gyro drift and accelerometer bias estimates over its
    interval ``dt`` [s]: ``(dtheta_k - eps dt, dvel_k - nabla dt)`` as two 3-tuples."""
    dth = (dtheta[k, 0] - bias_g[0] * dt, dtheta[k, 1] - bias_g[1] * dt,
           dtheta[k, 2] - bias_g[2] * dt)
    dvl = (dvel[k, 0] - bias_a[0] * dt, dvel[k, 1] - bias_a[1] * dt,
           dvel[k, 2] - bias_a[2] * dt)
    return dth, dvl


@njit(cache=True)
def euler_ypr(C):
    """``[yaw, pitch, roll]`` [rad] of ``C_b^n`` in the DESIGN convention (``yaw =
    atan2(C12, C22)``, ``pitch = asin(C32)``, ``roll = atan2(-C31, C33)``), in the row order
    of the attitude measurement (paper 000 eq. 23, paper 002 eq. 44)."""
    return np.array([math.atan2(C[0, 1], C[1, 1]), math.asin(min(1.0, max(-1.0, C[2, 1]))),
                     math.atan2(-C[2, 0], C[2, 2])])


@njit(cache=True)
def wrap_pi(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def correct_nav(x, mem, phi, dv, dp, with_velocity):
    """Closed-loop feedback into a kernel nav state, as ``Strapdown.correct`` does.

    ``q <- q(phi) (x) q`` (DESIGN misalignment, ``C_computed = (I - [phi x]) C_true``);
    ``v -= dv`` (if ``with_velocity``), ``[lat, lon, h] -= dp``; the epoch-earlier latitude,
    height and velocity kept for midpoint extrapolation shift by the same amounts.
    """
    q = K.qnormalize(K.qmul(K.quat_from_rotvec((phi[0], phi[1], phi[2])), K.get_q(x)))
    K.set_q(x, q)
    if with_velocity:
        for i in range(3):
            x[K.VE + i] -= dv[i]
            mem[K.M_V_OLD + i] -= dv[i]
    x[K.LAT] -= dp[0]
    x[K.LON] -= dp[1]
    x[K.H] -= dp[2]
    mem[K.M_LAT_OLD] -= dp[0]
    mem[K.M_H_OLD] -= dp[2]


@njit(cache=True)
def corrected_sins(out, xs, x, offs):
    """``out`` = the SINS state ``xs`` corrected by the estimate ``x`` not yet fed back (the
    open-loop output; a plain copy when the nav errors are zero, as right after feedback):
    ``q <- q(phi) (x) q``, ``v -= dv``, ``[lat, lon, h] -= dp``."""
    out[:] = xs
    o_phi, o_dv, o_dp = offs[0], offs[1], offs[2]
    nonzero = False
    for i in range(3):
        if x[o_phi + i] != 0.0 or x[o_dv + i] != 0.0 or x[o_dp + i] != 0.0:
            nonzero = True
    if nonzero:
        correct_nav(out, np.zeros(K.NMEM), x[o_phi:o_phi + 3], x[o_dv:o_dv + 3],
                     x[o_dp:o_dp + 3], True)


@njit(cache=True)
def velocity_shear(P, x, o_phi, o_dv, dV, sign):
    """``x <- J x``, ``P <- J P J^T`` in place with ``J = I + sign E``, ``E[dv, phi] = [dV x]``
    (``sign`` +1 or -1; ``J^-1 = I - E``): the covariance of the invariant velocity feedback
    carried across the velocity change ``dV`` (:mod:`inmotion.estimation.engine`, "Invariant
    velocity error"; the smoother undoes it with ``sign = -1``). ``x`` may be empty (length
    0: left alone). The ``dv`` rows and columns are averaged with their transposes (exact
    symmetry). Nothing for ``dV = 0``."""
    a, b, c = sign * dV[0], sign * dV[1], sign * dV[2]
    if a == 0.0 and b == 0.0 and c == 0.0:
        return
    d = (a, b, c)
    n = P.shape[0]
    for j in range(n):                  # rows: P[dv, :] += [d x] P[phi, :]
        w = K.cross(d, (P[o_phi, j], P[o_phi + 1, j], P[o_phi + 2, j]))
        for k in range(3):
            P[o_dv + k, j] += w[k]
    for i in range(n):                  # columns: P[:, dv] += P[:, phi] [d x]^T
        w = K.cross(d, (P[i, o_phi], P[i, o_phi + 1], P[i, o_phi + 2]))
        for k in range(3):
            P[i, o_dv + k] += w[k]
    for k in range(3):
        r = o_dv + k
        for j in range(n):
            m = 0.5 * (P[r, j] + P[j, r])
            P[r, j] = m
            P[j, r] = m
    if x.shape[0]:
        w = K.cross(d, (x[o_phi], x[o_phi + 1], x[o_phi + 2]))
        for k in range(3):
            x[o_dv + k] += w[k]
