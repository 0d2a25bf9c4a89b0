"""Process and measurement models of paper 001's unscented alignment (eq. 6-19, 23).

Frames: ``i`` is the body frame frozen at the start, ``b(0)`` (non-rotating); ``n(0)`` the
navigation frame frozen at the start. The filter's attitude is the quaternion of
``C_{n(t)}^i`` (eq. 7), and the vehicle attitude is ``C_b^n(t) = (C_{n(t)}^i)^T C_{b(t)}^i``.

Process model (eq. 9): ``C_{n(t_k)}^i = C_{n(t_{k-1})}^i C_{n(t_k)}^{n(t_{k-1})}``: every
sigma-point quaternion is right-multiplied by the same navigation-frame increment, computed
from ``omega_in^n`` (:func:`propagate`).

Measurement model (eq. 12-14, 23). Integrating the velocity equation (eq. 11) gives

    C_{b(t)}^i v^b(t) - v^b(0) + int C_b^i (omega_ie^b x v^b) - int C_b^i f^b
        = C_{n(t)}^i beta(t),       beta(t) = C_{n(0)}^{n(t)} int C_{n(tau)}^{n(0)} g^n dtau.

The Earth-rate integral (paper eq. 15-16) needs the attitude. We use an exact identity
instead of eq. 16's approximation: the Earth rate in the inertial frame i is a constant
vector ``w^i = C_{n(t)}^i omega_ie^{n(t)}`` (any t), and
``C_b^i (omega_ie^b x v^b) = w^i x (C_b^i v^b)``, so the integral is ``w^i x D^i(t)`` with
``D^i(t) = int C_b^i v^b dtau`` the displacement resolved in i. Since ``w^i`` depends only on
the attitude state, it moves into ``h``. The measurement and its model are then

    y   = C_{b(t)}^i v_m^b(t) - v_m^b(0) - int C_b^i f^b                      (computed)
    h(X) = C_{n(t)}^i beta(t) - (C_{n(t)}^i omega_ie^{n(t)}) x D_m^i(t) + S(t) x_e

where ``v_m = [0, v_LDV, 0]`` is the measured body velocity and ``x_e`` the optional extra
states (paper eq. 22), all entering linearly to first order with the sensitivities ``S``
(:func:`sensitivity`):

- ``dk``, LDV scale-factor error, ``v_true = (1 - dk) v_m``: column ``V_i = C_b^i v_m(t) - v_m(0)``
  (its tiny effect on the Earth-rate term is neglected; the samples are lagged by one row,
  :func:`dk_column`);
- ``nabla``, accelerometer bias in b [m/s^2] (``f_measured = f + nabla``): columns
  ``-B(t)``, ``B = int C_b^i dtau``;
- ``eps``, gyro drift in b [rad/s] (``omega_measured = omega + eps``): the computed
  ``C_b^i`` is ``(I - [psi x]) C_b^i`` with ``psi = -B eps``, so ``y`` changes by
  ``J eps``, ``J = int [(C_b^i f^b) x] B dtau - [(C_b^i v^b(t)) x] B(t)``.

- ``dv0``, the error of the one LDV sample taken for ``v^b(0)`` [m/s]
  (``v_m(0) = v(0) + dv0``): column ``[0, -1, 0]``. This error is a constant vector in ``y``
  that neither tilt (``~ t``) nor heading (``~ t^2``) can absorb, so with a noisy LDV it biases
  the heading by about ``dv0 / (g omega_ie cos(L) t^2 / 2)`` rad (1.4 deg at 200 s for 0.3 m/s).

The paper estimates none of them (its sec. 3: "other parameters are not estimated").

What the measurement's error is (issue 15; the ``noise_preset: matched`` of
:mod:`inmotion.align.usque`). The paper treats ``y - h`` as white noise of constant ``R`` and
the attitude's process noise as ``(1e-7 deg)^2`` per update; over Monte Carlo runs of its own
test 1 that filter's attitude NEES is 3e4-5e4 against a band of 1.7-4.7
(``benchmarks/nees_usque.py``; :mod:`inmotion.align.usque`, "Noise presets"). Derivation, with the sensor errors of the simulator (white
gyro and accelerometer noise of densities ``ARW``, ``VRW``; constant drift ``eps`` and bias
``nabla``; LDV white noise ``sigma_v`` per sample and scale factor ``dk``):

* Gyro noise. The computed ``C_b^i`` is ``(I - [psi x]) C_b^i`` (true), with
  ``d psi / dt = -C_b^i n_g``: ``psi`` is a random walk of density ``ARW`` (isotropic, so in
  any frame). Put into ``y``:
  ``y_c = y - psi(t) x (C_b^i v(t)) + int psi x a dtau`` with ``a = C_b^i f^b``, and, with
  ``A' = int_0^t a dtau + v_m^b(0)``, this is ``(I - [psi x]) y + m`` where
  ``m(t) = int_0^t psi x a dtau - psi(t) x A'(t)``, i.e. ``dm/dt = [A' x] d psi / dt``
  (the ``psi(t) x v(0)`` term included, exact to first order in ``psi``).
  The first part is ``h`` at the *effective* attitude ``C_{n}^i = C_b^i(computed) C_n^b``
  (``(I - [psi x]) h(X)`` equals ``h`` of the rotated ``X`` up to ``psi x (u x D)``
  terms of ``omega_ie |D| |psi|``, 1e-6 m/s): that is the attitude the filter estimates and
  the one that makes the output ``C_b^n`` right, so the gyro noise is the attitude's process
  noise, ``ARW^2 dt`` per update and axis (white, a random walk of the state). The second part
  ``m`` is NOT white: it integrates, and it is driven by the same increments ``d psi``.
  With the GRP error ``theta = -psi`` (``C(delta q) = I + [theta x]``) one update adds
  ``E[d theta d theta^T] = ARW^2 dt I``, ``E[dm dm^T] = ARW^2 dt [A' x][A' x]^T`` and
  ``E[d theta dm^T] = ARW^2 dt [A' x]``. Size on test 1: ``g ARW t^1.5 2/3`` = 0.03 m/s at
  300 s, with ``|A'|`` up to 3000 m/s.
* Accelerometer noise: ``-int C_b^i n_a dtau``, a random walk of density ``VRW``,
  isotropic in i (0.008 m/s at 300 s for 50 ug/sqrt(Hz)). Integrates; not white.
* Accelerometer bias and gyro drift: ``-B nabla`` and ``J eps`` above, growing with ``t`` and
  ``t^2``; constants, states.
* LDV: the current sample's white noise reaches ``y`` as ``C_b^i [0, n_v, 0]`` (white, one
  sample, ``sigma_v``); the sample taken as ``v^b(0)`` is a constant ``-dv0`` along i's y
  (i = b(0)); the scale factor ``dk``, a constant (column ``V_i``, built from samples
  whose noise is not the one in ``y``: :func:`dk_column`; with the current samples the
  estimate of ``dk`` took an errors-in-variables bias of ``sigma_v^2 / v^2``).
* The accumulator's own integration error: 1.1e-4 m/s at 300 s on the error-free drive
  (``tests/test_usque.py``), below the floor of 1e-3 m/s on ``sigma_v``.

So ``y = h(X) + S x_e + w + C_b^i [0, n_v, 0]`` with one random-walk state ``w`` (3, m/s, in
i) that carries both integrated noises: ``w = m - int C_b^i n_a``, started at
``w(0) = -dv0`` (``P0 = diag(floor, sigma_v, floor)^2``), ``dw = [A' x] d psi - C n_a dt``,
so one update adds ``Q_ww = (VRW^2 I + ARW^2 [A' x][A' x]^T) dt`` and couples ``w`` to the
attitude by ``Q_{theta,w} = ARW^2 dt [A' x]`` (:func:`add_integrated_noise`); ``w`` enters
``h`` with sensitivity ``I``. The attitude keeps the unscented machinery of the paper (the
sigma points carry ``w`` like the other extra states, eq. 24-38 unchanged). With ``w``,
``dk``, ``nabla`` and ``eps`` in the state and ``R = sigma_v^2`` per axis, the NEES lies in
its band (3.3-3.4 on test 1, 3.1-3.9 on test 2, against 1.7-4.7; ``benchmarks/nees_usque.py``;
``tests/test_consistency_nees_usque.py``). ``tests/test_usque.py`` checks this derivation
against the accumulator itself: over 200 realizations of gyro and accelerometer noise the
joint (attitude error, residual) whitened by the accumulated ``Q`` averages 6.01 for a
chi-square(6), and 82.8 with the coupling's sign flipped. What is
still approximate: ``R`` is taken isotropic in i (the LDV noise reaches only the body's
forward axis, so the other two axes are given ``sigma_v`` too: conservative); the output
attitude ignores the part ``-B eps`` of ``psi`` that the estimated drift explains (0.04 arcmin
at 300 s for 0.008 deg/h).

THE ALPHA/BETA ACCUMULATION HERE IS A MINIMAL STAND-IN. The optimization-based-alignment
vectors belong in the coarse-alignment module ``inmotion.align.obs_vectors`` (issue 5); it had
not landed when this filter was written, so :func:`accumulate` integrates what the filter
needs, in discrete form after paper 001 eq. 15-19:

- ``C_{b(t)}^i`` by the rotation-vector update with the two-sample (previous interval)
  coning correction;
- ``int C_b^i f^b`` as ``sum_k C_{b(t_{k-1})}^i dv^{b(t_{k-1})}`` with the rotation and
  two-sample sculling corrections of eq. 18 (previous-interval form:
  ``dv + dth x dv / 2 + (dth_prev x dv + dv_prev x dth) / 12``);
- ``D^i`` by the trapezoid rule on ``C_b^i v_m^b``;
- ``int C_{n(tau)}^{n(0)} g^n`` as in eq. 19, ``sum_k C_{n(t_k)}^{n(0)} (T I + T^2/2 [omega_in x]) g^n``,
  and ``C_{n(t)}^{n(0)}`` from ``omega_in^n`` (eq. 10);
- the position (for ``g``, ``omega_ie``, ``omega_en``) by dead reckoning with the filter's
  current attitude estimate and the LDV speed, starting from the given initial position.

All of it runs row by row in one numba kernel per chunk of IMU rows between filter updates.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..core import _kernels as kn

__all__ = ["ACC", "new_accumulator", "accumulate", "observation", "propagate",
           "predict_measurement", "attitude_bn", "add_integrated_noise"]


# Named slots of the flat accumulator state (module constants, so numba sees them).
Q_IB = 0        #: 4, quaternion of C_{b(t)}^i
Q_N0N = 4       #: 4, quaternion of C_{n(t)}^{n(0)}
ALPHA_F = 8     #: 3, int C_b^i f^b dtau [m/s], in i
D_I = 11        #: 3, int C_b^i v_m^b dtau [m], in i
BETA_N0 = 14    #: 3, int C_{n(tau)}^{n(0)} g^n dtau [m/s], in n(0)
LAT = 17        #: rad
LON = 18        #: rad
H = 19          #: m
DTH_PREV = 20   #: 3, previous angle increment [rad]
DV_PREV = 23    #: 3, previous velocity increment [m/s]
V_PREV = 26     #: previous LDV speed [m/s]
V0 = 27         #: LDV speed at the start [m/s]
B_I = 28        #: 9, B = int C_b^i dtau [s], row-major (accelerometer-bias sensitivity)
JF_I = 37       #: 9, int [(C_b^i f^b) x] B dtau [m/s * s], row-major (gyro-drift sensitivity)
V_LAG = 46      #: the LDV speed one row before the current one [m/s] (dk's column)
V0_COL = 47     #: the LDV speed at the first row after the start [m/s] (dk's column)
N_ROWS = 48     #: rows accumulated
E_S = 49        #: 3, the unit vector in b along which the vehicle moves (meta's mounting)
LEVER = 52      #: 3, the speed sensor's lever arm in b [m]
SIZE = 55


class ACC:
    """The accumulator's slots by name, for Python callers."""
    Q_IB, Q_N0N, ALPHA_F, D_I, BETA_N0 = Q_IB, Q_N0N, ALPHA_F, D_I, BETA_N0
    LAT, LON, H, DTH_PREV, DV_PREV, V_PREV, V0, SIZE = (LAT, LON, H, DTH_PREV, DV_PREV,
                                                        V_PREV, V0, SIZE)
    B_I, JF_I, V_LAG, V0_COL, N_ROWS = B_I, JF_I, V_LAG, V0_COL, N_ROWS
    E_S, LEVER = E_S, LEVER


