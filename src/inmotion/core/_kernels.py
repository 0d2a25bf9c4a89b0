"""numba kernels of the strapdown mechanization and of dead reckoning (sequential inner loops).

Everything here is ``@numba.njit(cache=True)`` and works on flat float64 arrays or on tuples of
floats (3-vectors and scalar-first quaternions as tuples, so that no small array is allocated
inside the loops). The public, documented entry points are :mod:`inmotion.core.mechanization`
and :mod:`inmotion.core.deadreckoning`; this module is their engine.

Navigation state vector ``x`` (length :data:`NX`), named slots:

=====  ======================  ====
slot   meaning                 unit
=====  ======================  ====
LAT    geodetic latitude       rad
LON    longitude               rad
H      ellipsoidal height      m
VE-VU  ENU velocity            m/s
Q0-Q3  attitude ``q_nb``       --   (scalar first, rotates b into n)
=====  ======================  ====

Step memory ``mem`` (length :data:`NMEM`): what one step needs from the previous one, by name:
the previous angle and velocity increments (two-sample coning and sculling), the state one epoch
earlier (latitude, height, velocity: linear extrapolation to the interval midpoint), whether
they exist yet, the last mean body rate ``omega_ib_b`` [rad/s] and specific force ``f_b`` [m/s^2]
for filters, and a row counter for output decimation.

The Earth model is the one of :mod:`inmotion.core.earth`, compiled from its source
(``numba.njit(earth.radii)``): one formula, one place.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import njit
from . import earth

# ---------------------------------------------------------------- state layout (by name)
LAT, LON, H, VE, VN, VU, Q0, Q1, Q2, Q3 = range(10)
NX = 10

# ---------------------------------------------------------------- step memory layout
M_DTH = 0          #: previous angle increment, 3 slots [rad]
M_DV = 3           #: previous velocity increment, 3 slots [m/s]
M_HAS_PREV = 6     #: 1.0 once a previous increment exists (coning/sculling usable)
M_LAT_OLD = 7      #: latitude one epoch earlier [rad]
M_H_OLD = 8        #: height one epoch earlier [m]
M_V_OLD = 9        #: ENU velocity one epoch earlier, 3 slots [m/s]
M_HAS_OLD = 12     #: 1.0 once the epoch-earlier state exists (midpoint extrapolation usable)
M_WIB = 13         #: last mean body rate omega_ib_b, 3 slots [rad/s]
M_FB = 16          #: last mean specific force f_b, 3 slots [m/s^2]
M_COUNT = 19       #: rows processed so far (output decimation)
NMEM = 20

OMEGA_IE = earth.OMEGA_IE

# one Earth model: compile the formulas of inmotion.core.earth, do not re-type them
radii = njit(cache=True)(earth.radii)
gravity = njit(cache=True)(earth.gravity)


# ---------------------------------------------------------------- 3-vectors and quaternions
@njit(cache=True)
def cross(a, b):
    """``a x b`` of two 3-tuples."""
    return (a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def skew(v):
    """``[v x]`` (3, 3) array of one 3-vector: the numba twin of
    :func:`inmotion.core.rotations.skew` (``skew(v) @ w = v x w``)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@njit(cache=True)
def qmul(p, q):
    """Hamilton product ``p (x) q`` of scalar-first quaternion 4-tuples."""
    return (p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
            p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
            p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
            p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0])


