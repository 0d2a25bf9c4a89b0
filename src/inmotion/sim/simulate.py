"""Scenario -> :class:`inmotion.core.bundle.Bundle`: truth, IMU, velocity sensors, baro, meta.

``simulate(scenario, rng)`` is the one entry point. All randomness goes through ``rng``:
draws happen in a fixed order (the vehicle's constraint violation if the scenario has one, IMU
constants, IMU noise, then each present sensor in the order radar, ldv, odometer, baro), so a
seed reproduces a bundle bit for bit (and a scenario without a violation draws as before).

The ``meta`` dict is what :mod:`inmotion.io` writes as ``meta.yaml``: the scenario name and
description, the initial position and attitude (degrees), ``vehicle_mounting_arcmin`` (the IMU's
mounting in the vehicle, ``C_v^b = exp([A x])``: what a dead reckoner's ``C_bm`` is), the IMU
rate and specification, each sensor's specification (human units, with lever arm
``lever_arm_m`` in b and beam misalignment ``mounting_arcmin`` relative to the vehicle), the
faults, which sensors exist, the segment timeline, the distance
driven, the vehicle spec ``vehicle`` (roll gain, blend time and, when present, the
``constraint_violation``: lateral / vertical 1-sigma and correlation times, the figures a
filter's matched noise reads), and under ``simulated_errors`` the constants drawn for this run (the truth an
estimator's calibration can be checked against).
"""
from __future__ import annotations

from typing import Union

import numpy as np

from .._typing import PathLike
from ..core.bundle import Bundle, ImuData, Truth
from . import faults as faults_mod
from .imu_errors import apply_imu_errors, draw_imu_errors
from .profile import build_profile
from .scenario import SPEED_SENSORS, Scenario, load_scenario
from .sensors import geometry, simulate_baro, simulate_speed_sensor, vehicle_C_vb
from .trajectory import generate

__all__ = ["simulate", "simulate_truth"]


def simulate_truth(scenario: Union[Scenario, dict, PathLike], rng=None) -> tuple:
    """``(Scenario, Profile, Trajectory)``: the error-free truth and increments of a scenario.

    The profile moves the vehicle frame v; the IMU is turned from it by
    ``vehicle_mounting_arcmin`` (``C_v^b``, None when zero so that an aligned IMU is exactly
    the vehicle). ``rng``: draws the vehicle's ``constraint_violation`` if the scenario has
    one (None: the motion without it)."""
    sc = load_scenario(scenario)
    prof = build_profile(sc, rng)
    rate = sc.imu.rate_hz
    n_rows = int(round(prof.duration_s * rate)) + 1
    C_vb = vehicle_C_vb(sc.vehicle_mounting_arcmin) if any(sc.vehicle_mounting_arcmin) else None
    geos = {n: geometry(getattr(sc.sensors, n), distance=_distance_output(n, sc), C_vb=C_vb)
            for n in SPEED_SENSORS if getattr(sc.sensors, n) is not None}
    traj = generate(prof, np.radians(sc.start.lat_deg), np.radians(sc.start.lon_deg),
                    sc.start.h_m, rate, n_rows, nodes=sc.nodes, sensors=geos, C_vb=C_vb)
    return sc, prof, traj


def _distance_output(name, sc) -> bool:
    return name == "odometer" or getattr(getattr(sc.sensors, name), "output", "speed") == "distance"


def simulate(scenario: Union[Scenario, dict, PathLike], rng: np.random.Generator) -> Bundle:
    """Simulate one drive.

    Parameters
    ----------
    scenario : Scenario, dict, path or shipped name (see :func:`inmotion.sim.scenario.load_scenario`)
    rng : numpy.random.Generator, the only source of randomness

    Returns
    -------
    Bundle
        truth at the IMU times, IMU increments with errors, the sensors present, ``meta``.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError("simulate needs a numpy.random.Generator (np.random.default_rng(seed))")
    sc, prof, traj = simulate_truth(scenario, rng)
    rate = sc.imu.rate_hz
    err = draw_imu_errors(sc.imu, rng)
    dtheta, dvel = apply_imu_errors(traj.dtheta, traj.dvel, 1.0 / rate, err, rng,
                                   in_place=True)     # traj is ours alone
    bundle = Bundle(ImuData(traj.t, dtheta, dvel),
                    truth=Truth(traj.t, traj.lat, traj.lon, traj.h, traj.vel_n, traj.euler))
    drawn = {"imu": err.to_meta()}
    for name in sc.present_sensors:
        spec = getattr(sc.sensors, name)
        own = [f for f in sc.faults if f.sensor == name]
        if name == "baro":
            bundle.baro, drawn[name] = simulate_baro(spec, traj, rate, own, rng)
        else:
            data, info = simulate_speed_sensor(name, spec, traj, rate, own, rng)
            setattr(bundle, name, data)
            drawn[name] = info
    bundle.meta = _meta(sc, prof, traj, drawn)
    return bundle


def _tidy(x: float) -> float:
    """A float for meta.yaml without round-off noise (12 decimals, no -0.0)."""
    return float(np.round(x, 12)) + 0.0


def _meta(sc, prof, traj, drawn) -> dict:
    sensors = {}
    for name in sc.present_sensors:
        spec = getattr(sc.sensors, name).model_dump()
        if name in SPEED_SENSORS:
            spec["output"] = "distance" if _distance_output(name, sc) else "speed"
        sensors[name] = spec
    return {
        "name": sc.name,
        "description": sc.description,
        "simulated": True,
        "lat_deg": sc.start.lat_deg, "lon_deg": sc.start.lon_deg, "h_m": sc.start.h_m,
        "initial_attitude_deg": {k: _tidy(np.degrees(traj.euler[0, i]))
                                 for i, k in enumerate(("pitch", "roll", "yaw"))},
        "vehicle_mounting_arcmin": [float(x) for x in sc.vehicle_mounting_arcmin],
        "vehicle": sc.vehicle.model_dump(exclude_none=True),
        "duration_s": float(traj.t[-1] - traj.t[0]),
        "distance_m": traj.distance_m,
        "imu": {"rate_hz": sc.imu.rate_hz, **sc.imu.model_dump(exclude={"rate_hz"})},
        "sensors": sensors,
        "lever_arms_m": {n: list(getattr(sc.sensors, n).lever_arm_m)
                         for n in sc.present_sensors if n in SPEED_SENSORS},
        "files": ["imu", "truth"] + sc.present_sensors,
        "faults": [faults_mod.describe(f) for f in sc.faults],
        "segments": [{"kind": k, "start_s": float(a), "end_s": float(b)} for k, a, b in prof.segments],
        "disturbances": sc.disturbances.model_dump(),
        "simulated_errors": drawn,
    }
