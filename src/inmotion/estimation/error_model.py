"""The one shared SINS / dead-reckoning error model (continuous ``F``, ``G q G^T``, ``H`` rows).

Every Kalman method of the package composes its model here instead of writing its own ``F``:
the method picks a :class:`~inmotion.estimation.layout.Layout` (which blocks exist) and
:class:`ErrorModel` fills the rows of the blocks present.

State (blocks of :mod:`inmotion.estimation.layout`; all SI)
    ``phi``   SINS misalignment, ENU, with ``C_b^n(computed) = (I - [phi x]) C_b^n(true)``
    ``dv``    SINS velocity error (computed minus true), ENU
    ``dp``    SINS position error ``[dlat, dlon, dh]`` in rad, rad, m (paper 000 eq. 15-21;
              chosen over metres so that rows match the paper and ``Strapdown.correct``)
    ``eps``   gyro drift in b [rad/s];  ``nabla`` accelerometer bias in b [m/s^2]
    ``phi_D``, ``dp_D``  the dead reckoner's misalignment and position error
    ``mount`` velocity-sensor mounting angles ``A = [alpha, beta, gamma]`` about b's x, y, z
    ``dk``    velocity-sensor scale-factor error, ``v_measured = (1 + dk) v``
    ``lever`` velocity-sensor lever-arm error in b (paper 003 hook)
    ``eps_gm`` the Gauss-Markov part of a constant + Gauss-Markov gyro bias [rad/s] in b
              (end of this docstring; issue 15)

SINS error equations (phi-angle model in ENU, derived for the DESIGN convention)::

    phi_dot = -[w_in x] phi + dw_in(dv, dp) - C_b^n eps - C_b^n w_g
    dv_dot  = [f_n x] phi + [v x](2 dw_ie + dw_en) - [(2 w_ie + w_en) x] dv + dg(dh)
              + C_b^n nabla + C_b^n w_a
    dp_dot  = M_pv dv + M_pp dp                                (paper 000 eq. 15-17 form)

These reproduce paper 000's printed SINS rows F(1..9, .) (a test compares them entry by
entry) plus one term the paper drops: the gravity gradient ``dg_U = 2 g / R dh`` (the
vertical channel's instability; kept because the truth has it, and harmless under baro).

Dead reckoning (paper 000 sec. 3): the DR's velocity error is algebraic in the state,
eq. 11, ``dv_D = [v x] phi_D + [v x] C_b^n A + dk v``, where ``A`` is the rotation of the
sensor frame m from b: the vehicle moves along m's forward (y) axis, ``C_m^b = I + [A x]``,
and the DR assumes ``C_m^b = I``. The DR attitude shares the SINS gyros, so

    phi_D_dot = -[w_in x] phi_D + dw_in(dv_D, dp_D) - C_b^n eps - C_b^n w_g

**The printed F of paper 000 has no ``-C_b^n eps`` in the phi_D rows** (F(16..18, 10..12)
are absent) although G gives them the same gyro noise. ``dr_sees_gyro_drift=True`` (the
default) keeps the derived term; ``False`` gives the printed form. A test propagates an
injected gyro drift through the nonlinear SINS and DR and shows the drift does tilt the DR
platform at the rate ``-C_b^n eps``, as derived; the printed form is kept only for comparison.

Process noise is ``Q_c = G diag(q) G^T`` with the *same* gyro noise driving ``phi`` and
``phi_D`` (paper 000's G), so their cross-covariance is built in.

Sensor biases (issue 15): ``eps`` and ``nabla`` are random constants (optionally plus a random
walk, ``gyro_bias_rw``) by default. With a finite correlation time ``gyro_bias_tau`` (and / or
``accel_bias_tau``) each is a first-order Gauss-Markov process, the model of paper 000 eq. 3
applied to the bias (the same one the simulator draws, :func:`inmotion.sim.random_processes.
markov`)::

    eps_dot = -eps / tau_g + w_g,   E[w_g w_g^T] = 2 sigma_g^2 / tau_g I

so ``F`` gets ``-1 / tau`` on the bias diagonal (an entry of :func:`F_pattern`) and ``Q_c``
``2 sigma^2 / tau`` (plus ``gyro_bias_rw^2`` if both are set). The whole bias state is then
the GM process: its prior should be ``sigma^2`` (stationary); a larger prior (a turn-on
constant) decays towards zero mean with time constant ``tau``, which is right only for a
bias whose mean was removed (the phone's "bias-corrected" gyro, or a bias compensated from a
still period). A test checks the filter's propagated bias variance against the nonlinear
simulated GM bias over Monte Carlo runs.

Constant + Gauss-Markov gyro bias (issue 15, block ``eps_gm``): a real gyro's bias is a
turn-on constant plus a slow wander (the comma2k19 phone: a mean of ~107 deg/h in z with
+-50 deg/h around it over a minute). One state per axis holds only one of the two; with
``eps_gm`` in the layout the gyro error is ``eps + eps_gm``, ``eps`` a random constant
(plus ``gyro_bias_rw``) and ``eps_gm`` the zero-mean first-order Gauss-Markov part of paper
000 eq. 3 (the same law as above, moved to its own block)::

    phi_dot   = ... - C_b^n (eps + eps_gm) - C_b^n w_g     (phi_D likewise, with dr_eps)
    eps_dot   = w_rw,                         E[w_rw w_rw^T] = gyro_bias_rw^2 I
    eps_gm_dot = -eps_gm / tau_g + w_gm,     E[w_gm w_gm^T] = 2 sigma_g^2 / tau_g I

so ``F[phi, eps_gm] = -C_b^n`` (as ``F[phi, eps]``), ``F[eps_gm, eps_gm] = -1 / tau_g``, no
``-1 / tau`` on ``eps``, and ``Q_c[eps_gm] = 2 sigma_g^2 / tau_g``, ``Q_c[eps] =
gyro_bias_rw^2``. Its prior is the stationary ``sigma_g^2``. ``eps_gm`` is not fed back
into the gyro compensation (the engine feeds back ``eps``): its estimate stays in the
error state, where ``F`` makes it decay with ``tau_g`` as the process's conditional mean
does, and drives ``phi`` through ``F[phi, eps_gm]``. Tests: the F entries against finite
differences of the nonlinear attitude propagation, the engine's propagated variances
against the exact GM law (``eps_gm``) and a random constant (``eps``), and attitude NEES of
``od-kf`` on simulated constant + GM gyro biases (``tests/test_gyro_bias_two_part.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _aot
from .._jit import intrinsic, njit
from ..core import _kernels as K

__all__ = ["LinPoint", "ProcessNoise", "ErrorModel", "transport_jacobians", "F_pattern",
           "dr_velocity_rows", "euler_rows", "EULER_ROW_NAMES"]

#: order of the attitude-difference measurement rows of paper 000 eq. 23: heading, pitch, roll
EULER_ROW_NAMES = ("yaw", "pitch", "roll")


@dataclass
class LinPoint:
    """Where the model is linearized: the computed navigation state.

    Parameters
    ----------
    lat : rad;  h : m
    vel_n : (3,) m/s ENU
    C_nb : (3, 3) ``C_b^n``
    f_n : (3,) specific force in n [m/s^2] (``C_b^n f_b``), mean over the last step
    omega_nb_b : (3,) body rate w.r.t. n in b [rad/s] (lever-arm rows only)
    """

    lat: float
    h: float
    vel_n: np.ndarray
    C_nb: np.ndarray
    f_n: np.ndarray
    omega_nb_b: np.ndarray | None = None


@dataclass
class ProcessNoise:
    """White-noise densities, SI.

    Parameters
    ----------
    gyro_arw : rad/sqrt(s), angle random walk (white noise on rate), per axis
    accel_vrw : m/s/sqrt(s), velocity random walk (white noise on specific force)
    gyro_bias_rw : rad/s/sqrt(s), random walk of the gyro drift (0: random constant)
    accel_bias_rw : m/s^2/sqrt(s), random walk of the accelerometer bias (0: constant)
    dk_sigma : steady-state 1-sigma of the first-order Markov scale factor ``dk``
    dk_tau : s, its correlation time (paper 000 eq. 3; ``q_k = 2 sigma^2 / tau``);
        ``inf`` makes ``dk`` a random constant
    mount_rw : rad/sqrt(s), random walk of the mounting angles (0: constants, eq. 4-6)
    lever_rw : m/sqrt(s), random walk of the lever arm (0: constant)
    gyro_bias_sigma : rad/s, stationary 1-sigma of the Gauss-Markov gyro bias (module
        docstring); used only with a finite ``gyro_bias_tau``
    gyro_bias_tau : s, its correlation time; ``inf`` (default): no Gauss-Markov term
    accel_bias_sigma : m/s^2, stationary 1-sigma of the Gauss-Markov accelerometer bias
    accel_bias_tau : s, its correlation time; ``inf`` (default): none
    """

    gyro_arw: float = 0.0
    accel_vrw: float = 0.0
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0
    dk_sigma: float = 0.0
    dk_tau: float = np.inf
    mount_rw: float = 0.0
    lever_rw: float = 0.0
    gyro_bias_sigma: float = 0.0
    gyro_bias_tau: float = np.inf
    accel_bias_sigma: float = 0.0
    accel_bias_tau: float = np.inf

    def __post_init__(self):
        for name in ("dk_tau", "gyro_bias_tau", "accel_bias_tau"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"ProcessNoise.{name} must be > 0 (inf: none), got "
                                 f"{getattr(self, name)}")

    @property
    def inv_tau_bias(self) -> tuple[float, float]:
        """``(1 / gyro_bias_tau, 1 / accel_bias_tau)`` [1/s], 0 where there is no
        Gauss-Markov term: the arguments of :func:`_fill_F` and :func:`F_pattern`."""
        return 1.0 / self.gyro_bias_tau, 1.0 / self.accel_bias_tau


#: ``[v x]`` of one 3-vector, numba (:func:`inmotion.core._kernels.skew`); kept under this name
#: for the error-model builders and their callers (``em.skew``).
skew = K.skew


@njit(cache=True)
def _transport_scalars(lat, h, ve, vn):
    """The formulas of :func:`transport_jacobians`, as scalars (no arrays)::

        (wie_N, wie_U, wen_E, wen_N, wen_U, inv_rm, inv_rn, t_rn, sec_rn,
         p02, p12, p20, p22, m10, m12, r_m, r_n)

    ``w_ie = [0, wie_N, wie_U]``; ``w_en = [wen_E, wen_N, wen_U]``;
    ``Wie_p = [[0, 0, 0], [-wie_U, 0, 0], [wie_N, 0, 0]]``;
    ``Wen_v = [[0, -inv_rm, 0], [inv_rn, 0, 0], [t_rn, 0, 0]]``;
    ``Wen_p = [[0, 0, p02], [0, 0, p12], [p20, 0, p22]]``;
    ``Mpv = [[0, inv_rm, 0], [sec_rn, 0, 0], [0, 0, 1]]``;
    ``Mpp = [[0, 0, -p02], [m10, 0, m12], [0, 0, 0]]``; ``r_m, r_n`` the radii at ``lat``.
    """
    r_m, r_n = K.radii(lat)
    rm, rn = r_m + h, r_n + h
    s, c = np.sin(lat), np.cos(lat)
    t, sec = s / c, 1.0 / c
    w = K.OMEGA_IE
    return (w * c, w * s, -vn / rm, ve / rn, ve * t / rn, 1.0 / rm, 1.0 / rn, t / rn, sec / rn,
            vn / rm ** 2, -ve / rn ** 2, ve * sec ** 2 / rn, -ve * t / rn ** 2,
            ve * t * sec / rn, -ve * sec / rn ** 2, r_m, r_n)


@njit(cache=True)
def transport_jacobians(lat, h, vel_n):
    """Rates and their Jacobians for the error equations.

    Returns
    -------
    w_ie, w_en : (3,) Earth and transport rate in n [rad/s]
    Wie_p : (3, 3) ``d w_ie / d[lat, lon, h]``
    Wen_v : (3, 3) ``d w_en / d v_n``
    Wen_p : (3, 3) ``d w_en / d[lat, lon, h]`` (radii held constant: their variation with
        latitude is 1e-3 of the terms kept)
    Mpv : (3, 3) ``d p_dot / d v``;  Mpp : (3, 3) ``d p_dot / d p`` (paper 000 eq. 15-17)

    The arrays of :func:`_transport_scalars` (the one place of the formulas; :func:`_fill_F`
    uses the scalars and allocates nothing).
    """
    (wie_n, wie_u, wen_e, wen_n, wen_u, inv_rm, inv_rn, t_rn, sec_rn,
     p02, p12, p20, p22, m10, m12, _, _) = _transport_scalars(lat, h, vel_n[0], vel_n[1])
    w_ie = np.array([0.0, wie_n, wie_u])
    w_en = np.array([wen_e, wen_n, wen_u])
    Wie_p = np.array([[0.0, 0.0, 0.0], [-wie_u, 0.0, 0.0], [wie_n, 0.0, 0.0]])
    Wen_v = np.array([[0.0, -inv_rm, 0.0], [inv_rn, 0.0, 0.0], [t_rn, 0.0, 0.0]])
    Wen_p = np.array([[0.0, 0.0, p02], [0.0, 0.0, p12], [p20, 0.0, p22]])
    Mpv = np.array([[0.0, inv_rm, 0.0], [sec_rn, 0.0, 0.0], [0.0, 0.0, 1.0]])
    Mpp = np.array([[0.0, 0.0, -p02], [m10, 0.0, m12], [0.0, 0.0, 0.0]])
    return w_ie, w_en, Wie_p, Wen_v, Wen_p, Mpv, Mpp


#: block offsets handed to the kernels, in this order; -1 marks a block the layout lacks
#: (``eps_gm`` last: the constant + Gauss-Markov gyro bias, issue 15)
_KERNEL_BLOCKS = ("phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk", "eps_gm")


def _offsets(layout):
    return tuple(layout[b].start if b in layout else -1 for b in _KERNEL_BLOCKS)


@njit(cache=True)
def _put(M, r, c, B):
    """``M[r:r+3, c:c+3] = B`` (3x3)."""
    for i in range(3):
        for j in range(3):
            M[r + i, c + j] = B[i, j]


@njit(cache=True)
def _dr_velocity_kernel(D, o_phiD, o_mount, o_dk, vel_n, C):
    V = skew(vel_n)
    if o_phiD >= 0:
        _put(D, 0, o_phiD, V)
    if o_mount >= 0:
        _put(D, 0, o_mount, V @ C)
    if o_dk >= 0:
        for i in range(3):
            D[i, o_dk] = vel_n[i]


@intrinsic
def _mad(typingctx, a, b, c):
    """``a * b + c`` with one rounding (``llvm.fma``).

    :func:`_fill_F` writes its 3x3 products ``[v x] M`` as scalars; each such entry is a sum
    of two products ``a_k b_k`` (``k`` the inner index), evaluated as
    ``_mad(a_hi, b_hi, a_lo * b_lo)``: the lower product rounded, the higher one fused, the
    rounding of the BLAS products of the former array form of :func:`_fill_F`, so that F did
    not change by a bit when it became scalar code (checked on 36,000 random states over six
    layouts; on CPUs without FMA, LLVM calls libm's ``fma``: slower, same values)."""
    from llvmlite import ir as llvm_ir
    from numba.core import types
    f8 = types.float64
    sig = f8(f8, f8, f8)

    def codegen(context, builder, signature, args):
        dbl = llvm_ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [dbl],
                                              llvm_ir.FunctionType(dbl, [dbl, dbl, dbl]))
        return builder.call(fn, args)

    return sig, codegen


