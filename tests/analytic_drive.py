"""Exact IMU increments of simple analytic motions, for the core tests (no simulator needed).

A vehicle with heading ``psi(t)``, pitch ``theta(t)`` (no roll) and forward speed ``v(t)``:
``C_b^n = R_z(-psi) R_x(theta)``, ``v_n = v [cos theta sin psi, cos theta cos psi, sin theta]``,
``omega_nb_b = [dtheta/dt, -dpsi/dt sin theta, -dpsi/dt cos theta]``. From the navigation
equations

    f_n = dv_n/dt - g_n + (2 omega_ie_n + omega_en_n) x v_n
    omega_ib_b = C_n^b (omega_ie_n + omega_en_n) + omega_nb_b

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
LAT, LON, HGT, TH, DV = 0, 1, 2, slice(3, 6), slice(6, 9)
NY = 9


def _zero(t):
    return 0.0 * np.asarray(t, dtype=float)


def drive_increments(t, lat0, lon0, h, psi, dpsi, speed, accel, pitch=_zero, dpitch=_zero):
    """Truth and exact increments of a drive (level unless ``pitch`` is given).

    Parameters
    ----------
    t : (N,) s, epochs; row 0 is the start (its increments are over (t0 - dt, t0], filled with
        the first interval's values).
    lat0, lon0 : rad; h : m, height at the start.
    psi, dpsi : callables t -> heading [rad], heading rate [rad/s].
    speed, accel : callables t -> forward speed [m/s], its derivative [m/s^2].
    pitch, dpitch : callables t -> pitch [rad], pitch rate [rad/s] (default level).

    Returns
    -------
    dict with t, lat, lon, h, vel_n (N,3), euler (N,3), dtheta (N,3), dvel (N,3), and
    omega_eb_b (N,3) [rad/s], the body rate over the Earth at each epoch (for what a sensor at a
    lever arm reads: ``speed + [omega_eb_b x l_b]_y``).
    """
    def rates(tt, y):
        lat, hh = y[LAT], y[HGT]
        r_m, r_n = earth.radii(lat)
        p, v, th = psi(tt), speed(tt), pitch(tt)
        dp, dth = dpsi(tt), dpitch(tt)
        sp, cp, st, ct = np.sin(p), np.cos(p), np.sin(th), np.cos(th)
        u = np.array([ct * sp, ct * cp, st])                    # forward axis in n
        du = np.array([-st * dth * sp + ct * cp * dp, -st * dth * cp - ct * sp * dp, ct * dth])
        vel = v * u
        acc = accel(tt) * u + v * du
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, hh, vel)
        f_n = acc - earth.gravity_n(lat, hh) + np.cross(2 * w_ie + w_en, vel)
        C_nb = dcm_from_euler(np.array([th, 0.0, p]))
        w_b = C_nb.T @ (w_ie + w_en) + np.array([dth, -dp * st, -dp * ct])
        out = np.empty(NY)
        out[LAT] = vel[1] / (r_m + hh)
        out[LON] = vel[0] / ((r_n + hh) * np.cos(lat))
        out[HGT] = vel[2]
        out[TH] = w_b
        out[DV] = C_nb.T @ f_n
        return out

    t = np.asarray(t, dtype=float)
    y0 = np.zeros(NY)
    y0[LAT], y0[LON], y0[HGT] = lat0, lon0, h
    sol = solve_ivp(rates, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-12,
                    atol=1e-13, max_step=max(t[1] - t[0], 1.0))
    y = sol.y.T
    dtheta = np.diff(y[:, TH], axis=0, prepend=y[:1, TH])
    dvel = np.diff(y[:, DV], axis=0, prepend=y[:1, DV])
    dtheta[0], dvel[0] = dtheta[1], dvel[1]
    p = psi(t) + 0.0 * t
    v = speed(t) + 0.0 * t
    th = pitch(t) + 0.0 * t
    vel_n = v[:, None] * np.stack([np.cos(th) * np.sin(p), np.cos(th) * np.cos(p), np.sin(th)], -1)
    euler = np.stack([th, np.zeros_like(p), p], -1)
    out = dict(t=t, lat=y[:, LAT], lon=y[:, LON], h=y[:, HGT], vel_n=vel_n,
               euler=euler, dtheta=dtheta, dvel=dvel)
    C_nb = dcm_from_euler(euler)
    w_en = earth.omega_en_n(out["lat"], out["h"], vel_n)
    w_nb_b = np.stack([dpitch(t) + 0.0 * t, -(dpsi(t) + 0.0 * t) * np.sin(th),
                       -(dpsi(t) + 0.0 * t) * np.cos(th)], -1)
    out["omega_eb_b"] = np.einsum("nji,nj->ni", C_nb, w_en) + w_nb_b
    return out


def stop_and_go_hills(t, lat0=np.radians(34.0), lon0=np.radians(108.0), h0=400.0):
    """A drive with turns, climbs and stops: speed ``14 (1 - cos(2 pi t / 600))`` m/s (a stop
    every 10 min, 14 m/s mean: 50.4 km in an hour), heading swinging by up to 100 deg, pitch
    +-3 deg with a 400 s period (+-300 m of height over a cycle at cruise)."""
    w = 2 * np.pi / 600
    a1, w1, a2, w2 = 1.2, 2 * np.pi / 900, 0.6, 2 * np.pi / 170
    p0, wp = np.radians(3.0), 2 * np.pi / 400
    return drive_increments(
        t, lat0, lon0, h0,
        psi=lambda t: 0.5 + a1 * np.sin(w1 * t) + a2 * np.sin(w2 * t),
        dpsi=lambda t: a1 * w1 * np.cos(w1 * t) + a2 * w2 * np.cos(w2 * t),
        speed=lambda t: 14 * (1 - np.cos(w * t)), accel=lambda t: 14 * w * np.sin(w * t),
        pitch=lambda t: p0 * np.sin(wp * t), dpitch=lambda t: p0 * wp * np.cos(wp * t))