def new_accumulator(lat, lon, h, v0, e_s=(0.0, 1.0, 0.0), lever=(0.0, 0.0, 0.0)):
    """A fresh accumulator at the start: identity rotations, zero integrals.

    Parameters
    ----------
    lat, lon : float, rad;  h : float, m
        Initial position.
    v0 : float, m/s
        LDV speed at the start time.
    e_s : (3,)
        The unit vector in b along which the vehicle moves, ``C_v^b [0, 1, 0]`` for the IMU's
        mounting in the vehicle (default: b's forward axis, paper 001's calibrated LDV): the
        body velocity is ``v e_s``.
    lever : (3,) m
        The speed sensor's lever arm in b: its reading less ``e_s . (omega x lever)`` is the
        vehicle's speed at the IMU (issue 15, session 25).
    """
    a = np.zeros(ACC.SIZE)
    a[ACC.E_S:ACC.E_S + 3] = e_s
    a[ACC.LEVER:ACC.LEVER + 3] = lever
    a[ACC.Q_IB] = 1.0
    a[ACC.Q_N0N] = 1.0
    a[ACC.LAT], a[ACC.LON], a[ACC.H] = lat, lon, h
    a[ACC.V_PREV] = v0
    a[ACC.V0] = v0
    a[ACC.V_LAG] = v0
    a[ACC.V0_COL] = v0
    return a


