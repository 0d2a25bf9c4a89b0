"""The main job in one call: parked / moving segments, alignment, navigation to the end of the
drive with the aiding the bundle has (``inmotion process``, issue 14).

:func:`run_process` chains the package's methods into stages and logs which ran when and why
(``Solution.info["stages"]``). The rules, in order:

1. **Sensors.** The forward-velocity sensors present (radar, LDV, odometer) and the barometer.
2. **Parked or moving** (paper 003 eq. 43-45, :func:`inmotion.align.strategy.detect_motion`):
   the chi-square test on the odometer and LDV speeds, on the radar's when the bundle has
   neither. With no velocity sensor the drive is taken as parked throughout if ``meta.yaml``
   says ``motion: {parked: true}``, else as moving from the start (no zero-velocity stage).
3. **Can the IMU find the heading?** Without GNSS the heading is observable only through the
   Earth's rotation (gyrocompassing), parked or moving: the velocity sensors and the vehicle
   constraint are body-frame quantities that a heading rotation leaves unchanged. The
   gyrocompass heading error is ``sigma_psi = eps / (Omega_ie cos L)`` for a gyro drift
   ``eps``. :func:`heading_observability` takes ``eps`` from ``meta.yaml``'s IMU spec
   (``imu.gyro.drift_deg_h`` (+ Markov part), the simulator's and the importers' spelling),
   else measures it on the parked data (at least ``min_parked_check_s``): the mean gyro rate
   of a parked vehicle is the Earth rate, so the difference of its up and horizontal
   components from ``Omega sin L`` and ``Omega cos L`` is a lower bound of the drift, and the
   scatter of the 1-s means divided by sqrt(number of seconds) its noise. The IMU finds the
   heading when ``sigma_psi <= max_gyrocompass_heading_sigma_deg`` (3 deg: a 0.5 deg/h gyro
   at 45 deg latitude; every navigation-grade IMU passes, every MEMS fails). Unknown (no spec,
   no parked period): it cannot. When it cannot, the heading comes from ``init`` (truth,
   meta, a result) with the sigma of that source (``heading_source`` in ``info``); without
   ``init`` the run stops with ``BadInput`` saying so. A gyrocompass-grade IMU also needs
   time: a coarse window shorter than ``min_gyrocompass_s`` (60 s; the Earth turns 0.25 deg
   in a minute) is treated the same way, and a log parked throughout must be parked for
   ``parked_coarse_s``.
4. **Alignment.**
   parked for ``parked_coarse_s`` or longer: parked coarse alignment (``coarse-inertial``,
   mode parked) over the first ``parked_coarse_s``, then the zero-velocity fine alignment
   (``parked-kf``) until the vehicle moves (or the end of the log);
   otherwise, with a velocity sensor: in-motion coarse alignment over ``coarse_window_s``
   (the fault-tolerant odometer / LDV speed of ``fine-mux``, else the radar), its attitude
   referred back to the start (information multiplexing), then the fine filter from the
   start; with no velocity sensor and moving, the attitude comes from ``init``.
5. **Fine alignment and navigation** from the handover to the end, fault detection on, the
   barometer if present: with a radar, ``dr-kf`` (paper 000, fine alignment in motion) for
   ``fine_s`` then ``sins-dr`` (paper 002, chi-square gate ``gate_probability``) to the end;
   else with the odometer and / or LDV the paper 003 filter (``fkf``, ``od-kf``, ``ldv-kf``:
   chi-square FDI, NHC fallback); else ``nhc-kf``. Each stage starts from the previous
   stage's end with its sigma as the prior.
6. **Stops** (``zupt``): whenever the vehicle stops during navigation
   (:func:`stop_windows`: the motion test of rule 2 below its threshold, margins cut, at
   least ``min_stop_s``, the IMU agreeing), the odometer / LDV filters add zero-velocity and
   zero angular rate updates there (``stops_s`` of their configuration), the radar filters
   (``dr-kf``, ``sins-dr``) zero-velocity updates; logged as the stage ``stops``.
7. **Smoothing** (``smooth``): every fine / navigation stage forward-backward (RTS); a bank
   of local filters (``fkf``, ``od-kf`` / ``ldv-kf`` with the NHC fallback) keeps its FDI:
   the bank decides which samples count, a central filter over them is smoothed
   (:func:`inmotion.align.aided_kf._smooth_bank`).

Filter noise and priors: one rule, the methods' own (``noise_preset: matched``, issue 15).
Process passes each stage only what it decides itself (the priors handed over from the
previous stage, the sensor, the stops, the gate, smoothing; for an IMU that cannot
gyrocompass on a bundle whose ``meta.yaml`` is silent the :data:`MEMS_CLASS` figures; without
``vehicle_mounting_arcmin`` the :data:`UNKNOWN_MOUNTING` priors; after a still start's bias
removal the residual drift) and what the user sets (``config.methods``, over everything);
each method takes every other noise figure and prior from the bundle's specs itself (IMU,
sensors, the vehicle's constraint violation: ``aided_kf.config_with_spec``,
``dr_kalman.config_with_spec``, ``sins_dr.config_with_spec``, ``parked_kf.config_with_spec``).
``info["config_source"]`` holds, per method run, where each value came from (the method's
``config_source`` with its ``config`` entries named: ``process (...)`` or ``config
(methods.NAME)``); ``info["imu_spec"]`` the IMU figures process itself reasons with (the
heading rule, the still start, the heading sigma floor).
"""
from __future__ import annotations

import math
import time
from typing import Callable, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from . import config_fields as cf
from . import registry
from .core import earth, rotations
from .align import meta_spec
from .core.bundle import Bundle
from .core.stillness import still_start
from .core.solution import NavState, Solution
from .errors import BadInput

__all__ = ["ProcessConfig", "InitInfo", "heading_observability", "run_process", "plan",
           "stop_windows"]

DEG = math.pi / 180.0
OMEGA_DEG_H = earth.OMEGA_IE / DEG * 3600.0   #: Earth rate [deg/h]


#: filter priors and noise of an IMU that cannot gyrocompass, where meta.yaml does not give
#: them: a consumer MEMS (phone, automotive; the real logs' class, docs/importers.md)
MEMS_CLASS = {"gyro_drift_deg_h": 150.0, "accel_bias_ug": 10000.0, "gyro_arw_deg_sqrt_h": 0.5,
              "accel_vrw_ug_sqrt_hz": 300.0, "nhc_noise_m_s": 0.3}
#: priors of the sensor mounting when meta.yaml has no vehicle_mounting_arcmin (a real log:
#: the IMU may sit degrees off the direction of travel, comma2k19 3.8 deg in pitch)
UNKNOWN_MOUNTING = {"mount_sigma_arcmin": meta_spec.UNKNOWN_MOUNTING_SIGMA_ARCMIN,
                    "od_scale_sigma_ppm": meta_spec.UNKNOWN_SCALE_SIGMA_PPM,
                    "ldv_scale_sigma_ppm": meta_spec.UNKNOWN_SCALE_SIGMA_PPM}


