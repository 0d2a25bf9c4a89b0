"""Adaptive alignment strategy of a vehicle that starts parked and drives off (paper 003
sec. 3.3.2, Figure 4): method ``adaptive``.

1. Parked or moving (eq. 43-45): the OD and LDV forward speeds, zero-mean noise of standard
   deviations ``parked_speed_noise_m_s`` while parked, give ``lambda_v = v_od^2 / s_od^2 +
   v_ldv^2 / s_ldv^2``, chi-square with 2 degrees of freedom (1 with one sensor). The vehicle is
   declared moving at the first sample of the first run of ``confirm_s`` seconds with
   ``lambda_v > T`` (``T`` the upper ``false_alarm_rate`` quantile); that time is the switch
   time, logged as an event with its test value.
Both strategies check the coarse stage's envelope against the IMU spec
(:func:`inmotion.align.multiplex.coarse_envelope`): outside it (a heading the gyros cannot
resolve) the parked and fine priors say so, the reported sigma is kept at what the IMU allows
and ``info['warnings']`` says why (issue 15).

2. Parked for at least ``parked_coarse_s`` (Strategy 1, "flag = 1"): inertial-frame coarse
   alignment on the wobbling base over the first ``parked_coarse_s`` seconds (low-pass and
   multi-vector integration of :mod:`inmotion.align.coarse_inertial`), whose attitude is
   referred back to the start (information multiplexing: parked, the attitude at the start is
   that of the whole window), then ``parked-kf`` from the start until the switch. When the
   vehicle moves, the parked result (attitude, with its 1-sigma as the prior) starts the
   in-motion fine alignment (``fkf`` by default) at the switch time, run to the end.
3. Parked for less than ``parked_coarse_s`` (Strategy 2): fault-tolerant in-motion coarse
   alignment from the start, then the fine alignment with information multiplexing from the
   start (:mod:`inmotion.align.multiplex`); the coarse alignment's in-motion model also
   holds while the speed is still zero.

The rotational modulation the paper mentions for the parked stage needs a rotating IMU and is
not modelled.
"""
from __future__ import annotations

import time
from typing import Callable, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .. import config_fields as cf
from ..core import rotations
from ..core.bundle import Bundle
from ..core.solution import NavState, Solution
from ..errors import BadInput
from ..estimation import chi2
from . import aided_kf as ak
from .attitude_determination import initial_position
from .coarse_inertial import CoarseInertialConfig, run_coarse_inertial
from .multiplex import (FINE_METHODS, UNKNOWN_HEADING_SIGMA_DEG, MuxConfig, auto_fine_method,
                        fine_config_from_coarse, first_covered, floor_attitude_sigma,
                        last_covered, run_multiplexed)
from .parked_kf import ParkedKfConfig, run_parked_kf
from .velocity_source import speed_on_imu_times

__all__ = ["motion_statistic", "AdaptiveConfig", "detect_motion", "run_adaptive"]


class AdaptiveConfig(BaseModel):
    """Configuration of ``adaptive`` (human units)."""

    model_config = ConfigDict(extra="forbid")
    parked_speed_noise_m_s: list[float] = Field([0.02, 0.02], min_length=2, max_length=2,
                                                description="[odometer, ldv] 1-sigma parked")
    false_alarm_rate: float = cf.false_alarm_rate(1e-4)
    confirm_s: float = cf.confirm_s(0.5)
    test_rate_hz: float = Field(
        10.0, gt=0, description="rate of the parked/moving chi-square test [Hz]")
    parked_coarse_s: float = Field(
        60.0, gt=0,
        description="parked this long or longer: parked coarse + parked-kf (Strategy 1) [s]")
    fine_method: Literal["auto", "fkf", "od-kf", "ldv-kf"] = Field(
        "auto", description="the fine alignment method that follows the coarse stage; auto: fkf "
                            "with odometer and LDV, od-kf or ldv-kf with one of them")
    fine: dict = Field(
        default_factory=dict, description="configuration of the fine method (a mapping)")
    parked: dict = Field(default_factory=dict, description="parked-kf configuration")
    coarse: dict = Field(default_factory=dict, description="coarse-inertial configuration")
    mux: dict = Field(default_factory=dict, description="fine-mux configuration (Strategy 2)")


