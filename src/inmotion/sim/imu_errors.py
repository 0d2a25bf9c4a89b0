"""IMU error model: constant drift and bias, white noise (random walks), scale factors,
misalignments, applied to exact increments.

For each row ``k`` of length ``dt``:

``dtheta_meas = (I + S_g + M_g) dtheta_true + (eps + eps_M(t_k)) dt + sigma_g sqrt(dt) w``,
``dvel_meas   = (I + S_a + M_a) dvel_true   + (nabla + nabla_M(t_k)) dt + sigma_a sqrt(dt) w``,

with ``eps_M``, ``nabla_M`` optional first-order Markov processes per axis (bias instability,
:mod:`inmotion.sim.random_processes`, held over each row), ``w`` standard normal (independent per row and axis), ``S = diag(scale factors)`` and ``M``
the misalignment: from 3 values ``a`` a small rotation ``M = -[a x]`` (the triad turned by ``a``:
it measures ``(I - [a x]) v``), from 6 values the non-orthogonality matrix with off-diagonal
entries ``[xy, xz, yx, yz, zx, zy]`` (row = sensing axis). ``sigma_g`` is the angle random walk
[rad/sqrt(s)], ``sigma_a`` the velocity random walk [m/s/sqrt(s)] = white acceleration noise
density [m/s^2/sqrt(Hz)]. A white-noise rate of density ``N`` integrated over ``dt`` has
standard deviation ``N sqrt(dt)``; that is what these increments carry.

Unit conversions (edges to SI): 1 deg/h = pi/180/3600 rad/s; 1 deg/sqrt(h) = pi/180/60
rad/sqrt(s); 1 ug = 9.80665e-6 m/s^2; 1 ug/sqrt(Hz) = 9.80665e-6 m/s^2/sqrt(Hz);
1 m/s/sqrt(h) = 1/60 m/s/sqrt(s).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import earth, rotations
from .random_processes import markov

__all__ = ["ImuErrors", "draw_imu_errors", "apply_imu_errors"]

DEG_H = np.pi / 180.0 / 3600.0        #: 1 deg/h in rad/s
DEG_SQRT_H = np.pi / 180.0 / 60.0     #: 1 deg/sqrt(h) in rad/sqrt(s)
UG = 1e-6 * earth.G0                  #: 1 micro-g in m/s^2
ARCSEC = np.pi / 180.0 / 3600.0


@dataclass
class ImuErrors:
    """The errors of one run, SI: ``eps`` [rad/s] (3,), ``nabla`` [m/s^2] (3,), ``arw``
    [rad/sqrt(s)], ``vrw`` [m/s/sqrt(s)], ``T_g``, ``T_a`` = I + S + M (3, 3)."""

    eps: np.ndarray
    nabla: np.ndarray
    arw: float
    vrw: float
    T_g: np.ndarray
    T_a: np.ndarray
    eps_markov: tuple = (0.0, 1.0)     #: (sigma [rad/s], tau [s])
    nabla_markov: tuple = (0.0, 1.0)   #: (sigma [m/s^2], tau [s])

    def to_meta(self) -> dict:
        """The drawn values in human units (for meta.yaml)."""
        return {"gyro_drift_deg_h": (self.eps / DEG_H).tolist(),
                "accel_bias_ug": (self.nabla / UG).tolist(),
                "gyro_error_matrix_ppm": ((self.T_g - np.eye(3)) * 1e6).round(6).tolist(),
                "accel_error_matrix_ppm": ((self.T_a - np.eye(3)) * 1e6).round(6).tolist()}


def _draw(value, random, rng):
    v = np.broadcast_to(np.asarray(value, dtype=float), 3).copy()
    return v * rng.standard_normal(3) if random else v


def _error_matrix(scale_ppm, mis_arcsec, random, rng):
    S = np.diag(_draw(scale_ppm, random, rng) * 1e-6)
    mis = np.asarray(mis_arcsec, dtype=float) * ARCSEC
    if random:
        mis = mis * rng.standard_normal(mis.shape)
    if mis.size == 3:
        M = -rotations.skew(mis)
    else:
        M = np.zeros((3, 3))
        M[[0, 0, 1, 1, 2, 2], [1, 2, 0, 2, 0, 1]] = mis
    return np.eye(3) + S + M


def draw_imu_errors(spec, rng: np.random.Generator) -> ImuErrors:
    """This run's IMU errors from a :class:`inmotion.sim.scenario.Imu` spec.

    With ``constant_errors: random`` the constants are drawn (zero mean, spec as 1-sigma);
    otherwise taken as given and ``rng`` is not used here.
    """
    rnd = spec.constant_errors == "random"
    g, a = spec.gyro, spec.accel
    if a.vrw_ug_sqrt_hz is not None:
        vrw = a.vrw_ug_sqrt_hz * UG
    elif a.vrw_m_s_sqrt_h is not None:
        vrw = a.vrw_m_s_sqrt_h / 60.0
    else:
        vrw = 0.0
    return ImuErrors(eps=_draw(g.drift_deg_h, rnd, rng) * DEG_H,
                     nabla=_draw(a.bias_ug, rnd, rng) * UG,
                     arw=g.arw_deg_sqrt_h * DEG_SQRT_H, vrw=vrw,
                     T_g=_error_matrix(g.scale_factor_ppm, g.misalignment_arcsec, rnd, rng),
                     T_a=_error_matrix(a.scale_factor_ppm, a.misalignment_arcsec, rnd, rng),
                     eps_markov=(g.drift_markov_deg_h * DEG_H, g.drift_markov_tau_s),
                     nabla_markov=(a.bias_markov_ug * UG, a.bias_markov_tau_s))


def apply_imu_errors(dtheta, dvel, dt, err: ImuErrors, rng: np.random.Generator, *,
                     in_place=False):
    """Measured increments from the true ones (N, 3), row length ``dt`` [s].

    New arrays, or with ``in_place=True`` the given arrays overwritten (no copy of the log).
    """
    n = len(dtheta)
    I = np.eye(3)
    if not in_place:
        dtheta, dvel = np.array(dtheta, dtype=float), np.array(dvel, dtype=float)
    if not np.array_equal(err.T_g, I):
        dtheta[:] = dtheta @ err.T_g.T
    if not np.array_equal(err.T_a, I):
        dvel[:] = dvel @ err.T_a.T
    dtheta += err.eps * dt
    dvel += err.nabla * dt
    if err.arw > 0:
        dtheta += err.arw * np.sqrt(dt) * rng.standard_normal((n, 3))
    if err.vrw > 0:
        dvel += err.vrw * np.sqrt(dt) * rng.standard_normal((n, 3))
    for out, (sigma, tau) in ((dtheta, err.eps_markov), (dvel, err.nabla_markov)):
        if sigma > 0:
            out += markov(n, dt, sigma, tau, rng, size=3) * dt
    return dtheta, dvel