@numba.njit(cache=True)
def _vec(a, i):
    return (a[i], a[i + 1], a[i + 2])


@numba.njit(cache=True)
def _quat(a, i):
    return (a[i], a[i + 1], a[i + 2], a[i + 3])


@numba.njit(cache=True)
def _put(a, i, v):
    for j in range(len(v)):
        a[i + j] = v[j]


@numba.njit(cache=True)
def _dcm_t(q):
    """Row-major 9-tuple of the DCM of ``q``."""
    q0, q1, q2, q3 = q
    return (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3),
            2 * (q1 * q3 + q0 * q2), 2 * (q1 * q2 + q0 * q3),
            q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1),
            2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1),
            q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3)


@numba.njit(cache=True)
def _step(acc, dth, dv, dt, v, q_bn):
    """Advance the accumulator over one IMU row (see the module docstring)."""
    e_s = _vec(acc, E_S)
    lev = _vec(acc, LEVER)
    if lev[0] != 0.0 or lev[1] != 0.0 or lev[2] != 0.0:      # the sensor's lever arm
        w = kn.cross((dth[0] / dt, dth[1] / dt, dth[2] / dt), lev)
        v = v - (e_s[0] * w[0] + e_s[1] * w[1] + e_s[2] * w[2])
    q_ib = _quat(acc, Q_IB)
    dth_p = _vec(acc, DTH_PREV)
    dv_p = _vec(acc, DV_PREV)
    # specific-force integral with rotation and sculling corrections (eq. 17-18)
    c1 = kn.cross(dth, dv)
    c2 = kn.cross(dth_p, dv)
    c3 = kn.cross(dv_p, dth)
    dvb = (dv[0] + 0.5 * c1[0] + (c2[0] + c3[0]) / 12.0,
           dv[1] + 0.5 * c1[1] + (c2[1] + c3[1]) / 12.0,
           dv[2] + 0.5 * c1[2] + (c2[2] + c3[2]) / 12.0)
    dvi = kn.qrotate(q_ib, dvb)
    af = _vec(acc, ALPHA_F)
    _put(acc, ALPHA_F, (af[0] + dvi[0], af[1] + dvi[1], af[2] + dvi[2]))
    # gyro-drift sensitivity: int [(C f) x] B, with B at the interval's start
    for r in range(3):
        b_col = (acc[B_I + r], acc[B_I + 3 + r], acc[B_I + 6 + r])
        cb = kn.cross(dvi, b_col)
        for c in range(3):
            acc[JF_I + 3 * c + r] += cb[c]
    # displacement in i (trapezoid)
    vp = acc[V_PREV]
    u_old = kn.qrotate(q_ib, (e_s[0] * vp, e_s[1] * vp, e_s[2] * vp))
    C_old = _dcm_t(q_ib)
    q_ib = kn.qnormalize(kn.qmul(q_ib, kn.quat_from_rotvec(kn.coning_rotvec(dth, dth_p))))
    u_new = kn.qrotate(q_ib, (e_s[0] * v, e_s[1] * v, e_s[2] * v))
    d = _vec(acc, D_I)
    _put(acc, D_I, (d[0] + 0.5 * dt * (u_old[0] + u_new[0]),
                        d[1] + 0.5 * dt * (u_old[1] + u_new[1]),
                        d[2] + 0.5 * dt * (u_old[2] + u_new[2])))
    _put(acc, Q_IB, q_ib)
    C_new = _dcm_t(q_ib)
    for r in range(9):
        acc[B_I + r] += 0.5 * dt * (C_old[r] + C_new[r])
    # navigation frame: velocity from the current attitude estimate, rates, gravity (eq. 19)
    lat, h = acc[LAT], acc[H]
    vn = kn.qrotate(q_bn, (e_s[0] * v, e_s[1] * v, e_s[2] * v))
    wie = kn.omega_ie_n(lat)
    wen = kn.omega_en_n(lat, h, vn)
    win = (wie[0] + wen[0], wie[1] + wen[1], wie[2] + wen[2])
    g = kn.gravity(lat, h)
    gn = (0.0, 0.0, -g)
    wg = kn.cross(win, gn)
    inc = (dt * gn[0] + 0.5 * dt * dt * wg[0], dt * gn[1] + 0.5 * dt * dt * wg[1],
           dt * gn[2] + 0.5 * dt * dt * wg[2])
    q_n0n = _quat(acc, Q_N0N)
    inc0 = kn.qrotate(q_n0n, inc)
    b = _vec(acc, BETA_N0)
    _put(acc, BETA_N0, (b[0] + inc0[0], b[1] + inc0[1], b[2] + inc0[2]))
    q_n0n = kn.qnormalize(kn.qmul(q_n0n, kn.quat_from_rotvec(
        (win[0] * dt, win[1] * dt, win[2] * dt))))
    _put(acc, Q_N0N, q_n0n)
    # position by dead reckoning
    r_m, r_n = kn.radii(lat)
    acc[LAT] = lat + vn[1] * dt / (r_m + h)
    acc[LON] = acc[LON] + vn[0] * dt / ((r_n + h) * math.cos(lat))
    acc[H] = h + vn[2] * dt
    _put(acc, DTH_PREV, dth)
    _put(acc, DV_PREV, dv)
    acc[V_LAG] = acc[V_PREV]
    if acc[N_ROWS] == 0.0:
        acc[V0_COL] = v
    acc[N_ROWS] += 1.0
    acc[V_PREV] = v


