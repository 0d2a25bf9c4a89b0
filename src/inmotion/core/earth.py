"""WGS-84 Earth model: radii of curvature, normal gravity, Earth and transport rates.

All inputs SI (latitude in rad, height in m, velocity ENU in m/s). The scalar functions
(:func:`radii`, :func:`gravity`) use only arithmetic and ``numpy`` ufuncs, so they work
elementwise on arrays and compile unchanged under ``numba.njit`` (see
``inmotion.core._kernels``): one formula, one source.

Gravity is the normal gravity of the ellipsoid (Somigliana) with the second-order height
correction; the navigation frame gravity vector is ``g_n = [0, 0, -g]`` (the deflection and the
small northward component of normal gravity above the ellipsoid are neglected in simulation and
mechanization alike, so they cannot cause a mismatch).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

A = 6378137.0                      #: semi-major axis [m]
F = 1.0 / 298.257223563            #: flattening
E2 = F * (2.0 - F)                 #: first eccentricity squared
B = A * (1.0 - F)                  #: semi-minor axis [m]
OMEGA_IE = 7.2921151467e-5         #: Earth rotation rate [rad/s]
GM = 3.986004418e14                #: gravitational constant [m^3/s^2]
GE = 9.7803253359                  #: normal gravity at the equator [m/s^2]
GP = 9.8321849378                  #: normal gravity at the poles [m/s^2]
K_SOM = (B * GP - A * GE) / (A * GE)   #: Somigliana constant
M_GRAV = OMEGA_IE ** 2 * A ** 2 * B / GM
G0 = 9.80665                       #: standard gravity, for units such as ug and g [m/s^2]

__all__ = ["A", "F", "E2", "OMEGA_IE", "G0", "radii", "gravity", "gravity_n",
           "omega_ie_n", "omega_en_n", "position_rate", "lla_to_ecef", "ecef_to_lla",
           "enu_from_ecef_matrix", "local_ne_offsets"]


def radii(lat: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Meridian and prime-vertical radii of curvature ``(R_M, R_N)`` [m] at latitude [rad]."""
    s2 = np.sin(lat) ** 2
    w = 1.0 - E2 * s2
    r_n = A / np.sqrt(w)
    r_m = r_n * (1.0 - E2) / w
    return r_m, r_n


def gravity(lat: ArrayLike, h: ArrayLike) -> np.ndarray:
    """Normal gravity magnitude [m/s^2] at latitude [rad] and ellipsoidal height [m].

    Somigliana's formula with the height series
    ``g(h) = g0 (1 - 2 (1 + f + m - 2 f sin^2 L) h / a + 3 h^2 / a^2)``.
    """
    s2 = np.sin(lat) ** 2
    g0 = GE * (1.0 + K_SOM * s2) / np.sqrt(1.0 - E2 * s2)
    return g0 * (1.0 - 2.0 * (1.0 + F + M_GRAV - 2.0 * F * s2) * h / A + 3.0 * h * h / (A * A))


def gravity_n(lat: ArrayLike, h: ArrayLike) -> np.ndarray:
    """Gravity vector in ENU ``[0, 0, -g]`` (..., 3)."""
    g = np.asarray(gravity(lat, h), dtype=float)
    z = np.zeros_like(g)
    return np.stack([z, z, -g], axis=-1)


def omega_ie_n(lat: ArrayLike) -> np.ndarray:
    """Earth rate in n (ENU): ``[0, w cos L, w sin L]`` [rad/s] (..., 3)."""
    lat = np.asarray(lat, dtype=float)
    return np.stack([np.zeros_like(lat), OMEGA_IE * np.cos(lat), OMEGA_IE * np.sin(lat)], -1)


def omega_en_n(lat: ArrayLike, h: ArrayLike, vel_n: ArrayLike) -> np.ndarray:
    """Transport rate ``[-vN/(R_M+h), vE/(R_N+h), vE tan L/(R_N+h)]`` [rad/s] (..., 3)."""
    vel_n = np.asarray(vel_n, dtype=float)
    r_m, r_n = radii(lat)
    ve, vn = vel_n[..., 0], vel_n[..., 1]
    return np.stack([-vn / (r_m + h), ve / (r_n + h), ve * np.tan(lat) / (r_n + h)], -1)


def position_rate(lat: ArrayLike, h: ArrayLike, vel_n: ArrayLike) -> np.ndarray:
    """``[dlat/dt, dlon/dt, dh/dt]`` [rad/s, rad/s, m/s] from the ENU velocity."""
    vel_n = np.asarray(vel_n, dtype=float)
    r_m, r_n = radii(lat)
    return np.stack([vel_n[..., 1] / (r_m + h),
                     vel_n[..., 0] / ((r_n + h) * np.cos(lat)),
                     vel_n[..., 2]], -1)


def lla_to_ecef(lat: ArrayLike, lon: ArrayLike, h: ArrayLike) -> np.ndarray:
    """ECEF position [m] (..., 3) of geodetic latitude, longitude [rad] and height [m]."""
    _, r_n = radii(lat)
    cl = np.cos(lat)
    return np.stack([(r_n + h) * cl * np.cos(lon), (r_n + h) * cl * np.sin(lon),
                     (r_n * (1.0 - E2) + h) * np.sin(lat)], -1)


def ecef_to_lla(r_e: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geodetic ``(lat, lon, h)`` [rad, rad, m] of ECEF positions (..., 3); Bowring + 3 iterations."""
    r_e = np.asarray(r_e, dtype=float)
    x, y, z = r_e[..., 0], r_e[..., 1], r_e[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - E2))
    for _ in range(5):
        _, r_n = radii(lat)
        h = p / np.cos(lat) - r_n
        lat = np.arctan2(z, p * (1.0 - E2 * r_n / (r_n + h)))
    _, r_n = radii(lat)
    h = p / np.cos(lat) - r_n
    return lat, lon, h


def enu_from_ecef_matrix(lat: ArrayLike, lon: ArrayLike) -> np.ndarray:
    """``C_e^n``: the matrix taking ECEF vectors to ENU at (lat, lon) [rad]; (..., 3, 3)."""
    lat = np.asarray(lat, dtype=float)
    lon = np.asarray(lon, dtype=float)
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(sl)
    return np.stack([np.stack([-so, co, z], -1),
                     np.stack([-sl * co, -sl * so, cl], -1),
                     np.stack([cl * co, cl * so, sl], -1)], -2)


def local_ne_offsets(lat: ArrayLike, lon: ArrayLike, lat0: float, lon0: float,
                     h: ArrayLike = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """North and East offsets [m] of (lat, lon) from (lat0, lon0) with the local radii.

    Accurate to well below a metre over tens of kilometres; used for position errors.
    """
    r_m, r_n = radii(lat0)
    d_north = (np.asarray(lat) - lat0) * (r_m + h)
    d_east = (np.asarray(lon) - lon0) * (r_n + h) * np.cos(lat0)
    return d_north, d_east