def motion_statistic(bundle: Bundle, t0: float, noise_m_s, rate_hz: float,
                     radar_noise_m_s: float | None = None):
    """Paper 003 eq. 43-44 on a ``rate_hz`` grid from ``t0`` to the end of the speed data:
    ``lambda = sum_s (v_s / sigma_s)^2`` over the odometer and LDV (``noise_m_s`` = [odometer,
    ldv] parked 1-sigma [m/s]), the radar's alone when the bundle has neither and
    ``radar_noise_m_s`` is given. Returns ``(t, lambda, dof)``."""
    t_imu = bundle.imu.t
    t0 = first_covered(bundle, t0)
    step = max(1, int(round(1.0 / (rate_hz * bundle.imu.dt))))
    k0 = int(np.searchsorted(t_imu, t0 - 1e-9))
    t = t_imu[k0::step]
    t = t[t <= last_covered(bundle, channels=("odometer", "ldv", "radar")) + 1e-9]
    lam = np.zeros(len(t))
    dof = 0
    for s, name in zip(noise_m_s, ("odometer", "ldv")):
        sp = getattr(bundle, name)
        if sp is None:
            continue
        v = speed_on_imu_times(name, sp, t)
        lam += (v / s) ** 2
        dof += 1
    if dof == 0 and radar_noise_m_s is not None and bundle.radar is not None:
        lam += (speed_on_imu_times("radar", bundle.radar, t) / radar_noise_m_s) ** 2
        dof = 1
    if dof == 0:
        raise BadInput(f"bundle {bundle.name!r} has neither odometer nor ldv: adaptive "
                       "alignment needs one to tell parked from moving")
    return t, lam, dof


def detect_motion(bundle: Bundle, t0: float, noise_m_s, false_alarm_rate: float,
                  confirm_s: float, rate_hz: float, radar_noise_m_s: float | None = None):
    """Switch time [s] from parked to moving (eq. 43-45), or None if the vehicle never moves.

    ``noise_m_s`` = [odometer, ldv] parked 1-sigma [m/s]; with neither sensor in the bundle and
    ``radar_noise_m_s`` given, the radar's speed is the test's one channel
    (:func:`motion_statistic`).
    Returns ``(t_switch, lambda_at_switch, threshold)``.
    """
    t, lam, dof = motion_statistic(bundle, t0, noise_m_s, rate_hz, radar_noise_m_s)
    thr = chi2.threshold(false_alarm_rate, dof)
    need = max(1, int(round(confirm_s * rate_hz)))
    run = 0
    for i, over in enumerate(lam > thr):
        run = run + 1 if over else 0
        if run >= need:
            j = i - need + 1
            return float(t[j]), float(lam[j]), thr
    return None, None, thr


def _parked_stage(bundle, cfg, init, t0, t_sw):
    """Strategy 1: parked coarse over ``parked_coarse_s``, then ``parked-kf`` from the start."""
    lat, lon, h = initial_position(bundle, init)
    t1 = t0 + cfg.parked_coarse_s
    ccfg = CoarseInertialConfig(**{"mode": "parked", **cfg.coarse})
    # both stream their rows (coarse-inertial integrates its vectors block by block,
    # parked-kf feeds its filter from imu_rows_after): a bundle read in chunks is passed as a
    # window, not loaded (a log parked from start to end would be its whole IMU)
    coarse = run_coarse_inertial(bundle.window(t0, t1), ccfg,
                                 NavState(t0, lat, lon, h, np.zeros(3), [1.0, 0, 0, 0]))
    a = coarse.info["attitude_start_deg"]
    C0 = rotations.dcm_from_euler(np.radians([a["pitch"], a["roll"], a["yaw"]]))
    start = NavState(t0, lat, lon, h, np.zeros(3), rotations.quat_from_dcm(C0))
    parked = run_parked_kf(bundle.window(None, t_sw), ParkedKfConfig(**cfg.parked), start,
                           end_s=t_sw)
    return coarse, parked


def _concat(parts):
    """One Solution from consecutive parts (later parts win on shared times)."""
    keep = []
    for i, s in enumerate(parts):
        t_next = parts[i + 1].t[0] if i + 1 < len(parts) else np.inf
        keep.append(s.t < t_next)
    cat = lambda f: np.concatenate([f(s)[m] for s, m in zip(parts, keep)])
    n = [int(m.sum()) for m in keep]
    sig_keys = set().union(*(s.sigma for s in parts))
    sigma = {k: np.concatenate([s.sigma[k][m] if k in s.sigma else np.full(c, np.nan)
                                for s, m, c in zip(parts, keep, n)]) for k in sig_keys}
    last = parts[-1]
    states = {k: np.concatenate([np.full(sum(n[:-1]), np.nan), v[keep[-1]]])
              for k, v in last.states.items()}
    return Solution(cat(lambda s: s.t), cat(lambda s: s.lat), cat(lambda s: s.lon),
                    cat(lambda s: s.h), cat(lambda s: s.vel_n), cat(lambda s: s.euler),
                    sigma=sigma, states=states, state_units=dict(last.state_units))