@numba.njit(cache=True)
def accumulate(acc, dtheta, dvel, dt, v, q_bn):
    """Advance the accumulator over IMU rows (M, 3), (M, 3), periods ``dt`` (M,) [s] and LDV
    speeds ``v`` (M,) [m/s] at the rows' end times, with the attitude estimate ``q_bn`` (4,)
    (quaternion of ``C_b^n``... see :func:`attitude_bn`) held over the chunk for the
    velocity used in the transport rate and dead reckoning. Modifies ``acc`` in place."""
    q = (q_bn[0], q_bn[1], q_bn[2], q_bn[3])
    for k in range(dtheta.shape[0]):
        _step(acc, (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]),
              (dvel[k, 0], dvel[k, 1], dvel[k, 2]), dt[k], v[k], q)


def observation(acc):
    """What the measurement model needs at the current epoch, from the accumulator.

    Returns
    -------
    dict with
        ``y``      (3,) the computed measurement [m/s] (in i);
        ``beta_n`` (3,) ``beta(t)`` in n(t) [m/s];
        ``D_i``    (3,) displacement in i [m];
        ``wie_n``  (3,) Earth rate in n(t) [rad/s];
        ``V_i``    (3,) ``C_b^i v_m^b(t) - v_m^b(0)`` [m/s]: sensitivity to the LDV scale ``dk``
                   (from the lagged samples of :func:`dk_column`);
        ``B``      (3, 3) ``int C_b^i dtau`` [s]: ``-B`` is the sensitivity to the
                   accelerometer bias ``nabla`` [m/s^2];
        ``J``      (3, 3) sensitivity to the gyro drift ``eps`` [rad/s]:
                   ``int [(C_b^i f^b) x] B dtau - [(C_b^i v^b(t)) x] B(t)``;
        ``q_ib``   (4,) quaternion of ``C_{b(t)}^i``;  ``q_n0n`` (4,) of ``C_{n(t)}^{n(0)}``.
    """
    q_ib = acc[ACC.Q_IB:ACC.Q_IB + 4].copy()
    q_n0n = acc[ACC.Q_N0N:ACC.Q_N0N + 4].copy()
    C_ib = kn.dcm_from_quat(q_ib)
    e_s = acc[ACC.E_S:ACC.E_S + 3]
    u_i = C_ib @ (acc[ACC.V_PREV] * e_s)
    V_i = u_i - acc[ACC.V0] * e_s
    V_col = dk_column(acc, C_ib)
    beta_n = kn.dcm_from_quat(q_n0n).T @ acc[ACC.BETA_N0:ACC.BETA_N0 + 3]
    lat = acc[ACC.LAT]
    B = acc[ACC.B_I:ACC.B_I + 9].reshape(3, 3).copy()
    J = acc[ACC.JF_I:ACC.JF_I + 9].reshape(3, 3) - np.cross(u_i[None, :], B.T).T
    return dict(y=V_i - acc[ACC.ALPHA_F:ACC.ALPHA_F + 3], beta_n=beta_n,
                D_i=acc[ACC.D_I:ACC.D_I + 3].copy(), V_i=V_col, B=B, J=J,
                wie_n=np.array([0.0, kn.OMEGA_IE * np.cos(lat), kn.OMEGA_IE * np.sin(lat)]),
                q_ib=q_ib, q_n0n=q_n0n, e_s=e_s.copy())


