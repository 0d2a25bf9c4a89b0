"""Velocity sensors (Doppler radar, LDV, odometer) and the barometric altimeter.

Every sensor samples on IMU times (its rate divides the IMU rate). A velocity sensor s sees the
velocity over ground of the point where it sits, ``v_v + omega_ev_v x l_v`` (the vehicle's
velocity ``v_v`` at the reference point, which is the IMU, plus the lever-arm term), resolved
in its own frame s, and reports the forward (s-frame y) component
``[C_v^s (v_v + omega_ev_v x l_v)]_y`` (docs/ARCHITECTURE.md "Vehicle frame and mounting";
:mod:`inmotion.sim.trajectory` computes it exactly, in b). Lever arms are given in the IMU frame
b (``l_v = C_b^v l_b``), the frame of the dead reckoner's ``lever_arm_b``.

Two mountings, both ``exp([A x])`` (:func:`inmotion.core.rotations.mounting_dcm`, paper 000
eq. 4-9, exact rotation vector form, no rotation order, ``I + [A x]`` to first order):

- the IMU in the vehicle, the scenario's ``vehicle_mounting_arcmin``: ``C_v^b = exp([A x])``.
  It acts to *first order*: the vehicle moves along v's forward axis, which in b is
  ``[-gamma, 1, alpha]``, so a dead reckoner that assumes ``C_v^b = I`` drifts cross-track by
  ``gamma`` and vertically by ``alpha`` times the distance.
- a sensor's own beam misalignment relative to v, its ``mounting_arcmin``:
  ``C_s^v = exp([A_s x])``. With no slip the sensor reads ``cos``-like ``v (1 - O(A_s^2))``:
  *second order* (a side slip ``v_x`` adds ``-gamma_s v_x``, first order in the slip).

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

__all__ = ["mounting_C_mb", "vehicle_C_vb", "geometry", "simulate_speed_sensor",
           "simulate_baro", "markov"]

ARCMIN = np.pi / 180.0 / 60.0


def mounting_C_mb(mounting_arcmin) -> np.ndarray:
    """``C_v^s = exp([A x])^T`` of a sensor's beam misalignment ``A = [alpha, beta, gamma]``
    [arcmin] relative to the vehicle frame (takes v-vectors to the sensor frame; module doc)."""
    return rotations.mounting_dcm(np.asarray(mounting_arcmin, dtype=float) * ARCMIN).T


def vehicle_C_vb(vehicle_mounting_arcmin) -> np.ndarray:
    """``C_v^b = exp([A x])`` of the IMU's mounting in the vehicle [arcmin] (module doc)."""
    return rotations.mounting_dcm(np.asarray(vehicle_mounting_arcmin, dtype=float) * ARCMIN)


def geometry(spec, distance=True, C_vb=None) -> SensorGeometry:
    """The :class:`SensorGeometry` of a velocity-sensor spec: ``C_b^s = C_v^s C_b^v`` from
    its beam misalignment and the vehicle mounting ``C_vb`` (``C_v^b``; None: identity), lever
    arm in b. ``distance``: the sensor outputs distance increments, so the trajectory
    integrates its speed."""
    C_sv = mounting_C_mb(spec.mounting_arcmin)
    C_sb = C_sv if C_vb is None else C_sv @ np.asarray(C_vb, dtype=float).T
    return SensorGeometry(C_sb, np.asarray(spec.lever_arm_m, float), distance)


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
