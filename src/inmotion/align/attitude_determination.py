"""Shared driver of the attitude-determination alignments: inputs, one level, the Solution.

A *level* is one pass of :func:`inmotion.align.obs_vectors.integrate_vectors` over the window
with one vector model, followed by Davenport's q-method at every output epoch. The attitude
time series is ``C_b^n(t_j) = C_{n(t_j)}^{n(0)T} C_hat(t_j) C_{b(t_j)}^{b(0)}`` with
``C_hat(t_j)`` the q-method answer from the vectors up to ``t_j`` (paper 004's "process
value"); the attitude at the start of the window is the final ``C_hat``, the one at the end is
``C_b^n(t_end)`` with it. Velocity and position in the :class:`Solution` are the dead reckoning
of the velocity sensor with the attitude the level used (the running answer for a first
level, the previous level's constant for higher levels), started from the initial position.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Optional

import numpy as np

from ..core import earth, rotations
from ..core.bundle import Bundle
from ..core.solution import NavState, Solution, StateUnit
from ..errors import BadInput
from ..estimation import qmethod
from . import obs_vectors as ov
from . import velocity_source as vs

__all__ = ["Inputs", "prepare", "window_blocks", "Level", "run_level", "to_solution",
           "euler_deg_dict", "window_error_map", "window_terms"]


@dataclass
class Inputs:
    """The alignment window, SI, on the IMU time base: its rows as arrays (a bundle in
    memory) or read block by block when asked (a bundle read in chunks,
    :class:`inmotion.io.bundle_stream.BundleStream`: ``t``, ``dtheta``, ``dvel``, ``speed``
    are None and :meth:`blocks` reads the rows again for every level)."""

    t: Optional[np.ndarray]
    dtheta: Optional[np.ndarray]
    dvel: Optional[np.ndarray]
    speed: Optional[np.ndarray]   #: forward speed at the IMU times [m/s]
    speed0: float             #: v^b(0) [m/s]
    lat0: float
    lon0: float
    h0: float
    sensor: Optional[str]     #: the velocity sensor's name, None when parked
    t0: float = float("nan")  #: the window's first IMU time [s]
    dt_s: float = float("nan")    #: median IMU period [s] of the window
    rows: Optional[Callable[[], Iterable]] = None   #: the blocks of a window read in chunks

    @property
    def dt(self) -> float:
        return self.dt_s if self.t is None else float(np.median(np.diff(self.t)))

    def blocks(self) -> Iterable:
        """The window's rows as consecutive blocks ``(t, dtheta, dvel, speed)``: the arrays
        as one block, or (a bundle read in chunks) read from the file as they are taken."""
        if self.rows is None:
            return [(self.t, self.dtheta, self.dvel, self.speed)]
        return self.rows()


def initial_position(bundle: Bundle, init: Optional[NavState]) -> tuple[float, float, float]:
    """``(lat, lon, h)`` [rad, rad, m]: from ``init``, else ``meta.yaml`` (``initial_position:
    {lat_deg, lon_deg, h_m}`` or top-level ``lat_deg, lon_deg, h_m``), else the first truth row."""
    if init is not None:
        return float(init.lat), float(init.lon), float(init.h)
    meta = bundle.meta or {}
    pos = meta.get("initial_position")          # the importers' spelling (io.bundle.meta_initial)
    for d in ((pos if isinstance(pos, dict) else {}), meta):
        if all(k in d for k in ("lat_deg", "lon_deg")):
            return np.radians(float(d["lat_deg"])), np.radians(float(d["lon_deg"])), \
                float(d.get("h_m", 0.0))
    if bundle.truth is not None:
        tr = bundle.truth
        if not hasattr(tr, "lat"):          # a truth read in chunks: its first row, read
            r = tr.at(float(tr.t[0]))
            return float(r["lat"]), float(r["lon"]), float(r["h"])
        return float(tr.lat[0]), float(tr.lon[0]), float(tr.h[0])
    raise BadInput("no initial position: give --init, or lat_deg/lon_deg in meta.yaml",
                   file="meta.yaml")


def prepare(bundle: Bundle, init: Optional[NavState], *, sensor: Optional[str],
            moving: bool, min_window_s: float, v0_fit_s: float) -> Inputs:
    """Check the window and gather the arrays (``BadInput`` on a short window or no sensor).

    A bundle read in chunks (:class:`inmotion.io.bundle_stream.BundleStream`, the command
    line's, cut to ``--start`` / ``--end``) is not loaded: its window's rows are read block by
    block each time a level integrates them (:meth:`Inputs.blocks`, :func:`window_blocks`:
    only the window's rows read and checked, as ``load_window`` reads them), the forward
    speed interpolated to
    each block's times (:func:`numpy.interp`, elementwise: the values of the whole window's),
    so a run's memory does not grow with the window's length; the result is bit for bit that
    of the window in memory (:func:`inmotion.align.obs_vectors.integrate_vector_blocks`)."""
    imu = bundle.imu
    t = imu.t                   # (a bundle read in chunks: the window's times, not kept)
    if len(t) < 3:
        raise BadInput(f"the alignment window holds {len(t)} IMU rows; need at least "
                       f"{min_window_s:g} s", file="imu")
    duration = float(t[-1] - t[0])
    if duration < min_window_s:
        raise BadInput(f"the alignment window is {duration:.3g} s long; this method needs at "
                       f"least {min_window_s:g} s (min_window_s)", file="imu",
                       time=float(t[-1]))
    streamed = not hasattr(imu, "dtheta")
    if not streamed:
        _check_finite(t, imu.dtheta, imu.dvel, 0)
    lat0, lon0, h0 = initial_position(bundle, init)
    t0, t1 = float(t[0]), float(t[-1])
    if moving:
        name, data = vs.pick_sensor(bundle, sensor)
        ts, vv = vs.covering_samples(name, data, t0, t1)
        speed0 = vs.initial_speed(name, data, t0, v0_fit_s)
    else:
        name, ts, vv, speed0 = None, None, None, 0.0
    dt = float(np.median(np.diff(t)))
    if not streamed:
        speed = np.interp(t, ts, vv) if moving else np.zeros(len(t))
        return Inputs(t, imu.dtheta, imu.dvel, speed, speed0, lat0, lon0, h0, name, t0, dt)
    del t
    return Inputs(None, None, None, None, speed0, lat0, lon0, h0, name, t0, dt,
                  lambda: window_blocks(bundle, t0, None if not moving else (ts, vv)))


def window_blocks(bundle, t0: float, samples=None):
    """The rows of ``bundle``'s window from its first row ``t0`` [s] as consecutive blocks
    ``(t, dtheta, dvel, speed)`` (:func:`inmotion.align.obs_vectors.integrate_vector_blocks`'s
    input): row 0 (its time only is used: the interval before it is not the window's), then
    the rows after it as the bundle reads them (a bundle read in chunks: only the window's,
    :meth:`~inmotion.io.bundle_stream.BundleStream.imu_rows_in_window`, as ``load_window``
    reads them; in memory: :meth:`~inmotion.core.bundle.Bundle.imu_rows_after`), the speed
    :func:`numpy.interp` of ``samples = (t, v)`` at their times (None: zero, parked)."""
    yield np.array([t0]), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(1)
    after = getattr(bundle, "imu_rows_in_window", bundle.imu_rows_after)
    _, _, pieces, _ = after(t0)
    row = 1
    for tp, dth, dvl in pieces:
        _check_finite(tp, dth, dvl, row)
        row += len(tp)
        yield tp, dth, dvl, (np.zeros(len(tp)) if samples is None else np.interp(tp, *samples))


def _check_finite(t, dtheta, dvel, row0: int):
    """``BadInput`` at the first row (window row ``row0`` + its index) with an increment that
    is not a finite number."""
    bad = ~(np.isfinite(dtheta).all(axis=1) & np.isfinite(dvel).all(axis=1))
    if bad.any():
        i = int(np.argmax(bad))
        raise BadInput("IMU increment is not a finite number", file="imu", row=row0 + i + 1,
                       time=float(t[i]))


@dataclass
class Level:
    """One pass: the vectors' run and the q-method at its epochs."""

    model: int
    run: ov.VectorRun
    qsol: qmethod.QSolution
    C_nb: np.ndarray          #: (M, 3, 3) attitude series

    @property
    def C0(self) -> np.ndarray:
        """The final estimate of ``C_b^n(0)``."""
        return self.qsol.C[-1]


def run_level(inp: Inputs, model: int, *, C_fixed=None, nav=ov.NAV_INTEGRATED,
              update_interval_s=0.1, output_interval_s=1.0, fading_time_constant_s=None,
              lowpass_time_constant_s=None, centered=False) -> Level:
    """One alignment level with the given vector model (see :mod:`obs_vectors`)."""
    T = 2.0 * inp.dt                                  # two IMU rows per interval
    fading = 1.0 if not fading_time_constant_s else float(np.exp(-T / fading_time_constant_s))
    lp = 0.0 if not lowpass_time_constant_s else float(np.exp(-T / lowpass_time_constant_s))
    run = ov.integrate_vector_blocks(inp.blocks(), inp.speed0,
                               inp.lat0, inp.lon0, inp.h0, model=model, nav=nav, C_fixed=C_fixed,
                               update_every=max(1, round(update_interval_s / T)),
                               out_every=max(1, round(output_interval_s / T)),
                               fading=fading, lowpass_a=lp, centered=centered,
                               skip=0 if not lowpass_time_constant_s
                               else int(np.ceil(3.0 * lowpass_time_constant_s / T)))
    qsol = qmethod.solve(run.K_used(centered))
    C_nb = (np.swapaxes(rotations.dcm_from_quat(run.q_n0n), -1, -2) @ qsol.C
            @ rotations.dcm_from_quat(run.q_b0b))
    return Level(model, run, qsol, C_nb)


def euler_deg_dict(C_nb) -> dict:
    """``{"pitch": .., "roll": .., "yaw": ..}`` in degrees (yaw in [0, 360))."""
    e = np.degrees(rotations.euler_from_dcm(C_nb))
    return {"pitch": float(e[0]), "roll": float(e[1]), "yaw": float(e[2])}


def level_info(level: Level, name: str) -> dict:
    return {"model": name,
            "attitude_start_deg": euler_deg_dict(level.C0),
            "attitude_end_deg": euler_deg_dict(level.C_nb[-1]),
            "eigval_gap_rel": float(level.qsol.gap_rel[-1])}


#: a coarse heading envelope above this [deg] means the coarse stage cannot resolve heading
UNRESOLVED_HEADING_DEG = 30.0


def coarse_envelope(gyro_drift_deg_h: float, accel_bias_ug: float, lat: float,
                    window_s: float) -> dict:
    """1-sigma envelope of a coarse (integral, Earth-rate) alignment [deg] from the IMU's
    drift and bias (module docstring): ``level_deg``, ``heading_deg`` (None when the heading
    cannot be resolved), ``heading_limit_deg`` (the figure before the cap) and
    ``resolvable``. ``lat`` [rad]; ``window_s``: the coarse window."""
    drift = np.radians(gyro_drift_deg_h) / 3600.0
    bias = accel_bias_ug * 1e-6                                  # rad (bias / g)
    gyro_walk = drift * window_s / 2.0
    level = float(np.degrees(np.hypot(bias, gyro_walk)))
    head = float(np.degrees(np.sqrt((drift / (earth.OMEGA_IE * np.cos(lat))) ** 2
                                    + (bias * np.tan(lat)) ** 2 + gyro_walk ** 2)))
    ok = head <= UNRESOLVED_HEADING_DEG
    return {"level_deg": level, "heading_deg": head if ok else None,
            "heading_limit_deg": head, "resolvable": bool(ok),
            "gyro_drift_deg_h": float(gyro_drift_deg_h), "accel_bias_ug": float(accel_bias_ug),
            "window_s": float(window_s)}


def envelope_from_meta(meta, lat: float, window_s: float) -> Optional[dict]:
    """:func:`coarse_envelope` from the IMU specification in ``meta['imu']`` (its drift and
    bias; ``source`` says where they came from), or None when the bundle states neither."""
    from .parked_kf import spec_from_meta
    spec, origin = spec_from_meta(meta)
    if "gyro_drift_deg_h" not in spec or "accel_bias_ug" not in spec:
        return None
    env = coarse_envelope(spec["gyro_drift_deg_h"], spec["accel_bias_ug"], lat, window_s)
    env["source"] = origin
    return env


def envelope_warning(env: dict, lat: float) -> Optional[str]:
    """The warning of a coarse alignment outside its envelope (heading not resolvable), or
    None inside it."""
    if env is None or env["resolvable"]:
        return None
    horizontal = np.degrees(earth.OMEGA_IE * np.cos(lat)) * 3600.0
    return (f"outside its envelope: gyro drift {env['gyro_drift_deg_h']:.3g} deg/h against the "
            f"horizontal Earth rate {horizontal:.3g} deg/h gives a heading limit of "
            f"{env['heading_limit_deg']:.3g} deg: the heading is not resolved; give it from "
            f"outside (--init). Level 1-sigma {env['level_deg'] * 60:.3g} arcmin")


def to_solution(inp: Inputs, level: Level, *, method: str, config, levels_info: list,
                meta=None, window_envelope=None) -> Solution:
    """The :class:`Solution` of the final level, with the start/end attitude and the quality
    figure (the q-method's relative eigenvalue gap ``(lambda_1 - lambda_2) / lambda_1``).

    With the bundle's ``meta`` stating the IMU's drift and bias, ``info['envelope']`` holds the
    1-sigma envelope of the result (:func:`coarse_envelope`, over the window) and, when the
    heading cannot be resolved, ``info['warnings']`` says so (issue 15: never a confident
    heading the sensors could not give). ``window_envelope``: a callable of the window's
    length [s] giving the envelope with the window's own terms beside the IMU's (a method
    run on its own, :func:`inmotion.align.multiplex.standalone_window_envelope`), used in
    place of the IMU's alone (its ``source`` kept)."""
    run = level.run
    euler = rotations.euler_from_dcm(level.C_nb)
    info = {
        "method": method,
        "config": config.model_dump(),
        "t_start_s": inp.t0,
        "t_end_s": float(run.t[-1]),
        "attitude_start_deg": euler_deg_dict(level.C0),
        "attitude_end_deg": euler_deg_dict(level.C_nb[-1]),
        "quality": {"eigval_gap_rel": float(level.qsol.gap_rel[-1]),
                    "eigval_gap": float(level.qsol.gap[-1]),
                    "n_vector_pairs": int(run.n_vectors)},
        "velocity_sensor": inp.sensor,
        "initial_speed_m_s": inp.speed0,
        "levels": levels_info,
    }
    window_s = float(run.t[-1] - inp.t0)
    env = envelope_from_meta(meta, inp.lat0, window_s)
    if env is not None:
        if window_envelope is not None:
            env = {**window_envelope(window_s), "source": env["source"]}
        info["envelope"] = env
        warning = envelope_warning(env, inp.lat0)
        if warning:
            info["warnings"] = [f"{method}: {warning}"]
    states = {"eigval_gap_rel": level.qsol.gap_rel}
    units = {"eigval_gap_rel": StateUnit("ratio")}
    return Solution(run.t, run.lat, run.lon, run.h, run.vel_n, euler, states=states,
                    state_units=units, info=info)


def window_error_map(inp: Inputs, level: Level, lowpass_time_constant_s=None) -> dict:
    """Linear map from an error of the body velocity ``v^b`` the vectors assumed to the error
    of the coarse attitude ``C_b^n(0)`` (issue 15: the window's own terms of the coarse
    envelope, beside the IMU's).

    Derivation. The centred q-method answer maximises ``sum_k w_k b_k^T C_hat a_k`` over the
    centred pairs (Davenport's ``K``; ``w_k`` the weights of the sum over the intervals).
    With ``a_k`` perturbed by ``da_k`` and the answer ``C_hat = (I - [eps x]) C``, the
    second-order expansion in ``eps`` (``[eps x]^2 = eps eps^T - |eps|^2 I``) gives ``eps =
    M^-1 sum_k w_k b_k x (C da_k)`` with ``M = sum_k w_k ((b_k . c_k) I - (b_k c_k^T + c_k
    b_k^T) / 2)``, ``c_k = C a_k`` (``= b_k`` without residuals: ``M = sum w (|b|^2 I - b
    b^T)``; the residuals ``b - C a`` of the actual vectors are kept, issue 15 helper
    h16scale: on the 85 s drive's 40 s window the scale factor's heading 92.1 arcmin per
    1000 ppm with them, 118.7 with ``c = b``, the coarse stage on the scaled speed 89.5);
    the centring of ``da`` drops out since ``sum w b = 0``. In
    motion ``alpha`` holds ``C_{b(t)}^{b(0)} v^b(t)`` (:data:`obs_vectors.MODEL_VB_EARTH`), so
    an error ``dv^b`` of the assumed ``[0, s, 0]`` (a mounting angle: ``s`` times it on the
    lateral / vertical axis; a scale factor; a lever arm's ``omega x l``; the vehicle
    constraint's violation; speed noise) gives ``da_k = C_{b(t_k)}^{b(0)} dv^b(t_k)`` plus,
    through the Earth-rate integral ``I_wv_b`` (which takes the assumed ``v^b`` too), ``[omega_ie^b0
    x] sum_(j <= k) C_{b(t_j)}^{b(0)} dv_j dt_j`` (``omega_ie^b0 = C^T omega_ie^n``, constant in
    the inertial frame ``b(0)``); so ``H_j = (A_j + sum_(k >= j) A_k [omega_ie^b0 x] dt_j)
    C_{b(t_j)}^{b(0)}`` with ``A = L^T A^f``, ``A^f_k = M^-1 w_k [b_k x] C`` and ``L`` the
    stage's low-pass (:class:`_Lowpass`): ``K`` sums the low-passed pairs, so ``b`` and ``c``
    are the low-passed vectors and ``da`` enters through the filter. The weights ``w`` are
    the trapezoid rule over the output epochs from the end of the low-pass's settling time
    (``K``'s sum over the intervals after it is that integral; the rectangle rule with each
    epoch standing for the interval before it, used before, is half an epoch late). The
    Earth-rate share is small (measured, issue 15, paper 003's 85 s drive, 80 s window: a
    30 arcmin yaw mounting's heading 217.1 arcmin with it, 217.8 without, the coarse stage
    on the turned IMU 205.0; the 300 s window's mean (e / sigma)^2 2.28 with it, 2.23
    without). Where the first-order effect nearly cancels, the heading is sensitive to
    timing: the scale factor's column (``dv = dk s e_y``) on that 80 s window, the 60 deg
    turn near its middle, was -5.7 arcmin per 1000 ppm with the rectangle rule, no low-pass
    and ``c = b``, -6.0 with the trapezoid rule, -6.5 with ``c``, -1.13 with the low-pass
    too; the coarse stage moves -1.22 with its attitude held (``C_fixed``) and +0.61 as it
    runs (the running answer, turned by the scaled speed early in the window, turns the
    dead-reckoned position and through ``C_{n(t)}^{n(0)}`` the ``beta``: a path the map
    leaves out). Elsewhere the column is within 2-7 % of the coarse stage (40, 300, 600 s:
    :func:`inmotion.align.multiplex.window_cross_maps`). ``eps = sum_j H_j dv_j`` with
    ``dv_j`` the value of ``dv^b`` at epoch ``j`` (1 <= j < M; between epochs linear).

    The accelerometer bias (issue 15, the fine prior's cross-covariance). A constant bias
    ``nabla`` in b adds ``int_0^t C_{b(tau)}^{b(0)} nabla dtau = G(t) nabla`` to ``I_f``, and
    ``alpha = vb_b0 - v^b(0) - I_f (+ I_wv_b)``, so it acts as ``da_k = -G(t_k) nabla``, the
    same place a velocity error ``C_{b(t_k)}^{b(0)} dv_k`` enters: ``eps = J_nabla nabla``
    with ``J_nabla = -sum_k A_k G(t_k)`` (``A`` as above, through the low-pass; ``G`` by the trapezoid rule over the
    epochs from the window's first row). Parked (no turn) ``G(t) = t I`` and this is the
    classic ``phi_E = -nabla_N / g``, ``phi_N = nabla_E / g`` with the heading's ``nabla_E
    tan L / g``; turns average the bias's nav-frame direction over the window.

    Returns ``{"H": (M, 3, 3) [rad per m/s], "dt": (M,) [s], "speed": (M,) [m/s],
    "rate_b": (M, 3) body rate over each interval [rad/s], "J_nabla": (3, 3) [rad per
    m/s^2]}`` (``eps`` in ``n(0)``, ENU at the window's start), or None with fewer than 3
    epochs or vectors that span no plane."""
    run = level.run
    t = run.t - run.t[0]
    tau = float(lowpass_time_constant_s or 0.0)
    skip = 3.0 * tau
    summed = np.flatnonzero(t > skip - 1e-9)
    summed = summed[summed > 0]
    if len(summed) < 3:               # too few epochs to size anything: no map
        return None
    use = np.arange(1, len(t))
    dt = np.diff(t)
    # K's sum over the intervals after the low-pass's settling is the integral over
    # [t_skip, t_end]: trapezoid weights on the epochs (a rectangle rule with the epoch's
    # value standing for the interval before it is half an epoch late, O(dt))
    wt = np.zeros(len(t))
    seg = np.diff(t[summed])
    np.add.at(wt, summed[:-1], 0.5 * seg)
    np.add.at(wt, summed[1:], 0.5 * seg)
    w = wt / wt.sum()
    L = _Lowpass(t, tau)
    Cb0b = rotations.dcm_from_quat(run.q_b0b)
    C = level.C0
    beta = L.apply(run.beta)
    b = beta - (w[:, None] * beta).sum(0)
    c = L.apply(run.alpha) @ C.T                   # C alpha: beta but for the residuals
    c = c - (w[:, None] * c).sum(0)
    M = (w[:, None, None] * (np.einsum("ki,ki->k", b, c)[:, None, None] * np.eye(3)
                             - 0.5 * (b[:, :, None] * c[:, None, :]
                                      + c[:, :, None] * b[:, None, :]))).sum(0)
    if np.linalg.cond(M) > 1e14:       # the vectors span no plane (parked-like, no Earth
        return None                      # rate seen yet): no linear map
    Minv = np.linalg.inv(M)
    # d eps / d y_k (y: the low-passed alpha) and, through the low-pass, d eps / d alpha_k
    A = L.adjoint(Minv[None] @ (w[:, None, None] * rotations.skew(b)) @ C[None])[use]
    # the Earth-rate integral's share (alpha's I_wv_b with the assumed v^b): eps_k also takes
    # [w_ie^b0 x] sum_(j <= k) C_{b(t_j)}^{b(0)} dv_j dt_j, so H_j gains
    # (sum_(k >= j) A_k) [w_ie^b0 x] C_{b(t_j)}^{b(0)} dt_j
    w_b0 = C.T @ (earth.OMEGA_IE * np.array([0.0, np.cos(inp.lat0), np.sin(inp.lat0)]))
    A_after = np.cumsum(A[::-1], axis=0)[::-1]
    H = (A + A_after @ rotations.skew(w_b0)[None] * dt[:, None, None]) @ Cb0b[use]
    rel = np.swapaxes(Cb0b[use - 1], -1, -2) @ Cb0b[use]          # C_{b(j)}^{b(j-1)}
    rate = rotations.rotvec_from_dcm(rel) / dt[:, None]
    speed = np.linalg.norm(run.vel_n[use], axis=1)
    steps = 0.5 * (Cb0b[1:] + Cb0b[:-1]) * np.diff(t)[:, None, None]
    G = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(steps, axis=0)])[use]
    J_nabla = -(A @ G).sum(0)
    return {"H": H, "dt": dt, "speed": speed, "rate_b": rate, "J_nabla": J_nabla}