@numba.njit(cache=True)
def dk_column(acc, C_ib):
    """The LDV scale factor's column ``C_b^i v^b(t) - v^b(0)`` built from samples whose noise
    is independent of the ones in ``y``: the speed one row before ``t`` and the one of the
    first row after the start (their difference from ``v(t)``, ``v(0)`` is ``a dt``, 0.01 m/s
    at 1 m/s^2 and 100 Hz, times ``dk``: 1e-5 m/s). Why: with the current samples the column
    carries the same noise ``n`` as the innovation, and the gain ``~ V^T e`` then gains
    ``E[n^T n] = sigma_v^2`` at every update: an errors-in-variables bias of ``dk`` of about
    ``sigma_v^2 / v^2`` (900 ppm for 0.3 m/s at 10 m/s), which made the matched filter
    overconfident on paper 001's test 2 (``benchmarks/nees_usque.py``)."""
    e = acc[E_S:E_S + 3]
    return C_ib @ (acc[V_LAG] * e) - acc[V0_COL] * e


def sensitivity(obs, blocks):
    """``S`` (3, n_e): the linear part of ``h`` in the extra states, columns in ``blocks`` order.

    ``dk`` -> ``V_i``; ``nabla`` -> ``-B``; ``eps`` -> ``J`` (see :func:`observation`);
    ``dv0`` -> ``[0, -1, 0]``; ``w`` (the integrated IMU noise, module docstring) -> ``I``.
    """
    cols = {"dk": obs["V_i"][:, None], "nabla": -obs["B"], "eps": obs["J"],
            "dv0": -obs["e_s"][:, None], "w": np.eye(3)}
    if not blocks:
        return np.zeros((3, 0))
    return np.hstack([cols[name] for name in blocks])