class ProcessConfig(BaseModel):
    """Configuration of ``inmotion process`` (human units in the field names)."""

    model_config = ConfigDict(extra="forbid")
    parked_coarse_s: float = Field(
        60.0, gt=0,
        description="parked this long or longer at the start: parked coarse + parked-kf [s]")
    coarse_window_s: float = Field(
        120.0, gt=0, description="window of the in-motion coarse alignment [s]")
    min_window_s: float = Field(
        10.0, gt=0, description="shortest coarse window accepted [s]")
    min_gyrocompass_s: float = Field(
        60.0, gt=0,
        description="shortest coarse window from which the heading is taken as found by "
                    "gyrocompassing (shorter: the heading comes from init) [s]")
    mems_coarse_window_s: float = Field(
        15.0, gt=0,
        description="window of the in-motion coarse alignment of an IMU that cannot "
                    "gyrocompass (its drift over a long window spoils the level) [s]")
    fine_s: float = Field(
        300.0, gt=0,
        description="radar: dr-kf fine alignment at least this long before sins-dr navigates "
                    "[s]")
    handover_heading_sigma_arcmin: float = Field(
        10.0, gt=0,
        description="radar: dr-kf hands over to sins-dr once its heading sigma is at most "
                    "this [arcmin] (else it runs to the end)")
    max_gyrocompass_heading_sigma_deg: float = Field(
        3.0, gt=0,
        description="the IMU finds the heading if its gyrocompass heading sigma "
                    "(drift / (Omega_ie cos L)) is at most this [deg]")
    min_parked_check_s: float = Field(
        20.0, gt=0,
        description="parked this long at least to measure the gyros when meta has no IMU spec "
                    "[s]")
    init_heading_sigma_deg: Optional[float] = Field(
        None, gt=0,
        description="1-sigma of a heading taken from init [deg]; None: by its source (truth "
                    "0.1, meta 2, a result its own sigma)")
    init_tilt_sigma_deg: Optional[float] = Field(
        None, gt=0,
        description="1-sigma of a level attitude taken from init [deg]; None: truth 0.05, "
                    "meta 1, a result its own sigma")
    parked_speed_noise_m_s: list[float] = Field(
        [0.02, 0.02], min_length=2, max_length=2,
        description="[odometer, ldv] 1-sigma speed of the parked vehicle (motion test) [m/s]")
    radar_parked_noise_m_s: float = Field(
        0.1, gt=0, description="1-sigma radar speed of the parked vehicle (motion test) [m/s]")
    false_alarm_rate: float = Field(
        1e-4, gt=0, lt=1, description="false-alarm probability of the motion test")
    confirm_s: float = cf.confirm_s(0.5)
    still_accel_m_s2: float = Field(
        0.15, gt=0,
        description="no velocity sensor: the vehicle is still at the start while every 0.25 s "
                    "mean specific force stays this close to the still mean [m/s^2]")
    still_gyro_deg_s: float = Field(
        0.25, gt=0, description="... and every 0.25 s mean rate this close [deg/s]")
    min_still_s: float = Field(
        1.0, gt=0, description="a still start shorter than this is ignored [s]")
    residual_gyro_drift_deg_h: float = Field(
        10.0, gt=0,
        description="gyro drift prior after the still-start bias of an IMU that cannot "
                    "gyrocompass is removed (its in-run change) [deg/h]")
    gate_probability: float = Field(
        0.9999, gt=0.5, le=1.0,
        description="chi-square gate of sins-dr's measurements (fault detection; 1: off)")
    methods: dict = Field(
        default_factory=dict,
        description="per-method settings over the stages' defaults, e.g. {od-kf: "
                    "{measurement: velocity}}")
    smooth: bool = Field(
        False,
        description="forward-backward (Rauch-Tung-Striebel) smoothing of the fine-alignment and "
                    "navigation stages (radar: dr-kf and sins-dr; odometer or LDV: fkf / od-kf "
                    "/ ldv-kf with FDI, the forward bank deciding which samples count and a "
                    "central filter over them smoothed; no velocity sensor: nhc-kf)")
    zupt: bool = Field(
        True,
        description="zero-velocity and zero angular rate updates whenever the vehicle stops "
                    "during navigation (stops: the motion test below its threshold, the IMU "
                    "still; odometer / LDV filters)")
    min_stop_s: float = Field(
        2.0, gt=0, description="a stop shorter than this (after the margins) gets no updates [s]")
    stop_margin_s: float = Field(
        0.5, ge=0,
        description="margin cut from each end of a detected stop before its updates [s]")


class InitInfo(BaseModel):
    """What ``init`` is: where it came from and the 1-sigma it carries (None: unknown)."""

    model_config = ConfigDict(extra="forbid")
    source: str = Field("none", description="truth | meta | result | none")
    heading_sigma_deg: Optional[float] = None
    tilt_sigma_deg: Optional[float] = None
    has_attitude: bool = False


# --------------------------------------------------------------------------- heading rule

def _spec_drift_deg_h(meta) -> tuple[Optional[float], str]:
    from .align.parked_kf import spec_from_meta
    spec, origin = spec_from_meta(meta)
    d = spec.get("gyro_drift_deg_h")
    return (None, "") if d is None else (float(d), origin or "meta.imu")


def heading_observability(bundle: Bundle, lat: float, t0: float, parked_until: Optional[float],
                          max_sigma_deg: float = 3.0, min_parked_s: float = 20.0) -> dict:
    """Can the IMU find the heading (module docstring, rule 3)?

    Returns ``{"can": bool, "sigma_deg": predicted gyrocompass heading sigma or None,
    "drift_deg_h", "from": "meta.imu ..." | "parked gyros" | "unknown", "why": text}``.
    """
    cos_l = max(abs(math.cos(lat)), 0.05)
    drift, origin = _spec_drift_deg_h(bundle.meta)
    measured = None
    if drift is None and parked_until is not None and parked_until - t0 >= min_parked_s:
        imu = _imu_span(bundle, t0, parked_until)
        m = (imu.t > t0) & (imu.t <= parked_until)
        dt = np.diff(imu.t, prepend=imu.t[0] - imu.dt)[m]
        dth, dv = imu.dtheta[m], imu.dvel[m]
        w = dth.sum(0) / dt.sum()                       # mean rate [rad/s] in b
        up = dv.sum(0)
        up /= np.linalg.norm(up)                         # up in b (specific force of a parked car)
        w_up = float(w @ up)
        w_h = float(np.linalg.norm(w - w_up * up))
        om = earth.OMEGA_IE
        bias_lb = max(abs(w_up - om * math.sin(lat)), abs(w_h - om * cos_l))
        n_s = int(dt.sum())
        edges = np.searchsorted(np.cumsum(dt), np.arange(1, n_s + 1))
        secs = np.add.reduceat(dth, np.r_[0, edges[:-1]])[:n_s] if n_s >= 2 else dth[:1]
        noise = float(np.std(secs, axis=0).max() / math.sqrt(max(n_s, 1))) if n_s >= 2 else 0.0
        drift = math.hypot(bias_lb, noise) / DEG * 3600.0
        origin = "parked gyros"
        measured = {"earth_rate_up_deg_h": w_up / DEG * 3600, "earth_rate_horizontal_deg_h":
                    w_h / DEG * 3600, "expected_up_deg_h": OMEGA_DEG_H * math.sin(lat),
                    "expected_horizontal_deg_h": OMEGA_DEG_H * cos_l,
                    "mean_noise_deg_h": noise / DEG * 3600, "parked_s": float(dt.sum())}
    if drift is None:
        return {"can": False, "sigma_deg": None, "drift_deg_h": None, "from": "unknown",
                "why": "meta.yaml has no IMU spec (imu.gyro.drift_deg_h) and the drive has no "
                       f"parked period of {min_parked_s:g} s to measure the gyros: the IMU is "
                       "not known to gyrocompass"}
    sigma = math.degrees(drift / OMEGA_DEG_H / cos_l)
    can = sigma <= max_sigma_deg
    out = {"can": can, "sigma_deg": sigma, "drift_deg_h": drift, "from": origin,
           "why": (f"gyro drift {drift:.3g} deg/h ({origin}) gives a gyrocompass heading sigma "
                   f"of {sigma:.3g} deg at latitude {math.degrees(lat):.1f} deg "
                   + ("<=" if can else ">") + f" {max_sigma_deg:g} deg: the IMU "
                   + ("finds the heading" if can else "cannot find the heading"))}
    if measured:
        out["measured"] = measured
    return out


