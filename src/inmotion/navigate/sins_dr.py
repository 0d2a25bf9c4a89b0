"""Integrated position and orientation from a SINS and gyro / Doppler-radar dead reckoning:
method ``sins-dr`` (paper 002).

Yang et al., *Accurate integrated position and orientation method for vehicles based on
SINS/Doppler radar*, Meas. Control 2018. The SINS and a dead reckoner (DR: the SINS's own gyros
for attitude, the radar's forward speed for velocity and position, paper 002 eq. 1-19) run side
by side; a Kalman filter estimates the errors of both and corrects both in closed loop
(engine: :mod:`inmotion.estimation.engine`, fed by :mod:`inmotion.estimation.velocity_aided`).

States (22, layout :data:`LAYOUT_SINS_DR`; paper 002 "system states", which are paper 000
eq. 21 without the radar installation angles, as paper 002 says they are calibrated out)::

    phi (3)  dv (3)  dp (3)  eps (3)  nabla (3)  phi_D (3)  dp_D (3)  dk (1)

with the one shared error model (:mod:`inmotion.estimation.error_model`: paper 000's F with
the derived ``-C_b^n eps`` in the DR attitude rows; the DR velocity error eq. 11 enters through
the DR position rows; ``dk`` first-order Markov, paper 002 eq. 22). Where the IMU's mounting
in the vehicle is not given (a real log; paper 002 assumes it calibrated) the mounting angles
come back as states, paper 000 eq. 21 whole (25 states, :data:`LAYOUT_SINS_DR_MOUNT`,
:func:`estimates_mounting`).

Modes (``mode`` in the configuration; ``--mode`` on the command line):

``attitude-position`` (paper 002 eq. 44-51, the paper's proposal)
    ``z = [yaw, pitch, roll]_SINS - [yaw, pitch, roll]_DR`` and
    ``[lat, lon, h]_SINS - [lat, lon, h]_DR``. The paper's eq. 45-50 (heading, pitch and roll
    errors in terms of the platform angles) are lost from its text; they are paper 000 eq.
    25-27 (:func:`error_model.euler_rows`), which hold as printed in the DESIGN convention.
``velocity-position`` (paper 002 eq. 52-55, the paper's comparison)
    ``z = v_SINS - v_DR`` and the position difference; the DR velocity error is paper 000
    eq. 11 without the mounting angles, ``dv_D = [v x] phi_D + dk v``.

Choices where the paper is silent (documented, not tuned to a seed):

* measurement and filter rate 10 Hz by default; updates are applied group by group (gated
  sequential scalar Joseph updates); the gate is off by default (``gate_probability = 1``):
  nothing in the model makes a SINS-minus-DR difference an outlier, and a gate that starts
  rejecting a diverging filter's updates never recovers;
* measurement noise: the attitude difference of two systems on the same gyros is nearly
  noise-free, 0.2 arcmin covers linearization and the DR's midpoint attitude; the position
  difference 0.5 m. The velocity difference is resolved in the DR's body frame: along the
  vehicle it carries the sensor's white noise (``velocity_noise_m_s``, 0.1 m/s, paper 000's
  figure); across and up (``velocity_cross_noise_m_s``) the DR velocity is zero by
  construction, and what the difference sees there is the vehicle's own lateral and vertical
  motion, for which 0.1 m/s (the usual non-holonomic noise, as ``dr-kf``'s) is the default:
  the same isotropic 0.1 m/s a per-axis reading of paper 002 gives. The DR position random
  walk from the sensor noise is process noise (:mod:`inmotion.estimation.velocity_aided`);
* noise settings (issue 15): with ``noise_preset: matched`` (the default) the IMU figures, the
  sensor's noise and scale-factor model and the cross-axis noise that the configuration does not
  set come from ``meta.yaml`` by ``dr-kf``'s rules (:func:`config_with_spec`, origins in
  ``info["config_source"]``); ``paper`` keeps the field defaults. Measured
  (``benchmarks/nees_methods.py 20 sins-dr``, paper 003's drive cut to 85 s, LDV, IMU figures
  and speed noise set as in ``tests/test_consistency_nees_other.py``, start 0.1 / 0.1 / 0.5 deg
  off): final-attitude NEES over 20 runs 2.64 with the field defaults for the rest, 2.95 matched
  (the LDV's 500 ppm constant scale factor in place of the 1000 ppm / 300 s Markov default;
  per axis E / N / U 1.58 / 0.71 / 0.66), band 2.02-4.16;
* the DR's position random walk (issue 15, session 20): besides the sensor's white noise,
  under ``matched`` the vehicle's lateral and vertical motion, which the DR takes as zero,
  ``2 sigma^2 tau`` of ``meta.yaml``'s ``vehicle.constraint_violation``
  (``dr_violation_rw_m2_s``; isotropic, as the engine's walk is, so conservative along
  track); and the start's level prior no tighter than the accelerometer bias over g
  (:func:`level_prior`). On comma2k19 (defaults, ``--init truth``) the three together took the
  run from 8.1x (heading 1309 arcmin off at 300, 192 m at 24 m) to 0.6x at most;
* the vertical channel: the SINS height is held by the position difference to the DR's height
  (the paper's measurement); a barometer can be added (``use_baro``);
* the scale factor ``dk`` is estimated, not fed back (the DR keeps the raw sensor speed).

What the measurements carry (measured, ``inmotion.reproductions.paper002``): the SINS and
the DR share the gyros and start from the same attitude, so ``phi - phi_D`` grows only from
the difference of their transport rates, ``Wen_v (dv - dv_D) ~ (dv - dv_D) / R``: the attitude
rows see the integral of the velocity-error difference that the position rows see, scaled by
``1 / R`` (1 m of position difference is 0.0005'). Open loop (pure SINS against pure DR,
velocity errors of m/s) it reaches about 1' in the hour; in the closed loop (cm/s) thousandths
of an arcminute, and the attitude/position mode behaves as a position-only filter: its results
do not change between 0.02' and 2' of attitude noise. Heading is learnt only by
gyrocompassing through the position difference (the SINS's tilt from ``omega_ie x phi_U``
makes it drift from the DR), slowly (1-sigma 1.8' -> 0.9' over the hour); the vertical gyro
drift is not observable. The velocity/position mode is worse than attitude/position with the
default cross-track noise at 10 Hz (as the paper found) and equal at 1 Hz; the comparison
depends on how the velocity difference is weighted across the vehicle, which the paper does not
give: on paper 002's drive (``inmotion reproduce 002``, 20 runs, paired per drive) it beats
attitude/position only below a cross-axis noise of about 0.009 m/s for the horizontal maximum
(bootstrap 95 % 0.004-0.015 m/s) and 0.007 m/s for the heading maximum (0.005-0.010 m/s).

Velocity source: the radar by default, or any forward-velocity sensor of the bundle
(``velocity_sensor``: ``radar``, ``ldv``, ``odometer``); its mounting and lever arm are taken
from the configuration or ``meta.yaml`` as for method ``dr`` (the IMU's mounting in the
vehicle, ``vehicle_mounting_arcmin``, and the sensor's lever arm).
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import ConfigDict, Field
from .. import config_fields as cf
from ..estimation import chi2
from ..align.meta_spec import UNKNOWN_MOUNTING_SIGMA_ARCMIN

from ..core import earth
from ..core.bundle import Bundle
from ..core.mechanization import _baro_on_imu, start_row
from ..core.solution import NavState, Solution
from ..errors import BadInput
from ..estimation import error_model as em
from ..estimation.layout import Layout, position_units
from ..estimation.velocity_aided import (GROUP_SIZES, GROUPS, ZUPT_ORIGIN, StopUpdateFields,
                                         VelocityAidedRun, dr_gyro_rows, with_dr_gyro,
                                         zupt_noise_from_meta)
from .pure import mounting_matrix, velocity_source

__all__ = ["SinsDrConfig", "run_sins_dr", "LAYOUT_SINS_DR", "LAYOUT_SINS_DR_MOUNT", "MODES",
           "initial_covariance", "config_with_spec", "estimates_mounting"]

ARCMIN = np.pi / 180.0 / 60.0
DEG_H = np.pi / 180.0 / 3600.0
UG = earth.G0 * 1e-6

#: paper 002's states: paper 000 eq. 21 without the mounting angles
LAYOUT_SINS_DR = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "dk"])
#: with the mounting angles back (paper 000 eq. 21 whole, ``dr-kf``'s layout): where the
#: mounting is not given (``estimate_mounting``)
LAYOUT_SINS_DR_MOUNT = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount",
                               "dk"])
#: measurement groups of each mode (paper 002 eq. 44 and 52)
MODES = {"attitude-position": ("attitude", "position"),
         "velocity-position": ("velocity", "position")}


class SinsDrConfig(StopUpdateFields):
    """Configuration of ``sins-dr``; every field carries its unit in its name.

    Priors are 1-sigma at the start (a fine-aligned SINS; the DR starts from the same state,
    so its errors start equal to the SINS's). Sensor figures default to paper 002 (gyro drift
    0.01 deg/h) and, where its text lost them, paper 000 sec. 5.

    Attributes (beyond the priors and noise densities, whose names carry their units)
    ----------
    mode : ``attitude-position`` or ``velocity-position`` (paper 002 eq. 44 / 52)
    velocity_sensor : radar, ldv or odometer; None takes the first present
    filter_rate_hz, measurement_rate_hz, output_rate_hz : rounded to whole IMU rows /
        filter epochs; output defaults to the filter rate
    use_baro : add the barometric height measurement (not in the paper)
    gate_probability : chi-square gate per measurement group (1: off)
    dr_sees_gyro_drift : keep ``-C_b^n eps`` in the DR attitude rows (error_model)
    mounting_arcmin : the IMU's mounting in the vehicle (``C_v^b``) for the DR; None: meta
    estimate_mounting, mount_sigma_arcmin : the mounting angles as states
        (:func:`estimates_mounting`; not in paper 002)
    lever_arm_m : the sensor's lever arm in b; None: meta
    speed_noise_m_s : the sensor's white noise, for the DR position random walk
    velocity_noise_m_s, velocity_cross_noise_m_s : velocity-difference noise along and
        across / up the vehicle (velocity/position mode)
    """

    model_config = ConfigDict(extra="forbid")
    mode: Literal["attitude-position", "velocity-position"] = Field(
        "attitude-position",
        description="measurement: attitude-position (paper 002 eq. 44) or velocity-position (eq. "
                    "52)")
    velocity_sensor: Optional[Literal["radar", "ldv", "odometer"]] = cf.velocity_sensor(None)
    noise_preset: Literal["matched", "paper"] = Field(
        "matched",
        description="matched: the IMU figures, the sensor's speed noise and scale-factor model "
                    "and the cross-axis noise from the vehicle's constraint violation that the "
                    "configuration does not set come from meta.yaml (config_with_spec); paper: "
                    "the field defaults (paper 002, paper 000 sec. 5) whatever the bundle says")
    filter_rate_hz: float = cf.filter_rate_hz(10.0)
    measurement_rate_hz: float = cf.measurement_rate_hz(10.0)
    output_rate_hz: Optional[float] = Field(
        None, gt=0, description="rate of the output rows [Hz]; None: the filter rate")
    use_baro: bool = cf.use_baro(False)
    gate_probability: float = cf.gate_probability(1.0)
    smooth: bool = cf.smooth(False)
    second_order_rows: bool = cf.second_order_rows()
    #: on (issue 15, session 24, measured): on the simulated city drive (100 + 50 deg/h
    #: gyro, ``benchmarks/nees_invariant.py sins-dr``, 5 runs) heading NEES 6.25 -> 0.43; on
    #: the phone drive without the mounting block (paper 002's 22 states, a mounting of 228 /
    #: -48 arcmin unknown to it, seeds 0-2) heading 28 deg -> 1-3 deg off, horizontal 205 -> 43-72 m
    invariant_velocity_error: bool = cf.invariant_velocity_error(True)
    dr_sees_gyro_drift: bool = cf.dr_sees_gyro_drift(True)
    mounting_arcmin: Optional[tuple[float, float, float]] = cf.mounting_arcmin(None)
    lever_arm_m: Optional[tuple[float, float, float]] = cf.lever_arm_m(None)
    estimate_mounting: Optional[bool] = Field(
        None,
        description="add paper 000 eq. 11's mounting angles to the states (LAYOUT_SINS_DR_MOUNT, "
                    "prior mount_sigma_arcmin); None: where the mounting is given neither here "
                    "nor in meta.yaml (vehicle_mounting_arcmin), which paper 002 assumes "
                    "calibrated")
    mount_sigma_arcmin: float = Field(
        UNKNOWN_MOUNTING_SIGMA_ARCMIN, ge=0,
        description="initial 1-sigma of the mounting angles when they are estimated [arcmin] "
                    "(default: an installation nobody surveyed)")
    mount_rw_arcmin_sqrt_s: float = cf.mount_rw_arcmin_sqrt_s(0.0)
    # priors
    init_tilt_sigma_arcmin: float = Field(
        1.0, gt=0, description="initial 1-sigma of the level (pitch, roll) error [arcmin]")
    init_heading_sigma_arcmin: float = Field(
        5.0, gt=0, description="initial 1-sigma of the heading error [arcmin]")
    init_velocity_sigma_m_s: float = cf.init_velocity_sigma_m_s(0.1)
    init_position_sigma_m: float = cf.init_position_sigma_m(15.0)
    gyro_drift_deg_h: float = cf.gyro_drift_deg_h(0.01)
    accel_bias_ug: float = cf.accel_bias_ug(100.0)
    dk_sigma_ppm: float = cf.dk_sigma_ppm(1000.0)
    dk_tau_s: float = cf.dk_tau_s(300.0)
    # process noise
    gyro_arw_deg_sqrt_h: float = cf.gyro_arw_deg_sqrt_h(0.003)
    accel_vrw_ug_sqrt_hz: float = cf.accel_vrw_ug_sqrt_hz(10.0)
    gyro_bias_rw_deg_h_sqrt_h: float = cf.gyro_bias_rw_deg_h_sqrt_h(0.0)
    accel_bias_rw_ug_sqrt_h: float = cf.accel_bias_rw_ug_sqrt_h(0.0)
    speed_noise_m_s: float = Field(
        0.1, ge=0,
        description="white noise of the sensor's speed, drives the DR position random walk [m/s]")
    # measurement noise
    attitude_noise_arcmin: float = cf.attitude_noise_arcmin(0.2)
    position_noise_m: float = Field(
        0.5, gt=0, description="1-sigma of the SINS-minus-DR position measurement [m]")
    velocity_noise_m_s: float = cf.velocity_noise_m_s(0.1)
    velocity_cross_noise_m_s: float = Field(
        0.1, gt=0,
        description="1-sigma of the velocity difference across and up the vehicle [m/s]")
    dr_violation_rw_m2_s: float = Field(
        0.0, ge=0,
        description="DR position random walk from the vehicle's lateral and vertical motion, "
                    "which the DR takes as zero [m^2/s]: 2 sigma^2 tau of the constraint "
                    "violation (matched: from meta.yaml vehicle.constraint_violation)")
    baro_noise_m: float = cf.baro_noise_m(2.0)


def level_prior(cfg: SinsDrConfig) -> dict:
    """``{"init_tilt_sigma_arcmin": b / g}`` where the accelerometer bias ``b``
    (``accel_bias_ug``, the spec's under ``matched``) puts it above the field default, else
    ``{}``. The start of a navigation method comes from an alignment of the same IMU, whose
    level is known no better than the accelerometer bias over gravity (a still or moving
    alignment takes gravity's direction in the accelerometer's axes; paper 000 sec. 5: 0.5
    arcmin for 100 ug). The default 1 arcmin is a navigation-grade IMU's; a phone's 10000 ug is
    34 arcmin. Measured on comma2k19 (``--init truth``, defaults; the reference is the
    camera's attitude, of no stated accuracy, and against it the phone's forward specific
    force moves by 0.05 m/s^2, 17 arcmin of pitch, between 45 and 60 s): with 1 arcmin the East
    tilt ended 29 arcmin off at a 13.5 arcmin sigma (2.1x), with 34 arcmin 4 at 21 (0.2x)."""
    tilt = float(np.arctan(cfg.accel_bias_ug * 1e-6) / ARCMIN)
    default = type(cfg).model_fields["init_tilt_sigma_arcmin"].default
    return {"init_tilt_sigma_arcmin": tilt} if tilt > default else {}


def config_with_spec(cfg: SinsDrConfig, meta, sensor: str) -> tuple:
    """``(cfg, config_source)``: with ``noise_preset: matched``, ``cfg`` with the fields it does
    not set taken from the bundle's ``meta.yaml``, by the rules ``dr-kf`` uses
    (:func:`inmotion.align.dr_kalman.config_with_spec`, one rule for both): the IMU figures
    (``gyro_drift_deg_h``, ``gyro_arw_deg_sqrt_h``, ``accel_bias_ug``, ``accel_vrw_ug_sqrt_hz``
    from ``meta['imu']``; a simulated IMU's fixed constant errors are not a specification);
    the sensor's forward noise at a measurement epoch (``velocity_noise_m_s``) and its
    scale-factor model (``dk_sigma_ppm``, ``dk_tau_s``) from ``meta['sensors'][sensor]``
    (:func:`inmotion.align.dr_kalman.sensor_spec_fields`); ``speed_noise_m_s`` (the DR position
    random walk) the sensor's per-sample white noise ``noise_m_s``; and
    ``velocity_cross_noise_m_s`` from the vehicle's constraint violation (the white equivalent
    at the measurement interval, :func:`inmotion.align.aided_kf.vehicle_constraint_noise`, the
    larger of the lateral and vertical figures); ``zupt_noise_m_s`` on a still simulated vehicle
    (:func:`inmotion.estimation.velocity_aided.zupt_noise_from_meta`). ``paper`` keeps every
    field as configured.
    ``{field: origin}`` says where each value came from (``config``, ``meta.imu (simulated)``,
    ``meta.sensors ...``, ``default``). A Gauss-Markov bias in the spec becomes the bias
    random walks (:func:`inmotion.align.meta_spec.markov_as_random_walk`). A sensor whose
    spec states no scale factor gets a 10000 ppm constant, as ``dr-kf``
    (:func:`inmotion.align.meta_spec.unknown_installation_priors`)."""
    from ..align.meta_spec import (constant_bias_imu_spec, fields_not_set, sensor_spec_fields,
                                   unknown_dk_prior, vehicle_constraint_noise)
    matched = cfg.noise_preset == "matched"
    cfg, src = constant_bias_imu_spec(cfg, meta, matched)
    spec, origin = sensor_spec_fields(meta, sensor) if matched else ({}, "")
    sp = ((meta.get("sensors") or {}).get(sensor) if matched and isinstance(meta, dict)
          and isinstance(meta.get("sensors"), dict) else None)
    if isinstance(sp, dict) and float(sp.get("noise_m_s") or 0.0) > 0.0:
        # a zero (the white noise switched off in a simulation) is no filter setting (as
        # dr_kalman._imu_spec_meta's zero densities): the configuration's is kept
        spec["speed_noise_m_s"] = float(sp["noise_m_s"])
    upd, s1 = fields_not_set(cfg, ("velocity_noise_m_s", "speed_noise_m_s", "dk_sigma_ppm",
                                   "dk_tau_s"), spec, origin)
    if matched:                    # a speed whose scale nobody stated: dr-kf's rule
        u1, s1u = unknown_dk_prior(cfg, meta, sensor)
        upd.update(u1)
        s1.update(s1u)
    interval = 1.0 / cfg.measurement_rate_hz
    cv = vehicle_constraint_noise(meta, interval) if matched else None
    # the white equivalent s_T of the interval means gives s_T^2 T = 2 sigma^2 tau whatever T
    u2, s2 = fields_not_set(cfg, ("velocity_cross_noise_m_s", "dr_violation_rw_m2_s"),
                            {} if cv is None else {"velocity_cross_noise_m_s": max(cv),
                                                   "dr_violation_rw_m2_s":
                                                       max(cv) ** 2 * interval},
                            "meta.vehicle.constraint_violation")
    upd.update(u2)
    u3, s3 = fields_not_set(cfg, ("zupt_noise_m_s",), zupt_noise_from_meta(meta) if matched else {},
                            ZUPT_ORIGIN)
    upd.update(u3)
    u4, s4 = fields_not_set(cfg, ("init_tilt_sigma_arcmin",),
                            level_prior(cfg) if matched else {},
                            "accel_bias_ug / g: the level of an alignment with this accelerometer")
    upd.update(u4)
    src.update(s1)
    src.update(s2)
    src.update(s3)
    src.update(s4)
    return (cfg.model_copy(update=upd) if upd else cfg), src


def process_noise(cfg: SinsDrConfig) -> em.ProcessNoise:
    """The shared model's noise densities in SI from the configuration's human units."""
    return em.ProcessNoise(
        gyro_arw=np.deg2rad(cfg.gyro_arw_deg_sqrt_h) / 60.0,
        accel_vrw=cfg.accel_vrw_ug_sqrt_hz * UG,
        gyro_bias_rw=cfg.gyro_bias_rw_deg_h_sqrt_h * DEG_H / 60.0,
        accel_bias_rw=cfg.accel_bias_rw_ug_sqrt_h * UG / 60.0,
        dk_sigma=cfg.dk_sigma_ppm * 1e-6, dk_tau=cfg.dk_tau_s,
        mount_rw=cfg.mount_rw_arcmin_sqrt_s * ARCMIN)


def initial_covariance(lay: Layout, cfg: SinsDrConfig, lat: float, h: float) -> np.ndarray:
    """Diagonal priors, with the DR's attitude and position errors equal to the SINS's
    (full correlation: both systems start from the same state)."""
    r_m, r_n = earth.radii(lat)
    pos = cfg.init_position_sigma_m
    tilt, head = cfg.init_tilt_sigma_arcmin * ARCMIN, cfg.init_heading_sigma_arcmin * ARCMIN
    var = {"phi": np.array([tilt, tilt, head]) ** 2,
           "dv": cfg.init_velocity_sigma_m_s ** 2,
           "dp": np.array([pos / (r_m + h), pos / ((r_n + h) * np.cos(lat)), pos]) ** 2,
           "eps": (cfg.gyro_drift_deg_h * DEG_H) ** 2,
           "nabla": (cfg.accel_bias_ug * UG) ** 2,
           "mount": (cfg.mount_sigma_arcmin * ARCMIN) ** 2,
           "dk": (cfg.dk_sigma_ppm * 1e-6) ** 2}
    P = lay.diag({k: v for k, v in var.items() if k in lay})
    for own, dr in (("phi", "phi_D"), ("dp", "dp_D")):
        block = P[lay[own], lay[own]]
        P[lay[dr], lay[dr]] = block
        P[lay[own], lay[dr]] = block
        P[lay[dr], lay[own]] = block
    return P


def _check_config(cfg: SinsDrConfig, bundle: Bundle):
    if cfg.measurement_rate_hz > cfg.filter_rate_hz * (1 + 1e-9):
        raise BadInput(f"measurement_rate_hz ({cfg.measurement_rate_hz}) must not exceed "
                       f"filter_rate_hz ({cfg.filter_rate_hz})", file="config")
    if cfg.output_rate_hz is not None and cfg.output_rate_hz > cfg.filter_rate_hz * (1 + 1e-9):
        raise BadInput(f"output_rate_hz ({cfg.output_rate_hz}) must not exceed "
                       f"filter_rate_hz ({cfg.filter_rate_hz})", file="config")
    if cfg.use_baro and bundle.baro is None:
        raise BadInput("use_baro is set but the bundle has no barometer (baro table)",
                       file="config")


def _sensor(bundle: Bundle, cfg: SinsDrConfig):
    """``(name, SpeedData, C_bm, lever_arm_b)`` of the velocity source."""
    name, speed, mount, l_b = velocity_source(bundle, cfg.velocity_sensor, cfg.mounting_arcmin,
                                              cfg.lever_arm_m)
    C_bm = None if mount is None else mounting_matrix(np.asarray(mount, dtype=float) * ARCMIN)
    return name, speed, C_bm, l_b


def estimates_mounting(cfg: SinsDrConfig, meta) -> bool:
    """Whether the run carries the mounting angles as states (:data:`LAYOUT_SINS_DR_MOUNT`).

    Paper 002 drops paper 000's installation angles, "calibrated out", and its DR takes the
    sensor's speed along the vehicle's forward axis turned by the nominal ``C_v^b``. Where
    nobody gave that mounting (no ``mounting_arcmin``, no ``meta.yaml``
    ``vehicle_mounting_arcmin``: a real log, an installation nobody surveyed) the DR runs along
    the IMU's own forward axis, and the mounting's pitch and yaw go one to one into the DR's
    velocity. Measured on comma2k19 with the defaults from the reference (the phone pitched
    3.8 deg, yawed -0.8 deg; ``inmotion reproduce real``, defaults table): without the angles
    the heading ended 1309 arcmin off at a 300 arcmin floored sigma and the position 192 m
    off at 24 m (8.1x). The angles are then estimated as in ``dr-kf`` (paper 000 eq. 11 in
    full, ``dv_D = [v x] phi_D + [v x] C_b^n A + dk v``; the shared F builder,
    :mod:`inmotion.estimation.error_model`), from ``mount_sigma_arcmin`` (300 arcmin, the
    unknown installation's prior, :data:`inmotion.align.meta_spec.
    UNKNOWN_MOUNTING_SIGMA_ARCMIN`). ``estimate_mounting`` True / False decides it
    explicitly; where the mounting is given the paper's 22 states stay the default."""
    if cfg.estimate_mounting is not None:
        return bool(cfg.estimate_mounting)
    given = isinstance(meta, dict) and meta.get("vehicle_mounting_arcmin") is not None
    return cfg.mounting_arcmin is None and not given


def _rates(cfg: SinsDrConfig, imu_dt: float):
    """IMU rows per filter epoch; measurement and output decimation in filter epochs."""
    step = max(1, int(round(1.0 / (cfg.filter_rate_hz * imu_dt))))
    f_filter = 1.0 / (step * imu_dt)
    meas_every = max(1, int(round(f_filter / cfg.measurement_rate_hz)))
    out_rate = cfg.output_rate_hz or cfg.filter_rate_hz
    out_every = max(1, int(round(f_filter / out_rate)))
    return step, meas_every, out_every


def build_filter(bundle: Bundle, cfg: SinsDrConfig, init: NavState):
    """The configured :class:`VelocityAidedRun` and what it runs on: ``(filter, rows, sensor)``
    with ``rows`` the IMU slice after ``init.t`` and ``sensor = (name, SpeedData)``."""
    _check_config(cfg, bundle)
    sensor = _sensor(bundle, cfg)
    cfg, _ = config_with_spec(cfg, bundle.meta, sensor[0])
    imu = bundle.imu
    k0 = start_row(imu.t, init.t)
    filt = _make_filter(bundle, cfg, init, sensor, float(np.median(np.diff(imu.t))))
    return filt, slice(k0, len(imu.t)), sensor[:2]


def _make_filter(bundle, cfg: SinsDrConfig, init: NavState, sensor, imu_dt: float):
    """The configured :class:`VelocityAidedRun` for an IMU of median period ``imu_dt`` [s];
    ``sensor`` = ``(name, SpeedData, C_bm, lever_arm_b)`` (:func:`_sensor`)."""
    name, speed, C_bm, l_b = sensor
    step, meas_every, out_every = _rates(cfg, imu_dt)
    lay = LAYOUT_SINS_DR_MOUNT if estimates_mounting(cfg, bundle.meta) else LAYOUT_SINS_DR
    model = em.ErrorModel(lay, process_noise(cfg), dr_sees_gyro_drift=cfg.dr_sees_gyro_drift)
    sensor_dt = float(np.median(np.diff(speed.t)))
    use = {g: g in MODES[cfg.mode] for g in GROUPS}
    use["height"] = cfg.use_baro
    use["zero_velocity"] = bool(cfg.stops_s)
    gates = {g: (float(chi2.ppf(cfg.gate_probability, m)) if cfg.gate_probability < 1 else 0.0)
             for g, m in GROUP_SIZES.items()}
    noise = {"attitude_rad": cfg.attitude_noise_arcmin * ARCMIN,
             "position_m": cfg.position_noise_m,
             "velocity_b_m_s": (cfg.velocity_cross_noise_m_s, cfg.velocity_noise_m_s,
                                cfg.velocity_cross_noise_m_s),
             "height_m": cfg.baro_noise_m,
             "dr_position_m2_s": cfg.speed_noise_m_s ** 2 * sensor_dt
             + cfg.dr_violation_rw_m2_s,
             "zupt_m_s": cfg.zupt_noise_m_s}
    return VelocityAidedRun(init, lay, model, initial_covariance(lay, cfg, init.lat, init.h),
                            use=use, noise=noise, gates=gates, step_rows=step,
                            meas_every=meas_every, out_every=out_every, C_bm=C_bm,
                            lever_arm_b=l_b, smooth=cfg.smooth, stops_s=cfg.stops_s,
                            second_order=cfg.second_order_rows,
                            invariant_velocity=cfg.invariant_velocity_error)


def _baro_source(bundle: Bundle, cfg: SinsDrConfig):
    if not cfg.use_baro:
        return None
    baro = bundle.baro
    max_gap = 5.0 * float(np.median(np.diff(baro.t)))
    return lambda t: _baro_on_imu(baro, t, max_gap)


def _solution(filt: VelocityAidedRun, out: dict, cfg: SinsDrConfig, sensor: str,
              wall: float) -> Solution:
    lay = filt.layout
    xs = out["x_sins"]
    sig = lay.as_dict(out["sigma"])
    lat, h = xs[:, 0], xs[:, 2]
    r_m, r_n = earth.radii(lat)
    sigma = {"phi_E": sig["phi_E"], "phi_N": sig["phi_N"], "phi_U": sig["phi_U"],
             "vE": sig["dv_E"], "vN": sig["dv_N"], "vU": sig["dv_U"],
             "north": sig["dp_lat"] * (r_m + h),
             "east": sig["dp_lon"] * (r_n + h) * np.cos(lat), "h": sig["dp_h"], "dk": sig["dk"]}
    info = {"method": "sins-dr", "mode": cfg.mode, "config": cfg.model_dump(mode="json"),
            "velocity_sensor": sensor, "layout": list(lay.names),
            "velocity_error": filt.filter.velocity_error,
            "filter_step_rows": filt.step, "measurement_every_filter_steps": filt.meas_every,
            "measurements": filt.counts(), "nis": filt.filter.nis_summary(),
            "timing": {"run_s": wall},
            "rows_without_speed": filt.rows_without_speed,
            "rows_in_speed_gaps": filt.rows_in_speed_gaps,
            "samples_skipped_blind": filt.samples_skipped_blind,
            "dr_reseeds": filt.dr_reseeds, "smoothed": bool(cfg.smooth)}
    states = lay.as_dict(out["states"])
    units = lay.unit_map(position_units(filt.init.lat, filt.init.h))
    for name in ("mount_x", "mount_y", "mount_z"):      # estimated where not given
        if name in sig:
            states[f"sigma_{name}"] = sig[name]         # 1-sigma, in the state's unit
            units[f"sigma_{name}"] = units[name]
    return Solution.from_arrays(out["t"], xs[:, 0:3], xs[:, 3:6], xs[:, 6:10], sigma=sigma,
                                states=states, state_units=units, info=info)


def run_sins_dr(bundle: Bundle, config: SinsDrConfig | dict | None = None,
                init: NavState | None = None,
                progress: Optional[Callable[[float], None]] = None, *,
                dtheta_dr=None, select=None, output_times=None) -> Solution:
    """``sins-dr``: SINS / dead-reckoning integrated position and orientation (paper 002).

    ``select``: which output rows to keep (:meth:`inmotion.estimation.velocity_aided.
    VelocityAidedRun.run_stream`; None: all; ``inmotion process`` keeps its output rate's).
    ``output_times``: a callable given the kept output rows' times as the run makes them
    (:meth:`~inmotion.estimation.velocity_aided.VelocityAidedRun.run_stream`; the command
    line's truth rows for the errors are read meanwhile).

    ``dtheta_dr`` (N, 3) [rad], one row per IMU row, or None: the gyro increments the dead
    reckoner integrates when it has its own gyro (as ``run_dr_kf``'s; with
    ``dr_sees_gyro_drift=False`` a gyro without the IMU's drift, the drift-free DR of paper
    000's printed F).

    Parameters
    ----------
    bundle : Bundle or inmotion.io.bundle_stream.BundleStream
        Needs ``imu`` and a forward-velocity sensor (``radar``, ``ldv`` or ``odometer``);
        ``baro`` when ``use_baro``. A bundle read in chunks is run as its IMU rows are read
        (the result is the same: the engine's chunks do not depend on the reading's).
    config : SinsDrConfig or dict (validated; a bad field raises :class:`BadInput`)
    init : NavState
        Start of the SINS and the DR (attitude needed).
    progress : callable(fraction), optional

    Returns
    -------
    Solution at the output rate: the closed-loop corrected SINS state; ``sigma`` of the
    misalignment, velocity, position (north, east, h [m]) and ``dk``; every named state
    (accumulated feedback plus the current estimate); ``info`` with the mode, the measurement
    counts and mean NIS per degree of freedom, timing, and the IMU rows the velocity sensor
    did not cover (``rows_without_speed``: the DR holds its position there, so a log whose
    sensor starts late or stops early should be cut to the sensor's span with ``--start`` /
    ``--end``) or covered across a gap (``rows_in_speed_gaps``; the measurement epochs there
    apply no sample that reads the speed, ``samples_skipped_blind``; as the speed comes
    back the DR's position is put on the SINS's, ``dr_reseeds``).
    """
    if init is None:
        raise BadInput("method 'sins-dr' needs an initial state with attitude (--init truth, "
                       "--init RESULT of an alignment, or initial_* in meta.yaml)")
    if isinstance(config, SinsDrConfig):
        cfg = config
    else:
        try:
            cfg = SinsDrConfig(**(config or {}))
        except Exception as exc:        # pydantic.ValidationError: name the first bad field
            err = exc.errors()[0] if hasattr(exc, "errors") else {"loc": (), "msg": str(exc)}
            raise BadInput(f"{'.'.join(map(str, err['loc'])) or 'config'}: {err['msg']}",
                           file="config") from None
    t0 = time.perf_counter()
    _check_config(cfg, bundle)
    sensor = _sensor(bundle, cfg)
    cfg, cfg_source = config_with_spec(cfg, bundle.meta, sensor[0])
    n_rows, imu_dt, pieces, k0 = bundle.imu_rows_after(init.t)   # whole, or read in chunks
    filt = _make_filter(bundle, cfg, init, sensor, imu_dt)
    name, speed = sensor[:2]
    if dtheta_dr is not None:                # the DR's own gyro (a bundle in memory)
        pieces = with_dr_gyro(pieces, dr_gyro_rows(bundle.imu, dtheta_dr,
                                                   slice(k0, k0 + n_rows)))
    out = filt.run_stream(pieces, n_rows, speed, h_baro=_baro_source(bundle, cfg), sensor=name,
                          progress=progress, select=select, output_times=output_times)
    sol = _solution(filt, out, cfg, name, time.perf_counter() - t0)
    if cfg.estimate_mounting is None and "mount" in filt.layout:
        cfg_source["estimate_mounting"] = ("the mounting is not given (no mounting_arcmin, no "
                                           "meta.yaml vehicle_mounting_arcmin)")
    sol.info["config_source"] = cfg_source
    if "mount" not in filt.layout:
        from ..align.meta_spec import note_unknown_mounting
        note_unknown_mounting(sol, "sins-dr", bundle.meta, cfg.mounting_arcmin)
    return sol