@numba.njit(cache=True)
def add_integrated_noise(Q, acc, i_w, arw2_dt, vrw2_dt):
    """The process noise of one update with the integrated-noise state ``w`` (module
    docstring, "What the measurement's error is"): ``Q`` (n, n) with, for the update's
    attitude increment ``d theta = -d psi`` (``E[d psi d psi^T] = arw2_dt I``, already in the
    attitude block of ``Q``) and ``w``'s increment ``d w = [A' x] d psi - int C_b^i n_a``:

        Q_ww += vrw2_dt I + arw2_dt [A' x] [A' x]^T,    Q_{att,w} += arw2_dt [A' x],
        Q_{w,att} = Q_{att,w}^T,

    with ``A' = int C_b^i f^b dtau + v_m^b(0)`` from the accumulator ``acc`` (resolved in
    i), ``i_w`` the index of ``w_x`` (the attitude is at 0-2). Returns a new array.
    """
    Qk = Q.copy()
    a0 = acc[ALPHA_F] + acc[V0] * acc[E_S]
    a1 = acc[ALPHA_F + 1] + acc[V0] * acc[E_S + 1]
    a2 = acc[ALPHA_F + 2] + acc[V0] * acc[E_S + 2]
    Ax = np.array([[0.0, -a2, a1], [a2, 0.0, -a0], [-a1, a0, 0.0]])
    AAt = Ax @ Ax.T
    for r in range(3):
        for c in range(3):
            Qk[i_w + r, i_w + c] += arw2_dt * AAt[r, c] + (vrw2_dt if r == c else 0.0)
            Qk[r, i_w + c] += arw2_dt * Ax[r, c]
            Qk[i_w + c, r] += arw2_dt * Ax[r, c]
    return Qk


