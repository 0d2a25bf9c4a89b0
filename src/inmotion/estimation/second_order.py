"""Second-order terms of the body-frame velocity rows under the filter's own Gaussian
(issue 15, session 21).

A row that compares the SINS's velocity (or displacement) in body axes with a sensor's is
linear in the errors only to first order: ``C_n^b (I + [phi x]) (v + dv)`` holds the product
``C_n^b [phi x] dv`` besides. With arc-minutes of attitude error and cm/s of velocity error it
is nothing; after a long coast (a speed-sensor gap, a start without a velocity) it is metres
per second times a degree, and systematic: a coast makes the velocity error of the tilt. A
measurement that asks for its filter's estimate and covariance of ``[phi, dv]``
(:attr:`~inmotion.estimation.measurements.Measurement.wants_state`, the engine's
``_state_to_params``) adds the term's variance to its noise and takes the term at the
estimate out of its innovation (:func:`bilinear_rows`).

A choice, measured (issue 15, session 21): the Gaussian second-order filter also moves the
innovation by the covariance part of the term's mean, ``tr(A P_vp)``. With it, ``nhc-kf`` on
the PSINS MEMS log (its 4.8 deg mounting not modelled) ended 353 m off at a 101 m sigma
(3.5x; without it 254 m at 110 m), and across the phone drive's 35 s speed gap (20 runs,
band 2.02-4.16) od-kf / dr-kf / od-velocity-kf read 3.19 / 1.81 / 1.95 against 2.99 / 1.69
/ 1.66 without it: a systematic correction from the covariance helps nothing measurable
here and costs the filter its footing where the model is wrong, so it is left out. Used by paper 003's displacement rows
(:func:`inmotion.align.aided_kf._length_fill`), :class:`~.measurements.ForwardVelocity` and
:class:`~.measurements.Nhc`.
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from ..core import _kernels as K

__all__ = ["bilinear_moments", "bilinear_rows"]


@njit(cache=True)
def bilinear_moments(st, h):
    """``(mean, variance)`` of a row's bilinear term ``h . (phi x dv)`` in the attitude and
    velocity errors under the filter's Gaussian ``[phi, dv] ~ N(m, P)`` (``st``: the mean and
    6 x 6 covariance, :data:`~inmotion.estimation.measurements.STATE_PARAMS`), for a row whose
    velocity columns are ``h`` (its ``dv`` columns of ``H``: a row of ``C_n^b``, times the
    interval for a displacement).

    Derivation: the SINS's body-frame velocity ``C_n^b (I + [phi x]) (v + dv)`` holds, beyond
    the first-order rows, ``C_n^b [phi x] dv``, whose row is ``h . (phi x dv) = phi^T A dv``
    with ``A = -[h x]``. For a Gaussian (Isserlis): mean ``m_phi^T A m_v + tr(A P_vp)``,
    variance ``tr(A^T P_pp A P_vv) + tr(A P_vp A P_vp)`` plus the mean's cross terms
    ``m_v^T A^T P_pp A m_v + m_phi^T A P_vv A^T m_phi + 2 m_phi^T A P_vp A m_v`` (``P_vp =
    Cov(dv, phi)``; ``tests/test_bilinear_rows.py`` checks both against sampling).

    With a small velocity error it is nothing (cm/s times arc-minutes). After a long coast (a
    speed-sensor gap) it is not: metres per second times a degree, and its mean is systematic,
    since a coast makes the velocity error of the tilt (``dv ~ -[f x] phi t``): the vertical
    row's mean is about ``-g t sigma_tilt^2``, tenths of a metre per second after 35 s of a
    phone IMU's coast. Taken at their first-order noise, the first samples after the gap put
    it into the tilt and heading (issue 15, session 21).
    """
    # 3 x 3 products by loops: a matrix product is a BLAS call in numba, whose first use
    # imports scipy (the ahead-of-time run path's cost, issue 13)
    A = -K.skew(h)
    Ppp, Pvv, Pvp = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            Ppp[a, b] = st[6 + 6 * a + b]
            Pvv[a, b] = st[6 + 6 * (3 + a) + 3 + b]
            Pvp[a, b] = st[6 + 6 * (3 + a) + b]
    mp, mv = st[0:3], st[3:6]
    AP = _mm(A, Pvp)
    Am = _mv(A, mv)
    mean = mp[0] * Am[0] + mp[1] * Am[1] + mp[2] * Am[2] + AP[0, 0] + AP[1, 1] + AP[2, 2]
    t1 = _mm(_mm(_mm(A.T.copy(), Ppp), A), Pvv)
    t2 = _mm(AP, AP)
    PAm = _mv(Ppp, Am)
    Atm = _mv(A.T.copy(), mp)
    PvAtm = _mv(Pvv, Atm)
    APAm = _mv(AP, Am)
    var = t1[0, 0] + t1[1, 1] + t1[2, 2] + t2[0, 0] + t2[1, 1] + t2[2, 2]
    for i in range(3):
        var += Am[i] * PAm[i] + Atm[i] * PvAtm[i] + 2.0 * mp[i] * APAm[i]
    return mean, max(0.0, var)


@njit(cache=True)
def _mm(A, B):
    """``A B`` of two 3 x 3 arrays, by loops (no BLAS)."""
    C = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                C[i, j] += A[i, k] * B[k, j]
    return C


@njit(cache=True)
def _mv(A, x):
    """``A x`` of a 3 x 3 array and a 3-vector, by loops."""
    y = np.zeros(3)
    for i in range(3):
        for k in range(3):
            y[i] += A[i, k] * x[k]
    return y


#: the attitude 1-sigma [rad] (root of the trace of its covariance) beyond which the
#: expansion is not used: the rows stay first order (at 0.1 rad the next terms are a few per
#: cent of the bilinear one; a filter started with a heading unknown by tens of degrees, as
#: on the PSINS MEMS log, is far outside it)
MAX_ANGLE_RAD = 0.1


@njit(cache=True)
def bilinear_rows(z, H, r, st, o_dv, a, b):
    """Rows ``a:b`` of ``z``, ``r`` with their bilinear term (``h`` each row's ``dv`` columns
    of ``H`` from ``o_dv``): its variance (:func:`bilinear_moments`) into the noise, its value
    at the estimate, ``h . (m_phi x m_v)`` (nonzero between feedbacks), out of the innovation;
    nothing beyond :data:`MAX_ANGLE_RAD` of attitude sigma (module docstring: why not the
    mean's covariance part)."""
    if st[6] + st[6 + 7] + st[6 + 14] > MAX_ANGLE_RAD * MAX_ANGLE_RAD:
        return
    # at the estimate (an open-loop interval's nonzero [phi, dv]): h . (m_phi x m_v)
    mx = K.cross((st[0], st[1], st[2]), (st[3], st[4], st[5]))
    h = np.empty(3)
    for i in range(a, b):
        for c in range(3):
            h[c] = H[i, o_dv + c]
        _, var = bilinear_moments(st, h)
        z[i] -= h[0] * mx[0] + h[1] * mx[1] + h[2] * mx[2]
        r[i] += var