class _Lowpass:
    """The coarse stage's first-order low-pass of the vectors (time constant ``tau``,
    :func:`inmotion.align.obs_vectors.integrate_vectors`, started on the first pair) on the
    epochs ``t``: the exact response to an input linear between the epochs (first-order
    hold), ``y_j = rho_j y_(j-1) + c0_j x_j + c1_j x_(j-1)``, ``rho = exp(-h / tau)``, ``c0 =
    1 - tau (1 - rho) / h``, ``c1 = tau (1 - rho) / h - rho`` (``h`` the epoch step), ``y_0 =
    x_0``; ``tau = 0``: the identity. :meth:`adjoint` maps the weights of ``y`` onto those of
    ``x`` (``sum_j a_j y_j = sum_i a'_i x_i``)."""

    def __init__(self, t, tau: float):
        h = np.diff(t)
        self.on = tau > 0.0
        if self.on:
            self.rho = np.exp(-h / tau)
            q = tau * (1.0 - self.rho) / h
            self.c0, self.c1 = 1.0 - q, q - self.rho

    def apply(self, x):
        if not self.on:
            return x
        y = np.empty_like(x)
        y[0] = x[0]
        for j in range(1, len(x)):
            y[j] = self.rho[j - 1] * y[j - 1] + self.c0[j - 1] * x[j] + self.c1[j - 1] * x[j - 1]
        return y

    def adjoint(self, a):
        if not self.on:
            return a
        lam = np.empty_like(a)            # lam_j = d (sum a y) / d y_j
        lam[-1] = a[-1]
        for j in range(len(a) - 2, -1, -1):
            lam[j] = a[j] + self.rho[j] * lam[j + 1]
        out = np.empty_like(a)
        out[0] = lam[0] + self.c1[0] * lam[1]
        out[1:-1] = self.c0[:-1, None, None] * lam[1:-1] + self.c1[1:, None, None] * lam[2:]
        out[-1] = self.c0[-1] * lam[-1]
        return out