@njit(cache=True)
def qnormalize(q):
    """Unit quaternion (sign kept)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit(cache=True)
def qrotate(q, v):
    """``q (x) v (x) q*`` = ``C(q) v`` for a unit quaternion 4-tuple and a 3-tuple."""
    u = (q[1], q[2], q[3])
    t = cross(u, v)
    t = (2.0 * t[0], 2.0 * t[1], 2.0 * t[2])
    s = cross(u, t)
    return (v[0] + q[0] * t[0] + s[0], v[1] + q[0] * t[1] + s[1], v[2] + q[0] * t[2] + s[2])


@njit(cache=True)
def qrotate_inv(q, v):
    """``C(q)^T v``: rotation by the conjugate quaternion."""
    return qrotate((q[0], -q[1], -q[2], -q[3]), v)


@njit(cache=True)
def quat_from_rotvec(r):
    """Quaternion of the rotation vector ``r`` [rad] (3-tuple); series below 0.01 rad.

    ``q = [cos(|r|/2), sin(|r|/2) r/|r|]``. Below ``a = |r| = 0.01`` rad (every increment of a
    land vehicle at 100 Hz) the series ``sin(a/2)/a = 1/2 - a^2/48 + a^4/3840`` and
    ``cos(a/2) = 1 - a^2/8 + a^4/384 - a^6/46080`` are used: the first omitted terms,
    ``a^6/645120`` and ``a^8/10321920``, are below 2e-18.
    """
    a2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    if a2 < 1e-4:
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0 - a2 * a2 * a2 / 46080.0
        k = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        k = math.sin(0.5 * a) / a
    return (c, k * r[0], k * r[1], k * r[2])


@njit(cache=True)
def dcm_from_quat_into(q, C):
    """Write ``C(q)`` (= ``C_b^n`` of ``q_nb``) into the (3, 3) array ``C``; ``q`` not normalized.

    The numba twin of :func:`inmotion.core.rotations.dcm_from_quat` (which normalizes first):
    the homogeneous quadratic form of a scalar-first quaternion, exact for a unit ``q``.
    """
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    C[0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    C[0, 1] = 2 * (q1 * q2 - q0 * q3)
    C[0, 2] = 2 * (q1 * q3 + q0 * q2)
    C[1, 0] = 2 * (q1 * q2 + q0 * q3)
    C[1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    C[1, 2] = 2 * (q2 * q3 - q0 * q1)
    C[2, 0] = 2 * (q1 * q3 - q0 * q2)
    C[2, 1] = 2 * (q2 * q3 + q0 * q1)
    C[2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@njit(cache=True)
def dcm_from_quat(q):
    """New (3, 3) array ``C(q)``: :func:`dcm_from_quat_into` into a fresh array."""
    C = np.empty((3, 3))
    dcm_from_quat_into(q, C)
    return C


@njit(cache=True)
def get_q(x):
    return (x[Q0], x[Q1], x[Q2], x[Q3])


@njit(cache=True)
def set_q(x, q):
    x[Q0] = q[0]
    x[Q1] = q[1]
    x[Q2] = q[2]
    x[Q3] = q[3]


# ---------------------------------------------------------------- Earth rates
@njit(cache=True)
def omega_ie_n(lat):
    """Earth rate in n (ENU) [rad/s]."""
    return (0.0, OMEGA_IE * math.cos(lat), OMEGA_IE * math.sin(lat))


@njit(cache=True)
def omega_en_n(lat, h, v):
    """Transport rate in n (ENU) [rad/s] for velocity 3-tuple ``v``."""
    r_m, r_n = radii(lat)
    return (-v[1] / (r_m + h), v[0] / (r_n + h), v[0] * math.tan(lat) / (r_n + h))


# ---------------------------------------------------------------- shared attitude update
@njit(cache=True)
def coning_rotvec(dth, dth_prev):
    """Body rotation vector over the interval, two-sample (previous-interval) coning correction.

    ``phi_b = dth + (1/12) dth_prev x dth`` (Savage 1998 / Yan Gongmin's PSINS "one plus
    previous" form). With no previous increment pass ``dth_prev = dth``: the correction
    vanishes, which is exact for a constant rate.
    """
    c = cross(dth_prev, dth)
    return (dth[0] + c[0] / 12.0, dth[1] + c[1] / 12.0, dth[2] + c[2] / 12.0)


@njit(cache=True)
def attitude_update(q_nb, phi_b, zeta_n):
    """``q_nb(k) = q(-zeta_n) (x) q_nb(k-1) (x) q(phi_b)``, normalized.

    ``phi_b`` [rad] is the body's rotation vector relative to inertial space over the interval
    (paper 002, "equivalent rotation vector" attitude update); ``zeta_n = omega_in_n dt`` [rad]
    the rotation of the navigation frame over the same interval (``C_{n(k-1)}^{n(k)} =
    exp(-[zeta x])``). Shared by the SINS and the dead reckoning.
    """
    q = qmul(quat_from_rotvec((-zeta_n[0], -zeta_n[1], -zeta_n[2])),
             qmul(q_nb, quat_from_rotvec(phi_b)))
    return qnormalize(q)


@njit(cache=True)
def midpoint(x, mem):
    """Latitude, height and ENU velocity extrapolated to the middle of the coming interval.

    ``y(k-1/2) = y(k-1) + (y(k-1) - y(k-2)) / 2`` (linear extrapolation); with no older
    epoch yet, ``y(k-1)``.
    """
    if mem[M_HAS_OLD] > 0.0:
        lat = 1.5 * x[LAT] - 0.5 * mem[M_LAT_OLD]
        h = 1.5 * x[H] - 0.5 * mem[M_H_OLD]
        v = (1.5 * x[VE] - 0.5 * mem[M_V_OLD],
             1.5 * x[VN] - 0.5 * mem[M_V_OLD + 1],
             1.5 * x[VU] - 0.5 * mem[M_V_OLD + 2])
    else:
        lat, h, v = x[LAT], x[H], (x[VE], x[VN], x[VU])
    return lat, h, v


@njit(cache=True)
def remember_old(x, mem):
    """Keep latitude, height and velocity of epoch k-1 for the next midpoint extrapolation."""
    mem[M_LAT_OLD] = x[LAT]
    mem[M_H_OLD] = x[H]
    mem[M_V_OLD] = x[VE]
    mem[M_V_OLD + 1] = x[VN]
    mem[M_V_OLD + 2] = x[VU]
    mem[M_HAS_OLD] = 1.0


@njit(cache=True)
def position_update(x, v_old, v_new, dt):
    """Trapezoidal position update from the ENU velocities at both ends of the interval.

    ``h += (vU_old + vU_new) dt / 2``; ``lat += (vN_old + vN_new) dt / 2 / (R_M + h_mid)``;
    ``lon += (vE_old + vE_new) dt / 2 / ((R_N + h_mid) cos lat_mid)``.
    """
    h_old = x[H]
    x[H] = h_old + 0.5 * (v_old[2] + v_new[2]) * dt
    h_mid = 0.5 * (h_old + x[H])
    lat_old = x[LAT]
    r_m, _ = radii(lat_old)
    x[LAT] = lat_old + 0.5 * (v_old[1] + v_new[1]) * dt / (r_m + h_mid)
    lat_mid = 0.5 * (lat_old + x[LAT])
    _, r_n = radii(lat_mid)
    x[LON] += 0.5 * (v_old[0] + v_new[0]) * dt / ((r_n + h_mid) * math.cos(lat_mid))


@njit(cache=True)
def displacement_update(x, ds_n):
    """Position update from an ENU displacement ``ds_n`` [m] (dead reckoning, paper 002).

    ``h += dS_U``; ``lat += dS_N / (R_M + h_mid)``; ``lon += dS_E / ((R_N + h_mid) cos lat_mid)``.
    """
    h_old = x[H]
    x[H] = h_old + ds_n[2]
    h_mid = 0.5 * (h_old + x[H])
    lat_old = x[LAT]
    r_m, _ = radii(lat_old)
    x[LAT] = lat_old + ds_n[1] / (r_m + h_mid)
    lat_mid = 0.5 * (lat_old + x[LAT])
    _, r_n = radii(lat_mid)
    x[LON] += ds_n[0] / ((r_n + h_mid) * math.cos(lat_mid))


@njit(cache=True)
def store_increments(mem, dth, dv, dt):
    """Previous increments for coning/sculling and the mean rates for filters."""
    for i in range(3):
        mem[M_DTH + i] = dth[i]
        mem[M_DV + i] = dv[i]
        mem[M_WIB + i] = dth[i] / dt
        mem[M_FB + i] = dv[i] / dt
    mem[M_HAS_PREV] = 1.0


# ---------------------------------------------------------------- one SINS step
# inline="always": numba inlines it into its callers (the engine's loop calls it every IMU
# row: no call boundary, no reference counting of x, mem there; issue 13)
@njit(cache=True, inline="always")
def sins_step(x, mem, dth, dv, dt, h_ref, k_h, k_v):
    """Advance the nav state ``x`` over one interval of length ``dt`` [s].

    Parameters
    ----------
    x : (NX,) state at ``t[k-1]``, overwritten with the state at ``t[k]``.
    mem : (NMEM,) step memory, updated.
    dth, dv : 3-tuples, angle [rad] and velocity [m/s] increments in b over the interval.
    h_ref : reference height [m] at ``t[k]`` for barometric damping; NaN: none this step.
    k_h, k_v : damping gains [1/s], [1/s^2] (0: undamped).

    Algorithm (Savage 1998; Yan Gongmin PSINS), increments in, one subsample per interval:

    1. ``phi_b = dth + dth_prev x dth / 12`` (two-sample coning, previous interval);
    2. ``dv_b = dv + dth x dv / 2 + dth x (dth x dv) / 6 + (dth_prev x dv + dv_prev x dth) / 12``
       (rotation to second order and two-sample sculling);
    3. ``zeta = omega_in_n(k-1/2) dt`` with latitude, height and velocity extrapolated to the
       midpoint; ``dv_n = (I - [zeta x]/2 + [zeta x]^2/6) C_b^n(k-1) dv_b
       - zeta x C_b^n(k-1) (dth x dv) / 12``. The second-order terms make the velocity update
       exact to second order in the rotation angles for constant rates (expand
       ``int_0^1 exp(-s [zeta x]) C exp(s [dth x]) f ds``): without them a stationary system
       at 10 Hz sees a spurious vertical acceleration ``g (omega_ie cos L dt)^2 / 4``
       (6e-11 m/s^2, 6 mm of height after an hour of the unstable vertical channel);
    4. ``v(k) = v(k-1) + dv_n + (g_n - (2 omega_ie_n + omega_en_n) x v)(k-1/2) dt``;
    5. position by the trapezoid of ``v(k-1)`` and ``v(k)``;
    6. ``q(k) = q(-zeta) (x) q(k-1) (x) q(phi_b)``;
    7. optional second-order barometric damping:
       ``h -= k_h (h - h_ref) dt``, ``vU -= k_v (h - h_ref) dt``.
    """
    if mem[M_HAS_PREV] > 0.0:
        dth_p = (mem[M_DTH], mem[M_DTH + 1], mem[M_DTH + 2])
        dv_p = (mem[M_DV], mem[M_DV + 1], mem[M_DV + 2])
    else:                       # first step: no previous interval, no correction
        dth_p = dth
        dv_p = dv
    phi_b = coning_rotvec(dth, dth_p)

    rot = cross(dth, dv)                      # dth x dv
    rot2 = cross(dth, rot)                    # dth x (dth x dv)
    s1 = cross(dth_p, dv)
    s2 = cross(dv_p, dth)
    dv_b = (dv[0] + 0.5 * rot[0] + rot2[0] / 6.0 + (s1[0] + s2[0]) / 12.0,
            dv[1] + 0.5 * rot[1] + rot2[1] / 6.0 + (s1[1] + s2[1]) / 12.0,
            dv[2] + 0.5 * rot[2] + rot2[2] / 6.0 + (s1[2] + s2[2]) / 12.0)

    lat_m, h_m, v_m = midpoint(x, mem)
    w_ie = omega_ie_n(lat_m)
    w_en = omega_en_n(lat_m, h_m, v_m)
    zeta = ((w_ie[0] + w_en[0]) * dt, (w_ie[1] + w_en[1]) * dt, (w_ie[2] + w_en[2]) * dt)

    q_old = get_q(x)
    f_n = qrotate(q_old, dv_b)
    zf = cross(zeta, f_n)
    zzf = cross(zeta, zf)
    zr = cross(zeta, qrotate(q_old, rot))
    dv_n = (f_n[0] - 0.5 * zf[0] + zzf[0] / 6.0 - zr[0] / 12.0,
            f_n[1] - 0.5 * zf[1] + zzf[1] / 6.0 - zr[1] / 12.0,
            f_n[2] - 0.5 * zf[2] + zzf[2] / 6.0 - zr[2] / 12.0)

    w_cor = (2.0 * w_ie[0] + w_en[0], 2.0 * w_ie[1] + w_en[1], 2.0 * w_ie[2] + w_en[2])
    cor = cross(w_cor, v_m)
    g = gravity(lat_m, h_m)
    v_old = (x[VE], x[VN], x[VU])
    v_new = (v_old[0] + dv_n[0] - cor[0] * dt,
             v_old[1] + dv_n[1] - cor[1] * dt,
             v_old[2] + dv_n[2] - (cor[2] + g) * dt)

    remember_old(x, mem)
    position_update(x, v_old, v_new, dt)
    x[VE], x[VN], x[VU] = v_new
    set_q(x, attitude_update(q_old, phi_b, zeta))

    if not math.isnan(h_ref):
        dh = x[H] - h_ref
        x[H] -= k_h * dh * dt
        x[VU] -= k_v * dh * dt

    store_increments(mem, dth, dv, dt)


@njit(cache=True)
def sins_run(x, mem, dtheta, dvel, dt, h_ref, k_h, k_v, out_stride, out_rows, out_x):
    """Run :func:`sins_step` over a chunk of M rows.

    ``dtheta``, ``dvel`` (M, 3); ``dt`` (M,) [s]; ``h_ref`` (M,) [m] (NaN: no damping that
    row). Every ``out_stride``-th row (counted over the object's whole life in ``mem``) is
    copied to ``out_x`` and its row index to ``out_rows``; returns the number written.
    """
    n_out = 0
    for k in range(dtheta.shape[0]):
        sins_step(x, mem, (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]),
                  (dvel[k, 0], dvel[k, 1], dvel[k, 2]), dt[k], h_ref[k], k_h, k_v)
        mem[M_COUNT] += 1.0
        if out_stride > 0 and int(mem[M_COUNT]) % out_stride == 0:
            out_x[n_out, :] = x
            out_rows[n_out] = k
            n_out += 1
    return n_out


# ---------------------------------------------------------------- one DR step
@njit(cache=True)
def dr_step(x, mem, dth, ds, v, dt, C_bm, l_b):
    """Advance the dead-reckoning state ``x`` over one interval (paper 002).

    Parameters
    ----------
    x : (NX,) state at ``t[k-1]``, overwritten with the state at ``t[k]``.
    mem : (NMEM,) step memory.
    dth : 3-tuple, gyro angle increment [rad] in b.
    ds : distance [m] the velocity sensor measured over the interval.
    v : the sensor's forward speed [m/s] at ``t[k]``.
    C_bm : (3, 3) ``C_m^b = C_v^b``: the frame m the vehicle moves along (forward y; the vehicle
        frame v of docs/ARCHITECTURE.md, paper 000's radar frame) to body b.
    l_b : (3,) lever arm [m], IMU to sensor, in b.

    Attitude: the SINS update (:func:`attitude_update`, two-sample coning) with ``omega_in``
    from the DR's own position and velocity. The IMU moves along the vehicle's forward axis
    ``u_b = C_m^b [0, 1, 0]`` (docs/ARCHITECTURE.md, "Vehicle frame and mounting"); the sensor
    at ``l_b`` reads the forward component of its own velocity over ground,
    ``s = u + u_b . (omega_eb_b x l_b)``. So the IMU's forward speed and distance are

        u = v - u_b . (omega_eb_b x l_b),     ds_imu = ds - u_b . (dth_eb x l_b),

    with ``dth_eb = dth - C_n^b omega_ie_n dt``; velocity ``v_n = C_b^n(k) u_b u`` (paper 002
    eq. 8, paper 000 eq. 8 with ``V^m = [0, u, 0]``), displacement
    ``dS_n = C_b^n(k-1/2) u_b ds_imu`` with the midpoint attitude (normalized quaternion mean,
    = slerp at 1/2).
    """
    dth_p = (mem[M_DTH], mem[M_DTH + 1], mem[M_DTH + 2]) if mem[M_HAS_PREV] > 0.0 else dth
    phi_b = coning_rotvec(dth, dth_p)
    lat_m, h_m, v_m = midpoint(x, mem)
    w_ie = omega_ie_n(lat_m)
    w_en = omega_en_n(lat_m, h_m, v_m)
    zeta = ((w_ie[0] + w_en[0]) * dt, (w_ie[1] + w_en[1]) * dt, (w_ie[2] + w_en[2]) * dt)

    q_old = get_q(x)
    q_new = attitude_update(q_old, phi_b, zeta)
    if q_old[0] * q_new[0] + q_old[1] * q_new[1] + q_old[2] * q_new[2] + q_old[3] * q_new[3] < 0:
        q_new = (-q_new[0], -q_new[1], -q_new[2], -q_new[3])
    q_mid = qnormalize((q_old[0] + q_new[0], q_old[1] + q_new[1],
                        q_old[2] + q_new[2], q_old[3] + q_new[3]))

    fwd_b = (C_bm[0, 1], C_bm[1, 1], C_bm[2, 1])          # C_m^b [0, 1, 0]
    l_t = (l_b[0], l_b[1], l_b[2])
    w_ie_b = qrotate_inv(q_mid, w_ie)
    dth_eb = (dth[0] - w_ie_b[0] * dt, dth[1] - w_ie_b[1] * dt, dth[2] - w_ie_b[2] * dt)
    lever = cross(dth_eb, l_t)                             # (omega_eb x l) dt
    lever_fwd = fwd_b[0] * lever[0] + fwd_b[1] * lever[1] + fwd_b[2] * lever[2]
    ds_imu = ds - lever_fwd
    u = v - lever_fwd / dt
    ds_n = qrotate(q_mid, (fwd_b[0] * ds_imu, fwd_b[1] * ds_imu, fwd_b[2] * ds_imu))

    remember_old(x, mem)
    displacement_update(x, ds_n)
    x[VE], x[VN], x[VU] = qrotate(q_new, (fwd_b[0] * u, fwd_b[1] * u, fwd_b[2] * u))
    set_q(x, q_new)
    store_increments(mem, dth, (0.0, 0.0, 0.0), dt)


@njit(cache=True)
def dr_run(x, mem, dtheta, ds, v, dt, C_bm, l_b, out_stride, out_rows, out_x):
    """Run :func:`dr_step` over a chunk of M rows; output as in :func:`sins_run`."""
    n_out = 0
    for k in range(dtheta.shape[0]):
        dr_step(x, mem, (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]), ds[k], v[k], dt[k],
                C_bm, l_b)
        mem[M_COUNT] += 1.0
        if out_stride > 0 and int(mem[M_COUNT]) % out_stride == 0:
            out_x[n_out, :] = x
            out_rows[n_out] = k
            n_out += 1
    return n_out


# ---------------------------------------------------------------- input checks (cheap per chunk)
@njit(cache=True)
def time_steps(t, t_prev, dt_out):
    """``dt_out[k] = t[k] - t[k-1]`` with ``t[-1] = t_prev``; returns the first row whose step
    is not a finite positive number, or -1."""
    prev = t_prev
    for k in range(t.shape[0]):
        d = t[k] - prev
        if not (d > 0.0 and d < math.inf):
            return k
        dt_out[k] = d
        prev = t[k]
    return -1


@njit(cache=True)
def first_not_increasing(t):
    """First index ``k`` with ``t[k]`` not finite or not after ``t[k-1]``, or -1."""
    for k in range(t.shape[0]):
        if not math.isfinite(t[k]) or (k > 0 and not t[k] > t[k - 1]):
            return k
    return -1


@njit(cache=True)
def first_nonfinite_row(a):
    """First row of the 2-D array ``a`` holding NaN or inf, or -1."""
    for k in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not math.isfinite(a[k, j]):
                return k
    return -1


def new_memory() -> np.ndarray:
    """A fresh step memory (no previous increments, no older epoch)."""
    return np.zeros(NMEM)