# --------------------------------------------------------------------------- helpers

def _speed_sensors(bundle):
    return [s for s in registry.SPEED_SENSORS if getattr(bundle, s) is not None]


def _imu_span(bundle, ta: float, tb: float):
    """The IMU rows from the last one at or before ``ta`` [s] (so the rows after ``ta`` keep
    the interval from the row before them) to ``tb``, in memory: only these rows are read
    from a bundle read in chunks (:meth:`Bundle.load_window`)."""
    t = bundle.imu.t
    k = max(int(np.searchsorted(t, ta, side="right")) - 1, 0)
    ta = float(t[k])
    del t
    return bundle.load_window(ta, tb).imu


def _cfg(cls, base: dict, cfg: ProcessConfig, name: str, own: dict):
    """Configuration ``cls`` of method ``name``: process's own settings ``own`` (``{field:
    (value, why)}``, module docstring), then the stage's ``base``, then the user's
    ``methods[name]``; fields the class lacks are dropped. Every field not set here the
    method takes from the bundle's specs (its matched preset) or its defaults."""
    fields = cls.model_fields
    data = {k: v for k, (v, _) in own.items() if k in fields}
    data.update({k: v for k, v in base.items() if k in fields})
    user = cfg.methods.get(name) or {}
    if not isinstance(user, dict):
        raise BadInput(f"process configuration: methods.{name} must be a mapping")
    data.update(user)
    try:
        return cls(**data)
    except Exception as e:  # pydantic
        raise BadInput(f"process configuration of {name}: {str(e).splitlines()[0]}") from None


def _config_source(sol: Solution, cfg: ProcessConfig, name: str, own: dict,
                   base: dict) -> dict:
    """``{field: origin}`` of method ``name``'s run ``sol``: its own ``info["config_source"]``
    (what it took from the bundle or left at its default), and every field process passed,
    named: the user's ``methods[name]`` (``config (methods.NAME)``), the stage's ``base``
    (``process (stage)``), process's own settings ``own`` (``process (why)``)."""
    src = dict(sol.info.get("config_source") or {})
    fields = set((sol.info.get("config") or {}).keys()) | set(src)
    user = cfg.methods.get(name) or {}
    for k in fields:
        if k in user:
            src[k] = f"config (methods.{name})"
        elif k in base:
            src[k] = "process (stage)"
        elif k in own:
            src[k] = f"process ({own[k][1]})"
    return dict(sorted(src.items()))


def _with_heading(C, yaw):
    e = rotations.euler_from_dcm(C)
    return rotations.dcm_from_euler(np.array([e[0], e[1], yaw]))


def _sig_deg(sol: Solution, key: str, floor: float) -> float:
    s = sol.sigma.get(key)
    if s is None or not len(s) or not np.isfinite(s[-1]):
        return floor
    return max(float(np.degrees(s[-1])), floor)


def _attitude_deg(state: NavState) -> dict:
    e = np.degrees(state.euler)
    return {"pitch": float(e[0]), "roll": float(e[1]), "yaw": float(e[2] % 360.0)}


def _head(sol: Solution, t1: float) -> Solution:
    """The rows of ``sol`` at or before ``t1`` (for the stage log)."""
    m = sol.t <= t1 + 1e-9
    return Solution(sol.t[m], sol.lat[m], sol.lon[m], sol.h[m], sol.vel_n[m], sol.euler[m],
                    sigma={k: v[m] for k, v in sol.sigma.items()})


class _OutputRows:
    """Which rows of a stage :func:`inmotion.io.result.thin` at ``rate_hz`` can keep from the
    concatenated result (the ``select`` of :meth:`VelocityAidedRun.run_stream`), so a stage
    holds its output rate's rows, not its filter's, and the written result is unchanged.

    ``thin`` keeps the first row, the last, and every row whose period index ``floor((t -
    t_first) rate + 1e-6)`` differs from the row before it. A row dropped here has the index
    of a row kept before it (the first row of each index is kept), so thinning the kept rows
    keeps exactly the rows thinning all of them keeps, provided the result's last row is kept:
    every chunk's last row is kept (a few extra rows, dropped by ``thin``). ``t_first`` [s]:
    the result's first time; ``t_prev`` [s]: the time of the row before the stage's first in
    the result (None: the stage starts the result)."""

    def __init__(self, t_first: float, rate_hz: float, t_prev: Optional[float]):
        self.t_first, self.rate = np.float64(t_first), float(rate_hz)
        self.k_prev = np.nan if t_prev is None else self._index(np.array([t_prev]))[0]

    def _index(self, t):
        return np.floor((t - self.t_first) * self.rate + 1e-6)     # as thin()

    def __call__(self, t, sigma=None):
        k = self._index(np.asarray(t, dtype=float))
        if not len(k):
            return np.zeros(0, dtype=bool), False
        mask = k != np.r_[self.k_prev, k[:-1]]          # (NaN: the first row of the result)
        mask[-1] = True
        self.k_prev = k[-1]
        return mask, False


class _UntilHandover(_OutputRows):
    """:class:`_OutputRows` of the radar fine stage (``dr-kf``), which also stops the run at
    the handover row (:func:`_navigate`: the first row at least ``fine_s`` after the start
    whose heading sigma is at most ``handover_heading_sigma_arcmin``, 30 s before the end at
    the latest), kept; the filter is causal, so the rows up to it are those of a run to the
    end."""

    def __init__(self, t_first, rate_hz, t_prev, t_from: float, t_to: float, sig_arcmin: float):
        super().__init__(t_first, rate_hz, t_prev)
        self.t_from, self.t_to, self.sig = t_from, t_to, sig_arcmin

    def __call__(self, t, sigma=None):
        mask, _ = super().__call__(t)
        sig_u = np.degrees(sigma["phi_U"]) * 60.0
        ok = np.flatnonzero((t >= self.t_from) & (sig_u <= self.sig) & (t <= self.t_to))
        if not len(ok):
            return mask, False
        mask[ok[0]] = True
        mask[ok[0] + 1:] = False
        return mask, True


def _rows_for(parts, rate_hz, t_start, cls=_OutputRows, **kw):
    """The ``select`` of a stage starting at ``t_start`` [s] after ``parts`` (None: no output
    rate given, every row kept)."""
    if rate_hz is None:
        return None
    prev = [float(p.t[p.t < t_start][-1]) for p in parts if len(p.t) and p.t[0] < t_start]
    t_first = float(parts[0].t[0]) if parts and len(parts[0].t) else float(t_start)
    return cls(t_first, rate_hz, prev[-1] if prev else None, **kw)