def _markov_bin_cov_sum(u: np.ndarray, sigma: float, tau: float, dt: float) -> np.ndarray:
    """``sum_ij u_i u_j^T c_ij`` (3x3): ``c_ij`` the covariance of the means over consecutive
    intervals of ``dt`` of a first-order Gauss-Markov process (``sigma``, ``tau``):
    ``c_ii = sigma^2 2 (x - 1 + e^-x) / x^2``, ``c_ij = sigma^2 (tau / dt)^2 (1 - e^-x)^2
    e^-(|i-j|-1) x`` (``x = dt / tau``); O(M) by the recursion ``r_j = rho r_(j-1) +
    u_(j-1)``."""
    if sigma <= 0.0 or len(u) == 0:
        return np.zeros((3, 3))
    x = dt / tau
    c0 = sigma * sigma * 2.0 * (x - 1.0 + np.exp(-x)) / (x * x)
    c1 = sigma * sigma * (tau / dt) ** 2 * (1.0 - np.exp(-x)) ** 2
    rho = np.exp(-x)
    S = c0 * u.T @ u
    r = np.zeros(3)
    acc = np.zeros((3, 3))
    for j in range(1, len(u)):
        r = rho * r + u[j - 1]
        acc += np.outer(u[j], r)
    return S + c1 * (acc + acc.T)


