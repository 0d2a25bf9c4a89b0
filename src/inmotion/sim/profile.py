"""The vehicle's motion as smooth functions of time: speed, heading, pitch, roll, disturbances.

Everything here is the motion of the *vehicle frame* v (Right-Forward-Up of the vehicle, see
docs/ARCHITECTURE.md "Vehicle frame and mounting"): the Euler angles are those of ``C_v^n`` and
the velocity is ``v_v``, ``[0, v, 0]`` plus the disturbances. The IMU frame b is turned from v
by the scenario's ``vehicle_mounting_arcmin``; :mod:`inmotion.sim.trajectory` makes that step.

The scenario's segments become three piecewise-polynomial *channels* (:class:`scipy.interpolate.PPoly`):
the forward acceleration ``a(t)``, the yaw rate ``r(t)`` and the pitch ``theta(t)``. Every change
is a septic smoothstep ``S(x) = 35 x^4 - 84 x^5 + 70 x^6 - 20 x^7`` (``S, S', S'', S'''`` are 0 / 1
at the ends), so acceleration, yaw rate and pitch are C3; speed ``v = v0 + int a`` and yaw
``psi = psi0 + int r`` are exact antiderivatives (C4). Roll follows the lateral acceleration:
``roll = -k v r`` (a right turn, ``r > 0``, rolls the vehicle to the left, roll < 0 in the DESIGN
convention where positive roll lowers the right side).

Disturbances add to the vehicle velocity ``v_v`` and the Euler angles in their windows (side slips, jumps,
engine vibration; see :mod:`inmotion.sim.scenario`). A vehicle's ``constraint_violation`` (real
side slip and bounce, a random process drawn per run) adds to ``v_v``'s lateral and vertical
components throughout (:func:`violation_ppoly`).

Everything is evaluated vectorized at any array of times, together with the analytic time
derivatives the IMU needs (Euler rates, body acceleration).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PPoly

__all__ = ["Profile", "build_profile", "smoothstep7", "violation_ppoly"]

#: coefficients of S(x) = 35 x^4 - 84 x^5 + 70 x^6 - 20 x^7, lowest power first
_S7 = np.array([0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0])
_PRE_S = 1.0   #: the motion is defined (and held constant) this long before t = 0


def smoothstep7(x, nu=0):
    """Septic smoothstep ``S(x)`` on [0, 1] (clipped outside) or its ``nu``-th derivative."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    c = np.polynomial.polynomial.polyder(_S7, nu) if nu else _S7
    return np.polynomial.polynomial.polyval(x, c)


class _Channel:
    """A signal that holds levels and ramps between them with S(x); built into a PPoly."""

    def __init__(self, t_begin, value0=0.0):
        self.t_begin = t_begin
        self.value = value0
        self.pieces = []          # (t0, t1, v0, v1)

    def ramp(self, t0, tau, v1):
        self.pieces.append((t0, t0 + tau, self.value, v1))
        self.value = v1

    def ppoly(self, t_end) -> PPoly:
        breaks, coefs = [self.t_begin], []
        level = self.pieces[0][2] if self.pieces else self.value
        for t0, t1, v0, v1 in self.pieces:
            if t0 > breaks[-1]:
                breaks.append(t0)
                coefs.append(_const(level))
            tau = t1 - t0
            c = (v1 - v0) * _S7 / tau ** np.arange(8)
            c[0] += v0
            breaks.append(t1)
            coefs.append(c[::-1])
            level = v1
        if t_end > breaks[-1]:
            breaks.append(t_end)
            coefs.append(_const(level))
        return PPoly(np.array(coefs).T, np.array(breaks), extrapolate=True)


def _const(v):
    c = np.zeros(8)
    c[-1] = v
    return c


