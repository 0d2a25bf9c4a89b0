"""Small analytic drives for the coarse-alignment tests, independent of ``inmotion.sim``.

The truth is given as functions of time (attitude, ENU velocity and acceleration, position);
the IMU increments are the exact integrals of the body rate and the specific force

    omega_ib^b = C_n^b (omega_ie^n + omega_en^n) + omega_nb^b,
    f^b = C_n^b (a^n + (2 omega_ie^n + omega_en^n) x v^n - g^n),

over each interval ``(t[k-1], t[k]]`` by 3-point Gauss-Legendre quadrature (exact to ~1e-15
for these smooth motions), ``omega_nb^b = vee(C^T dC/dt)`` with a 4th-order central difference.
"""
from __future__ import annotations

import numpy as np

from inmotion.core import earth, rotations
from inmotion.core.bundle import Bundle, ImuData, SpeedData, Truth

_GL_X = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_GL_W = np.array([5.0, 8.0, 5.0]) / 9.0


def _rates(tt, euler_fn, vel_fn, acc_fn, lat_fn, h):
    C = rotations.dcm_from_euler(euler_fn(tt))
    e = 1e-4
    dC = (-rotations.dcm_from_euler(euler_fn(tt + 2 * e)) + 8 * rotations.dcm_from_euler(euler_fn(tt + e))
          - 8 * rotations.dcm_from_euler(euler_fn(tt - e)) + rotations.dcm_from_euler(euler_fn(tt - 2 * e))) / (12 * e)
    w_nb = rotations.vee(np.swapaxes(C, -1, -2) @ dC)
    lat = lat_fn(tt)
    v = vel_fn(tt)
    w_ie = earth.omega_ie_n(lat)
    w_en = earth.omega_en_n(lat, h, v)
    CT = np.swapaxes(C, -1, -2)
    w_ib = np.einsum("...ij,...j->...i", CT, w_ie + w_en) + w_nb
    f_n = acc_fn(tt) + np.cross(2 * w_ie + w_en, v) - earth.gravity_n(lat, h)
    f_b = np.einsum("...ij,...j->...i", CT, f_n)
    return w_ib, f_b


def make_bundle(duration, rate_hz, euler_fn, vel_fn, acc_fn, lat_fn, lon_fn, h, name="analytic"):
    """Bundle with exact IMU increments, a radar of exact forward speed, and the truth."""
    n = int(round(duration * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    dt = 1.0 / rate_hz
    dth = np.zeros((n, 3))
    dv = np.zeros((n, 3))
    for x, w in zip(_GL_X, _GL_W):
        tt = t - dt / 2 + x * dt / 2
        w_ib, f_b = _rates(tt, euler_fn, vel_fn, acc_fn, lat_fn, h)
        dth += w * dt / 2 * w_ib
        dv += w * dt / 2 * f_b
    euler = euler_fn(t)
    vel = vel_fn(t)
    C = rotations.dcm_from_euler(euler)
    v_fwd = np.einsum("...ij,...j->...i", np.swapaxes(C, -1, -2), vel)[:, 1]
    truth = Truth(t, lat_fn(t), lon_fn(t), np.full(n, h), vel, euler)
    meta = {"name": name, "lat_deg": float(np.degrees(lat_fn(0.0))),
            "lon_deg": float(np.degrees(lon_fn(0.0))), "h_m": h}
    return Bundle(ImuData(t, dth, dv), meta, radar=SpeedData(t, v=v_fwd), truth=truth)


def straight_drive(speed=20.0, heading_deg=30.0, lat_deg=45.6778, lon_deg=126.6778, h=100.0,
                   duration=120.0, rate_hz=100.0, pitch_deg=0.0, roll_deg=0.0):
    """Constant speed and heading (a rhumb line), constant attitude."""
    psi = np.radians(heading_deg)
    v_n = speed * np.array([np.sin(psi), np.cos(psi), 0.0])
    lat0, lon0 = np.radians(lat_deg), np.radians(lon_deg)
    r_m, r_n = earth.radii(lat0)
    e0 = np.radians([pitch_deg, roll_deg, heading_deg])

    def lat_fn(t):
        return lat0 + v_n[1] * np.asarray(t) / (r_m + h)

    def lon_fn(t):
        return lon0 + v_n[0] * np.asarray(t) / ((r_n + h) * np.cos(lat0))

    return make_bundle(duration, rate_hz,
                       lambda t: np.broadcast_to(e0, np.shape(t) + (3,)).copy(),
                       lambda t: np.broadcast_to(v_n, np.shape(t) + (3,)).copy(),
                       lambda t: np.zeros(np.shape(t) + (3,)), lat_fn, lon_fn, h, "straight")


def wobbling_base(heading_deg=30.0, lat_deg=45.6778, lon_deg=126.6778, h=100.0,
                  duration=120.0, rate_hz=100.0, amp_deg=(0.3, 0.3, 0.2),
                  freq_hz=(1.3, 0.7, 0.4), lin_amp_m=(0.002, 0.002, 0.003),
                  lin_freq_hz=(2.1, 1.7, 3.0)):
    """Parked vehicle on a wobbling base: sinusoidal attitude sway about a fixed attitude and a
    few millimetres of linear vibration (engine, people getting in), no travel."""
    e0 = np.radians([0.0, 0.0, heading_deg])
    A = np.radians(amp_deg)
    w = 2 * np.pi * np.asarray(freq_hz)
    B = np.asarray(lin_amp_m)
    wl = 2 * np.pi * np.asarray(lin_freq_hz)
    lat0, lon0 = np.radians(lat_deg), np.radians(lon_deg)

    def euler_fn(t):
        t = np.asarray(t)[..., None]
        return e0 + A * np.sin(w * t + 0.3)

    def vel_fn(t):
        t = np.asarray(t)[..., None]
        return B * wl * np.cos(wl * t)

    def acc_fn(t):
        t = np.asarray(t)[..., None]
        return -B * wl ** 2 * np.sin(wl * t)

    return make_bundle(duration, rate_hz, euler_fn, vel_fn, acc_fn,
                       lambda t: np.full(np.shape(t), lat0), lambda t: np.full(np.shape(t), lon0),
                       h, "wobble")