def _concat(parts):
    from .align.strategy import _concat as cat
    parts = [p for p in parts if p is not None and len(p.t)]
    if len(parts) == 1:
        return parts[0]
    return cat(parts)


def _initial_speed(bundle, t0):
    from .align.velocity_source import initial_speed
    for name in ("ldv", "radar", "odometer"):
        sp = getattr(bundle, name)
        if sp is not None:
            try:
                return float(initial_speed(name, sp, t0, 1.0)), name
            except BadInput:
                continue
    return 0.0, None


# --------------------------------------------------------------------------- the plan

def _imu_still(bundle: Bundle, ta: float, tb: float, accel_m_s2: float, gyro_deg_s: float,
               block_s: float = 0.25, min_s: float = 0.0, dt: Optional[float] = None):
    """The part of ``[ta, tb]`` in which the IMU agrees that the vehicle stands still, as
    ``(start, end)``, or None: the longest run of ``block_s`` blocks whose mean specific force
    and rate lie within ``accel_m_s2`` / ``gyro_deg_s`` of the window's median block (the test
    of :func:`still_start`, robust to the ends of a stop, where the speed test already reads
    zero but the vehicle still brakes or pulls away), at least ``min_s`` long, with its mean
    rate within ``gyro_deg_s`` of zero (the Earth rate and a MEMS bias are far below it, a
    turn is not). Straight driving at constant speed cannot be told from standing by an
    IMU. ``dt``: the log's median IMU period [s] (None: read here); only the window's rows
    are read."""
    dt = bundle.imu.dt if dt is None else float(dt)
    imu = bundle.load_window(ta, tb).imu
    k = np.flatnonzero((imu.t > ta) & (imu.t <= tb))
    n = max(1, int(round(block_s / dt)))
    nb = len(k) // n
    if nb < 1:
        return None
    k = k[:nb * n]
    f = imu.dvel[k].reshape(nb, n, 3).sum(1) / (n * dt)
    w = imu.dtheta[k].reshape(nb, n, 3).sum(1) / (n * dt)
    ok = ((np.abs(f - np.median(f, 0)).max(1) <= accel_m_s2)
          & (np.degrees(np.abs(w - np.median(w, 0)).max(1)) <= gyro_deg_s))
    d = np.diff(np.r_[0, ok.astype(np.int8), 0])
    runs = list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))
    if not runs:
        return None
    i, j = max(runs, key=lambda r: r[1] - r[0])
    if (j - i) * n * dt < max(min_s, n * dt):
        return None
    if np.degrees(np.linalg.norm(w[i:j].mean(0))) > gyro_deg_s:
        return None
    t_blocks = imu.t[k].reshape(nb, n)
    return float(t_blocks[i, 0] - dt), float(t_blocks[j - 1, -1])


def stop_windows(bundle: Bundle, cfg: ProcessConfig, t_from: float) -> tuple[list, str]:
    """The stops of the drive after ``t_from``, for zero-velocity updates: the runs of the
    motion test (paper 003 eq. 43-45, :func:`inmotion.align.strategy.motion_statistic`, the
    statistic and threshold :func:`plan` uses, on a 10 Hz grid) below its threshold, each cut
    by ``stop_margin_s`` at both ends (the speed is below the test's resolution, ~0.08 m/s,
    not zero, at a stop's edges) and kept, cut to the part in which the IMU agrees, if that is
    ``min_stop_s`` long (:func:`_imu_still`: a speed channel reading zero while the vehicle
    turns or changes speed is not a stop; with odometer and LDV both must read zero). Returns ``([[start, end], ...], why)``."""
    from .align.strategy import motion_statistic
    from .estimation import chi2
    t, lam, dof = motion_statistic(bundle, t_from, cfg.parked_speed_noise_m_s, 10.0,
                                   radar_noise_m_s=cfg.radar_parked_noise_m_s)
    thr = chi2.threshold(cfg.false_alarm_rate, dof)
    d = np.diff(np.r_[0, (lam <= thr).astype(np.int8), 0])
    out, refused = [], 0
    dt = bundle.imu.dt
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1):
        ta, tb = float(t[a]) + cfg.stop_margin_s, float(t[b]) - cfg.stop_margin_s
        if tb - ta < cfg.min_stop_s:
            continue
        core = _imu_still(bundle, ta, tb, cfg.still_accel_m_s2, cfg.still_gyro_deg_s,
                          min_s=cfg.min_stop_s, dt=dt)
        if core is not None:
            out.append([round(core[0], 3), round(core[1], 3)])
        else:
            refused += 1
    why = (f"chi-square motion test (paper 003 eq. 43-45, threshold {thr:.3g}) below its "
           f"threshold for {cfg.min_stop_s:g} s or longer (margins {cfg.stop_margin_s:g} s) "
           f"and the IMU still: {len(out)} stop(s), {sum(b - a for a, b in out):.1f} s"
           + (f"; {refused} run(s) of zero speed refused: the IMU was not still"
              if refused else ""))
    return out, why


def plan(bundle: Bundle, cfg: ProcessConfig, t0: float) -> dict:
    """Parked / moving detection: ``{"t_move", "parked_s", "detector", "why", ...}``."""
    from .align.strategy import detect_motion
    speed = _speed_sensors(bundle)
    t_end = float(bundle.imu.t[-1])
    if speed:
        used = [s for s in ("odometer", "ldv") if s in speed] or ["radar"]
        t_sw, lam, thr = detect_motion(bundle, t0, cfg.parked_speed_noise_m_s,
                                       cfg.false_alarm_rate, cfg.confirm_s, 10.0,
                                       radar_noise_m_s=cfg.radar_parked_noise_m_s)
        why = (f"chi-square motion test (paper 003 eq. 43-45) on {', '.join(used)}, "
               f"threshold {thr:.3g}: " + (f"moving from {t_sw:.2f} s (test value "
                                          f"{lam:.3g})" if t_sw is not None else
                                          "never moves"))
        det = {"detector": "chi-square", "sensors": used, "threshold": thr,
               "test_value": lam}
    else:
        motion = bundle.meta.get("motion") if isinstance(bundle.meta, dict) else None
        parked = isinstance(motion, dict) and bool(motion.get("parked"))
        t_still = None if parked else still_start(bundle, t0, cfg.still_accel_m_s2,
                                                   cfg.still_gyro_deg_s)
        if parked:
            t_sw, why, det = None, "no velocity sensor; meta.yaml says motion: parked", \
                {"detector": "meta.yaml motion"}
        elif t_still is not None and t_still - t0 >= cfg.min_still_s:
            t_sw = t_still if t_still < float(bundle.imu.t[-1]) - 1.0 else None
            why = ("no velocity sensor: IMU stillness test (0.25 s means of specific force "
                   f"within {cfg.still_accel_m_s2:g} m/s^2, rate within "
                   f"{cfg.still_gyro_deg_s:g} deg/s): still until {t_still:.2f} s")
            det = {"detector": "imu stillness"}
        else:
            t_sw = t0
            why = ("no velocity sensor, meta.yaml does not say parked and the IMU shows no "
                   "still start: taken as moving from the start (no zero-velocity stage)")
            det = {"detector": "none"}
    parked_s = (t_sw if t_sw is not None else t_end) - t0
    return {"t_move": t_sw, "parked_s": float(parked_s), "why": why, **det}