def nav_increment(q_n0n_old, q_n0n_new):
    """``C_{n(t_k)}^{n(t_{k-1})}`` as a quaternion: ``q_old^* (x) q_new`` (eq. 9 increment)."""
    from ..core.rotations import quat_conjugate, quat_multiply
    return quat_multiply(quat_conjugate(q_n0n_old), q_n0n_new)


def propagate(q_in, dq_n):
    """Process model (eq. 9): ``C_{n(t_k)}^i = C_{n(t_{k-1})}^i C_{n(t_k)}^{n(t_{k-1})}``.

    Parameters
    ----------
    q_in : (m, 4) array, sigma-point quaternions of ``C_{n(t_{k-1})}^i``.
    dq_n : (4,) array, quaternion of ``C_{n(t_k)}^{n(t_{k-1})}``.
    """
    from ..core.rotations import quat_multiply
    return quat_multiply(q_in, dq_n)


def predict_measurement(q_in, x_e, S, obs):
    """Measurement model ``h`` (module docstring) for each sigma point, vectorized.

    Parameters
    ----------
    q_in : (m, 4) array, sigma-point quaternions of ``C_{n(t)}^i``.
    x_e : (m, n_e) array, the sigma points' extra states (may have 0 columns).
    S : (3, n_e) array, :func:`sensitivity`.
    obs : dict from :func:`observation`.

    Returns
    -------
    (m, 3) array [m/s]: ``C_n^i beta - (C_n^i omega_ie^n) x D^i + S x_e``.
    """
    from ..core.rotations import dcm_from_quat
    C_in = dcm_from_quat(q_in)                               # (m, 3, 3)
    Z = C_in @ obs["beta_n"] - np.cross(C_in @ obs["wie_n"], obs["D_i"])
    return Z + x_e @ S.T


def attitude_bn(q_in, q_ib):
    """Vehicle attitude quaternion of ``C_b^n = (C_n^i)^T C_b^i``: ``q_in^* (x) q_ib``."""
    from ..core.rotations import quat_conjugate, quat_multiply
    return quat_multiply(quat_conjugate(q_in), q_ib)
