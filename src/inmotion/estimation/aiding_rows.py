"""Measurement rows of the velocity-sensor sub-filters of paper 003 (eq. 14-24, 29-31).

State layouts (SI), the SINS part first so that the federated fusion works on a leading block:

``SUB_LAYOUT`` (21 states, eq. 20): ``phi, dv, dp, eps, nabla`` (the 15 SINS error states of
:mod:`inmotion.estimation.error_model`), then the sensor's ``dk`` (scale-factor error,
``v_measured = (1 + dk) v``), ``mount`` = ``[alpha, gamma]`` (the two mounting angles about
the body x and z axes that act on the velocity, eq. 19; the roll-like angle about y does not)
and ``lever`` (lever-arm error, computed minus true, in b).

``NHC_LAYOUT`` (15 states, eq. 27): the SINS part alone.

Sensor model (ARCHITECTURE "Vehicle frame and mounting"): the sensor reads the vehicle's
forward speed at its lever arm ``l``; the vehicle frame is ``C_v^b = (I + [A x]) C_v^b0`` with
``C_v^b0`` the nominal mounting (meta) and ``A`` the residual mounting the filter estimates
(the ``mount`` state holds ``A``, so it is "true minus nominal"). The vehicle constraint
holds at the IMU (the vehicle's reference point moves along ``C_v^b [0, 1, 0]``), so a sensor
at lever arm ``l`` reads the forward speed plus the *forward part* of ``omega_nb^b x l`` only
(the simulator's and the dead reckoner's model; issue 15: the former ``u = w_b - omega x l``,
the whole vector, put the lateral part of ``omega x l`` into the lateral rows, 4 cm over a
0.5 s interval at 3 deg/s for the odometer 1.5 m behind the IMU, and the residual test saw
chi-square values of 200 at every turn). With ``f = C_v^b0 [0, 1, 0]``, ``w_b = f v_m`` the
measured forward velocity in b, the IMU velocity the sensor implies is
``u = w_b - f f^T (omega_nb^b x l)``.

Velocity form (eq. 23-24), n frame, ``z = v_SINS - C_b^n(SINS) u``::

    z = dv - [v_s x] phi - w_n dk - C [w_b x] A + C f f^T [omega_nb^b x] dl   (v_s = C u)

(eq. 22's ``C_b^n M_v dK_alpha`` is the ``dk``/``mount`` part; its sign follows from the
mounting convention above, derived here and checked against numerical derivatives).

Displacement-increment form (the paper's ref. 38), b frame at the interval's end: over the
measurement interval ``T``, the SINS displacement ``Delta P = sum v_SINS dt`` against the
sensor's ``Delta D = sum_j C_b^n(t_j) (w_j - f f^T [dtheta_nb,j x] l)``, ``z = C_n^b
(Delta P - Delta D)``::

    z = T C_n^b dv - [Delta D_b x] C_n^b phi - Delta W_b dk - [Delta W_b x] A
        + f f^T [Delta theta_nb x] dl

with ``Delta W`` the distance part of ``Delta D`` and ``Delta theta_nb`` the body rotation
over the interval. Two approximations, both documented choices: ``int dv dt = T dv(t_k)``
(error ``T^2 |d dv/dt| / 2``, 1.5 mm for T = 1 s at the 3e-3 m/s^2 a 1 arcmin tilt gives),
and the body's rotation within the interval is neglected in the ``mount``/``lever`` rows
(a 2.5 deg turn over 0.5 s changes those small terms by 0.1 %). Resolving in b puts the
sensor's own noise on the forward row only; the lateral and vertical rows carry the vehicle
constraint, as ref. 38 intends.

NHC (eq. 29-31), in the vehicle frame: ``z = [C_v^b0^T C_n^b v_SINS]_{x, z}``, rows
``C_vn dv - C_vn [v x] phi`` (``C_vn = C_v^b0^T C_n^b``; eq. 31 with the IMU taken as the
vehicle when ``C_v^b0 = I``).
"""
from __future__ import annotations

import numpy as np

from .._jit import njit
from .error_model import skew
from .layout import Block, Layout, BLOCKS

__all__ = ["SUB_LAYOUT", "NHC_LAYOUT", "MOUNT_XZ", "velocity_rows", "displacement_rows",
           "nhc_vehicle_rows", "sub_offsets"]

#: the two mounting angles that act on the velocity (eq. 19): about b's x and z
MOUNT_XZ = Block("mount", ("x", "z"), (BLOCKS["mount"].units[0],) * 2)
#: paper 003 eq. 20: the 21 states of one velocity-sensor sub-filter
SUB_LAYOUT = Layout(["phi", "dv", "dp", "eps", "nabla", "dk", MOUNT_XZ, "lever"])
#: paper 003 eq. 27: the 15 states of the vehicle-constraint filter (and the fused part)
NHC_LAYOUT = Layout(["phi", "dv", "dp", "eps", "nabla"])