# --------------------------------------------------------------------------- the run

def run_process(bundle: Bundle, config: ProcessConfig | dict | None = None,
                init: Optional[NavState] = None, init_info: InitInfo | dict | None = None,
                progress: Optional[Callable] = None,
                output_rate_hz: Optional[float] = None) -> Solution:
    """The whole drive in one call (module docstring). ``init``: position (and velocity, and,
    where the IMU cannot find it, the heading) at its time ``init.t``, which is where the run
    starts (None: the start of the log, position from ``meta.yaml``). Returns one Solution
    whose ``info`` holds ``stages`` (the log), ``heading`` (the rule's verdict), ``motion``
    and the sensors used.

    ``output_rate_hz`` (None: every row of every stage): the rate the result will be thinned
    to (:func:`inmotion.io.result.thin`, the command line's ``--output-rate``); the radar
    stages then keep only the rows that thinning can keep (:class:`_OutputRows`) and the fine
    stage stops at its handover, so the result in memory grows with the output rate, not the
    filter's; ``thin`` of it equals ``thin`` of the full result, row for row.

    The bundle may be in memory or read in chunks
    (:class:`inmotion.io.bundle_stream.BundleStream`): every stage reads only its window's
    IMU rows (:meth:`Bundle.load_window`) or streams them (:meth:`Bundle.imu_rows_after`);
    the still stage's gyro bias is taken off the rows as they are read
    (:class:`_GyroBiasRemoved`)."""
    from .align.attitude_determination import initial_position
    from .align.multiplex import first_covered
    from .align.parked_kf import spec_from_meta
    cfg = config if isinstance(config, ProcessConfig) else ProcessConfig(**(config or {}))
    ii = init_info if isinstance(init_info, InitInfo) else InitInfo(**(init_info or {}))
    w0 = time.perf_counter()
    speed = _speed_sensors(bundle)
    t_start = float(bundle.imu.t[0]) if init is None else max(float(init.t),
                                                             float(bundle.imu.t[0]))
    t0 = first_covered(bundle, t_start) if speed else t_start
    if float(bundle.imu.t[-1]) - t0 < 1.0:
        raise BadInput(f"the log holds {float(bundle.imu.t[-1]) - t0:.3g} s after the start "
                       f"{t0:.6g} s: too short to process", file="imu")
    lat, lon, h = initial_position(bundle, init)
    spec, spec_origin = spec_from_meta(bundle.meta)
    own: dict = {}          # process's own settings: {field: (value, why)}
    stages: list[dict] = []

    def log(stage, method, start, end, why, sol=None, **extra):
        e = {"stage": stage, "method": method, "start_s": float(start),
             "end_s": None if end is None else float(end), "why": why, **extra}
        if sol is not None and len(sol.t):
            st = sol.final_state()
            e["attitude_end_deg"] = _attitude_deg(st)
            e["sigma_end_arcmin"] = {k: float(np.degrees(sol.sigma[k][-1]) * 60)
                                     for k in ("phi_E", "phi_N", "phi_U") if k in sol.sigma}
        if sol is not None:         # the stage's method's NIS and warnings (issue 15)
            registry.add_nis_warnings(sol.info)
            for key in ("nis", "warnings"):
                if sol.info.get(key):
                    e[key] = sol.info[key]
        stages.append(e)

    # ---- 1-2: sensors, parked / moving
    pl = plan(bundle, cfg, t0)
    t_move, parked_s = pl["t_move"], pl["parked_s"]
    t_end = float(bundle.imu.t[-1])
    log("detect", pl["detector"], t0, t_move, pl["why"], sensors=speed,
        baro=bundle.baro is not None)
    # ---- 3: heading
    head = heading_observability(bundle, lat, t0, t_move if t_move is not None else t_end,
                                 cfg.max_gyrocompass_heading_sigma_deg, cfg.min_parked_check_s)
    from_init = not head["can"]
    if t_move is None and parked_s < cfg.parked_coarse_s:
        raise BadInput(f"the vehicle is parked through the whole log ({parked_s:.1f} s); the "
                       f"parked alignment needs {cfg.parked_coarse_s:g} s (parked_coarse_s)")
    span = (parked_s if parked_s >= cfg.parked_coarse_s else
            (min(t_end, t0 + cfg.coarse_window_s) - t0 if speed else 0.0))
    if head["can"] and span < cfg.min_gyrocompass_s:
        # the Earth turns too little during the window for the coarse stage to see it
        head["can"] = False
        head["why"] += (f"; but the coarse window holds only {span:.1f} s < "
                        f"{cfg.min_gyrocompass_s:g} s (min_gyrocompass_s): too short to "
                        "gyrocompass")
        from_init = True
    if from_init and not head["can"] and head.get("drift_deg_h") is not None \
            and head["drift_deg_h"] / OMEGA_DEG_H < 0.1:
        pass                # a navigation-grade IMU on a short drive: its own priors stay
    elif from_init:         # not a gyrocompassing IMU: MEMS-class priors where meta is silent
        mems = {k: v for k, v in MEMS_CLASS.items() if k not in spec}
        own.update({k: (v, "MEMS class default: the IMU cannot gyrocompass and meta.yaml does "
                           "not give it") for k, v in mems.items()})
        spec = {**mems, **spec}
        spec_origin = (spec_origin + " + " if spec_origin else "") + "MEMS class defaults"
    if "vehicle_mounting_arcmin" not in (bundle.meta or {}):
        own.update({k: (v, "meta.yaml has no vehicle_mounting_arcmin")
                    for k, v in UNKNOWN_MOUNTING.items()})
    yaw0, head_sig = None, None
    if from_init:
        if init is None or not ii.has_attitude:
            given = ("" if init is None else
                     f"; the init given ({ii.source}) has no attitude (meta.yaml: "
                     "initial_attitude {pitch_deg, roll_deg, yaw_deg})")
            raise BadInput(f"the heading cannot be found from this bundle ({head['why']})"
                           f"{given}; give it with --init truth|meta|RESULT")
        yaw0 = float(init.euler[2])
        head_sig = cfg.init_heading_sigma_deg or ii.heading_sigma_deg or 2.0
        head["source"] = f"init ({ii.source})"
        head["init_heading_deg"] = math.degrees(yaw0) % 360.0
        head["init_heading_sigma_deg"] = head_sig
    else:
        head["source"] = "found by the IMU (gyrocompassing)"
    moving_no_sensor = not speed and t_move is not None and parked_s < cfg.parked_coarse_s
    if moving_no_sensor and (init is None or not ii.has_attitude) and parked_s <= 0:
        raise BadInput("the bundle has no velocity sensor and the vehicle moves from the "
                       "start: the level attitude cannot be found in motion; give it with "
                       "--init truth|meta|RESULT")
    parts: list[Solution] = []

    def progress_part(a, b):
        if progress is None:
            return None
        return lambda f: progress(a + (b - a) * min(max(f, 0.0), 1.0))

    # ---- 4: alignment
    if parked_s >= cfg.parked_coarse_s:
        from .align.coarse_inertial import CoarseInertialConfig, run_coarse_inertial
        from .align.parked_kf import ParkedKfConfig, run_parked_kf
        t1 = t0 + cfg.parked_coarse_s
        ccfg = _cfg(CoarseInertialConfig, {"mode": "parked"}, cfg, "coarse-inertial", {})
        coarse = run_coarse_inertial(bundle.load_window(t0, t1), ccfg,
                                     NavState(t0, lat, lon, h, np.zeros(3), [1.0, 0, 0, 0]))
        a = coarse.info["attitude_start_deg"]
        C0 = rotations.dcm_from_euler(np.radians([a["pitch"], a["roll"], a["yaw"]]))
        if from_init:
            C0 = _with_heading(C0, yaw0)
        log("parked coarse", "coarse-inertial", t0, t1,
            f"parked {parked_s:.1f} s >= {cfg.parked_coarse_s:g} s: inertial-frame coarse "
            "alignment on the parked vehicle (paper 003 Strategy 1)"
            + ("; heading from init" if from_init else ""),
            attitude_start_deg=a)
        t_park_end = t_move if t_move is not None else t_end
        pbase = {"output_interval_s": 1.0}
        if from_init:
            pbase["init_heading_sigma_deg"] = head_sig
        pcfg = _cfg(ParkedKfConfig, pbase, cfg, "parked-kf", own)
        start = NavState(t0, lat, lon, h, np.zeros(3), rotations.quat_from_dcm(C0))
        # parked-kf streams its rows (imu_rows_after): a bundle read in chunks is passed as a
        # window, not loaded (a log parked from start to end would be its whole IMU); a
        # bundle in memory, or the gyro-bias-corrected one, gives its window in memory
        parked = run_parked_kf(bundle.window(None, t_park_end), pcfg, start,
                               progress=progress_part(0.0, 0.3), end_s=t_park_end)
        parts.append(parked)
        log("parked fine", "parked-kf", t0, t_park_end,
            "zero-velocity fine alignment while parked (paper 003 eq. 11-13)", parked,
            config_source=_config_source(parked, cfg, "parked-kf", own, pbase))
        if t_move is None or t_end - t_move < 1.0:
            handover = None
        else:
            st = parked.state_at(min(t_move, float(parked.t[-1])))
            handover = NavState(t_move, st.lat, st.lon, st.h, np.zeros(3), st.q_nb)
            # the parked result's sigma, inflated by half for the change of model at the switch
            tilt_sig = 1.5 * max(_sig_deg(parked, "phi_E", 1e-3),
                                 _sig_deg(parked, "phi_N", 1e-3))
            h_sig = 1.5 * _sig_deg(parked, "phi_U", 1e-2)
            if from_init:
                h_sig = max(h_sig, head_sig)
    else:
        handover = None
        if speed:
            t1 = min(t0 + (cfg.mems_coarse_window_s if from_init else cfg.coarse_window_s),
                     t_end)
            from .align.multiplex import last_covered
            t1 = last_covered(bundle, t1, channels=tuple(speed))
            if t1 - t0 < cfg.min_window_s:
                raise BadInput(f"the drive holds {t1 - t0:.3g} s of velocity-sensor data after "
                               f"{t0:.6g} s; the in-motion coarse alignment needs "
                               f"{cfg.min_window_s:g} s")
            C0, cinfo, cmethod = _coarse_moving(bundle, cfg, init, t0, t1, speed)
            a = cinfo["attitude_start_deg"]
            if from_init:
                C0 = _with_heading(C0, yaw0)
            why = ("moving from the start" if parked_s <= 0 else
                   f"parked only {parked_s:.1f} s < {cfg.parked_coarse_s:g} s") + \
                ": in-motion coarse alignment, attitude referred back to the start " \
                "(information multiplexing, paper 003 Strategy 2)" + \
                ("; heading from init" if from_init else "")
            log("moving coarse", cmethod, t0, t1, why, attitude_start_deg=a,
                speed_sensor=cinfo.get("speed_sensor"))
            v0, _ = _initial_speed(bundle, t0)
            handover = NavState(t0, lat, lon, h, C0 @ np.array([0.0, v0, 0.0]),
                                rotations.quat_from_dcm(C0))
            tilt_sig, h_sig = 1.0, (head_sig if from_init else 3.0)
        elif parked_s > 0:
            # a short still start, no velocity sensor: level from the accelerometers, heading
            # from init, and (an IMU that cannot gyrocompass) the gyro bias measured as the
            # still mean rate minus the Earth rate
            bundle, handover, tilt_sig, h_sig, spec, rm = _still_stage(
                bundle, cfg, init, ii, t0, t_move, (lat, lon, h), yaw0 if from_init else None,
                head_sig, spec, from_init)
            if rm is not None:
                own["gyro_drift_deg_h"] = (spec["gyro_drift_deg_h"], "residual drift after the "
                                           "still start's gyro bias was removed")
            log("still start", "imu", t0, t_move,
                f"still {parked_s:.2f} s < {cfg.parked_coarse_s:g} s, no velocity sensor: "
                "level from the still specific force, heading from init"
                + ("; gyro bias removed (still mean rate minus the Earth rate), drift prior "
                   f"{spec['gyro_drift_deg_h']:g} deg/h" if rm is not None else ""),
                attitude_start_deg=_attitude_deg(handover),
                **({"gyro_bias_deg_h": rm} if rm is not None else {}))
        else:
            e = init.euler
            C0 = rotations.dcm_from_euler(np.array([e[0], e[1], yaw0 if from_init else e[2]]))
            handover = NavState(t0, lat, lon, h, init.vel_n if init is not None
                                else np.zeros(3), rotations.quat_from_dcm(C0))
            tilt_sig = cfg.init_tilt_sigma_deg or ii.tilt_sigma_deg or 1.0
            h_sig = head_sig if from_init else (ii.heading_sigma_deg or 2.0)
            log("attitude from init", "init", t0, t0,
                f"no velocity sensor and moving: attitude and velocity from init ({ii.source})",
                attitude_start_deg=_attitude_deg(handover))
    # ---- 5: fine alignment and navigation to the end
    if handover is not None:
        parts += _navigate(bundle, cfg, handover, tilt_sig, h_sig, own, log,
                           progress_part(0.3 if parts else 0.0, 1.0), stages,
                           parts, output_rate_hz)
    sol = _concat(parts)
    sol.info.update({
        "method": "process", "config": cfg.model_dump(), "stages": stages,
        "heading": head, "motion": {k: v for k, v in pl.items() if k != "why"} | {"why": pl["why"]},
        "sensors_present": registry.present_sensors(bundle),
        "sensors_used": sorted({s for p in parts for s in registry.sensors_used(p.info)}),
        "imu_spec": {"values": spec, "from": spec_origin or "none (method defaults)"},
        "config_source": {e["method"]: e["config_source"] for e in stages
                          if "config_source" in e},
        "init": ii.model_dump(), "wall_time_s": time.perf_counter() - w0})
    stage_warnings = [f"{e['stage']} ({e['method']}): {w}" for e in stages
                      for w in e.get("warnings", [])]
    if stage_warnings:
        sol.info["warnings"] = stage_warnings
    else:
        sol.info.pop("warnings", None)
    if from_init and "phi_U" in sol.sigma:
        # the heading is not observable: its sigma cannot fall below the init's, grown by the
        # gyro drift over the time since (the filters' linear models, far from their operating
        # point with a MEMS's drift, may claim more)
        drift = math.radians(float(spec.get("gyro_drift_deg_h", MEMS_CLASS["gyro_drift_deg_h"]))
                             ) / 3600.0
        floor = np.hypot(math.radians(head_sig), drift * np.maximum(sol.t - t0, 0.0))
        sol.sigma["phi_U"] = np.fmax(sol.sigma["phi_U"], floor)
        sol.info["heading_sigma_rule"] = (
            f"max(filter, hypot(init sigma {head_sig:.3g} deg, drift "
            f"{math.degrees(drift) * 3600:.3g} deg/h x time since {t0:.6g} s))")
    if from_init:
        sol.info["heading_note"] = ("heading not observable by this IMU: taken from init "
                                    f"({ii.source}) with 1-sigma {head_sig:.3g} deg; its "
                                    "sigma grows with the gyro drift")
    return sol