def run_adaptive(bundle: Bundle, config: AdaptiveConfig | dict | None = None,
                 init: NavState | None = None, progress: Optional[Callable] = None) -> Solution:
    """``adaptive``: parked / moving detection and the alignment strategy of sec. 3.3.2."""
    cfg = ak._config(config, AdaptiveConfig)
    w0 = time.perf_counter()
    t0 = first_covered(bundle, float(bundle.imu.t[0]) if init is None else float(init.t))
    t_sw, lam_sw, thr = detect_motion(bundle, t0, cfg.parked_speed_noise_m_s,
                                      cfg.false_alarm_rate, cfg.confirm_s, cfg.test_rate_hz)
    t_end = float(bundle.imu.t[-1])
    parked_s = (t_sw if t_sw is not None else t_end) - t0
    events = [{"t_s": t0, "event": "start", "state": "parked" if parked_s > 0 else "moving"}]
    if t_sw is not None:
        events.append({"t_s": t_sw, "event": "switch", "state": "moving",
                       "test_value": lam_sw, "threshold": thr})
    fine_method = auto_fine_method(bundle, cfg.fine_method)
    run_fine, cls = FINE_METHODS[fine_method]
    if parked_s >= cfg.parked_coarse_s:
        strategy = "1: parked coarse + parked-kf, then in-motion fine from the parked result"
        lat0 = initial_position(bundle, init)[0]
        _, env, warn = fine_config_from_coarse(cls, cfg.fine, bundle.meta, lat0,
                                               cfg.parked_coarse_s)
        if not env["resolvable"]:                 # the parked stage cannot resolve it either
            cfg = cfg.model_copy(update={"parked": {
                "init_heading_sigma_deg": UNKNOWN_HEADING_SIGMA_DEG, **cfg.parked}})
        coarse, parked = _parked_stage(bundle, cfg, init, t0, t_sw if t_sw else t_end)
        parts = [parked]
        info_fine = {}
        if t_sw is not None and t_end - t_sw > 1.0:
            st = parked.final_state()
            sig_tilt = float(np.degrees(max(parked.sigma["phi_E"][-1],
                                            parked.sigma["phi_N"][-1], 1e-5)))
            sig_head = float(np.degrees(max(parked.sigma["phi_U"][-1], 1e-4)))
            fcfg = cls(**{"init_tilt_sigma_deg": 3 * sig_tilt,
                          "init_heading_sigma_deg": min(3 * sig_head,
                                                        UNKNOWN_HEADING_SIGMA_DEG),
                          **cfg.fine})
            start = NavState(t_sw, st.lat, st.lon, st.h, np.zeros(3), st.q_nb)
            fine = run_fine(bundle, fcfg, start, progress=progress)
            parts.append(fine)
            events += fine.info.get("events", [])
            warn += list(fine.info.get("warnings", []))
            info_fine = {k: fine.info[k] for k in ("tests", "fdi_threshold") if k in fine.info}
        sol = _concat(parts)
        floor_attitude_sigma(sol, env)
        sol.info.update({"warnings": warn, "coarse_envelope": env})
        sol.info.update({"coarse_attitude_start_deg": coarse.info["attitude_start_deg"],
                         "parked_final_sigma_arcmin": {
                             k: float(np.degrees(parked.sigma[k][-1]) * 60)
                             for k in ("phi_E", "phi_N", "phi_U")}, **info_fine})
    else:
        strategy = "2: in-motion coarse (fault tolerant) + fine with information multiplexing"
        mux = MuxConfig(**{"fine_method": fine_method, "fine": cfg.fine, **cfg.mux})
        sol = run_multiplexed(bundle, mux, init, progress)
        events += sol.info.get("events", [])
    sol.info.update({"method": "adaptive", "config": cfg.model_dump(), "strategy": strategy,
                     "fine_method": fine_method,
                     "sensors": [c for c in ("odometer", "ldv") if getattr(bundle, c) is not None],
                     "switch_time_s": t_sw, "parked_s": parked_s, "events": events,
                     "wall_time_s": time.perf_counter() - w0})
    return sol