@dataclass
class Profile:
    """Channels of the motion; evaluate with :meth:`kinematics`."""

    accel: PPoly            #: forward acceleration [m/s^2]
    speed: PPoly            #: forward speed [m/s]
    yaw_rate: PPoly         #: [rad/s], clockwise positive
    yaw: PPoly              #: [rad], unwrapped
    pitch: PPoly            #: [rad]
    roll_gain_s2_m: float   #: roll = -k * lateral acceleration [rad per m/s^2]
    disturbances: object    #: scenario.Disturbances
    duration_s: float
    segments: list          #: [(kind, t_start, t_end)]
    #: the vehicle constraint's violation, vehicle-frame ``[lateral, vertical]`` velocity
    #: [m/s] before the standstill fade (a (k, m, 2) PPoly), or None
    violation: object = None
    fade_speed_m_s: float = 1.0

    def kinematics(self, t):
        """Euler angles, their rates, vehicle velocity and its time derivative at times ``t``.

        Returns
        -------
        euler, euler_dot : (N, 3) [rad], [rad/s], ``[pitch, roll, yaw]`` of ``C_v^n``
        vel_v, acc_v : (N, 3) [m/s], [m/s^2], vehicle-frame (R-F-U) velocity over ground and
            its derivative in v (d/dt of the components, not the n-frame acceleration).
        """
        t = np.asarray(t, dtype=float)
        v, a = self.speed(t), self.accel(t)
        r, rdot = self.yaw_rate(t), self.yaw_rate(t, 1)
        k = self.roll_gain_s2_m
        euler = np.stack([self.pitch(t), -k * v * r, self.yaw(t)], -1)
        euler_dot = np.stack([self.pitch(t, 1), -k * (a * r + v * rdot), r], -1)
        z = np.zeros_like(t)
        vel_v = np.stack([z, v, z], -1)
        acc_v = np.stack([z, a, z], -1)
        _add_disturbances(self.disturbances, t, euler, euler_dot, vel_v, acc_v)
        if self.violation is not None:
            _add_violation(self.violation, self.fade_speed_m_s, t, v, a, vel_v, acc_v)
        return euler, euler_dot, vel_v, acc_v


def build_profile(scenario, rng=None) -> Profile:
    """The motion channels of a :class:`inmotion.sim.scenario.Scenario`.

    ``rng`` (numpy Generator): draws the realization of ``vehicle.constraint_violation`` when
    the scenario has one (:func:`violation_ppoly`); None: no violation (the error-free,
    deterministic motion).

    Segment timing: ``accelerate`` / ``decelerate`` / ``stop`` last ``|dv| / a + tau`` (ramps of
    the acceleration of length ``tau`` at both ends, so the plateau acceleration is the one given
    and the speed change exact; if ``|dv| / a < tau``, ``tau`` shrinks to ``|dv| / a``); a
    ``turn`` lasts ``|angle| / rate + tau`` likewise; ``climb`` / ``descend`` ramp the pitch in
    over ``tau`` and out over ``tau`` within their ``duration_s`` (``tau <= duration / 2``).
    """
    t0 = -_PRE_S
    default_tau = scenario.vehicle.transition_s
    acc = _Channel(t0)
    rate = _Channel(t0)
    pitch = _Channel(t0)
    t, v = 0.0, scenario.start.speed_m_s
    segs = []
    for seg in scenario.segments:
        tau = seg.transition_s or default_tau
        kind = seg.kind
        if kind in ("rest", "wait", "cruise"):
            dur = seg.duration_s
        elif kind in ("accelerate", "decelerate", "stop"):
            target = 0.0 if kind == "stop" else seg.to_speed_m_s
            a_mag = seg.accel_m_s2 if kind == "accelerate" else seg.decel_m_s2
            dv = target - v
            tau = min(tau, abs(dv) / a_mag)
            dur = abs(dv) / a_mag + tau
            a_plateau = np.sign(dv) * a_mag
            acc.ramp(t, tau, a_plateau)
            acc.ramp(t + dur - tau, tau, 0.0)
            v = target
        elif kind == "turn":
            r_mag = np.radians(seg.rate_deg_s)
            ang = np.radians(seg.angle_deg)
            tau = min(tau, abs(ang) / r_mag)
            dur = abs(ang) / r_mag + tau
            rate.ramp(t, tau, np.sign(ang) * r_mag)
            rate.ramp(t + dur - tau, tau, 0.0)
        else:  # climb / descend
            dur = seg.duration_s
            tau = min(tau, dur / 2)
            p = np.radians(seg.pitch_deg) * (1.0 if kind == "climb" else -1.0)
            pitch.ramp(t, tau, p)
            pitch.ramp(t + dur - tau, tau, 0.0)
        segs.append((kind, t, t + dur))
        t += dur
    t_end = t + _PRE_S
    accel_pp = acc.ppoly(t_end)
    rate_pp = rate.ppoly(t_end)
    speed_pp = accel_pp.antiderivative()
    speed_pp.c[-1] += scenario.start.speed_m_s
    yaw_pp = rate_pp.antiderivative()
    yaw_pp.c[-1] += np.radians(scenario.start.heading_deg)
    k = np.radians(scenario.vehicle.roll_per_lateral_accel_deg_per_m_s2)
    cv = scenario.vehicle.constraint_violation
    viol = (violation_ppoly(cv, t0, t_end, rng) if cv is not None and cv.active
            and rng is not None else None)
    return Profile(accel_pp, _clean_speed(speed_pp), rate_pp, yaw_pp, pitch.ppoly(t_end), k,
                   scenario.disturbances, t, segs, viol,
                   cv.fade_speed_m_s if cv is not None else 1.0)