def _still_stage(bundle, cfg, init, ii, t0, t1, pos, yaw0, head_sig, spec, from_init):
    """The short still start of a drive with no velocity sensor (see :func:`run_process`):
    ``(bundle (gyro bias removed if so), state at t1, tilt sigma, heading sigma, spec,
    bias deg/h or None)``."""
    lat, lon, h = pos
    imu = _imu_span(bundle, t0, t1)             # the still rows (and the row before)
    m = (imu.t > t0) & (imu.t <= t1)
    dt = np.diff(imu.t, prepend=imu.t[0] - imu.dt)
    f = imu.dvel[m].sum(0) / dt[m].sum()
    pitch = math.atan2(f[1], math.hypot(f[0], f[2]))
    roll = math.atan2(-f[0], f[2])
    if yaw0 is None:
        if init is None or not ii.has_attitude:
            raise BadInput("the bundle has no velocity sensor and the still start is too short "
                           "to find the heading; give it with --init truth|meta|RESULT")
        yaw0 = float(init.euler[2])
    C = rotations.dcm_from_euler(np.array([pitch, roll, yaw0]))
    state = NavState(t1, lat, lon, h, np.zeros(3), rotations.quat_from_dcm(C))
    still_s = float(dt[m].sum())
    # level from a still accelerometer triad: its bias over g, ~ 0.1 deg for a MEMS
    tilt_sig = max(math.degrees(float(spec.get("accel_bias_ug", 1000.0)) * 1e-6), 0.05)
    bias = None
    if from_init:
        w = imu.dtheta[m].sum(0) / still_s
        w_e = C.T @ (earth.OMEGA_IE * np.array([0.0, math.cos(lat), math.sin(lat)]))
        b = w - w_e
        bundle = _GyroBiasRemoved(bundle, b)
        spec = {**spec, "gyro_drift_deg_h": min(float(spec.get("gyro_drift_deg_h", 1e9)),
                                                cfg.residual_gyro_drift_deg_h)}
        bias = (np.degrees(b) * 3600.0).tolist()
    return bundle, state, tilt_sig, head_sig, spec, bias


