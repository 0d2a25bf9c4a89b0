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

from .._jit import njit
from ..core import _kernels as K

__all__ = ["bilinear_moments", "bilinear_rows", "bilinear_rows_blocks", "cov_block"]


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
    # 3 x 3 products written out on tuples (:func:`_mm`): a matrix product is a BLAS call in
    # numba, whose first use imports scipy (the ahead-of-time run path's cost, issue 13), and
    # an array per product is an allocation in the fills' hot path
    return _moments((st[0], st[1], st[2]), (st[3], st[4], st[5]), cov_block(st, 0, 0),
                    cov_block(st, 3, 3), cov_block(st, 3, 0), (h[0], h[1], h[2]))


# 3 x 3 matrices as 9-tuples, row by row, and 3-vectors as 3-tuples: values on the stack, no
# allocation in the fills' hot path (issue 13's engine budget: the arrays these helpers made
# before, ~17 per row, cost the equal workload 0.2 s per hour, session 22)

@njit(cache=True)
def cov_block(st, r0, c0):
    """The 3 x 3 block at rows ``r0``, columns ``c0`` of the 6 x 6 covariance in ``st``."""
    o = 6 + 6 * r0 + c0
    return (st[o], st[o + 1], st[o + 2], st[o + 6], st[o + 7], st[o + 8],
            st[o + 12], st[o + 13], st[o + 14])


@njit(cache=True)
def _t(a):
    """Transpose of a 9-tuple matrix."""
    return (a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8])


@njit(cache=True)
def _mm(a, b):
    """``a b`` of two 9-tuple matrices (each entry summed over k = 0, 1, 2 in that order)."""
    return (a[0] * b[0] + a[1] * b[3] + a[2] * b[6], a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
            a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
            a[3] * b[0] + a[4] * b[3] + a[5] * b[6], a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
            a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
            a[6] * b[0] + a[7] * b[3] + a[8] * b[6], a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
            a[6] * b[2] + a[7] * b[5] + a[8] * b[8])


@njit(cache=True)
def _mv(a, x):
    """``a x`` of a 9-tuple matrix and a 3-tuple."""
    return (a[0] * x[0] + a[1] * x[1] + a[2] * x[2], a[3] * x[0] + a[4] * x[1] + a[5] * x[2],
            a[6] * x[0] + a[7] * x[1] + a[8] * x[2])


@njit(cache=True)
def _moments(mp, mv, Ppp, Pvv, Pvp, h):
    """:func:`bilinear_moments` on the blocks: the means ``mp``, ``mv``, the covariances
    ``Ppp``, ``Pvv``, ``Pvp = Cov(dv, phi)`` (9-tuples) and the row's ``h`` (3-tuple)."""
    A = (0.0, h[2], -h[1], -h[2], 0.0, h[0], h[1], -h[0], 0.0)      # -[h x]
    AP = _mm(A, Pvp)
    Am = _mv(A, mv)
    mean = mp[0] * Am[0] + mp[1] * Am[1] + mp[2] * Am[2] + AP[0] + AP[4] + AP[8]
    At = _t(A)
    t1 = _mm(_mm(_mm(At, Ppp), A), Pvv)
    t2 = _mm(AP, AP)
    PAm = _mv(Ppp, Am)
    Atm = _mv(At, mp)
    PvAtm = _mv(Pvv, Atm)
    APAm = _mv(AP, Am)
    var = t1[0] + t1[4] + t1[8] + t2[0] + t2[4] + t2[8]
    var += Am[0] * PAm[0] + Atm[0] * PvAtm[0] + 2.0 * mp[0] * APAm[0]
    var += Am[1] * PAm[1] + Atm[1] * PvAtm[1] + 2.0 * mp[1] * APAm[1]
    var += Am[2] * PAm[2] + Atm[2] * PvAtm[2] + 2.0 * mp[2] * APAm[2]
    return mean, max(0.0, var)


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
    bilinear_rows_blocks(z, H, r, (st[0], st[1], st[2]), (st[3], st[4], st[5]),
                         cov_block(st, 0, 0), cov_block(st, 3, 3), cov_block(st, 3, 0), o_dv, a, b)


@njit(cache=True)
def bilinear_rows_blocks(z, H, r, mp, mv, Ppp, Pvv, Pvp, o_dv, a, b):
    """:func:`bilinear_rows` with the estimate and covariance given as blocks (as
    :func:`_moments` takes them): the NHC rows at a mounting estimate hand the angle
    ``phi - C_vn^T a``'s (:func:`inmotion.estimation.measurements._with_mount_spread`)."""
    if Ppp[0] + Ppp[4] + Ppp[8] > MAX_ANGLE_RAD * MAX_ANGLE_RAD:
        return
    mx = K.cross(mp, mv)
    for i in range(a, b):
        h = (H[i, o_dv], H[i, o_dv + 1], H[i, o_dv + 2])
        _, var = _moments(mp, mv, Ppp, Pvv, Pvp, h)
        z[i] -= h[0] * mx[0] + h[1] * mx[1] + h[2] * mx[2]
        r[i] += var
