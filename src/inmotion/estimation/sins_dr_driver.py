"""A SINS and a dead reckoner side by side under one closed-loop error-state Kalman filter.

The one engine of the SINS / dead-reckoning (DR) methods: paper 002's ``sins-dr``
(:mod:`inmotion.navigate.sins_dr`) and paper 000's alignment ``dr-kf``
(:mod:`inmotion.align.dr_kalman`). Both mechanizations run on the same compensated gyro
increments, a Kalman filter on an error-state layout from :mod:`inmotion.estimation.layout`
(with the blocks ``phi, dv, dp, eps, nabla, phi_D, dp_D`` and optionally ``mount`` and ``dk``)
is predicted with the one shared error model (:mod:`inmotion.estimation.error_model`) and
updated with SINS-minus-DR differences (and paper 000's non-holonomic constraint), and the
estimate is fed back into both systems.

Per filter epoch (``step`` IMU rows, :func:`_run_epochs`, one numba loop):

1. the IMU increments, less the accumulated gyro drift and accelerometer bias estimates, drive
   the SINS (:func:`inmotion.core._kernels.sins_step`) and the DR
   (:func:`inmotion.core._kernels.dr_step`, gyro attitude + the velocity sensor's distance;
   with a model whose DR does not see the drift, paper 000's printed F, the DR's rows are
   not compensated, and a simulation study may add ``dr_gyro_offset_rad_s`` to them);
2. ``F`` is built at the SINS state (:func:`error_model._fill_F`) with the mean specific force
   of the epoch, and ``x, P`` are predicted (:func:`kalman._predict_kernel`: second-order
   transition, trapezoid ``Q_d``); the process noise is the model's ``G q G^T`` plus a random
   walk of the DR position, the velocity sensor's white noise integrated (below);
3. every ``meas_every`` epochs the enabled measurement groups are formed and applied one group
   after the other by gated sequential scalar Joseph updates (:func:`sequential_joseph`, the
   allocation-free form of :func:`kalman._update_rows_kernel`):

   ========  ============================================  ==================================
   group     z                                             H (rows of the shared model)
   ========  ============================================  ==================================
   attitude  ``[yaw, pitch, roll]_SINS - [..]_DR``,        ``euler_rows(C_S)`` on ``phi``,
             wrapped to +-pi (paper 002 eq. 44-51)         ``-euler_rows(C_D)`` on ``phi_D``
   velocity  ``v_SINS - v_DR`` (paper 002 eq. 52-55),     ``I`` on ``dv``; ``-[v x]`` on
             resolved in the DR's body frame               ``phi_D``, ``-v`` on ``dk`` (eq. 11),
                                                           times ``C_n^b`` of the DR
   position  ``[lat, lon, h]_SINS - [..]_DR`` (rad, rad,   ``I`` on ``dp``, ``-I`` on ``dp_D``
             m; paper 002 eq. 44, 52)
   height    ``h_SINS - h_baro``                           ``1`` on ``dp_h``
   nhc       ``[v_x, v_z]`` of ``C_n^b v_SINS``: zero for   ``C_n^b`` on ``dv``, ``-C_n^b [v x]``
             a vehicle that neither slips nor jumps        on ``phi``; with ``nhc_mount``
             (paper 000 eq. 32-38)                         ``-[v_b x]`` on ``mount``
                                                           (:func:`error_model.nhc_rows`)
   sensor_   ``v_SINS - C_S [0, v, 0]`` (the sensor's      ``I`` on ``dv``, ``-[v x]`` on
   velocity  speed along the SINS forward axis), in the    ``phi``, ``-[v_s x] C_S`` on
             SINS body frame; no DR (``od-velocity-kf``)   ``mount``, ``-v_s`` on ``dk``
                                                           (``sensor_velocity_rows``)
   ========  ============================================  ==================================

   With a ``mount`` block the velocity rows also carry ``-[v x] C_b^n`` (DR attitude) on it
   (paper 000 eq. 11, :func:`error_model.dr_velocity_rows`). Groups are applied in the order
   attitude, velocity, sensor_velocity, nhc, position, height (``GROUPS`` gives the index
   order of the flag, gate and count arrays, the new groups last so that paper 002's four
   keep their indices). Without the DR blocks (``phi_D``, ``dp_D``) the DR is not run and
   only the nhc, sensor_velocity and height groups can be used.

4. closed loop (``closed_loop``; after every ``feedback_every``-th measurement epoch, default
   each), right after the update: the SINS attitude, velocity and position and the DR
   attitude and position are corrected (:func:`_correct_nav`, the numba twin of
   :meth:`inmotion.core.mechanization.Strapdown.correct`), the drift and bias estimates are
   added to the IMU compensation, and those states are reset to zero. The scale factor ``dk``
   is only estimated (a first-order Markov state; the DR keeps its raw sensor), as are the
   mounting angles (the DR keeps its nominal ``C_bm``). Open loop nothing is fed back; the
   output is always the SINS corrected by the estimate not yet fed back (a plain copy right
   after feedback), with the ``phi`` block of ``P`` for NEES.

DR position random walk: the DR integrates the sensor's speed, whose white noise of 1-sigma
``sigma_v`` per sample (period ``T_s``) walks the DR position with density
``q = sigma_v^2 T_s`` [m^2/s] along the track. The shared model has no such term (paper 000's G
drives only ``dk`` with the radar noise); it is added here, isotropic in E, N, U (a bound on the
along-track term), converted to rad^2/s for latitude and longitude. (``dr-kf`` sets it to 0,
paper 000's model.)

Memory: the log is processed in chunks of whole epochs (the sensor is resampled to the IMU
epochs chunk by chunk), so only the output arrays grow with the log.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..core import _kernels as K
from ..core.bundle import SpeedData
from ..core.deadreckoning import DeadReckoner, speed_on_epochs
from ..core.mechanization import Strapdown
from ..core.solution import NavState
from ..errors import BadInput
from . import error_model as em
from .kalman import _predict_kernel
from .layout import Layout

__all__ = ["GROUPS", "GROUP_SIZES", "SinsDrFilter", "euler_ypr", "dcm_of_q",
           "measurement_rows", "stack_rows", "sequential_joseph"]

#: measurement groups (index order of the ``use``, ``thresholds`` and count arrays); within
#: an epoch they are applied in the order attitude, velocity, nhc, position, height
GROUPS = ("attitude", "velocity", "position", "height", "nhc", "sensor_velocity")
#: rows per group
GROUP_SIZES = (3, 3, 3, 1, 2, 3)
#: IMU rows per chunk handed to the numba loop (rounded to whole filter epochs)
CHUNK_ROWS = 16384
#: sensor samples whose median period sets the gap threshold (5 periods), as dead_reckon's
GAP_SAMPLES = 10001


# ----------------------------------------------------------------------------- small kernels
@numba.njit(cache=True)
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


@numba.njit(cache=True)
def compensated_row(dtheta, dvel, k, dt, bias_g, bias_a):
    """IMU row ``k`` less the accumulated gyro drift and accelerometer bias estimates over its
    interval ``dt`` [s]: ``(dtheta_k - eps dt, dvel_k - nabla dt)`` as two 3-tuples."""
    dth = (dtheta[k, 0] - bias_g[0] * dt, dtheta[k, 1] - bias_g[1] * dt,
           dtheta[k, 2] - bias_g[2] * dt)
    dvl = (dvel[k, 0] - bias_a[0] * dt, dvel[k, 1] - bias_a[1] * dt,
           dvel[k, 2] - bias_a[2] * dt)
    return dth, dvl


@numba.njit(cache=True)
def euler_ypr(C):
    """``[yaw, pitch, roll]`` [rad] of ``C_b^n`` in the DESIGN convention (``yaw =
    atan2(C12, C22)``, ``pitch = asin(C32)``, ``roll = atan2(-C31, C33)``), in the row order
    of the attitude measurement (paper 000 eq. 23, paper 002 eq. 44)."""
    return np.array([math.atan2(C[0, 1], C[1, 1]), math.asin(min(1.0, max(-1.0, C[2, 1]))),
                     math.atan2(-C[2, 0], C[2, 2])])


@numba.njit(cache=True)
def _wrap_pi(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True)
def _correct_nav(x, mem, phi, dv, dp, with_velocity):
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


@numba.njit(cache=True)
def measurement_rows(offs, use, xs, xd, h_baro, r_att, sig_pos_m, r_vel, r_h, n):
    """The four SINS-minus-DR groups of paper 002 (:func:`stack_rows` without the NHC).

    ``use``: (4,) flags of the first four :data:`GROUPS`. Returns ``z, H, r, starts, groups``
    as :func:`stack_rows`.
    """
    use6 = np.zeros(6, dtype=np.bool_)
    for i in range(4):
        use6[i] = use[i]
    return stack_rows(offs, use6, xs, xd, h_baro, r_att, sig_pos_m, r_vel, r_h, 0.0, False,
                      0.0, n)


@numba.njit(cache=True)
def _body_velocity_rows(z, H, r, m, C_bn, dv_n, r_vel, o_dv, o_att, V, o_dk, dk_vec, o_mount,
                        VM):
    """Fill rows ``m .. m+2``: a velocity difference ``dv_n`` (n frame) resolved in body axes.

    ``z = C_n^b dv_n`` with ``H = C_n^b [dv: I, att: -[v x] (V), dk: -dk_vec, mount: -VM]``
    and the noises ``r_vel`` (lateral, forward, vertical). Serves the SINS-minus-DR velocity
    (paper 002 eq. 52-55, paper 000 eq. 11: ``att`` = DR attitude, :func:`error_model.
    dr_velocity_rows`) and the SINS-minus-sensor velocity (``att`` = SINS attitude,
    :func:`error_model.sensor_velocity_rows`). ``o_dk`` / ``o_mount`` < 0: no such block.
    """
    for i in range(3):
        r[m + i] = r_vel[i]
        for j in range(3):
            c = C_bn[i, j]
            z[m + i] += c * dv_n[j]
            H[m + i, o_dv + j] = c
            if o_dk >= 0:
                H[m + i, o_dk] -= c * dk_vec[j]
            for l in range(3):
                H[m + i, o_att + l] -= c * V[j, l]
                if o_mount >= 0:
                    H[m + i, o_mount + l] -= c * VM[j, l]


@numba.njit(cache=True)
def stack_rows(offs, use, xs, xd, h_baro, r_att, sig_pos_m, r_vel, r_h, r_nhc, nhc_mount,
               speed, n):
    """Stack the enabled groups' ``z`` (m,), ``H`` (m, n), ``r`` (m,) and the group starts.

    ``offs``: block offsets (``error_model._offsets`` order ``phi, dv, dp, eps, nabla, phi_D,
    dp_D, mount, dk``); ``use``: (6,) flags of :data:`GROUPS`; ``xs``, ``xd``: SINS and DR
    kernel states; ``h_baro``: barometric height (NaN: none now); ``r_att`` [rad^2],
    ``sig_pos_m`` [m], ``r_vel`` (3,) [m^2/s^2] (lateral, forward, vertical in the DR's body
    frame), ``r_h`` [m^2], ``r_nhc`` [m^2/s^2] (each NHC row); ``nhc_mount``: the NHC rows
    carry the mounting columns (:func:`error_model.nhc_rows` ``with_mount``); ``speed`` [m/s]
    the sensor's speed now (``sensor_velocity``: SINS velocity minus the speed along the
    SINS forward axis, :func:`error_model.sensor_velocity_rows`, resolved in the SINS body
    frame with the noises ``r_vel``; no DR needed). With a ``mount`` block the velocity rows
    carry ``-[v x] C_b^n`` on it (paper 000 eq. 11, the DR's attitude). Groups are stacked in
    the order attitude, velocity, sensor_velocity, nhc, position, height.
    Returns ``z, H, r, starts, groups`` with ``groups[g]`` the index in :data:`GROUPS` of the
    ``g``-th stacked group.
    """
    o_phi, o_dv, o_dp, o_phiD, o_dpD, o_dk = offs[0], offs[1], offs[2], offs[5], offs[6], offs[8]
    o_mount = offs[7]
    z = np.zeros(15)
    H = np.zeros((15, n))
    r = np.zeros(15)
    starts = np.zeros(7, dtype=np.int64)
    groups = np.zeros(6, dtype=np.int64)
    m, g = 0, 0
    if use[0]:                                   # attitude (paper 002 eq. 44-51)
        C_S = dcm_of_q(xs[K.Q0:K.Q3 + 1])
        C_D = dcm_of_q(xd[K.Q0:K.Q3 + 1])
        d = euler_ypr(C_S) - euler_ypr(C_D)
        E_S = em.euler_rows(C_S)
        E_D = em.euler_rows(C_D)
        for i in range(3):
            z[m + i] = _wrap_pi(d[i])
            r[m + i] = r_att
            for j in range(3):
                H[m + i, o_phi + j] = E_S[i, j]
                H[m + i, o_phiD + j] = -E_D[i, j]
        groups[g] = 0
        g += 1
        m += 3
        starts[g] = m
    if use[1]:                                   # velocity (paper 002 eq. 52-55)
        # z_n = v_S - v_D, H_n = [dv: I, phi_D: -[v x], dk: -v]; applied as C_n^b z_n with
        # the DR attitude, whose rows have the independent noises r_vel (lateral, forward,
        # vertical): the sensor's white noise lies along its forward axis only
        v = xd[K.VE:K.VU + 1]
        C_D = dcm_of_q(xd[K.Q0:K.Q3 + 1])
        C_bn = C_D.T
        V = em.skew(v)
        VC = V @ C_D                             # dv_D on the mounting angles (eq. 11)
        _body_velocity_rows(z, H, r, m, C_bn, xs[K.VE:K.VU + 1] - xd[K.VE:K.VU + 1], r_vel,
                            o_dv, o_phiD, V, o_dk, v, o_mount, VC)
        groups[g] = 1
        g += 1
        m += 3
        starts[g] = m
    if use[5]:                                   # SINS minus sensor velocity (od-velocity-kf)
        # z_n = v_S - C_S [0, speed, 0], H_n = [dv: I, phi: -[v x], mount: -[v_s x] C_S,
        # dk: -v_s] (error_model.sensor_velocity_rows), applied as C_n^b z_n (SINS attitude)
        C_S = dcm_of_q(xs[K.Q0:K.Q3 + 1])
        C_bn = C_S.T
        v = xs[K.VE:K.VU + 1].copy()
        v_s = C_S[:, 1] * speed
        V = em.skew(v)
        VsC = em.skew(v_s) @ C_S
        _body_velocity_rows(z, H, r, m, C_bn, v - v_s, r_vel, o_dv, o_phi, V, o_dk, v_s,
                            o_mount, VsC)
        groups[g] = 5
        g += 1
        m += 3
        starts[g] = m
    if use[4]:                                   # NHC (paper 000 eq. 32-38)
        # z = [v_x, v_z] of C_n^b v (SINS); H: C_n^b on dv, -C_n^b [v x] on phi, and with
        # nhc_mount -[v_b x] on the mounting angles (error_model.nhc_rows)
        C_bn = dcm_of_q(xs[K.Q0:K.Q3 + 1]).T
        v = xs[K.VE:K.VU + 1].copy()
        v_b = C_bn @ v
        CV = C_bn @ em.skew(v)
        Vb = em.skew(v_b)
        for i in range(2):
            row = 2 * i                          # body x, then body z
            z[m + i] = v_b[row]
            r[m + i] = r_nhc
            for j in range(3):
                H[m + i, o_dv + j] = C_bn[row, j]
                H[m + i, o_phi + j] = -CV[row, j]
                if nhc_mount and o_mount >= 0:
                    H[m + i, o_mount + j] = -Vb[row, j]
        groups[g] = 4
        g += 1
        m += 2
        starts[g] = m
    if use[2]:                                   # position (paper 002 eq. 44, 52)
        r_m, r_n = K.radii(xs[K.LAT])
        scale = (r_m + xs[K.H], (r_n + xs[K.H]) * math.cos(xs[K.LAT]), 1.0)
        for i in range(3):
            z[m + i] = xs[K.LAT + i] - xd[K.LAT + i]
            r[m + i] = (sig_pos_m / scale[i]) ** 2
            H[m + i, o_dp + i] = 1.0
            H[m + i, o_dpD + i] = -1.0
        groups[g] = 2
        g += 1
        m += 3
        starts[g] = m
    if use[3] and not math.isnan(h_baro):        # barometric height
        z[m] = xs[K.H] - h_baro
        r[m] = r_h
        H[m, o_dp + 2] = 1.0
        groups[g] = 3
        g += 1
        m += 1
        starts[g] = m
    return z[:m], H[:m], r[:m], starts[:g + 1], groups[:g]


@numba.njit(cache=True)
def sequential_joseph(x, P, z, H, r, a, b, threshold, xw, Pw):
    """Gated sequential scalar Joseph updates with the rows ``a:b`` (in place, no allocation).

    The same update as :func:`inmotion.estimation.kalman._update_rows_kernel` (a test checks
    them against each other): for each row ``h`` with noise variance ``r_i``,
    ``s = h P h^T + r_i``, ``k = P h^T / s``, ``x += k (z_i - h x)``,
    ``P <- P - k (P h^T)^T - (P h^T) k^T + s k k^T`` (the Joseph form expanded). The group's
    NIS is accumulated from the sequential innovations, ``sum_i nu_i^2 / s_i``, which for a
    diagonal ``R`` equals the batch ``nu^T S^-1 nu`` (the sequential innovations are the
    batch innovation decorrelated by the Cholesky factor of ``S``), so no matrix is solved.
    The rows are applied to the work copies ``xw``, ``Pw``; if ``threshold > 0`` and the NIS
    exceeds it the group is rejected and ``x``, ``P`` stay as they were. Returns
    ``(accepted, nis)``.
    """
    n = x.shape[0]
    xw[:] = x
    Pw[:, :] = P
    Ph = np.empty(n)
    k = np.empty(n)
    nis = 0.0
    for i in range(a, b):
        s = r[i]
        innov = z[i]
        for p in range(n):
            acc = 0.0
            for q in range(n):
                acc += Pw[p, q] * H[i, q]
            Ph[p] = acc
            s += H[i, p] * acc
            innov -= H[i, p] * xw[p]
        nis += innov * innov / s
        for p in range(n):
            k[p] = Ph[p] / s
            xw[p] += k[p] * innov
        for p in range(n):
            for q in range(n):
                Pw[p, q] += -k[p] * Ph[q] - Ph[p] * k[q] + s * k[p] * k[q]
    if threshold > 0.0 and nis > threshold:
        return False, nis
    x[:] = xw
    for p in range(n):
        for q in range(p, n):
            m = 0.5 * (Pw[p, q] + Pw[q, p])
            P[p, q] = m
            P[q, p] = m
        if P[p, p] < 0.0:
            P[p, p] = 0.0
    return True, nis


@numba.njit(cache=True)
def _dr_position_noise(Qc, o_dpD, lat, h, q_m2_s):
    """``Qc`` plus the DR position random walk ``q_m2_s`` [m^2/s] on ``dp_D`` (rad, rad, m)
    (``Qc`` itself when there is no DR block, ``o_dpD < 0``)."""
    Q = Qc.copy()
    if o_dpD < 0:
        return Q
    r_m, r_n = K.radii(lat)
    Q[o_dpD, o_dpD] += q_m2_s / (r_m + h) ** 2
    Q[o_dpD + 1, o_dpD + 1] += q_m2_s / ((r_n + h) * math.cos(lat)) ** 2
    Q[o_dpD + 2, o_dpD + 2] += q_m2_s
    return Q


@numba.njit(cache=True)
def _feed_back(x, offs, xs, ms, xd, md, bias_g, bias_a, fed_back):
    """Closed loop: correct both systems, move drift and bias into the IMU compensation,
    accumulate what was fed back, zero those states (``dk`` stays)."""
    o_phi, o_dv, o_dp, o_eps, o_nabla, o_phiD, o_dpD = (offs[0], offs[1], offs[2], offs[3],
                                                         offs[4], offs[5], offs[6])
    _correct_nav(xs, ms, x[o_phi:o_phi + 3], x[o_dv:o_dv + 3], x[o_dp:o_dp + 3], True)
    if o_phiD >= 0:
        _correct_nav(xd, md, x[o_phiD:o_phiD + 3], x[o_dv:o_dv + 3], x[o_dpD:o_dpD + 3], False)
    for i in range(3):
        bias_g[i] += x[o_eps + i]
        bias_a[i] += x[o_nabla + i]
    for o in (o_phi, o_dv, o_dp, o_eps, o_nabla, o_phiD, o_dpD):
        if o < 0:
            continue
        for i in range(3):
            fed_back[o + i] += x[o + i]
            x[o + i] = 0.0


@numba.njit(cache=True)
def _corrected_sins(out, xs, x, offs):
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
        _correct_nav(out, np.zeros(K.NMEM), x[o_phi:o_phi + 3], x[o_dv:o_dv + 3],
                     x[o_dp:o_dp + 3], True)


@numba.njit(cache=True)
def _run_epochs(ends, dtheta, dvel, dt, ds, v, h_baro, t,
                xs, ms, xd, md, C_bm, l_b, dr_gyro_offset,
                x, P, offs, Qc, q_dr_m2_s, inv_tau_dk, dr_eps, grav_grad,
                use, r_att, sig_pos_m, r_vel, r_h, r_nhc, nhc_mount, thresholds,
                epoch0, meas_every, out_every, closed_loop, feedback_every,
                bias_g, bias_a, fed_back,
                out_t, out_xs, out_sig, out_states, out_cov_phi, n_out0, used, rejected,
                nis_sum):
    """The filter loop over one chunk of IMU rows (see the module docstring).

    ``ends`` (E,): exclusive end row of each epoch in the chunk (the first starts at row 0);
    ``epoch0``: epochs done before the chunk. Closed loop (``closed_loop``), the estimate is
    fed back after every ``feedback_every``-th measurement epoch. Outputs are written at
    epochs whose global index is a multiple of ``out_every`` from row ``n_out0`` on (the
    SINS corrected by the estimate not yet fed back, :func:`_corrected_sins`, and the
    ``phi`` block of ``P``); returns the next free output row.
    """
    n = x.shape[0]
    a = 0
    n_out = n_out0
    nan = np.nan
    xw = np.empty(n)
    Pw = np.empty((n, n))
    o_phi = offs[0]
    with_dr = offs[5] >= 0
    for e in range(ends.shape[0]):
        b = ends[e]
        sum_dt = 0.0
        f_sum = np.zeros(3)
        for k in range(a, b):
            dth, dvl = compensated_row(dtheta, dvel, k, dt[k], bias_g, bias_a)
            K.sins_step(xs, ms, dth, dvl, dt[k], nan, 0.0, 0.0)
            ms[K.M_COUNT] += 1.0
            if with_dr:
                # the DR's gyros are the SINS's (the same compensated rows), unless the model
                # is the printed one: a DR without drift, so none is compensated
                g = dth if dr_eps else (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2])
                dth_d = (g[0] + dr_gyro_offset[0] * dt[k], g[1] + dr_gyro_offset[1] * dt[k],
                         g[2] + dr_gyro_offset[2] * dt[k])
                K.dr_step(xd, md, dth_d, ds[k], v[k], dt[k], C_bm, l_b)
                md[K.M_COUNT] += 1.0
            sum_dt += dt[k]
            for i in range(3):
                f_sum[i] += dvl[i]
        C_S = dcm_of_q(xs[K.Q0:K.Q3 + 1])
        f_n = C_S @ (f_sum / sum_dt)
        F = np.zeros((n, n))
        em._fill_F(F, offs, xs[K.LAT], xs[K.H], xs[K.VE:K.VU + 1].copy(), C_S, f_n,
                   inv_tau_dk, dr_eps, grav_grad)
        _predict_kernel(x, P, F, _dr_position_noise(Qc, offs[6], xs[K.LAT], xs[K.H],
                                                    q_dr_m2_s), sum_dt)
        epoch = epoch0 + e + 1
        if epoch % meas_every == 0:
            z, H, r, starts, groups = stack_rows(offs, use, xs, xd, h_baro[b - 1], r_att,
                                                 sig_pos_m, r_vel, r_h, r_nhc, nhc_mount,
                                                 v[b - 1], n)
            for g in range(groups.shape[0]):
                gi = groups[g]
                ok, nis = sequential_joseph(x, P, z, H, r, starts[g], starts[g + 1],
                                            thresholds[gi], xw, Pw)
                if ok:
                    used[gi] += 1
                    nis_sum[gi] += nis
                else:
                    rejected[gi] += 1
            if closed_loop and (epoch // meas_every) % feedback_every == 0:
                _feed_back(x, offs, xs, ms, xd, md, bias_g, bias_a, fed_back)
        if epoch % out_every == 0:
            out_t[n_out] = t[b - 1]
            _corrected_sins(out_xs[n_out], xs, x, offs)
            for i in range(n):
                out_sig[n_out, i] = math.sqrt(max(P[i, i], 0.0))
                out_states[n_out, i] = fed_back[i] + x[i]
            for i in range(3):
                for j in range(3):
                    out_cov_phi[n_out, i, j] = P[o_phi + i, o_phi + j]
            n_out += 1
        a = b
    return n_out


def _speed_on_chunk(speed: SpeedData, edges, max_gap: float, sensor: str):
    """:func:`speed_on_epochs` on the sensor samples that cover ``edges[0] .. edges[-1]`` (one
    more on each side, at least two): resampling and validating a chunk costs memory of the
    chunk's size, not the log's. Distance differences inside the window are those of the whole
    log; consecutive windows share their end samples, so every pair of samples is checked, and
    a bad row is reported with its row number in the whole table."""
    ts = speed.t
    if len(ts) < 2:
        raise BadInput(f"need at least 2 samples, got {len(ts)}", file=sensor)
    i0 = max(0, min(int(np.searchsorted(ts, edges[0], side="right")) - 1, len(ts) - 2))
    i1 = min(len(ts), max(int(np.searchsorted(ts, edges[-1], side="left")) + 1, i0 + 1) + 1)
    w = slice(i0, i1)
    window = SpeedData(ts[w], None if speed.v is None else speed.v[w],
                       None if speed.ds is None else speed.ds[w])
    try:
        return speed_on_epochs(window, edges, max_gap=max_gap, what=sensor)
    except BadInput as e:
        raise BadInput(e.what, file=e.file, row=None if e.row is None else e.row + i0,
                       time=e.time) from None


# ----------------------------------------------------------------------------- the driver
class SinsDrFilter:
    """Streaming SINS + DR + closed-loop Kalman filter (see the module docstring).

    Parameters
    ----------
    init : NavState
        Start of both systems (the DR starts where the SINS does).
    layout : Layout
        Must hold ``phi, dv, dp, eps, nabla``; ``phi_D, dp_D`` (the DR), ``dk`` and ``mount``
        optional
        (the mounting angles, paper 000, are only estimated: the DR keeps its nominal
        mounting ``C_bm``).
    model : error_model.ErrorModel
        On ``layout``; gives ``F`` (numba kernel) and ``Qc``.
    P0 : (n, n) initial covariance.
    use : dict group name -> bool, which of :data:`GROUPS` update the filter.
    noise : dict with ``attitude_rad``, ``position_m``, ``velocity_b_m_s`` (3: lateral,
        forward, vertical in the DR's body frame), ``height_m`` (1-sigma of each measurement
        row) and ``dr_position_m2_s`` (DR random walk density); ``nhc_m_s`` (each NHC row)
        when the ``nhc`` group is used.
    gates : dict group name -> chi-square threshold of its NIS (0: never rejected).
    step_rows : IMU rows per filter epoch;  meas_every, out_every : in filter epochs.
    C_bm, lever_arm_b : the velocity sensor's nominal mounting and lever arm (DR).
    nhc_mount : the NHC rows carry the mounting columns (paper 000's eq. 37 as printed: False).
    dr_gyro_offset_rad_s : (3,) rad/s added to the DR's gyro rows only (default 0). A
        simulation-study knob: ``-eps_true`` gives the DR drift-free gyros, the world that
        paper 000's printed F describes (``reproduce 000``, ``paper_world``). With a model
        whose DR does not see the drift (``dr_sees_gyro_drift=False``) the DR's rows are not
        compensated by the drift estimate either.
    closed_loop : feed the estimate back (False: open loop, the output is the SINS corrected
        by the estimate);  feedback_every : measurement epochs per feedback.
    """

    def __init__(self, init: NavState, layout: Layout, model: em.ErrorModel, P0, *, use: dict,
                 noise: dict, gates: dict, step_rows: int, meas_every: int = 1,
                 out_every: int = 1, C_bm=None, lever_arm_b=None, nhc_mount: bool = True,
                 closed_loop: bool = True, feedback_every: int = 1,
                 dr_gyro_offset_rad_s=None):
        for name in ("phi", "dv", "dp", "eps", "nabla"):
            if name not in layout:
                raise ValueError(f"the SINS/DR filter needs block {name!r} in the layout")
        if ("phi_D" in layout) != ("dp_D" in layout):
            raise ValueError("the DR blocks 'phi_D' and 'dp_D' come together")
        if "phi_D" not in layout and any(use.get(g, False) for g in ("attitude", "velocity",
                                                                     "position")):
            raise ValueError("the attitude, velocity and position groups need the DR blocks")
        self.layout = layout
        self.model = model
        self.sins = Strapdown(init)
        self.dr = DeadReckoner(init, C_bm=C_bm, lever_arm_b=lever_arm_b)
        self.init = init
        self.x = layout.zeros()
        self.P = np.array(P0, dtype=float)
        self.offs = tuple(int(o) for o in em._offsets(layout))
        self.use = np.array([bool(use.get(g, False)) for g in GROUPS])
        self.noise = noise
        self.thresholds = np.array([float(gates.get(g, 0.0)) for g in GROUPS])
        self.step = int(step_rows)
        self.meas_every = int(meas_every)
        self.out_every = int(out_every)
        self.nhc_mount = bool(nhc_mount)
        self.closed_loop = bool(closed_loop)
        self.feedback_every = int(feedback_every)
        off = np.zeros(3) if dr_gyro_offset_rad_s is None else np.asarray(
            dr_gyro_offset_rad_s, dtype=float)
        if off.shape != (3,) or not np.all(np.isfinite(off)):
            raise ValueError(f"dr_gyro_offset_rad_s must be 3 finite values, got {off!r}")
        self.dr_gyro_offset = off
        self.bias_g = np.zeros(3)          # accumulated gyro drift compensation [rad/s]
        self.bias_a = np.zeros(3)          # accumulated accelerometer bias compensation [m/s^2]
        self.fed_back = layout.zeros()     # everything fed back so far, per state
        self.used = np.zeros(len(GROUPS), dtype=np.int64)
        self.rejected = np.zeros(len(GROUPS), dtype=np.int64)
        self.nis_sum = np.zeros(len(GROUPS))
        self.epochs = 0
        #: IMU rows outside the sensor's span (the DR holds its position there) and inside
        #: sensor gaps (distance interpolated across), as :func:`dead_reckon` counts them
        self.rows_without_speed = 0
        self.rows_in_speed_gaps = 0

    def output_rows(self, n_rows: int) -> int:
        """Output rows a run over ``n_rows`` IMU rows can write (the initial row, every
        ``out_every``-th epoch, and the last epoch if it is not one of them)."""
        n_epochs = -(-n_rows // self.step)
        return n_epochs // self.out_every + 2

    def run(self, t, dtheta, dvel, speed, h_baro=None, sensor="speed", progress=None):
        """Process rows of a log and return the outputs; successive calls continue the run
        (rows must follow the last row processed; a call whose row count is not a multiple
        of ``step_rows`` ends with a short epoch).

        Parameters
        ----------
        t : (N,) s;  dtheta, dvel : (N, 3) rad, m/s: IMU rows after ``init.t``
        speed : SpeedData, the velocity sensor (resampled to IMU epochs chunk by chunk)
        h_baro : callable ``t -> h`` [m] (NaN: none) or None
        sensor : its name for error messages
        progress : callable(fraction) or None

        Returns
        -------
        dict of arrays: ``t`` (M,), ``x_sins`` (M, 10) kernel states (corrected by the
        estimate not yet fed back), ``sigma`` (M, n), ``states`` (M, n) (fed back plus
        current estimate), ``cov_phi`` (M, 3, 3) the ``phi`` block of ``P`` [rad^2]; row 0 is
        the state before the call.
        """
        n_rows = len(t)
        if n_rows == 0:
            raise ValueError("SinsDrFilter.run needs at least one IMU row")
        n_out = self.output_rows(n_rows)
        lay = self.layout
        out = {"t": np.empty(n_out), "x_sins": np.empty((n_out, K.NX)),
               "sigma": np.empty((n_out, lay.n)), "states": np.empty((n_out, lay.n)),
               "cov_phi": np.empty((n_out, 3, 3))}
        i_out = self._write_now(out, 0)
        chunk = max(1, CHUNK_ROWS // self.step) * self.step
        max_gap = 5.0 * float(np.median(np.diff(speed.t[:GAP_SAMPLES])))
        Qc = np.ascontiguousarray(self.model.Qc())
        nz = self.noise
        for a in range(0, n_rows, chunk):
            b = min(a + chunk, n_rows)
            tc = t[a:b]
            t_prev = self.sins.t if a == 0 else t[a - 1]
            edges = np.concatenate([[t_prev], tc])
            ds, v, uncovered, in_gap = _speed_on_chunk(speed, edges, max_gap, sensor)
            self.rows_without_speed += int(uncovered.sum())
            self.rows_in_speed_gaps += int(in_gap.sum())
            dt = np.diff(edges)
            hb = h_baro(tc) if h_baro is not None else np.full(len(tc), np.nan)
            ends = np.arange(self.step, b - a + self.step, self.step)
            ends[-1] = b - a
            i_out = _run_epochs(
                ends.astype(np.int64), np.ascontiguousarray(dtheta[a:b], dtype=float),
                np.ascontiguousarray(dvel[a:b], dtype=float), dt, ds, v, hb, tc,
                self.sins._x, self.sins._mem, self.dr._x, self.dr._mem, self.dr.C_bm,
                self.dr.l_b, self.dr_gyro_offset, self.x, self.P, self.offs, Qc, float(nz["dr_position_m2_s"]),
                1.0 / self.model.noise.dk_tau, self.model.dr_sees_gyro_drift,
                self.model.gravity_gradient, self.use, float(nz["attitude_rad"]) ** 2,
                float(nz["position_m"]), np.asarray(nz["velocity_b_m_s"], dtype=float) ** 2,
                float(nz["height_m"]) ** 2, float(nz.get("nhc_m_s", 1.0)) ** 2, self.nhc_mount,
                self.thresholds, self.epochs, self.meas_every, self.out_every,
                self.closed_loop, self.feedback_every, self.bias_g, self.bias_a,
                self.fed_back, out["t"], out["x_sins"], out["sigma"], out["states"],
                out["cov_phi"], i_out, self.used, self.rejected, self.nis_sum)
            self.epochs += len(ends)
            for sys_ in (self.sins, self.dr):
                sys_.t = float(tc[-1])
                sys_.rows += len(tc)
            if progress is not None:
                progress(b / n_rows)
        if self.epochs % self.out_every:  # the last epoch is written even off the output grid
            i_out = self._write_now(out, i_out)
        return {k: val[:i_out] for k, val in out.items()}

    def _write_now(self, out, i):
        """Write the current state into output row ``i``; returns ``i + 1``."""
        out["t"][i] = self.sins.t
        _corrected_sins(out["x_sins"][i], self.sins._x, self.x, self.offs)
        out["sigma"][i] = np.sqrt(np.maximum(np.diagonal(self.P), 0.0))
        out["states"][i] = self.fed_back + self.x
        phi = self.layout["phi"]
        out["cov_phi"][i] = self.P[phi, phi]
        return i + 1

    def counts(self) -> dict:
        """Measurement groups used / rejected and their mean NIS per degree of freedom."""
        res = {}
        for i, g in enumerate(GROUPS):
            if self.use[i]:
                dof = self.used[i] * GROUP_SIZES[i]
                res[g] = {"used": int(self.used[i]), "rejected": int(self.rejected[i]),
                          "nis_per_dof": float(self.nis_sum[i] / dof) if dof else None}
        return res