def window_terms(emap: dict, *, mount_sigma_rad: float, scale_sigma: float,
                 lever_m=(0.0, 0.0, 0.0), lever_sigma_m: float = 0.0,
                 constraint_violation=None, speed_noise_m_s: float = 0.0,
                 speed_rate_hz: float = 0.0, accel_bias_sigma: float = 0.0) -> dict:
    """The window's terms of the coarse attitude error (:func:`window_error_map`), each a
    3x3 covariance [rad^2] of ``eps`` (ENU at the window's start):

    * ``mount``: the IMU's mounting in the vehicle, yaw and pitch each ``mount_sigma_rad``
      (``dv^b = s [mu_z, 0, mu_x]``, up to sign);
    * ``scale``: the speed's scale factor (``dv^b = k s e_y``);
    * ``lever``: the sensor's lever arm ``l`` (not compensated by the coarse stage;
      ``dv^b_y = omega_z l_x - omega_x l_z``), per axis 1-sigma ``hypot(l, lever_sigma_m)``;
    * ``constraint``: the vehicle constraint's violation, lateral and vertical Gauss-Markov
      ``(sigma, tau)`` pairs (``constraint_violation = ((s_lat, tau_lat), (s_vert,
      tau_vert))``) on ``dv^b_x`` / ``dv^b_z`` (:func:`_markov_bin_cov_sum`);
    * ``speed_noise``: white speed noise of ``speed_noise_m_s`` at ``speed_rate_hz`` on
      ``dv^b_y``;
    * ``bias`` (with ``accel_bias_sigma`` > 0 [m/s^2] per axis, and the map's ``J_nabla``):
      the accelerometer bias, ``J_nabla J_nabla^T sigma^2`` (the map's docstring): the
      parked figures ``bias / g`` (level) and ``bias tan L / g`` (heading) with the
      manoeuvres' turns, and the heading a forward bias turns over a short window.
    """
    H, dt, s, om = emap["H"], emap["dt"], emap["speed"], emap["rate_b"]
    P = {}

    def const(dv):                          # a random constant: eps = sum H dv
        e = np.einsum("kij,kj->i", H, dv)
        return np.outer(e, e)

    zero = np.zeros_like(s)
    P["mount"] = (const(np.stack([s, zero, zero], 1)) + const(np.stack([zero, zero, s], 1))) \
        * mount_sigma_rad ** 2
    P["scale"] = const(np.stack([zero, s, zero], 1)) * scale_sigma ** 2
    lx, _, lz = (float(np.hypot(a, lever_sigma_m)) for a in lever_m)
    P["lever"] = (const(np.stack([zero, om[:, 2] * lx, zero], 1))
                  + const(np.stack([zero, om[:, 0] * lz, zero], 1)))
    Pc = np.zeros((3, 3))
    if constraint_violation:
        d = float(np.median(dt)) if len(dt) else 1.0
        for axis, (sig, tau) in zip((0, 2), constraint_violation):
            if sig > 0 and tau > 0:
                Pc += _markov_bin_cov_sum(H[:, :, axis], sig, tau, d)
    P["constraint"] = Pc
    if speed_noise_m_s > 0 and speed_rate_hz > 0:
        u = H[:, :, 1]
        P["speed_noise"] = (u.T * (speed_noise_m_s ** 2 / (speed_rate_hz * dt))) @ u
    else:
        P["speed_noise"] = np.zeros((3, 3))
    if accel_bias_sigma > 0 and "J_nabla" in emap:
        J = np.asarray(emap["J_nabla"])
        P["bias"] = J @ J.T * accel_bias_sigma ** 2
    return P