# inline="always": inlined into the engine's loop (every filter epoch; issue 13)
@njit(cache=True, inline="always")
def _fill_F(F, offs, lat, h, vel_n, C, f_n, inv_tau_dk, dr_eps, grav_grad, inv_tau_gyro=0.0,
            inv_tau_accel=0.0):
    """The F of the module docstring on the blocks whose offsets ``offs`` are >= 0.

    Allocation-free (scalar code). It *assigns* the entries of F's structural pattern
    (:func:`F_pattern`: which entries depends only on ``offs``, ``inv_tau_dk != 0``,
    ``inv_tau_gyro != 0``, ``inv_tau_accel != 0``, ``dr_eps`` and ``F``'s shape, never on the
    navigation state) and leaves every other entry alone, so ``F`` must be zero outside the
    pattern: zero it once and refill it each epoch with no clearing. ``inv_tau_gyro``,
    ``inv_tau_accel`` [1/s]: the Gauss-Markov biases' ``1 / tau`` (0: none; module docstring).
    """
    o_phi, o_dv, o_dp, o_eps, o_nabla, o_phiD, o_dpD, o_mount, o_dk, o_gm = offs
    ve, vn, vu = vel_n[0], vel_n[1], vel_n[2]
    (wie_n, wie_u, wen_e, wen_n, wen_u, inv_rm, inv_rn, t_rn, sec_rn,
     p02, p12, p20, p22, m10, m12, r_m, r_n) = _transport_scalars(lat, h, ve, vn)
    # w_in = w_ie + w_en; u = 2 w_ie + w_en; Wie_p + Wen_p (Pj) and 2 Wie_p + Wen_p (Y)
    wi0, wi1, wi2 = wen_e, wie_n + wen_n, wie_u + wen_u
    u0, u1, u2 = wen_e, 2.0 * wie_n + wen_n, 2.0 * wie_u + wen_u
    pj20 = wie_n + p20
    y10, y20 = 2.0 * -wie_u, 2.0 * wie_n + p20
    # SINS attitude: -[w_in x] phi + Wen_v dv + (Wie_p + Wen_p) dp
    r, c = o_phi, o_phi
    F[r, c + 1] = wi2
    F[r, c + 2] = -wi1
    F[r + 1, c] = -wi2
    F[r + 1, c + 2] = wi0
    F[r + 2, c] = wi1
    F[r + 2, c + 1] = -wi0
    F[r, o_dv + 1] = -inv_rm
    F[r + 1, o_dv] = inv_rn
    F[r + 2, o_dv] = t_rn
    c = o_dp
    F[r, c + 2] = p02
    F[r + 1, c] = -wie_u
    F[r + 1, c + 2] = p12
    F[r + 2, c] = pj20
    F[r + 2, c + 2] = p22
    # SINS velocity: [f x] phi + ([v x] Wen_v - [u x]) dv + [v x] Y dp
    r, c = o_dv, o_phi
    F[r, c + 1] = -f_n[2]
    F[r, c + 2] = f_n[1]
    F[r + 1, c] = f_n[2]
    F[r + 1, c + 2] = -f_n[0]
    F[r + 2, c] = -f_n[1]
    F[r + 2, c + 1] = f_n[0]
    c = o_dv
    F[r, c] = _mad(vn, t_rn, -vu * inv_rn)
    F[r, c + 1] = u2
    F[r, c + 2] = -u1
    F[r + 1, c] = -ve * t_rn - u2
    F[r + 1, c + 1] = vu * -inv_rm
    F[r + 1, c + 2] = u0
    F[r + 2, c] = ve * inv_rn + u1
    F[r + 2, c + 1] = -vn * -inv_rm - u0
    c = o_dp
    F[r, c] = _mad(vn, y20, -vu * y10)
    F[r, c + 2] = _mad(vn, p22, -vu * p12)
    F[r + 1, c] = -ve * y20
    F[r + 1, c + 2] = _mad(-ve, p22, vu * p02)
    F[r + 2, c] = ve * y10
    f22 = _mad(ve, p12, -vn * p02)
    if grav_grad:
        f22 += 2.0 * K.gravity(lat, h) / (np.sqrt(r_m * r_n) + h)
    F[r + 2, c + 2] = f22
    # position: Mpv dv + Mpp dp
    r = o_dp
    F[r, o_dv + 1] = inv_rm
    F[r + 1, o_dv] = sec_rn
    F[r + 2, o_dv + 2] = 1.0
    F[r, o_dp + 2] = -p02
    F[r + 1, o_dp] = m10
    F[r + 1, o_dp + 2] = m12
    if o_eps >= 0:
        for i in range(3):
            for j in range(3):
                F[o_phi + i, o_eps + j] = -C[i, j]
    if o_nabla >= 0:
        for i in range(3):
            for j in range(3):
                F[o_dv + i, o_nabla + j] = C[i, j]
    # dead reckoning: dv_D = D x (D: [v x] on phi_D, [v x] C on mount, v on dk) enters
    # through the transport rate, Wen_v D, and the position rate, Mpv D
    if o_phiD >= 0:
        r, q, c = o_phiD, o_dpD, o_phiD
        F[r, c] = -inv_rm * vu
        F[r, c + 1] = wi2
        F[r, c + 2] = inv_rm * ve - wi1
        F[r + 1, c] = -wi2
        F[r + 1, c + 1] = inv_rn * -vu
        F[r + 1, c + 2] = inv_rn * vn + wi0
        F[r + 2, c] = wi1
        F[r + 2, c + 1] = t_rn * -vu - wi0
        F[r + 2, c + 2] = t_rn * vn
        F[q, c] = inv_rm * vu
        F[q, c + 2] = inv_rm * -ve
        F[q + 1, c + 1] = sec_rn * -vu
        F[q + 1, c + 2] = sec_rn * vn
        F[q + 2, c] = -vn
        F[q + 2, c + 1] = ve
        c = o_dpD
        F[r, c + 2] = p02
        F[r + 1, c] = -wie_u
        F[r + 1, c + 2] = p12
        F[r + 2, c] = pj20
        F[r + 2, c + 2] = p22
        F[q, c + 2] = -p02
        F[q + 1, c] = m10
        F[q + 1, c + 2] = m12
        if o_mount >= 0:
            c = o_mount
            for j in range(3):
                vc0 = _mad(vn, C[2, j], -vu * C[1, j])
                vc1 = _mad(-ve, C[2, j], vu * C[0, j])
                vc2 = _mad(ve, C[1, j], -vn * C[0, j])
                F[r, c + j] = -inv_rm * vc1
                F[r + 1, c + j] = inv_rn * vc0
                F[r + 2, c + j] = t_rn * vc0
                F[q, c + j] = inv_rm * vc1
                F[q + 1, c + j] = sec_rn * vc0
                F[q + 2, c + j] = vc2
        if o_dk >= 0:
            c = o_dk
            F[r, c] = -inv_rm * vn
            F[r + 1, c] = inv_rn * ve
            F[r + 2, c] = t_rn * ve
            F[q, c] = inv_rm * vn
            F[q + 1, c] = sec_rn * ve
            F[q + 2, c] = vu
        if o_eps >= 0 and dr_eps:
            for i in range(3):
                for j in range(3):
                    F[o_phiD + i, o_eps + j] = -C[i, j]
    if o_dk >= 0 and inv_tau_dk != 0.0:
        F[o_dk, o_dk] = -inv_tau_dk
    if o_eps >= 0 and inv_tau_gyro != 0.0 and o_gm < 0:   # Gauss-Markov gyro bias
        for i in range(3):
            F[o_eps + i, o_eps + i] = -inv_tau_gyro
    if o_gm >= 0:     # constant + Gauss-Markov gyro bias: the GM part (module docstring)
        for i in range(3):
            for j in range(3):
                F[o_phi + i, o_gm + j] = -C[i, j]
                if o_phiD >= 0 and dr_eps:
                    F[o_phiD + i, o_gm + j] = -C[i, j]
            if inv_tau_gyro != 0.0:
                F[o_gm + i, o_gm + i] = -inv_tau_gyro
    if o_nabla >= 0 and inv_tau_accel != 0.0:       # Gauss-Markov accelerometer bias
        for i in range(3):
            F[o_nabla + i, o_nabla + i] = -inv_tau_accel


