"""Exact IMU increments of simple analytic motions, for the core tests (no simulator needed).

A level vehicle with heading ``psi(t)`` and forward speed ``v(t)`` at constant height:
``C_b^n = R_z(-psi)``, ``v_n = v [sin psi, cos psi, 0]``. From the navigation equations

    f_n = dv_n/dt - g_n + (2 omega_ie_n + omega_en_n) x v_n
    omega_ib_b = C_n^b (omega_ie_n + omega_en_n) + [0, 0, -dpsi/dt]

the increments ``dtheta = int omega_ib_b dt`` and ``dvel = int f_b dt`` are integrated together
with latitude and longitude by a high-order ODE solver (rtol 1e-12), so they are exact far below
what the tests check. The Earth model is :mod:`inmotion.core.earth` (the one the code uses).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from inmotion.core import earth
from inmotion.core.rotations import dcm_from_euler

# ODE state layout, by name
LAT, LON, TH, DV = 0, 1, slice(2, 5), slice(5, 8)


def level_drive(t, lat0, lon0, h, psi, dpsi, speed, accel, lever_arm_b=None):
    """Truth and exact increments of a level drive.

    Parameters
    ----------
    t : (N,) s, epochs; row 0 is the start (its increments are over (t0 - dt, t0], filled with
        the first interval's values).
    lat0, lon0 : rad; h : m.
    psi, dpsi : callables t -> heading [rad], heading rate [rad/s].
    speed, accel : callables t -> forward speed [m/s], its derivative [m/s^2].
    lever_arm_b : (3,) m, optional. The trajectory above is then the sensor point's;
        ``lat_imu, lon_imu`` are returned for the IMU at ``-lever_arm_b`` from it.

    Returns
    -------
    dict with t, lat, lon, h, vel_n (N,3), euler (N,3), dtheta (N,3), dvel (N,3),
    and lat_imu, lon_imu, vel_imu_n.
    """
    def rates(tt, y):
        lat = y[LAT]
        r_m, r_n = earth.radii(lat)
        p, v = psi(tt), speed(tt)
        sp, cp = np.sin(p), np.cos(p)
        vel = v * np.array([sp, cp, 0.0])
        acc = accel(tt) * np.array([sp, cp, 0.0]) + v * dpsi(tt) * np.array([cp, -sp, 0.0])
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, h, vel)
        f_n = acc - earth.gravity_n(lat, h) + np.cross(2 * w_ie + w_en, vel)
        C_nb = dcm_from_euler(np.array([0.0, 0.0, p]))
        w_b = C_nb.T @ (w_ie + w_en) + np.array([0.0, 0.0, -dpsi(tt)])
        out = np.empty(8)
        out[LAT] = vel[1] / (r_m + h)
        out[LON] = vel[0] / ((r_n + h) * np.cos(lat))
        out[TH] = w_b
        out[DV] = C_nb.T @ f_n
        return out

    t = np.asarray(t, dtype=float)
    y0 = np.zeros(8)
    y0[LAT], y0[LON] = lat0, lon0
    sol = solve_ivp(rates, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-12,
                    atol=1e-13, max_step=max(t[1] - t[0], 1.0))
    y = sol.y.T
    dtheta = np.diff(y[:, TH], axis=0, prepend=y[:1, TH])
    dvel = np.diff(y[:, DV], axis=0, prepend=y[:1, DV])
    dtheta[0], dvel[0] = dtheta[1], dvel[1]
    p = psi(t)
    v = speed(t)
    vel_n = np.stack([v * np.sin(p), v * np.cos(p), np.zeros_like(p)], -1)
    euler = np.stack([np.zeros_like(p), np.zeros_like(p), p], -1)
    out = dict(t=t, lat=y[:, LAT], lon=y[:, LON], h=np.full(len(t), float(h)), vel_n=vel_n,
               euler=euler, dtheta=dtheta, dvel=dvel)
    l_b = np.zeros(3) if lever_arm_b is None else np.asarray(lever_arm_b, dtype=float)
    C_nb = dcm_from_euler(euler)
    l_n = C_nb @ l_b
    r_m, r_n = earth.radii(out["lat"])
    out["lat_imu"] = out["lat"] - l_n[:, 1] / (r_m + h)
    out["lon_imu"] = out["lon"] - l_n[:, 0] / ((r_n + h) * np.cos(out["lat"]))
    w_nb_n = np.stack([np.zeros_like(p), np.zeros_like(p), -dpsi(t)], -1)
    out["vel_imu_n"] = vel_n - np.cross(w_nb_n, l_n)
    return out