#: longest knot spacing of a constraint violation's realization [s]
VIOLATION_KNOT_S = 0.05


def violation_ppoly(cv, t_begin, t_end, rng) -> PPoly:
    """One realization of the vehicle constraint's violation (``scenario.
    ConstraintViolation``): the lateral and vertical velocities [m/s] as a cubic spline
    (``(4, m, 2)`` PPoly) through samples of two independent stationary first-order
    Gauss-Markov processes (:func:`inmotion.sim.random_processes.markov`: 1-sigma
    ``*_sigma_m_s``, autocorrelation ``sigma^2 exp(-|dt| / tau)``) every
    ``h = min(VIOLATION_KNOT_S, tau_min / 5)`` s (a multiple of 0.01 s apart from
    ``t_begin``, so 100 Hz IMU intervals lie within one cubic piece). The spline makes the
    process differentiable (a Gauss-Markov path is not): the accelerometers sense its
    derivative, and its spectrum is the process's up to about ``1 / (2 h)`` Hz. Draws
    ``2 n`` normals from ``rng`` (n knots), lateral first."""
    from scipy.interpolate import CubicSpline

    from .random_processes import markov
    tau_min = min(cv.lateral_tau_s, cv.vertical_tau_s)
    h = max(0.01, np.floor(min(VIOLATION_KNOT_S, tau_min / 5.0) * 100.0 + 1e-9) / 100.0)
    n = int(np.ceil((t_end - t_begin) / h)) + 1
    x = np.stack([markov(n, h, cv.lateral_sigma_m_s, cv.lateral_tau_s, rng)
                  if cv.lateral_sigma_m_s > 0 else np.zeros(n),
                  markov(n, h, cv.vertical_sigma_m_s, cv.vertical_tau_s, rng)
                  if cv.vertical_sigma_m_s > 0 else np.zeros(n)], -1)
    sp = CubicSpline(t_begin + h * np.arange(n), x, axis=0, bc_type="natural")
    return PPoly(sp.c, sp.x, extrapolate=True)


def _add_violation(pp, v0, t, v, a, vel_v, acc_v):
    """Add the violation ``g(v) x(t)`` to the vehicle frame's x (lateral) and z (vertical)
    velocity and ``g'(v) a x + g x'`` to its derivative in place; ``g = v^2 / (v^2 + v0^2)``
    fades it out towards standstill (exactly 0 at rest)."""
    x, xd = pp(t), pp(t, 1)
    d = v * v + v0 * v0
    g = v * v / d
    gd = 2.0 * v * v0 * v0 / (d * d) * a
    for col, k in ((0, 0), (2, 1)):
        vel_v[:, col] += g * x[:, k]
        acc_v[:, col] += gd * x[:, k] + g * xd[:, k]


