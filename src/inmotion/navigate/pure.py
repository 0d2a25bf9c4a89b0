"""Pure navigation, the two references every aided method is measured against.

``sins``
    Pure strapdown inertial navigation: :func:`inmotion.core.mechanization.strapdown` from the
    initial state, with optional barometric damping of the (unstable) vertical channel.
``dr``
    Pure dead reckoning (paper 002, sec. 2): the same gyro attitude update and a forward-velocity
    sensor, :func:`inmotion.core.deadreckoning.dead_reckon`. The speed is put along the
    vehicle's forward axis, ``C_bm = C_v^b = exp([A x])`` with ``A`` the IMU's mounting in the
    vehicle (docs/ARCHITECTURE.md "Vehicle frame and mounting"), and the sensor's lever arm is
    removed; both come from the configuration or, if absent there, from ``meta.yaml``
    (``vehicle_mounting_arcmin`` at the top level, ``sensors.<sensor>.lever_arm_m``).

Both are ``run(bundle, config, init, progress=None) -> Solution`` methods of
:mod:`inmotion.registry`; neither reads files nor prints.
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .. import config_fields as cf
from ..core import rotations
from ..core.bundle import Bundle
from ..core.deadreckoning import dead_reckon_rows
from ..core.mechanization import strapdown_rows
from ..core.solution import NavState, Solution
from ..errors import BadInput

__all__ = ["SinsConfig", "DrConfig", "run_sins", "run_dr", "mounting_from_meta",
           "mounting_matrix"]


class SinsConfig(BaseModel):
    """Configuration of ``sins``.

    Attributes
    ----------
    height_damping : {"auto", "none", "baro"}
        ``baro`` damps the vertical channel with the barometer (the bundle must have one),
        ``none`` leaves it free (it diverges with the time constant ``sqrt(R / 2 g)`` ~ 570 s),
        ``auto`` uses the barometer when the bundle has one.
    baro_tau_s : float
        Time constant of the critically damped barometric loop [s]
        (:mod:`inmotion.core.mechanization`).
    out_stride : int
        Output the initial state and then every ``out_stride``-th IMU epoch.
    """

    model_config = ConfigDict(extra="forbid")
    height_damping: Literal["auto", "none", "baro"] = Field(
        "auto",
        description="vertical channel: baro = damped by the barometer, none = free (diverges, "
                    "~570 s time constant), auto = baro if the bundle has one")
    baro_tau_s: float = Field(
        10.0, gt=0,
        description="time constant of the critically damped barometric height loop [s]")
    out_stride: int = cf.out_stride(1)


class DrConfig(BaseModel):
    """Configuration of ``dr``.

    Attributes
    ----------
    sensor : {"radar", "ldv", "odometer"} or None
        The forward-velocity sensor; None takes the first present of radar, ldv, odometer.
    speed_scale : float
        Multiplies the sensor's output (dimensionless): a sensor reading ``(1 + dk)`` times
        the truth is corrected by ``1 / (1 + dk)``.
    mounting_arcmin : [alpha, beta, gamma] or None
        The IMU's mounting angles in the vehicle [arcmin], ``C_v^b = exp([A x])`` (paper 000
        eq. 4-9, where the radar frame is the vehicle's; :func:`mounting_matrix`): the speed is
        put along ``C_v^b [0, 1, 0] ~ [-gamma, 1, alpha]`` in b. None: from ``meta.yaml``
        (``vehicle_mounting_arcmin``) if there, else the IMU is taken as aligned with the
        vehicle. A sensor's own beam misalignment (``sensors.<sensor>.mounting_arcmin``) is
        not used: it changes the reading only to second order.
    lever_arm_m : [x, y, z] or None
        The sensor's position in b relative to the IMU [m]; None: from ``meta.yaml``
        (``sensors.<sensor>.lever_arm_m``) if there, else zero. The IMU moves along the
        vehicle's forward axis and the sensor reads the forward part of ``omega_eb x l`` on top,
        which the dead reckoner removes (:mod:`inmotion.core.deadreckoning`).
    max_gap_s : float or None
        Sensor gap threshold [s] (None: 5 sensor periods); see
        :mod:`inmotion.core.deadreckoning` for how gaps are bridged.
    out_stride : int
        Output the initial state and then every ``out_stride``-th IMU epoch.
    """

    model_config = ConfigDict(extra="forbid")
    sensor: Optional[Literal["radar", "ldv", "odometer"]] = Field(
        None,
        description="forward-velocity sensor; None: the first present of radar, ldv, odometer")
    speed_scale: float = Field(
        1.0, gt=0,
        description="multiplies the sensor's speed (1 / (1 + dk) undoes a scale-factor error dk)")
    mounting_arcmin: Optional[tuple[float, float, float]] = cf.mounting_arcmin(None)
    lever_arm_m: Optional[tuple[float, float, float]] = cf.lever_arm_m(None)
    max_gap_s: Optional[float] = Field(
        None, gt=0, description="sensor gap threshold [s]; None: 5 sensor periods")
    out_stride: int = cf.out_stride(1)


def _require_init(init: Optional[NavState], method: str) -> NavState:
    if init is None:
        raise BadInput(f"method {method!r} needs an initial state (position, velocity, "
                       "attitude): use --init truth, --init RESULT or initial_* in meta.yaml")
    return init


def run_sins(bundle: Bundle, config: SinsConfig, init: NavState,
             progress: Optional[Callable[[float], None]] = None) -> Solution:
    """Pure strapdown inertial navigation from ``init``.

    Parameters
    ----------
    bundle : Bundle
        Uses ``imu`` and, for height damping, ``baro``.
    config : SinsConfig
    init : NavState
        The starting state; rows with ``t > init.t`` are processed.
    progress : callable, optional
        ``progress(fraction)``; called at the end (the mechanization is one fast pass).

    Returns
    -------
    Solution
        ``info`` holds ``method``, ``config`` (echo) and ``timing`` (``run_s``).
    """
    init = _require_init(init, "sins")
    damping = config.height_damping
    if damping == "auto":
        damping = "baro" if bundle.baro is not None else "none"
    if damping == "baro" and bundle.baro is None:
        raise BadInput("height_damping='baro' but the bundle has no barometer (baro table)")
    t0 = time.perf_counter()
    n, _, pieces, k0 = bundle.imu_rows_after(init.t, min_rows=0)   # whole, or in chunks
    sol = strapdown_rows(n, pieces, init, bundle.baro if damping == "baro" else None,
                         damping=damping, out_stride=config.out_stride,
                         baro_tau=config.baro_tau_s, first_row=k0)
    run_s = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    sol.info.update(method="sins", config=config.model_dump(mode="json"),
                    timing={"run_s": run_s}, height_damping=damping)
    return sol


def mounting_matrix(angles_rad) -> np.ndarray:
    """``C_bm = C_v^b = exp([A x])``, the vehicle's (= the speed's) frame in the IMU frame, from
    the mounting angles ``A = [alpha, beta, gamma]`` [rad].

    The package's one mounting function, :func:`inmotion.core.rotations.mounting_dcm`, which
    the simulator uses too (paper 000 eq. 4-9 to first order, ``I + [A x]``).
    """
    return rotations.mounting_dcm(np.asarray(angles_rad, dtype=float).reshape(3))


def _three_numbers(value, where: str):
    if value is None:
        return None
    try:
        return np.asarray(value, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise BadInput(f"meta.yaml {where} must be 3 numbers, got {value!r}") from None


def mounting_from_meta(meta: dict, sensor: str):
    """``(vehicle_mounting_arcmin, lever_arm_m)`` for dead reckoning with ``sensor``.

    The mounting is the IMU's in the vehicle, ``meta['vehicle_mounting_arcmin']`` (top level,
    one for all sensors: they all read the vehicle's forward speed); the lever arm is
    ``meta['sensors'][sensor]['lever_arm_m']`` (in b). Either is None when absent. Raises
    :class:`BadInput` if present but not 3 numbers.
    """
    meta = meta or {}
    spec = (meta.get("sensors") or {}).get(sensor) or {}
    lever = spec.get("lever_arm_m") if isinstance(spec, dict) else None
    return (_three_numbers(meta.get("vehicle_mounting_arcmin"), "vehicle_mounting_arcmin"),
            _three_numbers(lever, f"sensors.{sensor}.lever_arm_m"))


def velocity_source(bundle: Bundle, sensor, mounting_arcmin, lever_arm_m):
    """The forward-velocity sensor a dead reckoner uses and where it sits.

    Parameters
    ----------
    bundle : Bundle
    sensor : str or None
        ``radar``, ``ldv``, ``odometer``, or None for the bundle's first one
        (:meth:`Bundle.velocity_sensor`).
    mounting_arcmin, lever_arm_m : 3 numbers or None
        The configuration's values; None takes them from ``meta.yaml``
        (:func:`mounting_from_meta`).

    Returns
    -------
    ``(name, SpeedData, mount, lever_arm_b)``: the vehicle mounting ``[alpha, beta, gamma]``
    [arcmin] as given (None: none known) and the lever arm [m] in b as a float array (None:
    none known). Raises :class:`BadInput` when the bundle has no such sensor.
    """
    try:
        name, speed = bundle.velocity_sensor(sensor)
    except ValueError as e:
        raise BadInput(str(e)) from None
    meta_mount, meta_lever = mounting_from_meta(bundle.meta, name)
    mount = mounting_arcmin if mounting_arcmin is not None else meta_mount
    lever = lever_arm_m if lever_arm_m is not None else meta_lever
    lever_arm_b = None if lever is None else np.asarray(lever, dtype=float)
    return name, speed, mount, lever_arm_b


def run_dr(bundle: Bundle, config: DrConfig, init: NavState,
           progress: Optional[Callable[[float], None]] = None) -> Solution:
    """Pure dead reckoning from ``init`` with the gyros and one forward-velocity sensor.

    Parameters
    ----------
    bundle : Bundle
        Uses ``imu`` and the chosen velocity sensor.
    config : DrConfig
    init : NavState
        The starting state (its velocity is not used after the first speed sample).
    progress : callable, optional
        ``progress(fraction)``; called at the end.

    Returns
    -------
    Solution
        ``info`` holds ``method``, ``config``, ``timing``, ``sensor`` (the one used),
        ``mounting_arcmin`` (the vehicle mounting used) and ``lever_arm_m``.

    Notes
    -----
    With the true vehicle mounting and lever arm and error-free sensors the dead reckoner
    reproduces the simulated truth up to its discretization (attitude as the SINS; distance
    interpolated to IMU epochs). Without the mounting (``C_v^b = I`` assumed) it errs to first
    order: cross-track ``gamma * d`` (to the right for gamma > 0, the speed is put along
    ``+y`` instead of ``[-gamma, 1, alpha]``) and vertically ``-alpha * d`` after a distance
    ``d`` (``tests/test_navigate_pure.py``).
    """
    init = _require_init(init, "dr")
    name, speed, mount, lever_arm_b = velocity_source(bundle, config.sensor,
                                                      config.mounting_arcmin, config.lever_arm_m)
    C_bm = None if mount is None else mounting_matrix(np.radians(np.asarray(mount) / 60.0))
    t0 = time.perf_counter()
    n, _, pieces, k0 = bundle.imu_rows_after(init.t, min_rows=0)   # whole, or in chunks
    sol = dead_reckon_rows(n, pieces, speed, init, C_bm=C_bm, lever_arm_b=lever_arm_b,
                           scale=config.speed_scale, out_stride=config.out_stride,
                           max_gap=config.max_gap_s, first_row=k0)
    run_s = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    sol.info.update(method="dr", config=config.model_dump(mode="json"), timing={"run_s": run_s},
                    sensor=name,
                    mounting_arcmin=None if mount is None else [float(x) for x in mount],
                    lever_arm_m=None if lever_arm_b is None else [float(x) for x in lever_arm_b])
    return sol
