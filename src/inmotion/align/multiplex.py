"""Fault-tolerant inertial-frame coarse alignment and information multiplexing (paper 003
sec. 3.2.1 and 3.3.1): method ``fine-mux``.

Fault-tolerant speed (sec. 3.2.1, Figure 2)
    The vehicle's forward speed is redundant in the odometer, the LDV and the IMU. At every
    IMU row the IMU predicts the speed from the value accepted ``horizon_s`` (0.2 s) earlier
    and its forward velocity increments since, ``v_imu(k) = v(k-N) + sum (dvel_y - g
    sin(theta) dt)`` (``d v / dt = f_y - g sin(theta)`` along the forward axis, whose
    ``omega x v`` term vanishes). A channel is healthy while it agrees with ``v_imu`` within
    ``speed_tolerance_m_s``; of two healthy channels the LDV is used (the paper's "smaller
    difference" rule would switch on noise between two healthy channels; the LDV has the
    smaller scale-factor error, sec. 4.1), else the healthy one. The horizon makes a fault that sets in over a few samples
    (a distance sensor's interval straddling the fault's start) show in full, while the
    pitch estimate's error acts only over 0.2 s. When neither channel agrees with the IMU
    but both agree with each other (the IMU bridge has drifted after a double fault), the
    two sensors win; otherwise the IMU prediction bridges the gap (both channels faulty,
    rare and short). ``sin(theta)`` is a
    low-pass (``pitch_time_constant_s``) of ``(f_y - dv/dt) / g`` with the accepted speed:
    the coarse stage needs no attitude. Channel changes are logged as events.

Information multiplexing (sec. 3.3.1, Figure 3)
    The inertial-frame coarse alignment (:mod:`inmotion.align.coarse_inertial`, eq. 1-10) over
    ``[t0, t0 + coarse_window_s]`` gives ``C_{ib0}^{i0}``; with ``C_b^{ib0}(t0) = I`` and the
    start position it gives the attitude *at the window's start* (eq. 1 at ``t0``). The fine
    alignment then starts at ``t0`` from that attitude and the sensor's speed along it and
    runs over the stored data and on to the end of the log. Because the fine filter runs
    faster than real time (the ``catch_up`` block of ``info`` gives the factor), it reaches
    the present at ``t_c + (t_c - t0) / (factor - 1)`` with ``t_c`` the end of the coarse
    window, without dropping a sample (every stored row is processed once, in order).

The coarse stage's envelope and the fine prior (issue 15)
    The coarse answer is only as good as the IMU lets it be (:func:`coarse_envelope`, from
    the IMU spec the fine filter uses: ``meta['imu']`` or its configuration): level about
    ``hypot(bias / g, drift T / 2)`` and heading about ``hypot(drift / (Omega_ie cos L),
    bias tan L / g, drift T / 2)`` (the limits of :mod:`inmotion.align.coarse_inertial`, plus
    the drift the gyros add to the attitude over a window of ``T`` seconds; in motion, with
    the window's error map, the bias's part is the map's instead, :func:`window_envelope`'s
    ``imu_bias``: the bias turned by the manoeuvres). Those 1-sigma
    become the fine filter's attitude prior (where ``fine`` does not set it), and the start
    velocity, made from the coarse attitude, carries its correlation with the attitude error
    (``init_velocity_from_attitude``). When the heading envelope exceeds
    :data:`UNRESOLVED_HEADING_DEG` the coarse stage cannot resolve the heading (a MEMS gyro
    of 200 deg/h against the 12 deg/h horizontal Earth rate): the prior is the sigma of a
    heading known only to lie in +-180 deg (:data:`UNKNOWN_HEADING_SIGMA_DEG`), the fine
    stage's reported heading sigma is kept at least that (a linear filter cannot resolve a
    heading error of tens of degrees, and with an odometer and the vehicle constraint alone
    heading is observable only through the Earth rate), its level sigma at least
    ``bias / g`` (what no filter without an external attitude reference can beat), and the
    summary warns (``info['warnings']``).

The coarse window's own terms (issue 15)
    Beside the IMU, the window's data limit the coarse answer: the vectors assume the body
    velocity ``[0, s, 0]``, while the IMU's mounting in the vehicle (yaw, pitch), the speed's
    scale factor, the sensor's lever arm (``omega x l``), the vehicle constraint's violation
    and the speed noise make it differ; the centred vectors remove only the part that stays
    constant (constant speed and body direction). The heading information grows as ``g
    Omega_ie cos(L) T^2 / 2``, so a short window (tens of seconds) turns centimetres per
    second into degrees of heading. :func:`~inmotion.align.attitude_determination.
    window_error_map` linearises the q-method's answer in the velocity error (checked
    against the coarse stage run on the IMU increments turned by a mounting angle:
    ``benchmarks/coarse_window_sensitivity.py``), :func:`window_envelope` sizes each term
    from the fine configuration's priors and the bundle's spec, and their sum goes into the
    envelope in quadrature (``info['coarse_envelope']``: ``imu``, ``window.terms`` [E, N, U]
    arcmin per term) and so into the fine prior. It costs no extra coarse run (a 600 s window:
    0.62 s with it, 0.64 s without, measured). Beyond :data:`LINEAR_HEADING_DEG` of coarse
    heading 1-sigma (still resolvable) the fine filter's small-angle model no longer holds:
    the reported sigma is kept covering (:func:`linear_range_check`) and ``info['warnings']``
    names the window length to use.

The coarse error's correlation with the fine filter's states (issue 15, ``prior_cross``)
    The coarse attitude error is largely made by sensor errors the fine filter has states
    for: the accelerometer bias (a tilt of about ``-bias / g`` in the nav frame, averaged
    over the window's turns, and a forward bias turns a short window's heading), the IMU's
    mounting in the vehicle (the vectors assume ``v^b = [0, s, 0]``) and the coarse
    channel's scale factor. A prior that takes the
    attitude error as independent of those states tells the filter that a mounting or bias
    it estimates says nothing about its attitude, and the scalar level floor ``bias / g``
    then had to stand in for the missing correlation (conservative: per-axis mean ``(e /
    sigma)^2`` 0.00 / 0.00 / 1.57 at the default 600 s window). With ``prior_cross`` the
    prior carries ``cov(phi, s) = J_s P_s`` (:func:`window_cross_maps`, :func:`attitude_cross`;
    the fine filters' ``init_attitude_cross``), the attitude 1-sigma is the coarse envelope
    itself (the correlated model is the error's; not raised to the fine filter's default
    priors) and the level floor applies only where the heading is not resolved
    (:func:`floor_attitude_sigma`). Measured (``benchmarks/fine_mux_level_floor.py``, 20 runs,
    band 2.02-4.16): see that script's docstring.
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..core import earth, rotations
from ..core.bundle import Bundle, SpeedData
from ..core.solution import NavState, Solution
from ..errors import BadInput
from . import aided_kf as ak
from .attitude_determination import (UNRESOLVED_HEADING_DEG, coarse_envelope, initial_position,
                                     window_terms)
from .meta_spec import _constraint_violation_sigmas
from .coarse_inertial import CoarseInertialConfig, run_coarse_inertial
from .velocity_source import initial_speed, speed_on_imu_times

__all__ = ["auto_fine_method", "MuxConfig", "fault_tolerant_speed", "coarse_fault_tolerant",
           "last_covered", "first_covered", "run_multiplexed", "run_fine_mux", "FINE_METHODS",
           "start_state", "coarse_envelope", "fine_config_from_coarse", "floor_attitude_sigma",
           "floor_unresolved_horizontal_sigma",
           "UNRESOLVED_HEADING_DEG", "UNKNOWN_HEADING_SIGMA_DEG", "window_envelope",
           "linear_range_check", "LINEAR_HEADING_DEG", "window_cross_maps", "attitude_cross"]

#: the fine alignments ``fine-mux`` can run after the coarse stage
FINE_METHODS = {"fkf": (ak.run_fkf, ak.FkfConfig), "od-kf": (ak.run_od_kf, ak.AidedKfConfig),
                "ldv-kf": (ak.run_ldv_kf, ak.AidedKfConfig),
                "nhc-kf": (ak.run_nhc_kf, ak.NhcKfConfig)}
_CHANNELS = ("odometer", "ldv")
#: 1-sigma of a heading known only to lie in +-180 deg (uniform): 360 / sqrt(12) [deg]
UNKNOWN_HEADING_SIGMA_DEG = 360.0 / np.sqrt(12.0)


#: the accelerometer bias as a window term (``window_terms``' ``bias``, through the map's
#: ``J_nabla``) in place of the IMU envelope's parked figures
WINDOW_BIAS_TERM = True


def window_envelope(emap: Optional[dict], base, meta, channel: Optional[str],
                    rate_hz: float = 0.0) -> Optional[dict]:
    """The coarse window's own terms (issue 15; :func:`inmotion.align.attitude_determination.
    window_terms` on the window's error map): the IMU's mounting (the fine configuration's
    ``mount_sigma_arcmin``), the speed's scale factor (``{od,ldv}_scale_sigma_ppm``), the
    sensor's lever arm (``meta['lever_arms_m']``, not compensated by the coarse stage, with
    ``lever_sigma_m``), the vehicle constraint's violation (``meta['vehicle']
    ['constraint_violation']``; without it ``nhc_noise_m_s`` with a 0.5 s correlation time)
    and the speed noise (``meta['sensors'][channel]['noise_m_s']``, else the fine
    configuration's forward figure, at the sensor's rate). With :data:`WINDOW_BIAS_TERM`
    also the accelerometer bias through the map (``window_terms``' ``bias``, the fine
    prior's bias 1-sigma), returned apart as ``imu_bias`` (``arcmin``, ``level_deg``,
    ``heading_deg``, ``cov_rad2``): the IMU's term, which :func:`fine_config_from_coarse`
    puts in place of the parked ``bias / g`` and ``bias tan L / g`` (issue 15: at 300 s the
    bias turned by the manoeuvres gave 19.8 arcmin of heading RMS, the parked figure 0.1;
    ``benchmarks/coarse_cross_truth.py``). Returns ``{"terms": {name: [E, N, U] 1-sigma
    arcmin}, "level_deg", "heading_deg", "cov_rad2", "imu_bias"}`` or None without a map
    (parked)."""
    if emap is None or channel is None:
        return None
    short = ak.sensor_short(channel)
    meta = meta if isinstance(meta, dict) else {}
    sig = _constraint_violation_sigmas(meta, lambda sg, tau, _: sg, 0.0)
    cv = None if sig is None else tuple(zip(sig, _constraint_violation_sigmas(
        meta, lambda sg, tau, _: tau, 0.0)))          # the taus: not None where sig is not
    if cv is None:
        nhc = float(getattr(base, "nhc_noise_m_s", 0.1))
        cv = ((nhc, 0.5), (nhc, 0.5))
    sens = (meta.get("sensors") or {}).get(channel) or {}
    noise = sens.get("noise_m_s")
    if noise is None:
        noise = (getattr(base, f"{short}_noise_m_s", None) or [0.0, 0.0, 0.0])[1]
    rate = float(sens.get("rate_hz") or rate_hz or 0.0)
    lever = ak.stated_installation(meta, channel)[1]
    lever = np.zeros(3) if lever is None else lever
    P = window_terms(
        emap, mount_sigma_rad=np.radians(float(getattr(base, "mount_sigma_arcmin", 30.0)) / 60),
        scale_sigma=float(getattr(base, f"{short}_scale_sigma_ppm", 3000.0)) * 1e-6,
        lever_m=[float(x) for x in lever], lever_sigma_m=float(getattr(base, "lever_sigma_m", 0.05)),
        constraint_violation=cv, speed_noise_m_s=float(noise), speed_rate_hz=rate,
        accel_bias_sigma=float(ak._bias_prior(base)[1]) if WINDOW_BIAS_TERM else 0.0)
    bias = P.pop("bias", None)
    total = sum(P.values())
    arcmin = np.degrees(1.0) * 60.0
    out = {"terms": {k: (np.sqrt(np.diag(v)) * arcmin).round(3).tolist() for k, v in P.items()},
           "level_deg": float(np.degrees(np.sqrt(max(total[0, 0], total[1, 1])))),
           "heading_deg": float(np.degrees(np.sqrt(total[2, 2]))),
           "cov_rad2": total.tolist(), "channel": channel}
    if bias is not None:           # the IMU's term, through the window's map (not the window's)
        out["imu_bias"] = {"arcmin": (np.sqrt(np.diag(bias)) * arcmin).round(3).tolist(),
                           "level_deg": float(np.degrees(np.sqrt(max(bias[0, 0], bias[1, 1])))),
                           "heading_deg": float(np.degrees(np.sqrt(bias[2, 2]))),
                           "cov_rad2": bias.tolist()}
    return out


def window_cross_maps(emap: Optional[dict]) -> Optional[dict]:
    """The coarse attitude error ``eps`` (ENU at the window's start, the fine filter's
    ``phi`` at its start: both ``C_hat = (I - [eps x]) C``) per unit of the fine filter's
    sensor-error states (issue 15), from the window's error map (:func:`inmotion.align.
    attitude_determination.window_error_map`, ``eps = sum_k H_k dv_k`` with ``dv`` the error
    of the body velocity ``[0, s, 0]`` the vectors assumed, assumed minus true):

    * ``nabla`` (3, 3): the accelerometer bias in b, the map's ``J_nabla`` (its docstring);
    * ``mount`` (3, 2): the mounting ``A = [alpha, gamma]`` of :data:`inmotion.estimation.
      aiding_rows.SUB_LAYOUT` (``C_v^b = (I + [A x]) C_v^b0``): the vehicle moves along
      ``(I + [A x]) e_y = e_y + [-gamma, 0, alpha]`` in b, so ``dv = s [gamma, 0, -alpha]``
      and the columns are ``sum_k H_k s_k [0, 0, -1]`` and ``sum_k H_k s_k [1, 0, 0]``;
    * ``dk`` (3,): the speed's scale factor (``v_measured = (1 + dk) v``): ``dv = dk s e_y``,
      ``sum_k H_k s_k e_y``.

    The IMU's mounting is one for every channel (a sensor's beam misalignment changes its
    speed only at second order), so every channel's ``mount`` states share this map; the
    scale factor is the coarse channel's (:func:`attitude_cross`).
    The signs and sizes are checked against the coarse stage run on a simulated drive with
    the bias and the mounting injected (``tests/test_multiplex_cross.py``) and against the
    drawn bias and mounting over a Monte Carlo (``benchmarks/coarse_cross_truth.py``:
    correlation 0.96-1.00, regression slope 0.88-1.06 at 120 / 300 / 600 s). The ``dk``
    column against the coarse stage run on the speed scaled by 1 -+ 1000 ppm (issue 15,
    helper h16scale; arcmin of heading per +1000 ppm, coarse run / map): 85 s drive, 40 s
    window +89.5 (-86.4 for -1000 ppm) / +92.1, 80 s window +0.61 / -1.13; paper 003's drive
    (seed 300), 300 s -7.52 / -7.81, 600 s -0.274 / -0.269 (the map before: +147.8, -5.74,
    -7.97, -0.255). The 80 s window is the one miss: the coarse stage with its attitude
    held (``C_fixed``) moves -1.22, the map's -1.13; the +1.8 difference is the running
    answer's own error from the scaled speed, which turns the dead-reckoned position and
    through it ``C_{n(t)}^{n(0)}`` and ``beta`` (a second pass the map does not follow),
    large only where the first-order effect nearly cancels (the 60 deg turn near the
    window's middle). None without a map."""
    if emap is None:
        return None
    H, s = emap["H"], emap["speed"]
    col = lambda j: (H[:, :, j] * s[:, None]).sum(0)          # noqa: E731
    return {"nabla": np.asarray(emap["J_nabla"]), "mount": np.stack([-col(2), col(0)], 1),
            "dk": col(1)}


def attitude_cross(maps: Optional[dict], base, sensors=(), channel: Optional[str] = None) -> dict:
    """The fine prior's ``init_attitude_cross`` (:class:`inmotion.align.aided_kf.
    NhcKfConfig`; issue 15): ``cov(phi, s) = J_s P_s`` for the sensor states ``s`` whose
    error made the coarse attitude's, ``J_s`` of :func:`window_cross_maps` and ``P_s`` the
    fine configuration's own prior of ``s`` (``base``): the accelerometer bias (``nabla``,
    its 1-sigma :func:`inmotion.align.aided_kf._bias_prior`), every channel of ``sensors``'
    mounting (``mount_sigma_arcmin``: one physical mounting, one map) and, when ``channel``
    (the coarse stage's speed) is one of ``sensors``, its scale factor (``<channel>.dk``,
    ``{od,ldv}_scale_sigma_ppm``; the map's forward column, checked against the coarse stage
    run on a scaled speed since the map follows the stage's low-pass, its sum over the
    window and the vectors' residuals: :func:`inmotion.align.attitude_determination.
    window_error_map`). Values [rad x the state's SI unit], as lists; ``{}`` without a map."""
    if maps is None:
        return {}
    s_nabla = ak._bias_prior(base)[1]
    out = {"nabla": (maps["nabla"] * s_nabla ** 2).tolist()}
    s_m = float(getattr(base, "mount_sigma_arcmin", 0.0)) * ak.ARCMIN
    if s_m > 0:
        for ch in sensors:
            out[f"{ch}.mount"] = (maps["mount"] * s_m ** 2).tolist()
    if channel in sensors and "dk" in maps:
        short = ak.sensor_short(channel)
        s_k = float(getattr(base, f"{short}_scale_sigma_ppm", 0.0)) * 1e-6
        if s_k > 0:
            out[f"{channel}.dk"] = (np.asarray(maps["dk"])[:, None] * s_k ** 2).tolist()
    return out


def _cover_cross(tilt_deg: float, head_deg: float, cross: dict, base) -> tuple:
    """``(tilt_deg, head_deg)`` raised (by 5 % steps) until ``diag(tilt, tilt, head)^2 -
    sum_s X_s P_s^-1 X_s^T`` is positive semi-definite for the nabla, one channel's mount and
    the coarse channel's scale factor (each local filter holds one channel; the coarse
    channel's holds the most): a prior the cross-covariance fits."""
    s_nabla = ak._bias_prior(base)[1]
    S = np.zeros((3, 3))
    if "nabla" in cross:
        X = np.asarray(cross["nabla"])
        S += X @ X.T / s_nabla ** 2
    mounts = [np.asarray(v) for k, v in cross.items() if k.endswith(".mount")]
    if mounts:
        s_m = float(base.mount_sigma_arcmin) * ak.ARCMIN
        S += mounts[0] @ mounts[0].T / s_m ** 2
    for k, v in cross.items():        # the coarse channel's filter also holds its scale factor
        if k.endswith(".dk"):
            short = "od" if k.startswith("odometer") else "ldv"
            X = np.asarray(v)
            S += X @ X.T / (float(getattr(base, f"{short}_scale_sigma_ppm")) * 1e-6) ** 2
    t, h = np.radians(tilt_deg), np.radians(head_deg)
    for _ in range(200):
        if np.linalg.eigvalsh(np.diag([t, t, h]) ** 2 - S)[0] >= 0:
            break
        short_h = S[2, 2] >= 0.999 * h * h
        short_t = max(S[0, 0], S[1, 1]) >= 0.999 * t * t
        t, h = (t * 1.05 if short_t or not short_h else t), (h * 1.05 if short_h or not short_t else h)
    return float(np.degrees(t)), float(np.degrees(h))


def coarse_window_envelope(base, meta, lat: float, window_s: float,
                           emap: Optional[dict] = None, channel: Optional[str] = None,
                           rate_hz: float = 0.0) -> dict:
    """The coarse stage's 1-sigma envelope (:func:`coarse_envelope`'s keys): the IMU's terms
    from ``base`` (a fine configuration with the bundle's spec) over ``window_s`` and, with
    the window's error map ``emap``, the window's own terms (:func:`window_envelope`: the
    mounting, the speed's scale factor, lever arm, constraint violation and noise at the
    fine configuration's priors; the accelerometer bias through the map) in quadrature
    (``imu``, ``window``)."""
    env = coarse_envelope(base.gyro_drift_deg_h, base.accel_bias_ug, lat, window_s)
    window = window_envelope(emap, base, meta, channel, rate_hz)
    if window is not None and "imu_bias" in window:
        # the accelerometer bias through the window's map (turned with the vehicle) in place
        # of the parked figures bias / g, bias tan L / g; the gyros' terms as they were
        gyro = coarse_envelope(base.gyro_drift_deg_h, 0.0, lat, window_s)
        b = window["imu_bias"]
        env = {**gyro, "accel_bias_ug": float(base.accel_bias_ug),
               "level_deg": float(np.hypot(gyro["level_deg"], b["level_deg"])),
               "heading_limit_deg": float(np.hypot(gyro["heading_limit_deg"], b["heading_deg"]))}
    if window is not None:
        env["imu"] = {"level_deg": env["level_deg"], "heading_deg": env["heading_limit_deg"]}
        env["window"] = window
        env["level_deg"] = float(np.hypot(env["level_deg"], window["level_deg"]))
        head = float(np.hypot(env["heading_limit_deg"], window["heading_deg"]))
        env["heading_limit_deg"] = head
        env["resolvable"] = bool(head <= UNRESOLVED_HEADING_DEG)
        env["heading_deg"] = head if env["resolvable"] else None
    return env


def standalone_coarse_envelope(bundle: Bundle, lat: float, window_s: float, emap: dict,
                               channel: str) -> dict:
    """:func:`coarse_window_envelope` for a coarse alignment run on its own (issue 15,
    session 24): the priors of the fine method ``fine-mux`` would run on the bundle
    (:func:`auto_fine_method`, with the bundle's spec), so the envelope is the one
    ``fine-mux`` hands its fine stage for the same window."""
    cls = FINE_METHODS[auto_fine_method(bundle)][1]
    base, _ = ak.config_with_spec(ak._config({}, cls), bundle.meta)
    return coarse_window_envelope(base, bundle.meta, lat, window_s, emap, channel,
                                  _rate_hz(bundle, channel))


def standalone_window_envelope(bundle: Bundle, inp, emap):
    """For a coarse alignment run on its own (issue 15, session 24): the callable
    :func:`inmotion.align.attitude_determination.to_solution` takes as ``window_envelope``,
    the envelope of :func:`standalone_coarse_envelope` (the one ``fine-mux`` hands its fine
    stage for the same window) for a window of the given length. ``emap``: the final level's
    :func:`~inmotion.align.attitude_determination.window_error_map`, or a callable making it
    (it is made only where the bundle states its IMU and an envelope is reported).

    Measured on paper 003's drive (window 1-120 s, seeds 3-8), ``coarse-inertial``: heading
    errors 2.7-31.6 arcmin against the IMU's envelope alone of 1.5 arcmin (up to 21 times
    it: the speed's lever arm, scale factor, the IMU's mounting and the vehicle constraint's
    violation were left out of it); with the window's terms 52-53 arcmin (mean (e /
    sigma)^2 0.14, level 0.18: conservative here, the scenario's 15 arcmin mounting and 500
    ppm scale factor lying inside the 30 arcmin and 1000 ppm priors; drawn from them,
    ``fine-mux``'s coarse stage: ``benchmarks/coarse_window_nees.py``)."""
    def envelope(window_s: float) -> dict:
        m = emap() if callable(emap) else emap
        return standalone_coarse_envelope(bundle, inp.lat0, window_s, m, inp.sensor)
    return envelope


def fine_config_from_coarse(cls, fine: dict, meta, lat: float, window_s: float,
                            emap: Optional[dict] = None, channel: Optional[str] = None,
                            rate_hz: float = 0.0, sensors=(), cross: bool = False):
    """``(config, envelope, warnings)``: the fine method's configuration with the coarse
    envelope as its attitude prior (fields ``fine`` does not set; module docstring).
    ``emap``: the window's error map (:func:`coarse_fault_tolerant`), whose terms
    (:func:`window_envelope` with the fine configuration's priors, ``channel``'s spec at
    ``rate_hz``) are added in quadrature to the IMU's envelope. ``cross`` (with a map and a
    resolvable heading): the prior also carries the coarse attitude error's covariance with
    the accelerometer bias and the mounting of every channel of ``sensors``
    (:func:`attitude_cross`, ``init_attitude_cross``), the attitude 1-sigma raised where
    needed for it to fit (:func:`_cover_cross`)."""
    base, _ = ak.config_with_spec(ak._config(fine, cls), meta)
    env = coarse_window_envelope(base, meta, lat, window_s, emap, channel, rate_hz)
    # the standard feedback (issue 15, session 23, measured): started from a coarse
    # attitude, on the PSINS MEMS log with its unresolved heading (45 deg off) the invariant
    # velocity feedback ended 3.5 times its sigma off in level, the standard 0.6
    # and (session 25) the sharing in the sub-filters with it: the sharing at the fusion
    # (fkf's default) needs the invariant feedback (FkfConfig.information_sharing)
    upd = {"init_velocity_from_attitude": True, "invariant_velocity_error": False,
           "init_tilt_sigma_deg": max(env["level_deg"], base.init_tilt_sigma_deg),
           "init_heading_sigma_deg": (max(env["heading_deg"], base.init_heading_sigma_deg)
                                      if env["resolvable"] else UNKNOWN_HEADING_SIGMA_DEG)}
    if cross and env["resolvable"] and emap is not None and "init_attitude_cross" not in (fine or {}):
        X = attitude_cross(window_cross_maps(emap), base, sensors, channel)
        tilt, head = _cover_cross(env["level_deg"], env["heading_deg"], X, base)
        if "init_tilt_sigma_deg" in (fine or {}) or "init_heading_sigma_deg" in (fine or {}):
            tilt, head = (float(fine.get("init_tilt_sigma_deg", tilt)),
                          float(fine.get("init_heading_sigma_deg", head)))
        upd.update({"init_attitude_cross": X, "init_tilt_sigma_deg": tilt,
                    "init_heading_sigma_deg": head})
        env["attitude_cross"] = X
    if "information_sharing" in cls.model_fields:
        upd["information_sharing"] = "sub-filters"
    upd = {k: v for k, v in upd.items() if k not in (fine or {})}
    warnings = []
    if not env["resolvable"]:
        warnings.append(
            f"coarse stage outside its envelope: gyro drift {env['gyro_drift_deg_h']:.3g} "
            f"deg/h against the horizontal Earth rate {np.degrees(earth.OMEGA_IE * np.cos(lat)) * 3600:.3g} "
            f"deg/h gives a heading limit of {env['heading_limit_deg']:.3g} deg: the heading "
            "is not resolved (fine prior and reported heading 1-sigma "
            f"{UNKNOWN_HEADING_SIGMA_DEG:.0f} deg; fine prior level 1-sigma "
            f"{env['level_deg'] * 60:.3g} arcmin, reported level 1-sigma per axis at least "
            f"bias / g = {env['accel_bias_ug'] * 1e-6 * 180 / np.pi * 60:.3g} arcmin); give "
            "the heading from outside (--init)")
    elif env["level_deg"] > 1.0:
        warnings.append(f"coarse level envelope {env['level_deg'] * 60:.3g} arcmin (gyro "
                        f"drift {env['gyro_drift_deg_h']:.3g} deg/h over {window_s:.0f} s, "
                        f"accelerometer bias {env['accel_bias_ug']:.3g} ug)")
    return ak._config({**(fine or {}), **upd}, cls), env, warnings


def floor_attitude_sigma(sol: Solution, env: dict, level: bool = True) -> None:
    """Keep the reported attitude 1-sigma of ``sol`` at least what the IMU allows without an
    external attitude reference: level ``bias / g`` (with ``level``, or when the heading is
    not resolved); heading :data:`UNKNOWN_HEADING_SIGMA_DEG` when the coarse stage could not
    resolve it, and then the horizontal position and velocity too
    (:func:`floor_unresolved_horizontal_sigma`).

    ``level=False`` (issue 15): the solution is a velocity-aided filter whose prior carries
    the coarse tilt's correlation with the accelerometer bias (``env['attitude_cross']``),
    started from a resolved heading. Its covariance then holds what separates the two (the
    bias turns with the vehicle in the nav frame, the tilt does not), so its level sigma is
    its own; ``bias / g`` is the limit only where nothing turns the bias (parked, or a
    heading the linear filter cannot hold). Measured on paper 003's drive (600 s window, 20
    runs) the fine level errors are 0.001-0.011 arcmin, under the 0.172 floor."""
    lvl = env["accel_bias_ug"] * 1e-6                   # bias / g [rad]
    for k in ("phi_E", "phi_N"):
        if k in sol.sigma and (level or not env["resolvable"]):
            sol.sigma[k] = np.maximum(sol.sigma[k], lvl)
    if not env["resolvable"] and "phi_U" in sol.sigma:
        sol.sigma["phi_U"] = np.maximum(sol.sigma["phi_U"],
                                        np.radians(UNKNOWN_HEADING_SIGMA_DEG))
    if not env["resolvable"]:
        floor_unresolved_horizontal_sigma(sol)


def floor_unresolved_horizontal_sigma(sol: Solution) -> None:
    """Keep the horizontal position and velocity 1-sigma of ``sol`` per axis at least what a
    heading known only to lie in +-180 deg leaves of them (issue 15, session 19).

    A start heading error ``psi`` turns the whole horizontal track about its first point: the
    position error is ``(R(psi) - I) d``, ``d = [d_N, d_E]`` the displacement from the start
    (its length is the same in the solution as in truth: a rotation keeps it). For ``psi``
    uniform on +-180 deg (``E cos psi = E sin psi cos psi = 0``, ``E cos^2 = E sin^2 = 1/2``)
    its north component ``(cos psi - 1) d_N - sin psi d_E`` has mean square
    ``1.5 d_N^2 + 0.5 d_E^2``, the east ``0.5 d_N^2 + 1.5 d_E^2`` (radially 1.5 ``|d|^2``, across
    0.5). The velocity likewise with ``v = [v_N, v_E]``. The linear filter's own sigma knows
    nothing of this: on comma2k19 ``fine-mux`` (heading unresolved, reported heading sigma
    104 deg) ended 1.8 km off at a 32 m horizontal sigma."""
    d_n, d_e = earth.local_ne_offsets(sol.lat, sol.lon, sol.lat[0], sol.lon[0], sol.h[0])
    v_n, v_e = sol.vel_n[:, 1], sol.vel_n[:, 0]
    floors = {"north": np.sqrt(1.5 * d_n ** 2 + 0.5 * d_e ** 2),
              "east": np.sqrt(0.5 * d_n ** 2 + 1.5 * d_e ** 2),
              "vN": np.sqrt(1.5 * v_n ** 2 + 0.5 * v_e ** 2),
              "vE": np.sqrt(0.5 * v_n ** 2 + 1.5 * v_e ** 2)}
    for k, floor in floors.items():
        if k in sol.sigma:
            sol.sigma[k] = np.maximum(sol.sigma[k], floor)


#: the largest coarse heading 1-sigma [deg] the fine (linear, small-angle) filter is trusted
#: to take. Measured (issue 15, ``tests/consistency_mc.final_nees``, paper 003's drive cut
#: to 85 s, 20 runs, start error drawn from the prior): ``fkf`` from a 2 deg heading prior
#: ends with NEES 1.80 (band 2.02-4.16: covered), from 3.7 deg 108.6 (four runs above 100);
#: ``fine-mux`` with an 80 s window (coarse heading 1-sigma 3.7 deg) 9.48, one run 192
#: arcmin off with a 20 arcmin sigma. So 2 deg, the fine filters' default heading prior
#: (``init_heading_sigma_deg``), not ``aided_kf.LENGTH_MAX_ANGLE`` (5.7 deg).
LINEAR_HEADING_DEG = 2.0


def linear_range_check(sol: Solution, env: dict, window_s: float) -> list:
    """When the coarse heading 1-sigma (IMU and window terms, :func:`fine_config_from_coarse`)
    exceeds :data:`LINEAR_HEADING_DEG` but the heading is resolvable, the fine filter's own
    heading sigma cannot be trusted: keep the reported heading 1-sigma at least the coarse
    one, and the level 1-sigma at least ``hypot(level envelope, sqrt(3) / 2 sigma_psi^2
    a_max / g)``: a heading error ``psi`` leaves a second-order forward velocity error
    ``(1 - cos psi) v ~ psi^2 / 2 v`` the linear filter can only take as a pitch ``psi^2 / 2
    a / g`` (``a_max`` the largest horizontal acceleration of the solution over 1 s;
    ``sqrt(E psi^4) = sqrt(3) sigma_psi^2``); return the warning (else ``[]``). The window
    needed is sized by the heading sigma falling at least as ``1 / T`` (the Earth-rate
    information grows as ``T^2``)."""
    head = env.get("heading_limit_deg")
    if not env.get("resolvable") or head is None or head <= LINEAR_HEADING_DEG:
        return []
    if "phi_U" in sol.sigma:
        sol.sigma["phi_U"] = np.maximum(sol.sigma["phi_U"], np.radians(head))
    t, v = np.asarray(sol.t, float), np.asarray(sol.vel_n, float)[:, :2]
    a_max = 0.0
    if len(t) > 2:
        k = max(1, int(round(1.0 / max(float(np.median(np.diff(t))), 1e-6))))
        if len(t) > k:
            a_max = float(np.max(np.linalg.norm(v[k:] - v[:-k], axis=1)
                                 / (t[k:] - t[:-k])))
    lvl = float(np.hypot(np.radians(env["level_deg"]),
                         np.sqrt(3.0) / 2.0 * np.radians(head) ** 2 * a_max / earth.G0))
    for c in ("phi_E", "phi_N"):
        if c in sol.sigma:
            sol.sigma[c] = np.maximum(sol.sigma[c], lvl)
    need = window_s * head / LINEAR_HEADING_DEG
    return [f"coarse window {window_s:.0f} s too short for the heading: coarse heading "
            f"1-sigma {head * 60:.0f} arcmin (window terms: mounting, scale factor, lever "
            "arm, vehicle constraint violation, speed noise; info['coarse_envelope']) exceeds "
            f"the {LINEAR_HEADING_DEG:.1f} deg the fine filter linearises; reported heading "
            f"1-sigma kept at least that; lengthen coarse_window_s to >= {need:.0f} s"]


def auto_fine_method(bundle: Bundle, choice: str = "auto") -> str:
    """The fine method ``choice`` names, or for ``auto`` the one the bundle's sensors fit:
    ``fkf`` with odometer and LDV, ``od-kf`` / ``ldv-kf`` with one of them, ``nhc-kf`` with
    neither."""
    if choice != "auto":
        return choice
    od, ldv = bundle.odometer is not None, bundle.ldv is not None
    return "fkf" if od and ldv else "od-kf" if od else "ldv-kf" if ldv else "nhc-kf"


class MuxConfig(BaseModel):
    """Configuration of ``fine-mux`` (human units)."""

    model_config = ConfigDict(extra="forbid")
    coarse_window_s: float = Field(600.0, gt=0, description="coarse alignment window")
    fault_tolerant_coarse: bool = Field(
        True,
        description="coarse stage on the fault-tolerant speed (odometer / LDV / IMU voting)")
    speed_tolerance_m_s: float = Field(
        0.15, gt=0,
        description="a speed channel is healthy while it agrees with the IMU prediction within "
                    "this [m/s]")
    pitch_time_constant_s: float = Field(
        1.0, gt=0,
        description="low-pass time constant of the pitch used by the IMU speed prediction [s]")
    coarse_sensor: Optional[Literal["odometer", "ldv"]] = Field(
        None, description="the one sensor of a non-fault-tolerant coarse stage (default: "
                          "ldv if present)")
    fine_method: Literal["auto", "fkf", "od-kf", "ldv-kf", "nhc-kf"] = Field(
        "auto", description="the fine alignment method that follows the coarse stage; auto: "
                            "fkf with odometer and LDV, od-kf or ldv-kf with one of them "
                            "(info: fine_method)")
    prior_cross: bool = Field(
        True,
        description="the fine prior carries the coarse attitude error's covariance with the "
                    "accelerometer bias, the mounting and the coarse channel's scale factor "
                    "(init_attitude_cross; "
                    "multiplex.attitude_cross) and the reported level 1-sigma is the fine "
                    "filter's own where the heading is resolved (floor_attitude_sigma's "
                    "level=False); issue 15. False: the prior independent and the level "
                    "floor bias / g everywhere (before issue 15's session 12: NEES 1.08 at the "
                    "600 s window, conservative; benchmarks/fine_mux_level_floor.py)")
    fine: dict = Field(default_factory=dict, description="configuration of the fine method")
    coarse: dict = Field(default_factory=dict, description="coarse-inertial configuration")


def fault_tolerant_speed(bundle: Bundle, t: np.ndarray, tolerance_m_s: float = 0.15,
                         pitch_tau_s: float = 1.0, horizon_s: float = 0.2):
    """The forward speed picked from OD / LDV by the IMU (module docstring).

    Parameters
    ----------
    bundle : with ``imu`` and at least one of ``odometer``, ``ldv``
    t : (N,) IMU times of the window [s] (a contiguous run of the IMU rows)

    Returns
    -------
    v : (N,) m/s;  source : (N,) int, 0 odometer, 1 LDV, 2 IMU bridge;
    events : list of ``{"t_s", "source"}`` where the source changes
    """
    present = [c for c in _CHANNELS if getattr(bundle, c) is not None]
    if not present:
        raise BadInput(f"bundle {bundle.name!r} has neither odometer nor ldv")
    V = np.full((2, len(t)), np.nan)
    for i, c in enumerate(_CHANNELS):
        if c in present:
            V[i] = speed_on_imu_times(c, getattr(bundle, c), t)
    imu = bundle.imu
    k0 = int(np.searchsorted(imu.t, t[0]))
    dvy = imu.dvel[k0:k0 + len(t), 1]
    dt = np.diff(t, prepend=t[0] - imu.dt)
    g = earth.G0
    n = len(t)
    v = np.empty(n)
    src = np.empty(n, dtype=np.int64)
    cum = np.zeros(n)              # cumulated IMU forward velocity increments [m/s]
    first = np.nanargmin(np.where(np.isnan(V[:, 0]), np.inf, 0.0))
    v[0], src[0] = V[first, 0], first
    lag = max(1, int(round(horizon_s / float(np.median(dt)))))
    s_pitch = 0.0
    for k in range(1, n):
        cum[k] = cum[k - 1] + dvy[k] - g * s_pitch * dt[k]
        j0 = max(k - lag, 0)
        v_imu = v[j0] + cum[k] - cum[j0]
        d = np.abs(V[:, k] - v_imu)
        d[np.isnan(d)] = np.inf
        j = int(np.argmin(d))
        if d[1] <= tolerance_m_s:
            j = 1                    # a healthy LDV is preferred (the smaller scale error)
        if d[j] <= tolerance_m_s:
            v[k], src[k] = V[j, k], j
        elif abs(V[0, k] - V[1, k]) <= tolerance_m_s:
            # both sensors agree with each other but not with the IMU (whose bridge has
            # drifted after a double fault): two independent sensors win
            v[k], src[k] = V[j, k], j
        else:
            v[k], src[k] = v[k - 1] + cum[k] - cum[k - 1], 2
        a = dt[k] / pitch_tau_s
        s_pitch += a * ((dvy[k] - (v[k] - v[k - 1])) / (g * dt[k]) - s_pitch)
    change = np.flatnonzero(np.diff(src)) + 1
    names = ("odometer", "ldv", "imu")
    events = [{"t_s": float(t[k]), "event": "speed source", "source": names[src[k]]}
              for k in change]
    return v, src, events


def coarse_fault_tolerant(bundle: Bundle, cfg: MuxConfig, init: Optional[NavState],
                          t0: float, t1: float, error_map: bool = False):
    """Coarse alignment over ``[t0, t1]`` with the fault-tolerant (or a single) speed.

    Returns ``(solution, C_nb0)``: the coarse solution and the attitude at ``t0``; with
    ``error_map`` also the window's error map
    (:func:`inmotion.align.attitude_determination.window_error_map`).
    """
    t0 = first_covered(bundle, t0)
    win = bundle.load_window(t0, t1)          # the window's IMU rows only (read in chunks)
    events = []
    ccfg = CoarseInertialConfig(**{"mode": "moving", **cfg.coarse})
    if cfg.fault_tolerant_coarse:
        # the speeds from the whole log: a window cut at t0, t1 may lose the samples either
        # side of its ends (a real log's irregular CAN speed)
        v, _, events = fault_tolerant_speed(
            Bundle(win.imu, win.meta, bundle.radar, bundle.ldv, bundle.odometer),
            win.imu.t, cfg.speed_tolerance_m_s, cfg.pitch_time_constant_s)
        win = Bundle(win.imu, win.meta, None, SpeedData(win.imu.t, v=v), None, win.baro, win.truth)
        ccfg = ccfg.model_copy(update={"velocity_sensor": "ldv"})
    else:
        name = cfg.coarse_sensor or ("ldv" if bundle.ldv is not None else "odometer")
        ccfg = ccfg.model_copy(update={"velocity_sensor": name})
    sol, emap = run_coarse_inertial(win, ccfg, init, error_map=True)
    sol.info["speed_source_events"] = events
    # the channel whose spec sizes the window's terms: the LDV the fault-tolerant speed
    # prefers (or the one sensor used)
    sol.info["coarse_channel"] = (("ldv" if bundle.ldv is not None else "odometer")
                                  if cfg.fault_tolerant_coarse else ccfg.velocity_sensor)
    a = sol.info["attitude_start_deg"]
    C0 = rotations.dcm_from_euler(np.radians([a["pitch"], a["roll"], a["yaw"]]))
    return (sol, C0, emap) if error_map else (sol, C0)


def start_state(bundle: Bundle, C_nb, t0: float, init: Optional[NavState] = None) -> NavState:
    """The state a fine alignment starts from after a coarse one: attitude ``C_nb`` (``C_b^n``
    at ``t0``, e.g. the coarse result referred back to its window's start, sec. 3.3.1), the
    sensor's forward speed at ``t0`` along it (the LDV if present, else the odometer; a 1 s line
    fit), the position of ``init`` (else ``meta.yaml``, else the first truth row:
    :func:`inmotion.align.attitude_determination.initial_position`). ``fine-mux`` starts its
    fine stage from it; a user chaining a coarse and a fine alignment by hand does the same."""
    lat, lon, h = initial_position(bundle, init)
    name = "ldv" if bundle.ldv is not None else "odometer"
    v0 = initial_speed(name, getattr(bundle, name), t0, 1.0)
    C_nb = np.asarray(C_nb, dtype=float)
    return NavState(t0, lat, lon, h, C_nb @ np.array([0.0, v0, 0.0]),
                    rotations.quat_from_dcm(C_nb))


def _rate_hz(bundle: Bundle, channel: Optional[str]) -> float:
    """The sample rate of ``channel``'s speed [Hz] (0 without it)."""
    sp = getattr(bundle, channel, None) if channel else None
    if sp is None or len(sp.t) < 2:
        return 0.0
    return float(1.0 / np.median(np.diff(sp.t[:1000])))


def first_covered(bundle: Bundle, t_from: float) -> float:
    """The first IMU time at or after ``t_from`` at which every OD / LDV present has a speed
    (a distance sensor's first speed is at the middle of its first interval)."""
    t_min = t_from
    for c in _CHANNELS:
        sp = getattr(bundle, c)
        if sp is None or len(sp.t) < 2:
            continue
        t_min = max(t_min, float(sp.t[0] if sp.v is not None else 0.5 * (sp.t[0] + sp.t[1])))
    k = int(np.searchsorted(bundle.imu.t, t_min - 1e-9))
    if k >= len(bundle.imu.t) - 1:
        raise BadInput(f"no IMU rows after {t_min:.3f} s covered by the velocity sensors",
                       file="imu")
    return float(bundle.imu.t[k])


def last_covered(bundle: Bundle, t_to: float | None = None,
                 channels=_CHANNELS) -> float:
    """The last IMU time at or before ``t_to`` (default: the end) at which every sensor of
    ``channels`` present still has a speed (a real log's speed may end a few ms before its
    IMU)."""
    t_max = float(bundle.imu.t[-1]) if t_to is None else float(t_to)
    for c in channels:
        sp = getattr(bundle, c)
        if sp is not None and len(sp.t):
            t_max = min(t_max, float(sp.t[-1]))
    k = int(np.searchsorted(bundle.imu.t, t_max + 1e-9, side="right")) - 1
    return float(bundle.imu.t[max(k, 0)])


def run_multiplexed(bundle: Bundle, cfg: MuxConfig, init: Optional[NavState] = None,
                    progress: Optional[Callable] = None) -> Solution:
    """Coarse over the window, attitude back-derived to its start, fine from the start to the
    end of the log (module docstring)."""
    t0 = first_covered(bundle, float(bundle.imu.t[0]) if init is None else float(init.t))
    t1 = last_covered(bundle, t0 + cfg.coarse_window_s)
    w0 = time.perf_counter()
    coarse, C0, emap = coarse_fault_tolerant(bundle, cfg, init, t0, t1, error_map=True)
    start = start_state(bundle, C0, t0, init)
    fine_method = auto_fine_method(bundle, cfg.fine_method)
    run, cls = FINE_METHODS[fine_method]
    channel = coarse.info.get("coarse_channel")
    sensors = {"fkf": ("odometer", "ldv"), "od-kf": ("odometer",),
               "ldv-kf": ("ldv",)}.get(fine_method, ())
    fcfg, env, warn = fine_config_from_coarse(cls, cfg.fine, bundle.meta, start.lat, t1 - t0,
                                              emap, channel, _rate_hz(bundle, channel),
                                              sensors, cfg.prior_cross)
    w_coarse = time.perf_counter() - w0
    w1 = time.perf_counter()
    sol = run(bundle, fcfg, start, progress=progress)
    w_fine = time.perf_counter() - w1
    floor_attitude_sigma(sol, env, level=not cfg.prior_cross)
    warn += linear_range_check(sol, env, t1 - t0)
    sol.info["warnings"] = warn + list(sol.info.get("warnings", []))
    sol.info["coarse_envelope"] = env
    data_s = float(bundle.imu.t[-1] - t0)
    factor = data_s / max(w_fine, 1e-9)
    sol.info.update({
        "method": "fine-mux", "mux_config": cfg.model_dump(), "fine_method": fine_method,
        "multiplexing": {"t_start_s": t0, "coarse_end_s": t1,
                         "attitude_start_deg": coarse.info["attitude_start_deg"],
                         "coarse_attitude_end_deg": coarse.info["attitude_end_deg"],
                         "speed_source_events": coarse.info["speed_source_events"],
                         "coarse_wall_s": w_coarse, "fine_wall_s": w_fine},
        "catch_up": {"speed_factor": factor,
                     "real_time_reached_s": (t1 + (t1 - t0) / (factor - 1.0)
                                             if factor > 1.0 else None)}})
    sol.info["coarse_solution_end"] = coarse.final_state().euler.tolist()
    return sol


def run_fine_mux(bundle: Bundle, config: MuxConfig | dict | None = None,
                 init: NavState | None = None, progress: Optional[Callable] = None) -> Solution:
    """``fine-mux``: fault-tolerant coarse, then fine alignment with information multiplexing."""
    cfg = ak._config(config, MuxConfig)
    return run_multiplexed(bundle, cfg, init, progress)
