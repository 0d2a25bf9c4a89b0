"""Velocity sensors (Doppler radar, LDV, odometer) and the barometric altimeter.

Every sensor samples on IMU times (its rate divides the IMU rate). A velocity sensor sees the
velocity over ground of the point where it sits, ``v_b + omega_eb_b x l_b`` (lever arm ``l_b``),
resolved in its own frame m, and reports the forward (m-frame y) component
(:mod:`inmotion.sim.trajectory` computes it exactly).

Mounting (paper 000 eq. 4-9): ``A = [alpha, beta, gamma]`` are the residual mounting angles
about the x, y, z axes of the measuring frame. Paper 000 writes the installed sensor as
``C_m^b(nominal) = (I - [A x]) C_m^b(true)`` with a nominal identity; we take the exact rotation
``C_m^b = exp([A x])`` (rotation vector ``A``), which has no rotation order: it equals
``I + [A x]`` to first order, and every Euler order of three such angles agrees with it to
second order (a few 1e-6 rad for 10 arcmin). A sensor with nominal mounting therefore reads, for
the body velocity ``[0, v, 0]``, the forward speed ``v`` up to ``O(A^2)``; a dead reckoner that
assumes ``C_m^b = I`` puts that speed along the wrong body direction ``[-gamma, 1, alpha]``.

Outputs:

- radar: ``v = (1 + k + dk(t)) u + n``; ``k`` constant, ``dk`` first-order Markov (paper 000
  eq. 3) with stationary sigma ``s`` and correlation time ``tau``, started stationary and
  sampled exactly: ``dk_{j+1} = exp(-T/tau) dk_j + s sqrt(1 - exp(-2T/tau)) w_j``.
- LDV: ``v = (1 + k) u + n`` or ``ds = (1 + k) int u dt + n T`` (``T`` the sample period).
- odometer: cumulative wheel distance ``D = sum((1 + k) int u dt + n T)``; pulses
  ``floor(D * ppm)``; ``ds`` = new pulses / ``ppm`` per sample.
- baro: ``h = h_true + bias + n``.

Speed outputs are sampled at IMU rows ``0, s, 2s, ...`` (``s`` = IMU rate / sensor rate);
distance outputs at rows ``s, 2s, ...``, each ``ds`` covering the period that ends there.
"""
from __future__ import annotations

import numpy as np
from ..core import rotations
from ..core.bundle import BaroData, SpeedData
from . import faults as faults_mod
from .random_processes import markov
from .trajectory import SensorGeometry

__all__ = ["mounting_C_mb", "geometry", "simulate_speed_sensor", "simulate_baro", "markov"]

ARCMIN = np.pi / 180.0 / 60.0


def mounting_C_mb(mounting_arcmin) -> np.ndarray:
    """``C_b^m = exp(-[A x])`` for ``A = [alpha, beta, gamma]`` [arcmin] (see module doc)."""
    return rotations.dcm_from_rotvec(-np.asarray(mounting_arcmin, dtype=float) * ARCMIN)


def geometry(spec, distance=True) -> SensorGeometry:
    """The :class:`SensorGeometry` of a velocity-sensor spec (``distance``: the sensor
    outputs distance increments, so the trajectory integrates its speed)."""
    return SensorGeometry(mounting_C_mb(spec.mounting_arcmin),
                          np.asarray(spec.lever_arm_m, float), distance)


def _step(imu_rate_hz, rate_hz):
    return int(round(imu_rate_hz / rate_hz))


def simulate_speed_sensor(name, spec, traj, imu_rate_hz, faults, rng):
    """``(SpeedData, truth_meta)`` of one velocity sensor; ``truth_meta`` holds the drawn
    constant scale factor [ppm]."""
    s = _step(imu_rate_hz, spec.rate_hz)
    period = s / imu_rate_hz
    k = (spec.scale_factor_ppm + spec.scale_factor_sigma_ppm * rng.standard_normal()) * 1e-6
    distance = name == "odometer" or getattr(spec, "output", "speed") == "distance"
    if distance:
        idx = np.arange(s, len(traj.t), s)
        cum = np.concatenate([[0.0], np.cumsum(traj.sensor_distance[name])])
        true = cum[idx + 1] - cum[idx + 1 - s]
    else:
        idx = np.arange(0, len(traj.t), s)
        true = traj.sensor_speed[name][idx]
    t = traj.t[idx]
    scale = 1.0 + k
    if name == "radar" and spec.scale_markov_sigma_ppm > 0:
        scale = scale + markov(len(t), period, spec.scale_markov_sigma_ppm * 1e-6,
                               spec.scale_markov_tau_s, rng)
    noise = spec.noise_m_s * rng.standard_normal(len(t)) * (period if distance else 1.0)
    val = scale * true + noise
    val = faults_mod.apply_value_faults(t, val, faults, period_s=period if distance else None,
                                        rng=rng)
    if name == "odometer":
        pulses = np.floor(np.cumsum(val) * spec.pulses_per_m)
        val = np.diff(np.concatenate([[0.0], pulses])) / spec.pulses_per_m
    t, val = faults_mod.apply_stream_faults(t, val, faults)
    data = SpeedData(t, ds=val) if distance else SpeedData(t, v=val)
    return data, {"scale_factor_ppm": float(k * 1e6)}


def simulate_baro(spec, traj, imu_rate_hz, faults, rng):
    """``(BaroData, truth_meta)``: barometric altitude samples with bias, noise and faults;
    ``truth_meta`` holds the bias of this run [m]."""
    s = _step(imu_rate_hz, spec.rate_hz)
    idx = np.arange(0, len(traj.t), s)
    t = traj.t[idx]
    bias = spec.bias_m + spec.bias_sigma_m * rng.standard_normal()
    h = traj.h[idx] + bias + spec.noise_m * rng.standard_normal(len(t))
    h = faults_mod.apply_value_faults(t, h, faults, rng=rng)
    t, h = faults_mod.apply_stream_faults(t, h, faults)
    return BaroData(t, h), {"bias_m": float(bias)}