def F_pattern(n, offs, inv_tau_dk=0.0, dr_eps=True, inv_tau_gyro=0.0, inv_tau_accel=0.0):
    """(n, n) bool: the entries :func:`_fill_F` writes (F's structural nonzeros).

    The same for every navigation state of a run; a filter engine zeroes its ``F`` once and
    lets :func:`_fill_F` overwrite these entries each epoch, and
    :func:`inmotion.estimation.predict.make_workspace` takes it as F's sparsity pattern.
    ``offs`` as for :func:`_fill_F` (``_offsets(layout)``); ``inv_tau_gyro``,
    ``inv_tau_accel`` nonzero add the Gauss-Markov bias diagonals
    (:attr:`ProcessNoise.inv_tau_bias`).
    """
    F = np.full((n, n), np.nan)
    _aot.call("fill_F", _fill_F, F, tuple(int(o) for o in offs), 0.7, 100.0, np.array([3.0, -4.0, 0.5]),
            np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]]),
            np.array([0.1, -0.2, 9.8]), float(inv_tau_dk), bool(dr_eps), True,
            float(inv_tau_gyro), float(inv_tau_accel))
    return ~np.isnan(F)


def dr_velocity_rows(layout, pt: LinPoint):
    """(3, n) matrix ``D`` with ``dv_D = D x``: paper 000 eq. 11-14.

    ``dv_D = [v x] phi_D + [v x] C_b^n A + dk v`` (DR velocity computed minus true).
    Blocks missing from ``layout`` contribute nothing.
    """
    D = np.zeros((3, layout.n))
    offs = _offsets(layout)
    _dr_velocity_kernel(D, offs[5], offs[7], offs[8], np.asarray(pt.vel_n, dtype=float),
                        np.ascontiguousarray(pt.C_nb, dtype=float))
    return D