class _GyroBiasRemoved:
    """``bundle`` with a constant gyro bias ``b`` [rad/s] taken off every IMU row as its rows
    are read: ``dtheta - dt b``, ``dt`` the row's interval (row 0: the median period), the
    arithmetic of the whole table's ``dtheta - outer(dt, b)``. It answers what the stages
    after the still stage ask (``imu.t`` / ``imu.dt``, :meth:`imu_rows_after`,
    :meth:`imu_rows_in_window`, :meth:`load_window`, :meth:`window`, the sensors, ``meta``); its ``imu`` has no
    ``dtheta`` (a raw read would miss the correction)."""

    def __init__(self, bundle, bias):
        self._b, self._bias = bundle, np.asarray(bias, dtype=float)

    def __getattr__(self, name):
        return getattr(self._b, name)

    @property
    def imu(self):
        from .io.bundle_stream import _TimesOf
        return _TimesOf(self._b.imu.t)

    def _t_before(self, t_first: float) -> float:
        t = self._b.imu.t
        k = int(np.searchsorted(t, t_first, side="left"))
        return float(t[k - 1]) if k > 0 else float(t[0]) - float(np.median(np.diff(t)))

    def _fixed(self, t, dtheta, t_prev):
        return dtheta - np.outer(np.diff(t, prepend=t_prev), self._bias)

    def imu_rows_after(self, t0: float, min_rows: int = 2):
        return self._fixed_rows(self._b.imu_rows_after(t0, min_rows))

    def imu_rows_in_window(self, t0: float, min_rows: int = 2):
        """:meth:`imu_rows_after` reading only the window's rows where the bundle can
        (:meth:`inmotion.io.bundle_stream.BundleStream.imu_rows_in_window`), corrected: a
        method that asks for it (``aided_kf._feed``) must not reach the uncorrected rows
        through ``__getattr__``."""
        rows = getattr(self._b, "imu_rows_in_window", self._b.imu_rows_after)
        return self._fixed_rows(rows(t0, min_rows))

    def _fixed_rows(self, answer):
        n, period, pieces, k0 = answer

        def fixed():
            t_prev = None
            for t, dth, dvl, *rest in pieces:
                if t_prev is None:
                    t_prev = self._t_before(float(t[0]))
                yield (t, self._fixed(t, dth, t_prev), dvl, *rest)
                t_prev = float(t[-1])
        return n, period, fixed(), k0

    def load_window(self, start=None, end=None, truth: bool = False) -> Bundle:
        from .core.bundle import ImuData
        w = self._b.load_window(start, end, truth)
        if len(w.imu.t):
            w.imu = ImuData(w.imu.t, self._fixed(w.imu.t, w.imu.dtheta,
                                                 self._t_before(float(w.imu.t[0]))),
                            w.imu.dvel)
        return w

    def window(self, start=None, end=None):
        """The window's rows in memory, corrected once (:meth:`load_window`): wrapping them
        again would take the bias off twice."""
        return self.load_window(start, end)


def _coarse_moving(bundle, cfg, init, t0, t1, speed):
    """In-motion coarse alignment over ``[t0, t1]``: the attitude at ``t0``."""
    from .align.coarse_inertial import CoarseInertialConfig, run_coarse_inertial
    from .align.multiplex import MuxConfig, coarse_fault_tolerant
    if "odometer" in speed and "ldv" in speed:
        # two speed channels and the IMU vote (paper 003 sec. 3.2.1); with one channel the
        # vote has no second sensor, and a noisy channel would hand the speed to the drifting
        # IMU bridge: the sensor itself is used then
        mux = MuxConfig(coarse_window_s=t1 - t0,
                        coarse=dict(cfg.methods.get("coarse-inertial") or {}))
        sol, C0 = coarse_fault_tolerant(bundle, mux, init, t0, t1)
        used = [s for s in ("odometer", "ldv") if s in speed]
        return C0, {"attitude_start_deg": sol.info["attitude_start_deg"],
                    "speed_sensor": "fault-tolerant " + " / ".join(used + ["imu"])}, \
            "coarse-inertial (fault-tolerant speed, fine-mux)"
    name = next(s for s in ("ldv", "radar", "odometer") if s in speed)
    ccfg = _cfg(CoarseInertialConfig, {"mode": "moving", "velocity_sensor": name}, cfg,
                "coarse-inertial", {})
    # the IMU cut to the window, the sensor whole (a real log's speed may stop just short of
    # a window's ends)
    win = Bundle(bundle.load_window(t0, t1).imu, bundle.meta,
                 **{name: getattr(bundle, name)})
    sol = run_coarse_inertial(win, ccfg, init)
    a = sol.info["attitude_start_deg"]
    C0 = rotations.dcm_from_euler(np.radians([a["pitch"], a["roll"], a["yaw"]]))
    return C0, {"attitude_start_deg": a, "speed_sensor": name}, "coarse-inertial"