def _clean_speed(speed_pp: PPoly) -> PPoly:
    """Pieces that are standstill up to round-off become exactly 0 (no creeping at rest)."""
    c = speed_pp.c
    still = (np.abs(c[:-1]).max(axis=0) < 1e-12) & (np.abs(c[-1]) < 1e-9)
    c[:, still] = 0.0
    return speed_pp


# ----------------------------------------------------------------------------- disturbances
def _bump(s, nu):
    """``sin^4(pi s)`` on [0, 1] (0 outside) and its derivatives in s (nu = 0, 1, 2)."""
    inside = (s > 0.0) & (s < 1.0)
    sn, cs = np.sin(np.pi * s), np.cos(np.pi * s)
    if nu == 0:
        out = sn ** 4
    elif nu == 1:
        out = 4 * np.pi * sn ** 3 * cs
    else:
        out = 4 * np.pi ** 2 * (3 * sn ** 2 * cs ** 2 - sn ** 4)
    return np.where(inside, out, 0.0)


def _envelope(t, start, end, fade, nu):
    """C3 fade-in / fade-out window (or its derivative ``nu``) for vibration."""
    up = smoothstep7((t - start) / fade, nu) / fade ** nu
    down = smoothstep7((end - t) / fade, nu) * (-1.0 / fade) ** nu
    if nu == 0:
        return up * down
    up0, down0 = smoothstep7((t - start) / fade), smoothstep7((end - t) / fade)
    if nu == 1:
        return up * down0 + up0 * down
    up1 = smoothstep7((t - start) / fade, 1) / fade
    down1 = -smoothstep7((end - t) / fade, 1) / fade
    return up * down0 + 2 * up1 * down1 + up0 * down


def _add_disturbances(dist, t, euler, euler_dot, vel_b, acc_b):
    """Add side slips (vehicle x velocity), jumps (vehicle z) and vibration in place
    (``vel_b``, ``acc_b`` here are the vehicle frame's ``v_v`` and its derivative)."""
    for s in dist.side_slips:
        x = (t - s.t_s) / s.duration_s
        vel_b[:, 0] += s.speed_m_s * _bump(x, 0)
        acc_b[:, 0] += s.speed_m_s * _bump(x, 1) / s.duration_s
    for j in dist.jumps:
        x = (t - j.t_s) / j.duration_s
        vel_b[:, 2] += j.height_m * _bump(x, 1) / j.duration_s
        acc_b[:, 2] += j.height_m * _bump(x, 2) / j.duration_s ** 2
    for vib in dist.vibration:
        m = (t > vib.start_s) & (t < vib.end_s)
        if not m.any():
            continue
        tm = t[m]
        w = 2 * np.pi * vib.frequency_hz
        e0, e1, e2 = (_envelope(tm, vib.start_s, vib.end_s, vib.fade_s, nu) for nu in (0, 1, 2))
        ang = np.radians(np.broadcast_to(vib.angular_amplitude_arcsec, 3) / 3600.0)
        lin = np.broadcast_to(vib.linear_amplitude_mm, 3) * 1e-3
        for i, phase in enumerate(np.radians(vib.phases_deg)):
            sn, cs = np.sin(w * tm + phase), np.cos(w * tm + phase)
            euler[m, i] += ang[i] * e0 * sn
            euler_dot[m, i] += ang[i] * (e1 * sn + e0 * w * cs)
            vel_b[m, i] += lin[i] * (e1 * sn + e0 * w * cs)
            acc_b[m, i] += lin[i] * (e2 * sn + 2 * e1 * w * cs - e0 * w * w * sn)