class ErrorModel:
    """Continuous error model ``x_dot = F x + G w`` on a layout (see the module docstring).

    Parameters
    ----------
    layout : Layout, must contain ``phi``, ``dv``, ``dp``; the other blocks are optional
        (``phi_D`` needs ``dp_D``)
    noise : ProcessNoise
    dr_sees_gyro_drift : bool, keep ``-C_b^n eps`` in the DR attitude rows (derived, default)
        or drop it as paper 000's printed F does
    gravity_gradient : bool, keep ``dg_U = 2 g / R dh`` in the up-velocity row

    ``F`` is filled by one numba kernel (:func:`_fill_F`, the equations of the module
    docstring written once); ``Qc`` does not depend on the navigation state (``C C^T = I``)
    and is built once.
    """

    def __init__(self, layout, noise: ProcessNoise, *, dr_sees_gyro_drift=True,
                 gravity_gradient=True):
        for name in ("phi", "dv", "dp"):
            if name not in layout:
                raise ValueError(f"the error model needs block {name!r} in the layout")
        if ("phi_D" in layout) != ("dp_D" in layout):
            raise ValueError("the DR blocks 'phi_D' and 'dp_D' come together")
        if "eps_gm" in layout and not ("eps" in layout and np.isfinite(noise.gyro_bias_tau)):
            raise ValueError("block 'eps_gm' (the Gauss-Markov part of a constant + "
                             "Gauss-Markov gyro bias) needs 'eps' in the layout and a finite "
                             "ProcessNoise.gyro_bias_tau")
        self.layout = layout
        self.noise = noise
        self.dr_sees_gyro_drift = dr_sees_gyro_drift
        self.gravity_gradient = gravity_gradient
        self._offs = _offsets(layout)
        self._Qc = self._build_Qc()

    # -- F -----------------------------------------------------------------------------
    def F(self, pt: LinPoint) -> np.ndarray:
        """Continuous system matrix at ``pt`` [1/s, in the units of the states]."""
        n = self.layout.n
        F = np.zeros((n, n))
        itg, ita = self.noise.inv_tau_bias
        _fill_F(F, self._offs, float(pt.lat), float(pt.h), np.asarray(pt.vel_n, dtype=float),
                np.ascontiguousarray(pt.C_nb, dtype=float), np.asarray(pt.f_n, dtype=float),
                1.0 / self.noise.dk_tau, self.dr_sees_gyro_drift, self.gravity_gradient,
                itg, ita)
        return F

    def F_pattern(self) -> np.ndarray:
        """:func:`F_pattern` of this model (its layout, ``dk``, bias and DR settings)."""
        return F_pattern(self.layout.n, self._offs, 1.0 / self.noise.dk_tau,
                         self.dr_sees_gyro_drift, *self.noise.inv_tau_bias)

    # -- Q -----------------------------------------------------------------------------
    def Qc(self, pt: LinPoint | None = None) -> np.ndarray:
        """``G diag(q) G^T`` [state^2 / s] (paper 000's G, plus bias random walks).

        The gyro and accelerometer noises enter as ``C_b^n w`` with the same density on
        every axis, so ``C diag(q) C^T = q I`` whatever the attitude: ``pt`` is not needed.
        """
        return self._Qc

    def _build_Qc(self):
        lay, q = self.layout, self.noise
        Q = np.zeros((lay.n, lay.n))
        Qg = (q.gyro_arw ** 2) * np.eye(3)
        att = [lay["phi"]] + ([lay["phi_D"]] if "phi_D" in lay else [])
        for a in att:                          # one gyro noise drives both platforms
            for b in att:
                Q[a, b] = Qg
        Q[lay["dv"], lay["dv"]] = (q.accel_vrw ** 2) * np.eye(3)
        gm_g = 2.0 * q.gyro_bias_sigma ** 2 / q.gyro_bias_tau     # 0 with tau = inf
        gm_a = 2.0 * q.accel_bias_sigma ** 2 / q.accel_bias_tau
        if "eps_gm" in lay:            # constant + Gauss-Markov: the GM noise drives eps_gm
            Q[lay["eps_gm"], lay["eps_gm"]] = gm_g * np.eye(3)
            gm_g = 0.0
        for name, var in (("eps", q.gyro_bias_rw ** 2 + gm_g),
                          ("nabla", q.accel_bias_rw ** 2 + gm_a),
                          ("mount", q.mount_rw ** 2), ("lever", q.lever_rw ** 2)):
            if name in lay:
                sl = lay[name]
                Q[sl, sl] = var * np.eye(sl.stop - sl.start)
        if "dk" in lay and np.isfinite(q.dk_tau):
            Q[lay["dk"], lay["dk"]] = 2.0 * q.dk_sigma ** 2 / q.dk_tau
        return Q