def _navigate(bundle, cfg, state, tilt_sig, head_sig, own, log, progress, stages, before=(),
              rate_hz=None):
    """Fine alignment and navigation from ``state`` to the end (module docstring, rule 5);
    ``before``: the stages' results so far, ``rate_hz``: :func:`run_process`'s
    ``output_rate_hz``."""
    speed = _speed_sensors(bundle)
    t_end = float(bundle.imu.t[-1])
    t0 = float(state.t)
    prior = {"init_tilt_sigma_deg": max(tilt_sig, 1e-3),
             "init_heading_sigma_deg": max(head_sig, 1e-3)}
    if "radar" in speed:
        from .align.dr_kalman import DrKfConfig, run_dr_kf
        from .navigate.sins_dr import SinsDrConfig, run_sins_dr
        stops, why_stops = stop_windows(bundle, cfg, t0) if cfg.zupt else ([], "")
        dbase = {**prior, "velocity_sensor": "radar", "stops_s": stops}
        dcfg = _cfg(DrKfConfig, dbase, cfg, "dr-kf", own)
        fine = run_dr_kf(bundle, dcfg, state,
                         progress=None if progress is None else lambda f: progress(0.5 * f),
                         select=_rows_for(before, rate_hz, t0, _UntilHandover,
                                          t_from=t0 + cfg.fine_s, t_to=t_end - 30.0,
                                          sig_arcmin=cfg.handover_heading_sigma_arcmin))
        sig_u = np.degrees(fine.sigma["phi_U"]) * 60.0
        ok = np.flatnonzero((fine.t >= t0 + cfg.fine_s) & (sig_u <= cfg.handover_heading_sigma_arcmin)
                            & (fine.t <= t_end - 30.0))
        t1 = float(fine.t[ok[0]]) if len(ok) else t_end
        if len(ok):
            why = (f"radar present: SINS / radar-DR fine alignment in motion (paper 000), "
                   f"chi-square gate, until its heading sigma is {sig_u[ok[0]]:.3g} arcmin <= "
                   f"{cfg.handover_heading_sigma_arcmin:g} after at least {cfg.fine_s:g} s")
        else:
            why = ("radar present: SINS / radar-DR fine alignment in motion (paper 000), "
                   f"chi-square gate; its heading sigma did not reach "
                   f"{cfg.handover_heading_sigma_arcmin:g} arcmin with 30 s left after "
                   f"{cfg.fine_s:g} s, so it runs to the end")
        if cfg.smooth:       # the handover is decided forward; each stage is then smoothed
            fine = run_dr_kf(bundle.window(None, t1), dcfg.model_copy(update={"smooth": True}),
                             state, select=_rows_for(before, rate_hz, t0))
            why += "; smoothed forward-backward (RTS) over the stage"
        if stops:
            why += f"; zero-velocity updates at the stops ({len(stops)} in the drive)"
        log("fine", "dr-kf", t0, t1, why, _head(fine, t1),
            config_source=_config_source(fine, cfg, "dr-kf", own, dbase))
        out = [fine]
        if len(ok):
            k = int(ok[0])
            st = fine.state_at(t1)
            base = {"init_tilt_sigma_arcmin": 1.5 * 60 * max(
                        float(np.degrees(fine.sigma["phi_E"][k])),
                        float(np.degrees(fine.sigma["phi_N"][k])), 1e-3),
                    "init_heading_sigma_arcmin": 1.5 * max(float(sig_u[k]), 0.01),
                    "velocity_sensor": "radar", "gate_probability": cfg.gate_probability}
            nav_stops = [w for w in stops if w[1] > st.t]
            if nav_stops:
                base["stops_s"] = nav_stops
            base["smooth"] = cfg.smooth
            ncfg = _cfg(SinsDrConfig, base, cfg, "sins-dr", own)
            nav = run_sins_dr(bundle, ncfg, st,
                              progress=None if progress is None else
                              lambda f: progress(0.5 + 0.5 * f),
                              select=_rows_for([*before, fine], rate_hz, st.t))
            log("navigate", "sins-dr", st.t, t_end, "SINS / radar-DR integrated navigation "
                "(paper 002) to the end, chi-square gate "
                f"{cfg.gate_probability:g}" + (", barometer" if bundle.baro is not None
                                                else "")
                + ("; smoothed forward-backward (RTS)" if cfg.smooth else "")
                + (f"; zero-velocity updates at {len(nav_stops)} stop(s)" if nav_stops else ""),
                nav, config_source=_config_source(nav, cfg, "sins-dr", own, base))
            out.append(nav)
        if stops:
            log("stops", "zero-velocity", stops[0][0], stops[-1][1], why_stops, stops_s=stops)
        return out
    from .align import aided_kf as ak
    from .align.multiplex import auto_fine_method
    name = auto_fine_method(bundle)
    run = {"fkf": ak.run_fkf, "od-kf": ak.run_od_kf, "ldv-kf": ak.run_ldv_kf,
           "nhc-kf": ak.run_nhc_kf}[name]
    cls = {"fkf": ak.FkfConfig, "od-kf": ak.AidedKfConfig, "ldv-kf": ak.AidedKfConfig,
           "nhc-kf": ak.NhcKfConfig}[name]
    base = {**prior, "smooth": cfg.smooth}
    stops = []
    if cfg.zupt and speed:
        stops, why_stops = stop_windows(bundle, cfg, t0)
        base["stops_s"] = stops
    fcfg = _cfg(cls, base, cfg, name, own)
    sol = run(bundle, fcfg, state, progress=progress)
    why = {"fkf": "odometer and LDV: federated filter with chi-square FDI and Table 1 "
                  "reconfiguration (paper 003)",
           "od-kf": "odometer: SINS / odometer filter, chi-square FDI, NHC fallback (paper 003)",
           "ldv-kf": "LDV: SINS / LDV filter, chi-square FDI, NHC fallback (paper 003)",
           "nhc-kf": "no velocity sensor: vehicle-constraint (NHC) filter (paper 003)"}[name]
    if cfg.smooth:
        why += ("; smoothed forward-backward (RTS)" if name == "nhc-kf" else
                "; smoothed forward-backward (RTS): the bank's FDI decides which samples "
                "count, a central filter over exactly those is smoothed")
    if stops:
        why += f"; zero-velocity and zero angular rate updates at {len(stops)} stop(s)"
    log("fine + navigate", name, t0, t_end, why + (", barometer" if bundle.baro is not None
                                                  else ""), sol,
        config_source=_config_source(sol, cfg, name, own, base),
        **({"smoothing": sol.info["smoothing"]} if "smoothing" in sol.info else {}))
    if stops:
        log("stops", "zero-velocity + zero-rate", stops[0][0], stops[-1][1], why_stops,
            stops_s=stops)
    return [sol]