def sub_offsets(layout=SUB_LAYOUT):
    """``(phi, dv, dk, mount, lever)`` offsets of a sub-filter layout (-1: block absent)."""
    return tuple(layout[b].start if b in layout else -1
                 for b in ("phi", "dv", "dk", "mount", "lever"))


@njit(cache=True)
def _velocity_rows(H, offs, C_nb, w_b, u_b, omega_nb_b, fwd):
    o_phi, o_dv, o_dk, o_mount, o_lever = offs
    v_s = C_nb @ u_b
    w_n = C_nb @ w_b
    Vs = skew(v_s)
    Mw = C_nb @ skew(w_b)
    Lw = C_nb @ (np.outer(fwd, fwd) @ skew(omega_nb_b))   # the forward part of omega x l
    for i in range(3):
        H[i, o_dv + i] = 1.0
        for j in range(3):
            H[i, o_phi + j] = -Vs[i, j]
            if o_lever >= 0:
                H[i, o_lever + j] = Lw[i, j]
        if o_dk >= 0:
            H[i, o_dk] = -w_n[i]
        if o_mount >= 0:
            H[i, o_mount] = -Mw[i, 0]
            H[i, o_mount + 1] = -Mw[i, 2]


@njit(cache=True)
def _displacement_rows(H, offs, C_bn, T, dD_b, dW_b, dth_nb, fwd):
    o_phi, o_dv, o_dk, o_mount, o_lever = offs
    A = -skew(dD_b) @ C_bn
    W = skew(dW_b)
    L = np.outer(fwd, fwd) @ skew(dth_nb)          # the forward part of dtheta x l
    for i in range(3):
        for j in range(3):
            H[i, o_dv + j] = T * C_bn[i, j]
            H[i, o_phi + j] = A[i, j]
            if o_lever >= 0:
                H[i, o_lever + j] = L[i, j]
        if o_dk >= 0:
            H[i, o_dk] = -dW_b[i]
        if o_mount >= 0:
            H[i, o_mount] = -W[i, 0]
            H[i, o_mount + 1] = -W[i, 2]


def velocity_rows(layout, C_nb, speed_m_s, C_vb0, lever_b, omega_nb_b):
    """(3, n) rows of the velocity form (module docstring), and the implied velocity ``v_s``.

    Parameters
    ----------
    C_nb : (3, 3) SINS attitude;  speed_m_s : measured forward speed [m/s]
    C_vb0 : (3, 3) nominal ``C_v^b``;  lever_b : (3,) nominal lever arm [m]
    omega_nb_b : (3,) body rate relative to n [rad/s]
    """
    fwd = np.ascontiguousarray(np.asarray(C_vb0, dtype=float)[:, 1])
    w_b = fwd * speed_m_s
    u_b = w_b - fwd * (fwd @ np.cross(omega_nb_b, lever_b))
    H = np.zeros((3, layout.n))
    _velocity_rows(H, sub_offsets(layout), np.ascontiguousarray(C_nb, dtype=float), w_b, u_b,
                   np.asarray(omega_nb_b, dtype=float), fwd)
    return H, C_nb @ u_b


def displacement_rows(layout, C_nb, T, dD_n, dW_n, dth_nb, C_vb0=None):
    """(3, n) rows of the displacement-increment form (module docstring).

    Parameters
    ----------
    C_nb : (3, 3) SINS attitude at the interval's end;  T : interval [s]
    dD_n, dW_n : (3,) the sensor's displacement and its distance part in n [m]
    dth_nb : (3,) body rotation relative to n over the interval [rad]
    C_vb0 : (3, 3) nominal mounting ``C_v^b0`` (identity by default): its forward axis
    """
    C_bn = np.ascontiguousarray(np.asarray(C_nb, dtype=float).T)
    fwd = np.ascontiguousarray((np.eye(3) if C_vb0 is None else np.asarray(C_vb0, float))[:, 1])
    H = np.zeros((3, layout.n))
    _displacement_rows(H, sub_offsets(layout), C_bn, float(T), C_bn @ dD_n, C_bn @ dW_n,
                       np.asarray(dth_nb, dtype=float), fwd)
    return H


def nhc_vehicle_rows(layout, C_nb, vel_n, C_vb0):
    """(2, n) NHC rows in the vehicle frame (module docstring): the rows of the one NHC
    measurement, :class:`inmotion.estimation.measurements.Nhc` with ``C_v^b0``."""
    from ..core.rotations import quat_from_dcm
    from .measurements import Nhc

    xs = np.zeros(10)
    xs[3:6] = vel_n
    xs[6:10] = quat_from_dcm(np.asarray(C_nb, dtype=float))
    _, H, _ = Nhc(1.0, mount_terms=False, vehicle_mounting=C_vb0).rows(
        (xs, xs, np.zeros(10)), None, layout)
    return H