# -- measurement rows ---------------------------------------------------------------------

@njit(cache=True)
def euler_rows(C_nb):
    """(3, 3) ``d[yaw, pitch, roll] / d phi`` for ``C_computed = (I - [phi x]) C_true``.

    Paper 000 eq. 25-27 with ``T = C_b^n`` (DESIGN Euler convention ``pitch = asin(T32)``,
    ``roll = atan2(-T31, T33)``, ``yaw = atan2(T12, T22)``)::

        d yaw   = -(T12 T32 phi_E + T32 T22 phi_N) / (T12^2 + T22^2) + phi_U
        d pitch = (-T22 phi_E + T12 phi_N) / sqrt(1 - T32^2)
        d roll  = ((T21 T33 - T23 T31) phi_E + (T13 T31 - T11 T33) phi_N) / (T31^2 + T33^2)

    The rows of the DR attitude are the same function of the DR's ``R = C_bD^n`` with the
    opposite sign (the measurement is SINS minus DR).
    """
    T = C_nb
    h2 = T[0, 1] ** 2 + T[1, 1] ** 2
    cp = np.sqrt(max(1.0 - T[2, 1] ** 2, 1e-12))     # cos(pitch), kept off zero
    r2 = T[2, 0] ** 2 + T[2, 2] ** 2
    return np.array([
        [-T[0, 1] * T[2, 1] / h2, -T[2, 1] * T[1, 1] / h2, 1.0],
        [-T[1, 1] / cp, T[0, 1] / cp, 0.0],
        [(T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0]) / r2,
         (T[0, 2] * T[2, 0] - T[0, 0] * T[2, 2]) / r2, 0.0]])
