"""In-motion fine alignment aided by a forward-velocity sensor (paper 000): ``dr-kf`` and the
velocity-matching baseline ``od-velocity-kf``.

``dr-kf`` (paper 000 sec. 4)
    A SINS and a gyro / Doppler-radar dead reckoner (DR) run side by side on the same gyros.
    The 25-state Kalman filter (eq. 21: ``phi, dv, dp, eps, nabla, phi_D, dp_D, mount, dk``,
    model from :mod:`inmotion.estimation.error_model`) uses

    * Z1 (eq. 23-31): SINS minus DR heading, pitch, roll and E, N, U velocity; the attitude
      rows are eq. 25-27 in the DESIGN Euler convention (:func:`error_model.euler_rows`), the
      velocity rows eq. 28-30 (``dv - dv_D``, :func:`error_model.dr_velocity_rows`);
    * Z2 (eq. 32-38): the SINS velocity on the body x and z axes, zero for a vehicle that
      neither slips nor jumps (:func:`error_model.nhc_rows`). The constraint holds in the
      vehicle frame v, which the mounting angles ``A`` turn away from the IMU frame b
      (docs/ARCHITECTURE.md "Vehicle frame and mounting"; ``C_v^b = I + [A x]``, the same
      angles as eq. 9-11): in b the lateral and vertical velocity are ``-gamma V`` and
      ``alpha V``. ``nhc_mount_terms=True`` (default) adds these mounting columns to eq. 37;
      ``False`` is eq. 37 as printed, right only for an IMU aligned with the vehicle;
    * optionally the barometric height (sec. 2: "the altitude output of the barometric
      altimeter replaces the SINS's"), as the measurement ``h_SINS - h_baro``.

    Each measurement group can be switched off. A chi-square gate on each group's innovation
    (probability ``gate_probability``) rejects slips and jumps instead of letting them pull
    the misalignment; every rejection is counted in ``Solution.info``.

``od-velocity-kf``
    The classic alignment by velocity matching: SINS velocity minus the sensor's speed mapped
    to n with the SINS attitude (:func:`error_model.sensor_velocity_rows`), 19 states
    ``phi, dv, dp, eps, nabla, mount, dk``, the same NHC and baro options, no DR.

Filter loop: both methods run on the one SINS + DR + Kalman engine of the package,
:class:`inmotion.estimation.engine.ErrorStateFilter`, fed by
:class:`inmotion.estimation.velocity_aided.VelocityAidedRun` (also paper 002's ``sins-dr``;
``od-velocity-kf`` on its layout without DR blocks, with the ``sensor_velocity`` measurement):
the whole loop (mechanizations, ``F`` at the SINS state, prediction, gated sequential Joseph
updates of the measurement plug-ins attitude, velocity, NHC, height, feedback) runs in numba,
the Python side only configures it and packs the :class:`Solution`. Per epoch the model is
linearized at the current SINS state, discretized (:func:`kalman.discretize`), and, at
measurement epochs, updated group by group in Joseph form. Closed loop
(default): the estimated SINS (and DR) attitude, velocity and position errors are fed back into
the mechanizations and reset to zero, the gyro drift and accelerometer bias are accumulated
into the IMU compensation subtracted from the increments. The mounting angles and the scale
factor are only estimated (the DR keeps its nominal mounting, identity, and scale 1; the
mounting in ``meta.yaml`` is the simulator's truth and is not read): they are
arc-minutes and 1e-3, well inside the linear model, and feeding a Markov state back would
break its model. The sensor's lever arm (``meta.yaml`` ``sensors.<name>.lever_arm_m``, in b,
a surveyed installation value, :func:`inmotion.navigate.pure.mounting_from_meta`) is used by
the DR as by ``sins-dr``: the DR removes the ``omega x l`` part of the sensor's reading (the
layout has no lever-arm state; unremoved, a 1.2 m arm in a 5 deg/s turn reads 0.03 m/s off,
which an LDV's 0.01 m/s noise does not cover, and the smoothed tilt went overconfident, issue
14). ``od-velocity-kf`` removes the same term from the speed it matches
(:func:`inmotion.estimation.velocity_aided.imu_point_speed`): paper 000's velocity model
(eq. 8-11) is the IMU point's, and left in, a 0.3 m lateral arm in a 4 deg/s turn reads
0.02 m/s high, which the filter took for a tilt (issue 15: a level error of -0.1 to -0.26
arcmin about East against a 0.08 arcmin sigma, NEES 7.3 over 6 runs). Open loop
(``closed_loop=False``): nothing is fed back, the output is the SINS corrected by the current
estimate.

Noise settings (issue 15): with ``noise_preset: matched`` (the default) every IMU figure, the
sensor's forward noise and its scale-factor model that the configuration does not set come
from the bundle's ``meta.yaml`` (:func:`config_with_spec`, :func:`sensor_spec_fields`; the
origin of each in ``info["config_source"]``); ``paper`` keeps the field defaults, paper 000
sec. 5's figures (on paper 000's simulated bundles both give the same values). Two settings
matter for the consistency of the sigma on a distance-output LDV: its 500 ppm constant scale
factor modelled as paper 000's 1000 ppm / 300 s Markov process left the level sigma twice the
error; its 0.01 m/s per-sample noise is 0.0071 m/s in the speed at a measurement epoch (the
mean of two intervals). The lateral / NHC rows' floor (``lateral_noise_m_s``,
``nhc_noise_m_s``) is not a sensor figure and stays as configured. Measured over 20 Monte
Carlo runs of paper 003's drive cut to 85 s (``benchmarks/nees_methods.py 20``; LDV, start
0.1 / 0.1 / 0.5 deg and 0.1 m/s off, floor 3e-3 m/s): mean final-attitude NEES 1.51 (dr-kf)
and 1.65 (od-velocity-kf) against the band 2.02-4.16, on the safe side by about 1.3 in sigma
(6 runs, the test: 2.04 and 2.24, band 1.37-5.25); before issue 15's fixes 0.87 and 7.3 over
the 6 runs. On paper 000's bundles the matched values are the paper defaults, and its
trajectory-1 results are unchanged to the last digit.

The filter rate and measurement rate are set in the configuration, independent of the IMU
rate (rounded to a whole number of IMU rows). Defaults: prediction at 10 Hz, measurements and
feedback at 2 Hz (on paper 000's experiments 10 Hz measurements gave the same accuracy within
the Monte Carlo scatter, at twice the cost; the chi-square gate sees a 1.5 s slip at 2 Hz).

What the measurements can see (documented because the paper claims more): on a straight
road the heading misalignment and the east gyro drift are separated only by gyrocompassing,
so the heading settles at ``phi_U = -eps_E / (Omega cos L)`` (8' for 0.03 deg/h at 34 deg N);
the mounting angle ``gamma`` shares that direction with the heading once the NHC is written in
the vehicle frame; ``beta`` (about the forward axis) is unobservable. The filter's sigma says
all three (``inmotion.reproductions.paper000`` measures them).

Initial covariance: the DR starts from the same attitude and position as the SINS (paper 000
sec. 5: "the initial errors of the dead reckoning system were the same"), so ``phi_D(0) =
phi(0)`` and ``dp_D(0) = dp(0)`` exactly: the prior puts full correlation between them. The
SINS and DR attitudes are started identical.
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import ConfigDict, Field, ValidationError
from .. import config_fields as cf
from ..estimation import chi2

from ..core import earth
from ..core.bundle import Bundle
from ..core.mechanization import _check_finite
from ..core.solution import NavState, Solution
from ..errors import BadInput
from ..estimation import error_model as em
from ..estimation.layout import Layout, position_units
from ..estimation.velocity_aided import (GROUP_SIZES, GROUPS, ZUPT_ORIGIN, StopUpdateFields,
                                         VelocityAidedRun, dr_gyro_rows, with_dr_gyro,
                                         zupt_noise_from_meta)

__all__ = ["DrKfConfig", "OdVelocityKfConfig", "run_dr_kf", "run_od_velocity_kf",
           "config_with_spec", "sensor_spec_fields", "IMU_SPEC_FIELDS",
           "LAYOUT_DR_KF", "LAYOUT_OD_KF"]

ARCMIN = np.pi / 180.0 / 60.0
DEG_H = np.pi / 180.0 / 3600.0
UG = earth.G0 * 1e-6

#: paper 000 eq. 21: the 25 states of ``dr-kf``
LAYOUT_DR_KF = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk"])
#: the 19 states of ``od-velocity-kf``
LAYOUT_OD_KF = Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk"])


class OdVelocityKfConfig(StopUpdateFields):
    """Configuration of ``od-velocity-kf`` (and the common part of ``dr-kf``).

    Rates: ``filter_rate_hz`` (prediction, model relinearization), ``measurement_rate_hz``
    (updates), ``feedback_rate_hz`` (closed-loop corrections); rounded to whole IMU rows.
    Priors (1-sigma) and noise densities carry their unit in the name; the defaults are paper
    000 sec. 5 where it gives them. Measurement noise: ``velocity_noise_m_s`` the radar's
    0.1 m/s; ``nhc_noise_m_s`` 0.03 m/s (paper 000 puts no noise on Z2, eq. 39; a small floor
    keeps the update well conditioned, and lets the chi-square gate see side slips);
    ``lateral_noise_m_s`` the floor across the sensor's axis of the velocity difference
    (resolved in body axes: the sensor's noise is along its axis only);
    ``baro_noise_m``; ``attitude_noise_arcmin`` for the SINS-minus-DR attitude (both from the
    same gyros, so only numerical and transport-rate differences: small).
    """

    model_config = ConfigDict(extra="forbid")
    velocity_sensor: Optional[Literal["radar", "ldv", "odometer"]] = cf.velocity_sensor(None)
    noise_preset: Literal["matched", "paper"] = Field(
        "matched",
        description="matched: the IMU figures, the sensor's forward noise and its scale-factor "
                    "model the configuration does not set come from meta.yaml (config_with_spec); "
                    "paper: the field defaults (paper 000 sec. 5) whatever the bundle says")
    filter_rate_hz: float = cf.filter_rate_hz(10.0)
    measurement_rate_hz: float = cf.measurement_rate_hz(2.0)
    use_nhc: bool = Field(
        True,
        description="add the non-holonomic constraint (zero lateral and vertical velocity in the "
                    "vehicle frame)")
    use_baro: bool = cf.use_baro(True)
    second_order_rows: bool = cf.second_order_rows()
    #: on (issue 15, session 24, measured with ``benchmarks/nees_invariant.py``, city drive,
    #: 100 + 50 deg/h gyro, 5 runs): od-velocity-kf heading NEES 5.23 -> 0.80; dr-kf 2.02 ->
    #: 2.04 (its DR attitude difference rows keep it in the band either way)
    invariant_velocity_error: bool = cf.invariant_velocity_error(True)
    nhc_mount_terms: bool = Field(
        True,
        description="NHC rows with the mounting-angle columns (False: paper 000 eq. 37 as "
                    "printed)")
    closed_loop: bool = Field(
        True,
        description="feed the estimated errors back into the mechanizations (False: open loop)")
    feedback_rate_hz: float = Field(
        2.0, gt=0,
        description="closed-loop feedback rate [Hz], rounded to whole filter epochs")
    gate_probability: float = cf.gate_probability(0.9999)
    keep_covariance: bool = Field(
        False,
        description="keep the attitude covariance series in the result's info (memory)")
    smooth: bool = cf.smooth(False)
    # priors
    init_tilt_sigma_deg: float = cf.init_tilt_sigma_deg(1.0)
    init_heading_sigma_deg: float = cf.init_heading_sigma_deg(1.0)
    init_velocity_sigma_m_s: float = cf.init_velocity_sigma_m_s(0.1)
    init_position_sigma_m: float = cf.init_position_sigma_m(15.0)
    gyro_drift_deg_h: float = cf.gyro_drift_deg_h(0.03)
    accel_bias_ug: float = cf.accel_bias_ug(100.0)
    mount_sigma_arcmin: float = cf.mount_sigma_arcmin(20.0)
    mount_rw_arcmin_sqrt_s: float = cf.mount_rw_arcmin_sqrt_s(0.0)
    dk_sigma_ppm: float = cf.dk_sigma_ppm(1000.0)
    dk_tau_s: float = cf.dk_tau_s(300.0)
    # noise
    gyro_arw_deg_sqrt_h: float = cf.gyro_arw_deg_sqrt_h(0.003)
    accel_vrw_ug_sqrt_hz: float = cf.accel_vrw_ug_sqrt_hz(10.0)
    gyro_bias_rw_deg_h_sqrt_h: float = cf.gyro_bias_rw_deg_h_sqrt_h(0.0)
    accel_bias_rw_ug_sqrt_h: float = cf.accel_bias_rw_ug_sqrt_h(0.0)
    velocity_noise_m_s: float = cf.velocity_noise_m_s(0.1)
    nhc_noise_m_s: float = cf.nhc_noise_m_s(0.03)
    lateral_noise_m_s: float = Field(
        0.03, gt=0,
        description="noise floor of the velocity difference across the sensor's axis [m/s]")
    baro_noise_m: float = cf.baro_noise_m(2.0)
    output_interval_s: Optional[float] = Field(
        None, gt=0,
        description="rows written every round(output_interval_s / filter interval) filter "
                    "epochs, and the last [s]; None: every filter epoch. --output-rate sets it "
                    "where those are the rows thinning keeps (issue 13: written at 100 Hz and "
                    "thinned afterwards, the kernel spent three quarters of its hour on rows "
                    "the result drops)")

    def output_interval_for_rate(self, dt_imu: float, rate_hz: float) -> Optional[float]:
        """The ``output_interval_s`` whose rows are those :func:`inmotion.io.result.thin` at
        ``rate_hz`` keeps of the every-epoch run (``1 / rate_hz`` when it is a whole number of
        filter intervals of an IMU of period ``dt_imu`` [s]), else None (every epoch); None
        also for a smoothed run or one that keeps its covariance series (their rows are
        every epoch's)."""
        if self.smooth or self.keep_covariance:
            return None
        step = max(1, int(round(1.0 / (self.filter_rate_hz * dt_imu))))
        k = 1.0 / (rate_hz * step * dt_imu)
        return 1.0 / rate_hz if round(k) >= 1 and abs(k - round(k)) < 1e-6 else None


class DrKfConfig(OdVelocityKfConfig):
    """Configuration of ``dr-kf``: the common fields plus the switches of Z1's two halves,
    the attitude-difference noise and the DR gyro-drift coupling of the error model."""

    use_attitude: bool = Field(
        True, description="use Z1's attitude half (SINS minus DR heading, pitch, roll)")
    use_velocity: bool = Field(True, description="use Z1's velocity half (SINS minus DR velocity)")
    attitude_noise_arcmin: float = cf.attitude_noise_arcmin(0.2)
    dr_sees_gyro_drift: bool = cf.dr_sees_gyro_drift(True)


from .meta_spec import IMU_SPEC_FIELDS, _imu_spec_meta, sensor_spec_fields  # noqa: F401


def config_with_spec(cfg, meta, sensor: str) -> tuple:
    """``(cfg, config_source)``: with ``noise_preset: matched``, ``cfg`` with the IMU fields
    (:data:`IMU_SPEC_FIELDS`, from ``meta['imu']``:
    :func:`inmotion.align.parked_kf.config_with_spec`) and the sensor fields
    (:func:`sensor_spec_fields`) it does not set taken from the bundle (a simulated IMU's
    fixed constant errors drawn per axis are not a specification, :func:`_imu_spec_meta`), the
    cross rows' and NHC noise from the vehicle's constraint violation and ``zupt_noise_m_s`` on
    a still simulated vehicle (:func:`inmotion.estimation.velocity_aided.zupt_noise_from_meta`);
    ``paper`` keeps every
    field as configured. ``{field: origin}`` says where each value came from (``config``,
    ``meta.imu (simulated)``, ``meta.sensors ...``, ``default``). A Gauss-Markov bias in the
    spec becomes the bias random walks (:func:`inmotion.align.meta_spec.markov_as_random_walk`).
    An installation ``meta.yaml`` does not describe gets wide priors
    (:func:`inmotion.align.meta_spec.unknown_installation_priors`): the mounting 300 arcmin
    without ``vehicle_mounting_arcmin``, the scale factor a 10000 ppm constant where the
    sensor's spec states none."""
    from .meta_spec import constant_bias_imu_spec, unknown_dk_prior
    from .parked_kf import fields_not_set
    matched = cfg.noise_preset == "matched"
    cfg, src = constant_bias_imu_spec(cfg, meta, matched)
    spec, origin = sensor_spec_fields(meta, sensor) if matched else ({}, "")
    upd, s1 = fields_not_set(cfg, ("velocity_noise_m_s", "dk_sigma_ppm", "dk_tau_s"), spec,
                             origin)
    if matched:
        u1, s1u = unknown_dk_prior(cfg, meta, sensor)
        upd.update(u1)
        s1.update(s1u)
    cons = constraint_noise_from_meta(cfg, meta) if matched else {}
    u2, s2 = fields_not_set(cfg, ("lateral_noise_m_s", "nhc_noise_m_s"), cons,
                            "meta.vehicle.constraint_violation")
    upd.update(u2)
    u3, s3 = fields_not_set(cfg, ("zupt_noise_m_s",), zupt_noise_from_meta(meta) if matched else {},
                            ZUPT_ORIGIN)
    upd.update(u3)
    src.update(s3)
    src.update(s1)
    src.update(s2)
    return (cfg.model_copy(update=upd) if upd else cfg), src


def constraint_noise_from_meta(cfg, meta) -> dict:
    """``lateral_noise_m_s`` and ``nhc_noise_m_s`` from the vehicle's measured constraint
    violation ``meta['vehicle']['constraint_violation']`` (issue 15), ``{}`` without one.

    The vehicle's real lateral and vertical velocity (side slip, bounce; a Gauss-Markov
    velocity of 1-sigma ``sigma`` and correlation time ``tau``) is what both the velocity
    difference's cross rows (Z1's velocity half: the DR takes the velocity along the sensor's
    axis only) and the vehicle-constraint rows (Z2) take as noise. At the measurement interval
    ``T = 1 / measurement_rate_hz`` its white equivalent is ``sqrt(2 sigma^2 tau / T)``
    (:func:`inmotion.align.aided_kf.markov_white_equivalent_sigma`: what keeps the attitude's
    sigma honest over a run of correlated rows). One field covers both cross axes, so the
    larger of the lateral and vertical figures. Both groups see the same violation: when both
    are used each gets the variance twice over (half the information each, as ``fkf`` shares
    it between its channels), so together they claim no more than the violation allows."""
    from .aided_kf import vehicle_constraint_noise
    cv = vehicle_constraint_noise(meta, 1.0 / cfg.measurement_rate_hz)
    if cv is None:
        return {}
    sigma = max(cv)
    share = np.sqrt(2.0) if cfg.use_nhc else 1.0
    return {"lateral_noise_m_s": float(sigma * share), "nhc_noise_m_s": float(sigma * share)}


def _process_noise(cfg) -> em.ProcessNoise:
    return em.ProcessNoise(
        gyro_arw=np.deg2rad(cfg.gyro_arw_deg_sqrt_h) / 60.0,
        accel_vrw=cfg.accel_vrw_ug_sqrt_hz * UG,
        gyro_bias_rw=cfg.gyro_bias_rw_deg_h_sqrt_h * DEG_H / 60.0,
        accel_bias_rw=cfg.accel_bias_rw_ug_sqrt_h * UG / 60.0,
        dk_sigma=cfg.dk_sigma_ppm * 1e-6, dk_tau=cfg.dk_tau_s,
        mount_rw=cfg.mount_rw_arcmin_sqrt_s * ARCMIN)


def _initial_covariance(lay: Layout, cfg, lat, h):
    """Diagonal priors; the DR's attitude and position errors equal the SINS's at start."""
    r_m, r_n = earth.radii(lat)
    pos = cfg.init_position_sigma_m
    tilt, head = np.deg2rad(cfg.init_tilt_sigma_deg), np.deg2rad(cfg.init_heading_sigma_deg)
    var = {"phi": np.array([tilt, tilt, head]) ** 2,
           "dv": cfg.init_velocity_sigma_m_s ** 2,
           "dp": np.array([pos / (r_m + h), pos / ((r_n + h) * np.cos(lat)), pos]) ** 2,
           "eps": (cfg.gyro_drift_deg_h * DEG_H) ** 2,
           "nabla": (cfg.accel_bias_ug * UG) ** 2,
           "mount": (cfg.mount_sigma_arcmin * ARCMIN) ** 2,
           "dk": (cfg.dk_sigma_ppm * 1e-6) ** 2}
    P = lay.diag({k: v for k, v in var.items() if k in lay})
    if "phi_D" in lay:
        for own, dr in (("phi", "phi_D"), ("dp", "dp_D")):
            P[lay[dr], lay[dr]] = P[lay[own], lay[own]]
            P[lay[own], lay[dr]] = P[lay[own], lay[own]]
            P[lay[dr], lay[own]] = P[lay[own], lay[own]]
    return P


def _baro_on_epochs(bundle: Bundle, t):
    """Barometric height at the times ``t`` (NaN outside its span)."""
    b = bundle.baro
    h = np.interp(t, b.t, b.h)
    h[(t < b.t[0]) | (t > b.t[-1])] = np.nan
    return h


def _pack(lay, init, cfg, info, out_t, out_lla, out_vel, out_q, out_sig, out_states,
          out_cov_phi) -> Solution:
    """The :class:`Solution` of either method (sigmas of the nav states, every named state,
    ``sigma_<state>`` of the mounting, scale factor and gyro drifts)."""
    sig = lay.as_dict(out_sig)
    r_m, r_n = earth.radii(out_lla[:, 0])
    sigma = {"phi_E": sig["phi_E"], "phi_N": sig["phi_N"], "phi_U": sig["phi_U"],
             "vE": sig["dv_E"], "vN": sig["dv_N"], "vU": sig["dv_U"],
             "north": sig["dp_lat"] * (r_m + out_lla[:, 2]),
             "east": sig["dp_lon"] * (r_n + out_lla[:, 2]) * np.cos(out_lla[:, 0]),
             "h": sig["dp_h"]}
    states = lay.as_dict(out_states)
    units = lay.unit_map(position_units(init.lat, init.h))
    for name in ("mount_x", "mount_y", "mount_z", "dk", "eps_x", "eps_y", "eps_z"):
        states[f"sigma_{name}"] = sig[name]          # 1-sigma, written in the state's unit
        units[f"sigma_{name}"] = units[name]
    if cfg.keep_covariance:
        info["cov_phi"] = out_cov_phi
    return Solution.from_arrays(out_t, out_lla, out_vel, out_q, sigma=sigma,
                                states=states, state_units=units, info=info)


# -- dr-kf on the shared SINS / DR engine ---------------------------------------------------

#: the engine's group names -> this method's (``Solution.info`` counts)
_GROUP_NAMES = {"attitude": "attitude", "velocity": "velocity", "sensor_velocity": "velocity",
                "nhc": "nhc", "height": "baro", "zero_velocity": "zero velocity"}


def _gates(p):
    """Chi-square threshold of each engine group's NIS at probability ``p`` (``p = 1``: 0,
    never rejects)."""
    return {g: (float(chi2.ppf(p, m)) if p < 1.0 else 0.0) for g, m in GROUP_SIZES.items()}


def _engine_filter(bundle: Bundle, cfg, init: NavState, with_dr: bool):
    """The configured engine and what it runs on: ``(filter, (n_rows, pieces, first_row),
    (sensor name, speed))`` with the IMU rows after ``init.t`` (:meth:`Bundle.imu_rows_after`);
    ``with_dr``: ``dr-kf`` (25 states, Z1 = SINS minus DR), else ``od-velocity-kf`` (19
    states, SINS minus the sensor's velocity)."""
    if init is None:
        raise BadInput("this method needs an initial attitude (--init truth, a coarse "
                       "alignment result, or meta.yaml)")
    try:
        sensor_name, speed = bundle.velocity_sensor(cfg.velocity_sensor)
    except ValueError as exc:
        raise BadInput(str(exc)) from None
    cfg, cfg_source = config_with_spec(cfg, bundle.meta, sensor_name)
    n_rows, imu_dt, pieces, k0 = bundle.imu_rows_after(init.t)   # whole, or read in chunks
    if isinstance(pieces, list):         # in memory: check it (a chunked reader checks chunks)
        for t, dtheta, dvel in pieces:
            _check_finite(dtheta, t, "dtheta", "imu", row0=k0)
            _check_finite(dvel, t, "dvel", "imu", row0=k0)
    step = max(1, int(round(1.0 / (cfg.filter_rate_hz * imu_dt))))
    meas_every = max(1, int(round(cfg.filter_rate_hz / cfg.measurement_rate_hz)))
    feedback_every = max(1, int(round(cfg.measurement_rate_hz / cfg.feedback_rate_hz)))
    out_every = (1 if cfg.output_interval_s is None
                 else max(1, int(round(cfg.output_interval_s / (step * imu_dt)))))
    use = {"nhc": cfg.use_nhc, "height": cfg.use_baro and bundle.baro is not None}
    if with_dr:
        lay = LAYOUT_DR_KF
        model = em.ErrorModel(lay, _process_noise(cfg),
                              dr_sees_gyro_drift=cfg.dr_sees_gyro_drift)
        use.update(attitude=cfg.use_attitude, velocity=cfg.use_velocity)
    else:
        lay = LAYOUT_OD_KF
        model = em.ErrorModel(lay, _process_noise(cfg))
        use.update(sensor_velocity=True)
    # velocity noise in body axes (lateral, forward, vertical): the sensor's noise lies along
    # its forward axis only, so resolved in the (computed) body axes R is diagonal, with only
    # the model floor lateral_noise_m_s across; the rotation by the computed C_n^b changes
    # the measurement only to second order
    noise = {"attitude_rad": getattr(cfg, "attitude_noise_arcmin", 1.0) * ARCMIN,
             "position_m": 1.0,
             "velocity_b_m_s": (cfg.lateral_noise_m_s, cfg.velocity_noise_m_s,
                                cfg.lateral_noise_m_s),
             "height_m": cfg.baro_noise_m, "nhc_m_s": cfg.nhc_noise_m_s,
             "dr_position_m2_s": 0.0,    # paper 000's G: no DR position random walk
             "zupt_m_s": cfg.zupt_noise_m_s}
    use["zero_velocity"] = bool(cfg.stops_s)
    from ..navigate.pure import mounting_from_meta
    _, lever = mounting_from_meta(bundle.meta, sensor_name)
    filt = VelocityAidedRun(init, lay, model, _initial_covariance(lay, cfg, init.lat, init.h),
                        use=use, noise=noise, gates=_gates(cfg.gate_probability),
                        step_rows=step, meas_every=meas_every, out_every=out_every,
                        nhc_mount=cfg.nhc_mount_terms, closed_loop=cfg.closed_loop,
                        second_order=cfg.second_order_rows,
                        feedback_every=feedback_every, smooth=cfg.smooth,
                        lever_arm_b=None if lever is None else np.asarray(lever, float),
                        stops_s=cfg.stops_s,
                        invariant_velocity=cfg.invariant_velocity_error)
    return filt, (n_rows, pieces, k0), (sensor_name, speed), (cfg, cfg_source)


def _engine_solution(filt: VelocityAidedRun, out: dict, cfg, method: str, sensor: str,
                     wall: float) -> Solution:
    xs = out["x_sins"]
    used, rejected = {}, {}
    nis, dof = 0.0, 0
    counts, sums = filt.counts(), filt.filter.nis_sums()
    for g in GROUPS:                           # in the order the groups are applied
        c = counts.get(g)
        if g in _GROUP_NAMES and c is not None and c["used"] + c["rejected"] > 0:
            used[_GROUP_NAMES[g]] = c["used"]
            rejected[_GROUP_NAMES[g]] = c["rejected"]
            nis += sums[g][0]
            dof += c["used"] * GROUP_SIZES[g]
    info = {"method": method, "config": cfg.model_dump(), "velocity_sensor": sensor,
            "layout": list(filt.layout.names), "filter_step_rows": filt.step,
            "measurement_every_filter_steps": filt.meas_every,
            "measurements_used": used, "measurements_rejected": rejected,
            "nis_mean_per_dof": nis / max(dof, 1), "nis": filt.filter.nis_summary(),
            "wall_time_s": wall}
    info["smoothed"] = bool(cfg.smooth)
    info["velocity_error"] = filt.filter.velocity_error
    info["samples_skipped_blind"] = filt.samples_skipped_blind
    info["dr_reseeds"] = filt.dr_reseeds
    sol = _pack(filt.layout, filt.init, cfg, info, out["t"], xs[:, 0:3], xs[:, 3:6],
                xs[:, 6:10], out["sigma"], out["states"], out["cov_phi"])
    if "sigma_forward" in out:          # the forward filter's sigma beside the smoothed one
        fwd = filt.layout.as_dict(out["sigma_forward"])
        for name in ("phi_E", "phi_N", "phi_U"):
            sol.states[f"sigma_forward_{name}"] = fwd[name]
            sol.state_units[f"sigma_forward_{name}"] = sol.state_units[name]
    return sol


def _config(config, cls):
    """The validated configuration; a wrong field raises :class:`BadInput` naming it."""
    if isinstance(config, cls):
        cfg = config
    else:
        try:
            cfg = cls(**(config or {}))
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(x) for x in err["loc"])
            raise BadInput(f"{where}: {err['msg']}", file="config") from None
    if cfg.measurement_rate_hz > cfg.filter_rate_hz * (1 + 1e-9):
        raise BadInput(f"measurement_rate_hz ({cfg.measurement_rate_hz}) must not exceed "
                       f"filter_rate_hz ({cfg.filter_rate_hz})", file="config")
    return cfg


def _run(bundle, config, init, progress, cls, with_dr, method, dtheta_dr=None, select=None,
         output_times=None):
    cfg = _config(config, cls)
    t0 = time.perf_counter()
    filt, (n_rows, pieces, k0), (sensor, speed), (cfg, cfg_source) = _engine_filter(
        bundle, cfg, init, with_dr)
    h_baro = (lambda t: _baro_on_epochs(bundle, t)) if filt.use["height"] else None
    if dtheta_dr is not None:                # the DR's own gyro (a bundle in memory)
        pieces = with_dr_gyro(pieces, dr_gyro_rows(bundle.imu, dtheta_dr,
                                                   slice(k0, k0 + n_rows)))
    out = filt.run_stream(pieces, n_rows, speed, h_baro=h_baro, sensor=sensor,
                          progress=progress, select=select, output_times=output_times)
    sol = _engine_solution(filt, out, cfg, method, sensor, time.perf_counter() - t0)
    sol.info["config_source"] = cfg_source
    return sol


def run_dr_kf(bundle: Bundle, config: DrKfConfig | dict | None = None,
              init: NavState | None = None, progress: Optional[Callable] = None, *,
              dtheta_dr=None, select=None, output_times=None) -> Solution:
    """``dr-kf``: paper 000's SINS / radar-DR alignment filter (see the module docstring).

    ``dtheta_dr`` (N, 3) [rad], one row per IMU row, or None: the gyro increments the dead
    reckoner integrates, when it has its own gyro (:func:`inmotion.estimation.velocity_aided.dr_gyro_rows`;
    with ``dr_sees_gyro_drift=False`` a gyro without the IMU's drift, the world paper 000's
    printed F describes).

    Returns a :class:`Solution` at the filter rate: the (closed-loop corrected) SINS state,
    ``sigma`` for ``phi_E/N/U``, velocity and position, every named state of the layout
    (accumulated feedback plus the current estimate) and ``sigma_<state>`` for the mounting
    angles, scale factor and gyro drifts (in ``states``, with the state's display unit), and in ``info`` the measurement counts,
    gate rejections, mean NIS per degree of freedom and, with ``keep_covariance=True``, the
    (N, 3, 3) misalignment covariance history ``cov_phi`` [rad^2] (for NEES; off by default
    because ``summary.json`` would carry it).

    ``select``: which output rows to keep and where to stop
    (:meth:`inmotion.estimation.velocity_aided.VelocityAidedRun.run_stream`; None: all, to
    the end; ``inmotion process`` keeps its output rate's rows and stops at the handover).
    ``output_times``: a callable given the kept output rows' times as the run makes them
    (:meth:`~inmotion.estimation.velocity_aided.VelocityAidedRun.run_stream`).
    """
    return _run(bundle, config, init, progress, DrKfConfig, True, "dr-kf", dtheta_dr, select,
                output_times)


def run_od_velocity_kf(bundle: Bundle, config: OdVelocityKfConfig | dict | None = None,
                       init: NavState | None = None,
                       progress: Optional[Callable] = None, *,
                       select=None, output_times=None) -> Solution:
    """``od-velocity-kf``: SINS / velocity-sensor velocity matching (the baseline).
    ``select``, ``output_times``: as :func:`run_dr_kf`'s."""
    return _run(bundle, config, init, progress, OdVelocityKfConfig, False, "od-velocity-kf",
                select=select, output_times=output_times)
