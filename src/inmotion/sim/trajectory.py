"""The truth: position, velocity, attitude and exact IMU increments of a simulated drive.

Given the motion of :mod:`inmotion.sim.profile` (the vehicle frame's Euler angles ``e(t)`` and
velocity ``v_v(t)`` as smooth functions with analytic derivatives) and the IMU's mounting in the
vehicle ``C_v^b = exp([A x])`` (constant; :func:`inmotion.core.rotations.mounting_dcm`,
docs/ARCHITECTURE.md "Vehicle frame and mounting"), everything else follows from the navigation
equations, so that an error-free mechanization reproduces the truth:

- vehicle attitude ``C_v^n = R_z(-psi) R_x(theta) R_y(gamma)`` (DESIGN convention); the IMU's
  ``C_b^n = C_v^n C_b^v`` (``C_b^v = (C_v^b)^T``), and the truth attitude is the IMU's;
- IMU-frame motion (the IMU is the vehicle's reference point, so they share the velocity):
  ``v_b = C_v^b v_v``, ``dv_b/dt = C_v^b dv_v/dt``, ``omega_nb_b = C_v^b omega_nv_v``;
- velocity ``v_n = C_b^n v_b = C_v^n v_v``;
- position by integrating ``[dL, dlambda, dh]/dt = [vN/(R_M+h), vE/((R_N+h) cos L), vU]``
  (radii from :mod:`inmotion.core.earth`): per IMU interval by Gauss-Legendre quadrature of the
  rates, with ``L`` and ``h`` inside the interval from cubic Hermite interpolation and ``L``
  iterated to a fixed point (three Picard sweeps, each shrinking the error by ~1e-5);
- vehicle rate relative to n from the Euler rates (differentiate ``C_v^n``):
  ``omega_nv_v = [cg th' + sg cth psi', g' - sth psi', sg th' - cg cth psi']``;
- ``omega_ib_b = omega_nb_b + C_n^b (omega_ie_n + omega_en_n)``;
- ``f_b = omega_nb_b x v_b + dv_b/dt + C_n^b ((2 omega_ie_n + omega_en_n) x v_n - g_n)``,
  which is ``C_n^b (dv_n/dt + (2 omega_ie_n + omega_en_n) x v_n - g_n)`` since
  ``dv_n/dt = C_b^n (omega_nb_b x v_b + dv_b/dt)``;
- increments ``dtheta_k = int omega_ib_b dt``, ``dvel_k = int f_b dt`` over ``(t_{k-1}, t_k]``
  with ``n`` Gauss-Legendre nodes (exact for polynomials of degree ``2n - 1``; the motion is
  C3 or smoother and slow against 100 Hz, so 3 nodes are exact to round-off; fast engine
  vibration takes 6, see :attr:`inmotion.sim.scenario.Scenario.nodes`).

``dvel`` is the integral of the specific force resolved in the *instantaneous* body frame, what an
accelerometer triad integrates; turning it into n-frame velocity (rotation and sculling
compensation) is the mechanization's job.

Row ``k`` of the IMU covers ``(t_{k-1}, t_k]``; row 0 covers ``(-dt, 0]`` (the motion is
extended backwards, see :mod:`inmotion.sim.profile`). Truth rows are at the IMU times.

The work is done in chunks of rows, so memory stays at the output arrays.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import earth, rotations

__all__ = ["Trajectory", "generate", "omega_nb_b_from_euler", "SensorGeometry"]

CHUNK_ROWS = 8192


@dataclass
class SensorGeometry:
    """Where a velocity sensor sits: ``C_mb`` (= ``C_b^m`` = ``C_v^m C_b^v``, takes b to the
    sensor frame m: the vehicle mounting and the sensor's beam misalignment together) and
    ``lever_arm_b`` [m] from the IMU, in b; ``distance``: its speed is integrated per row (for
    distance outputs) instead of sampled at the rows' ends."""

    C_mb: np.ndarray
    lever_arm_b: np.ndarray
    distance: bool = False


@dataclass
class Trajectory:
    """Truth at the IMU times and exact, error-free IMU increments (all SI).

    ``sensor_speed[name]`` (N,) is the forward (m-frame y) component of the velocity over ground
    of the point where sensor ``name`` sits, at ``t`` (sensors with ``distance=False``);
    ``sensor_distance[name]`` (N,) its integral over each row's interval ``(t_{k-1}, t_k]`` [m]
    (sensors with ``distance=True``).
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    vel_n: np.ndarray
    euler: np.ndarray
    dtheta: np.ndarray
    dvel: np.ndarray
    sensor_speed: dict = field(default_factory=dict)
    sensor_distance: dict = field(default_factory=dict)

    @property
    def distance_m(self) -> float:
        """Length of the path driven [m] (horizontal and vertical)."""
        return float(np.sum(np.linalg.norm(np.diff(self._ecef(), axis=0), axis=1)))

    def _ecef(self):
        return earth.lla_to_ecef(self.lat, self.lon, self.h)


def omega_nb_b_from_euler(euler, euler_dot):
    """Rate of a frame relative to n, in that frame [rad/s] (N, 3), from its
    ``[pitch, roll, yaw]`` and their rates (used for the vehicle frame: ``omega_nv_v``).

    From ``[omega_nb_b x] = C_n^b dC_b^n/dt`` with ``C_b^n = R_z(-psi) R_x(theta) R_y(gamma)``:
    ``R_y(g)^T (R_x(th)^T [0, 0, -psi'] + [th', 0, 0]) + [0, g', 0]``.
    """
    th, g = euler[..., 0], euler[..., 1]
    dth, dg, dpsi = euler_dot[..., 0], euler_dot[..., 1], euler_dot[..., 2]
    sg, cg, sth, cth = np.sin(g), np.cos(g), np.sin(th), np.cos(th)
    return np.stack([cg * dth + sg * cth * dpsi,
                     dg - sth * dpsi,
                     sg * dth - cg * cth * dpsi], -1)


def _mv(C, v):
    return np.einsum("...ij,...j->...i", C, v)


def _mtv(C, v):
    return np.einsum("...ji,...j->...i", C, v)


def _hermite(y0, y1, d0, d1, x, dt):
    """Cubic Hermite between (y0, d0) and (y1, d1) at fractions ``x`` (n,) of a step ``dt``.
    ``y0 ...`` are (m,); returns (m, n)."""
    x = x[None, :]
    h00 = 2 * x ** 3 - 3 * x ** 2 + 1
    h10 = x ** 3 - 2 * x ** 2 + x
    h01 = -2 * x ** 3 + 3 * x ** 2
    h11 = x ** 3 - x ** 2
    return (h00 * y0[:, None] + h10 * dt * d0[:, None] + h01 * y1[:, None]
            + h11 * dt * d1[:, None])


def generate(profile, start_lat, start_lon, start_h, rate_hz, n_rows, *, nodes=3,
             sensors=None, C_vb=None) -> Trajectory:
    """Simulate the truth and error-free increments.

    Parameters
    ----------
    profile : :class:`inmotion.sim.profile.Profile`
    start_lat, start_lon : float [rad];  start_h : float [m]  (position at ``t = 0``)
    rate_hz : float, IMU rate [Hz];  n_rows : int, rows at ``t_k = k / rate_hz``
    nodes : int, Gauss-Legendre nodes per interval
    sensors : dict name -> :class:`SensorGeometry`, velocity sensors to evaluate
    C_vb : (3, 3) or None, ``C_v^b``, the IMU's mounting in the vehicle (None: identity)

    Returns
    -------
    Trajectory
        attitude, increments and sensors of the IMU frame b; position and velocity of the
        IMU (the vehicle's reference point).
    """
    sensors = sensors or {}
    C_vb = None if C_vb is None else np.asarray(C_vb, dtype=float)
    dt = 1.0 / rate_hz
    t = np.arange(n_rows) / rate_hz
    xi, wi = np.polynomial.legendre.leggauss(nodes)
    frac, wts = (xi + 1.0) / 2.0, wi / 2.0          # node fractions of an interval, weights
    out = _allocate(t, sensors)
    pos = None                                       # (lat, lon, h) at t_{k0-1}
    for k0 in range(0, n_rows, CHUNK_ROWS):
        k1 = min(n_rows, k0 + CHUNK_ROWS)
        pos = _chunk(profile, out, k0, k1, dt, frac, wts, pos,
                     (start_lat, start_lon, start_h), sensors, C_vb)
    return out


def _allocate(t, sensors):
    n = len(t)
    z1, z3 = (lambda: np.empty(n)), (lambda: np.empty((n, 3)))
    return Trajectory(t, z1(), z1(), z1(), z3(), z3(), z3(), z3(),
                      {k: z1() for k, g in sensors.items() if not g.distance},
                      {k: z1() for k, g in sensors.items() if g.distance})


@dataclass
class _Motion:
    """IMU-frame kinematics at a set of times: ``omega_nb_b``, velocity ``v_b`` and its
    derivative, ``C_b^n``, ``v_n`` and the Euler angles of ``C_b^n`` (arrays with the times'
    shape plus the vector/matrix axes), from the vehicle's motion and ``C_v^b`` (module doc).
    The Euler angles of a mounted IMU are computed from ``C_b^n`` only when asked for."""

    euler_v: np.ndarray
    omega_nb_b: np.ndarray
    vel_b: np.ndarray
    acc_b: np.ndarray
    C_nb: np.ndarray
    vel_n: np.ndarray
    mounted: bool = False

    @property
    def euler(self):
        return rotations.euler_from_dcm(self.C_nb) if self.mounted else self.euler_v

    @classmethod
    def at(cls, profile, t, C_vb=None):
        e_v, ed_v, vel_v, acc_v = (x.reshape(t.shape + (3,))
                                   for x in profile.kinematics(t.ravel()))
        C_nv = rotations.dcm_from_euler(e_v)
        w_nv_v = omega_nb_b_from_euler(e_v, ed_v)
        vel_n = _mv(C_nv, vel_v)
        if C_vb is None:                      # IMU aligned with the vehicle: b = v
            return cls(e_v, w_nv_v, vel_v, acc_v, C_nv, vel_n)
        C_nb = C_nv @ C_vb.T                  # C_b^n = C_v^n C_b^v
        return cls(e_v, _mv(C_vb, w_nv_v), _mv(C_vb, vel_v), _mv(C_vb, acc_v), C_nb, vel_n,
                   mounted=True)


def _imu_rates(mq, lat_q, h_q):
    """``omega_ib_b``, ``f_b`` and ``omega_en_n`` at the nodes (module docstring formulas)."""
    w_ie = earth.omega_ie_n(lat_q)
    w_en = earth.omega_en_n(lat_q, h_q, mq.vel_n)
    w_nb = mq.omega_nb_b
    w_ib = w_nb + _mtv(mq.C_nb, w_ie + w_en)
    f = (np.cross(w_nb, mq.vel_b) + mq.acc_b
         + _mtv(mq.C_nb, np.cross(2 * w_ie + w_en, mq.vel_n) - earth.gravity_n(lat_q, h_q)))
    return w_ib, f, w_en


def _chunk(profile, out, k0, k1, dt, frac, wts, pos_prev, start, sensors, C_vb):
    """Fill rows k0..k1-1; returns the position at t_{k1-1}."""
    t_grid = np.arange(k0 - 1, k1) * dt                     # t_{k0-1} .. t_{k1-1}
    mg = _Motion.at(profile, t_grid, C_vb)
    mq = _Motion.at(profile, t_grid[:-1, None] + dt * frac[None, :], C_vb)   # (m, n) nodes
    lat_g, lon_g, h_g, lat_q, h_q = _integrate_position(mg.vel_n, mq.vel_n, dt, frac, wts,
                                                        pos_prev, start, k0)
    w_ib, f, w_en = _imu_rates(mq, lat_q, h_q)
    rows = slice(k0, k1)
    wdt = (wts * dt)[None, :, None]
    out.dtheta[rows] = np.sum(w_ib * wdt, axis=1)
    out.dvel[rows] = np.sum(f * wdt, axis=1)
    out.lat[rows], out.lon[rows], out.h[rows] = lat_g[1:], lon_g[1:], h_g[1:]
    out.vel_n[rows] = mg.vel_n[1:]
    euler = mg.euler[1:].copy()
    euler[:, 2] = rotations.wrap_2pi(euler[:, 2])
    out.euler[rows] = euler
    if sensors:
        _sensor_outputs(out, rows, sensors, mg, mq, w_en,
                        earth.omega_en_n(lat_g, h_g, mg.vel_n), wts * dt)
    return lat_g[-1], lon_g[-1], h_g[-1]


def _sensor_outputs(out, rows, sensors, mg, mq, w_en_q, w_en_g, wdt):
    """Forward speed at the rows' ends, or its integral over the rows, of each sensor's point:
    ``[C_b^m (v_b + omega_eb_b x l_b)]_y`` with ``omega_eb_b = omega_nb_b + C_n^b omega_en_n``
    (``= [C_v^m (v_v + omega_ev_v x l_v)]_y`` with ``C_b^m = C_v^m C_b^v``, ``l_v = C_b^v l_b``:
    the architecture's sensor model, evaluated in b)."""
    for name, geo in sensors.items():
        if geo.distance:
            w_eb = mq.omega_nb_b + _mtv(mq.C_nb, w_en_q)
            u = _mv(geo.C_mb, mq.vel_b + np.cross(w_eb, geo.lever_arm_b))[..., 1]
            out.sensor_distance[name][rows] = np.sum(u * wdt[None, :], axis=1)
        else:
            w_eb = mg.omega_nb_b[1:] + _mtv(mg.C_nb[1:], w_en_g[1:])
            u = _mv(geo.C_mb, mg.vel_b[1:] + np.cross(w_eb, geo.lever_arm_b))[:, 1]
            out.sensor_speed[name][rows] = u


def _integrate_position(vn_g, vn_q, dt, frac, wts, pos_prev, start, k0):
    """Latitude, longitude, height on the grid (m+1,) and latitude, height at the nodes (m, n).

    In the first chunk the grid starts at t_{-1} and the constants are fixed by the start
    position at t_0 (grid index 1); later chunks continue from ``pos_prev`` at grid index 0.
    """
    def anchor(increments, value):
        c = np.concatenate([[0.0], np.cumsum(increments)])
        return value - c[1] + c if k0 == 0 else value + c

    lat0, lon0, h0 = start if k0 == 0 else pos_prev
    h_g = anchor(np.sum(vn_q[..., 2] * wts, axis=1) * dt, h0)
    h_q = _hermite(h_g[:-1], h_g[1:], vn_g[:-1, 2], vn_g[1:, 2], frac, dt)

    lat_g = np.full(len(h_g), lat0)
    for _ in range(3):                                    # Picard sweeps on R_M(L)
        r_m_g, _ = earth.radii(lat_g)
        dlat_g = vn_g[:, 1] / (r_m_g + h_g)
        lat_q = _hermite(lat_g[:-1], lat_g[1:], dlat_g[:-1], dlat_g[1:], frac, dt)
        r_m_q, _ = earth.radii(lat_q)
        lat_g = anchor(np.sum(vn_q[..., 1] / (r_m_q + h_q) * wts, axis=1) * dt, lat0)
    r_m_g, r_n_g = earth.radii(lat_g)
    dlat_g = vn_g[:, 1] / (r_m_g + h_g)
    lat_q = _hermite(lat_g[:-1], lat_g[1:], dlat_g[:-1], dlat_g[1:], frac, dt)
    _, r_n_q = earth.radii(lat_q)
    lon_rate_q = vn_q[..., 0] / ((r_n_q + h_q) * np.cos(lat_q))
    lon_g = anchor(np.sum(lon_rate_q * wts, axis=1) * dt, lon0)
    return lat_g, lon_g, h_g, lat_q, h_q
