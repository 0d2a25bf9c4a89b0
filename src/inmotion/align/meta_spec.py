"""What a bundle's ``meta.yaml`` says of its IMU, its velocity sensors and its vehicle, as
configuration fields of the filters (issue 15, ``noise_preset: matched``).

The functions the methods share to read those figures: the IMU's specification
(:func:`spec_from_meta`, :func:`config_with_spec`, :func:`fields_not_set`; used by
``parked-kf``, ``dr-kf``, ``sins-dr``, the paper 003 filters and ``process``), a velocity
sensor's forward noise and scale-factor model (:func:`sensor_noise_from_meta`,
:func:`sensor_spec_fields`) and the vehicle's constraint violation
(:func:`vehicle_constraint_noise`, :func:`nhc_noise_from_meta`). They lived in
:mod:`inmotion.align.aided_kf`, :mod:`~inmotion.align.parked_kf` and
:mod:`~inmotion.align.dr_kalman`, which still export them; here they import without those
modules' configuration classes and filters (their import cost ``sins-dr``'s command-line run
0.035 s of CPU, issue 13).
"""
from __future__ import annotations

import numpy as np

from ..core import earth
from ..errors import BadInput
from ..estimation.velocity_aided import calm_simulation

__all__ = ["SPEC_FIELDS", "IMU_SPEC_FIELDS", "spec_from_meta", "config_with_spec",
           "fields_not_set", "sensor_spec_fields", "sensor_noise_from_meta",
           "vehicle_constraint_noise", "nhc_noise_from_meta", "markov_mean_sigma",
           "markov_white_equivalent_sigma", "markov_sample_white_equivalent_sigma",
           "quantization_end_factor", "interval_end_alpha", "SIM_CONSTRAINT_PER_FORWARD",
           "SIM_CONSTRAINT_MAX_DRIFT_DEG_H", "MARKOV_RW_FIELDS", "markov_as_random_walk",
           "unknown_mounting_warning", "constant_bias_imu_spec", "UNKNOWN_MOUNTING_SIGMA_ARCMIN",
           "UNKNOWN_SCALE_SIGMA_PPM", "unknown_installation_priors",
           "floor_unknown_mounting", "note_unknown_mounting", "unknown_dk_prior"]

UG = earth.G0 * 1e-6


#: the lateral and vertical sensor rows' 1-sigma as a fraction of the forward one (displacement
#: form) on a simulated vehicle with no disturbances, whose constraint holds exactly at the
#: IMU: the documented fallback when the bundle has no vehicle spec (``meta['vehicle']
#: ['constraint_violation']``, which sets these rows when present, root sum of squares with
#: this model error). What is left is model error: against truth the rows' residual is 1-6e-5 m/s (more in
#: turns), but the first-order model's own error for a start heading a fraction of a degree
#: off is ``v psi^2 / 2`` (5e-4 m/s at 14 m/s for 0.5 deg), and the forward noise is laid
#: across the axis by the turn within the interval. A measured choice, not a derivation (issue
#: 15): on short paper 003 drives started 0.1 / 0.1 / 0.5 deg (1-sigma) off, random IMU
#: errors, 6-8 runs, the final attitude NEES (band 1.4-5.3) was 6-11 for both sensors at
#: 1e-4 m/s; 4.5-6.7 (fkf, od-kf) at 3e-4; at 1e-3 od-kf 1.6-2.9 and fkf 2.3-2.4 but ldv-kf
#: 1.3-1.5 (under); ldv-kf 3.1 at 3e-4. A quarter of the forward 1-sigma (odometer 1.0e-3,
#: LDV 3.5e-4 m/s) fits both (``tests/test_consistency_nees.py``); the residual test then
#: fires below its set rate (``benchmarks/fdi_calibration.py``)
SIM_CONSTRAINT_PER_FORWARD = 0.25
#: ... only for an IMU whose gyro drift is at most this [deg/h]: with a MEMS IMU (100 deg/h in
#: ``tests/test_process.py``'s stop-and-go drive) the attitude errors make the first-order
#: rows' own error far larger, and such tight rows made od-kf's stop updates lose their effect
#: (horizontal error 9.7 m against 29 m without them, the test asks for 30 %); the rows then
#: keep the configured values (issue 15, a measured gate, not a derivation)
SIM_CONSTRAINT_MAX_DRIFT_DEG_H = 1.0
def markov_mean_sigma(sigma, tau_s, interval_s):
    """1-sigma of the mean over ``interval_s`` of a stationary first-order Gauss-Markov
    process (1-sigma ``sigma``, correlation time ``tau_s``): ``sigma^2 (2 tau^2 / T^2)
    (T / tau - 1 + exp(-T / tau))`` (the double integral of ``sigma^2 exp(-|s| / tau)`` over
    the interval, divided by ``T^2``; -> ``sigma^2`` as ``T / tau -> 0``, ``2 sigma^2 tau /
    T`` as ``T / tau -> inf``)."""
    if sigma <= 0.0:
        return 0.0
    x = interval_s / tau_s
    if x < 1e-6:
        return float(sigma)
    return float(sigma * np.sqrt(2.0 * (x - 1.0 + np.exp(-x)) / (x * x)))


def markov_white_equivalent_sigma(sigma, tau_s, interval_s):
    """1-sigma of the white sequence equivalent to the interval means of a stationary
    first-order Gauss-Markov process: ``sqrt(2 sigma^2 tau / T)``, the sum of the means'
    autocovariances over all lags (``(1 / T^2) int_0^T du int R(s - u) ds = 2 sigma^2 tau /
    T``, exact for any ``T``), so a filter that takes the rows as white noise with this
    variance gains from a long run of them what the correlated sequence really holds (its
    sigma of slowly varying states, attitude and mounting, stays honest). It exceeds the
    one-interval spread :func:`markov_mean_sigma` by ``sqrt(2 / (x - 1 + exp(-x))) * x /
    sqrt(2)`` (``x = T / tau``; 1.64 at ``x = 1``, 1.12 at ``x = 5``, -> 1), by which a residual
    test on single intervals is then conservative."""
    return float(np.sqrt(2.0 * sigma * sigma * tau_s / interval_s)) if sigma > 0 else 0.0


def markov_sample_white_equivalent_sigma(sigma, tau_s, interval_s):
    """1-sigma of the white sequence equivalent to samples of a stationary first-order
    Gauss-Markov process (1-sigma ``sigma``, correlation time ``tau_s``) taken every
    ``interval_s``: the sum of the samples' autocovariances over all lags, ``sigma^2 (1 +
    2 sum_k rho^k) = sigma^2 (1 + rho) / (1 - rho) = sigma^2 coth(T / (2 tau))`` with ``rho =
    exp(-T / tau)`` (-> ``2 sigma^2 tau / T``, :func:`markov_white_equivalent_sigma`, as ``T /
    tau -> 0``; -> ``sigma^2`` as ``T / tau -> inf``). The rows of a point measurement (the
    SINS velocity at an epoch against the vehicle constraint, ``nhc-kf`` and the NHC fallback)
    see the violation at the epoch, not its mean over the interval."""
    if sigma <= 0.0:
        return 0.0
    x = interval_s / (2.0 * tau_s)
    return float(sigma * np.sqrt(1.0 / np.tanh(x))) if x > 1e-9 else float("inf")


def nhc_noise_from_meta(meta, interval_s: float):
    """``nhc_noise_m_s`` of the vehicle-constraint rows (``nhc-kf``, the NHC fallback of
    ``od-kf`` / ``ldv-kf`` / ``fkf``) from the vehicle's measured constraint violation
    ``meta['vehicle']['constraint_violation']`` (issue 15), or None without one: the white
    equivalent of its samples at the rows' interval (:func:`markov_sample_white_equivalent_sigma`),
    the larger of the lateral and vertical figures (one noise for both rows).

    Measured (issue 15, ``benchmarks/nees_methods.py 20 nhc-kf``, paper 003's drive cut to 85
    s with the violation 0.010 m/s / 0.5 s lateral, 0.020 m/s / 0.2 s vertical, rows every 0.5
    s: 0.0217 m/s): final-attitude NEES over 20 runs 3.57 (band 2.02-4.16); with the 0.01 m/s
    the test set before, 6.18 (overconfident: the violation alone exceeds it); with the
    lateral figure (0.0147 m/s) for both rows 4.34.

    Per component (issue 15, the East tilt's ``(error / sigma)^2`` was 2.0 over those 20
    runs, seeds 100-119, while the total was in band): seed-to-seed variation, not a
    defect. Seeds 120-139 gave 0.68, seeds 140-159 1.17; over the 60 runs East 1.28, North
    0.52, up 1.00 (95 % band of a component's mean over 60 runs 0.67-1.39), total 2.81 (band
    2.41-3.65). The violation adds to the East part (without it, rows at 0.0217 m/s: 0.87
    and 0.60 over seeds 100-119 and 120-139; lateral slip alone 1.48, bounce alone 1.51 over
    100-119), and neither a larger row noise (0.03 m/s: 1.84) nor rows every 0.1 s (1.99)
    moves it on seeds 100-119: the NHC rows' noise is not what sets it. Runs whose heading
    ends more than 30 arcmin off have the larger East part (1.6 against 1.16; rank
    correlation 0.11 over the 60 runs)."""
    out = _constraint_violation_sigmas(meta, markov_sample_white_equivalent_sigma, interval_s)
    return None if out is None else max(out)


def stated_installation(meta, sensor=None) -> tuple:
    """``(mounting_arcmin, lever_arm_m)`` as ``meta.yaml`` states them: the IMU's mounting in
    the vehicle ``vehicle_mounting_arcmin`` and ``sensor``'s lever arm in b
    ``lever_arms_m[sensor]``, each a (3,) array or None where ``meta`` gives none;
    :class:`~inmotion.errors.BadInput` for a value that is not three finite numbers."""
    meta = meta if isinstance(meta, dict) else {}
    arms = meta.get("lever_arms_m")
    out = []
    for where, v in (("vehicle_mounting_arcmin", meta.get("vehicle_mounting_arcmin")),
                     (f"lever_arms_m.{sensor}",
                      arms.get(sensor) if isinstance(arms, dict) and sensor else None)):
        if v is None:
            out.append(None)
            continue
        try:
            a = np.asarray(v, float)
        except (TypeError, ValueError):
            a = None
        if a is None or a.shape != (3,) or not np.all(np.isfinite(a)):
            raise BadInput(f"{where} must be three finite numbers, got {v!r}", file="meta.yaml")
        out.append(a)
    return tuple(out)


def _constraint_violation_sigmas(meta, f, interval_s: float):
    """``(f(lateral), f(vertical))``, ``f(sigma, tau, interval_s)`` of the Gauss-Markov
    figures of ``meta['vehicle']['constraint_violation']``, or None without one or when both
    are zero; :class:`~inmotion.errors.BadInput` when its figures are not numbers."""
    veh = meta.get("vehicle") if isinstance(meta, dict) else None
    cv = veh.get("constraint_violation") if isinstance(veh, dict) else None
    if not isinstance(cv, dict):
        return None
    try:
        out = tuple(f(float(cv.get(f"{a}_sigma_m_s", 0.0) or 0.0),
                      float(cv.get(f"{a}_tau_s", 1.0) or 1.0), interval_s)
                    for a in ("lateral", "vertical"))
    except (TypeError, ValueError):
        raise BadInput("meta vehicle.constraint_violation: sigma and tau must be numbers "
                       f"(got {cv!r})"[:200]) from None
    return out if max(out) > 0.0 else None


def vehicle_constraint_noise(meta, interval_s: float, equivalent: bool = True):
    """``(lateral, vertical)`` 1-sigma [m/s] of the vehicle constraint's violation over a
    measurement interval from ``meta['vehicle']['constraint_violation']`` (the simulator's
    :class:`inmotion.sim.scenario.ConstraintViolation`, or what an importer documents), or
    None when the bundle has no such spec. ``equivalent`` (the rows' noise): the white
    equivalent of the interval means (:func:`markov_white_equivalent_sigma`); else the
    one-interval spread (:func:`markov_mean_sigma`). Why the former (issue 15): with the
    one-interval spread, on paper 003's drive (tau 0.5 / 0.2 s, T = 0.5 s), the residual
    test was calibrated (mean statistic 3.02 over 3 runs, rates 4.2e-2 at 0.05 and 5.6e-4 at
    1e-3) but the rows' correlation over successive intervals (0.54 lateral) made the
    attitude overconfident: final NEES fkf 8.1, ldv-kf 5.6 against a band of 1.37-5.25."""
    return _constraint_violation_sigmas(
        meta, markov_white_equivalent_sigma if equivalent else markov_mean_sigma, interval_s)


def quantization_end_factor(alpha: float) -> float:
    """Variance of a distance-output sensor's quantization error at a measurement interval's
    end, in units of one sample's ``q^2 / 12``, when the end falls a fraction ``alpha`` of a
    sample period after a sample: the engine interpolates the cumulative distance linearly
    between samples (:func:`inmotion.core.deadreckoning.speed_on_epochs`), so the end's error
    is ``(1 - alpha) e_k + alpha e_(k+1)`` of two samples' quantization errors, independent
    and uniform over the drives (the phase step between samples is uniform over the
    scale-factor spread): ``(1 - alpha)^2 + alpha^2`` (1 on a sample, 1/2 midway)."""
    return float((1.0 - alpha) ** 2 + alpha ** 2)


def interval_end_alpha(sensor_t, t_ends) -> float:
    """The fraction ``alpha`` of a sample period at which the measurement intervals' ends
    ``t_ends`` fall after the sensor's samples ``sensor_t``, as one figure: the ``alpha`` in
    [0, 1/2] whose :func:`quantization_end_factor` is the ends' mean factor (ends outside the
    samples' span are left out; 0 when every end falls on a sample, as when the run starts on
    a sample and the sensor's period divides the measurement period; paper 003's drives
    started at 0.15 s, a 10 Hz odometer and 0.5 s intervals: 1/2)."""
    ts = np.asarray(sensor_t, dtype=float)
    te = np.asarray(t_ends, dtype=float)
    te = te[(te >= ts[0]) & (te <= ts[-1])] if len(ts) > 1 else te[:0]
    if len(te) == 0:
        return 0.0
    i = np.clip(np.searchsorted(ts, te), 1, len(ts) - 1)
    al = np.clip((te - ts[i - 1]) / np.maximum(ts[i] - ts[i - 1], 1e-12), 0.0, 1.0)
    f = float(np.mean((1.0 - al) ** 2 + al ** 2))
    return float(0.5 * (1.0 - np.sqrt(max(2.0 * f - 1.0, 0.0))))


def sensor_noise_from_meta(meta, name: str, interval_s: float, measurement: str,
                           share: float = 1.0, equivalent: bool = True, alpha: float = 0.0):
    """``(forward, lateral, origin)``: the 1-sigma [m/s] of a velocity sensor's forward row
    and of its lateral / vertical rows from the bundle's ``meta`` (None where it says
    nothing; ``lateral`` a float for both rows or a ``(lateral, vertical)`` pair), and where
    they came from.

    Forward, from ``meta['sensors'][name]``: the displacement form over an interval ``T``
    sums the white noise of ``T * rate_hz`` samples (``noise_m_s`` per sample, in distance
    ``noise_m_s / rate_hz``) and differences two pulse quantizations (uniform over ``1 /
    pulses_per_m``, variance ``q^2 / 12`` each), so ``sigma^2 = noise_m_s^2 / (rate_hz T) +
    2 f q^2 / (12 T^2)``, ``f`` the :func:`quantization_end_factor` of ``alpha``, where the
    interval's ends fall between samples (1 on samples; 1/2 midway, where the forward
    variance of paper 003's 10 Hz odometer halves: issue 15, its false-alarm rate at 0.05 was
    1.3e-2 over 20 drives started 0.15 s off its samples); the velocity form reads one sample, ``noise_m_s^2 + 2 q^2 rate_hz^2 /
    12`` (a speed from two quantized counts one period apart).

    Lateral / vertical, in this order: ``constraint_noise_m_s`` in the sensor's spec; for the
    displacement form, the vehicle's measured constraint violation (also where the bundle has
    no spec of the sensor: a real log's CAN speed, issue 15 session 19)
    ``meta['vehicle']['constraint_violation']`` (:func:`vehicle_constraint_noise`, its variance
    divided by the channel's sharing factor ``share``, then root sum of squares with the rows'
    own model error; ``equivalent=False``: the one-interval spread instead of the white
    equivalent, what a single residual sees, :data:`SIM_CONSTRAINT_PER_FORWARD` of the forward
    value on a simulated bundle whose IMU is within :data:`SIM_CONSTRAINT_MAX_DRIFT_DEG_H`);
    the fallback when the bundle has no vehicle spec: for the displacement form on a simulated
    bundle with no disturbances and such an IMU, :data:`SIM_CONSTRAINT_PER_FORWARD` times the
    forward value (the margin measured on a simulator whose constraint holds exactly). The
    velocity form's rows compare the SINS velocity at the epoch's end with the sensor's mean
    over its last period, a lag that leaves centimetres per second in turns and accelerations:
    they keep the configured values.
    """
    meta = meta if isinstance(meta, dict) else {}
    spec = (meta.get("sensors") or {}).get(name) if isinstance(meta.get("sensors"), dict) else None
    if not isinstance(spec, dict):
        if measurement != "displacement" or vehicle_constraint_noise(meta, interval_s) is None:
            return None, None, ""
        spec = None   # no sensor spec: the vehicle's violation still sets the cross rows
    has_spec = spec is not None
    spec = spec or {}
    fwd = None
    noise, rate = spec.get("noise_m_s"), spec.get("rate_hz")
    ppm = spec.get("pulses_per_m")
    if noise is not None and rate:
        q = 1.0 / float(ppm) if ppm else 0.0
        if measurement == "displacement":
            var = (float(noise) ** 2 / (float(rate) * interval_s)
                   + 2 * quantization_end_factor(alpha) * q * q / (12 * interval_s ** 2))
        else:
            var = float(noise) ** 2 + 2 * (q * float(rate)) ** 2 / 12
        fwd = float(np.sqrt(var))
    lat = spec.get("constraint_noise_m_s")
    calm = calm_simulation(meta)
    gyro = ((meta.get("imu") or {}).get("gyro") or {}) if isinstance(meta.get("imu"), dict) else {}
    drift = np.abs(np.atleast_1d(np.asarray(gyro.get("drift_deg_h", 0.0) or 0.0, float))).max()
    model = (SIM_CONSTRAINT_PER_FORWARD * fwd if fwd is not None and meta.get("simulated")
             and measurement == "displacement" and drift <= SIM_CONSTRAINT_MAX_DRIFT_DEG_H
             else None)
    veh = (vehicle_constraint_noise(meta, interval_s, equivalent)
           if measurement == "displacement" else None)
    from_vehicle = lat is None and veh is not None
    if from_vehicle:
        lat = tuple(float(np.hypot(x / np.sqrt(share), model or 0.0)) for x in veh)
    elif lat is None and model is not None and calm:
        lat = model
    origin = ("meta.sensors (documented)" if spec.get("source") == "documented"
              else "meta.sensors (simulated)" if meta.get("simulated") else "meta.sensors")
    if from_vehicle:
        origin = (origin + " + meta.vehicle.constraint_violation (lateral/vertical)" if has_spec
                  else "meta.vehicle.constraint_violation")
    if isinstance(lat, tuple):
        return fwd, lat, origin
    return fwd, (None if lat is None else float(lat)), origin


SPEC_FIELDS = ("gyro_drift_deg_h", "gyro_arw_deg_sqrt_h", "accel_bias_ug", "accel_vrw_ug_sqrt_hz")


def _magnitude(v):
    """A spec value as one non-negative number: a per-axis list by its largest magnitude."""
    if v is None:
        return None
    a = np.abs(np.atleast_1d(np.asarray(v, dtype=float)))
    return float(a.max()) if a.size and np.isfinite(a).all() else None


def spec_from_meta(meta, markov=False) -> tuple[dict, str]:
    """``({field: value}, origin)``: the IMU specification in ``meta['imu']`` as
    :class:`ParkedKfConfig` fields (module docstring), and where it came from.

    ``markov=False``: a Gauss-Markov part (``drift_markov_deg_h``, ``bias_markov_ug``) is
    folded into the constant's 1-sigma (root sum of squares), for a filter whose biases are
    random constants. ``markov=True`` (a filter with the Gauss-Markov option,
    :class:`inmotion.align.aided_kf.NhcKfConfig`): the constant alone, and the Gauss-Markov
    parts as ``gyro_markov_deg_h``, ``gyro_markov_tau_s``, ``accel_markov_ug``,
    ``accel_markov_tau_s`` (the simulator's and importers' ``drift_markov_tau_s``,
    ``bias_markov_tau_s``), given only where the spec states a correlation time."""
    imu = (meta or {}).get("imu") if isinstance(meta, dict) else None
    if not isinstance(imu, dict):
        return {}, ""
    gyro = imu.get("gyro") if isinstance(imu.get("gyro"), dict) else {}
    acc = imu.get("accel") if isinstance(imu.get("accel"), dict) else {}
    out = {}
    drift, mk = _magnitude(gyro.get("drift_deg_h")), _magnitude(gyro.get("drift_markov_deg_h"))
    bias, bmk = _magnitude(acc.get("bias_ug")), _magnitude(acc.get("bias_markov_ug"))
    if markov:
        for (sig, tau, f_sig, f_tau) in ((mk, _magnitude(gyro.get("drift_markov_tau_s")),
                                          "gyro_markov_deg_h", "gyro_markov_tau_s"),
                                         (bmk, _magnitude(acc.get("bias_markov_tau_s")),
                                          "accel_markov_ug", "accel_markov_tau_s")):
            if sig and tau:
                out[f_sig], out[f_tau] = float(sig), float(tau)
        mk = bmk = None                        # not folded into the constants
    if drift is not None:
        out["gyro_drift_deg_h"] = float(np.hypot(drift, mk or 0.0))
    if _magnitude(gyro.get("arw_deg_sqrt_h")) is not None:
        out["gyro_arw_deg_sqrt_h"] = _magnitude(gyro.get("arw_deg_sqrt_h"))
    if bias is not None:
        out["accel_bias_ug"] = float(np.hypot(bias, bmk or 0.0))
    vrw = _magnitude(acc.get("vrw_ug_sqrt_hz"))
    if vrw is None and _magnitude(acc.get("vrw_m_s_sqrt_h")) is not None:
        vrw = _magnitude(acc.get("vrw_m_s_sqrt_h")) / 60.0 / UG      # m/s/sqrt(h) -> ug/sqrt(Hz)
    if vrw is not None:
        out["accel_vrw_ug_sqrt_hz"] = vrw
    said = imu.get("source")
    origin = (f"meta.imu ({said})" if isinstance(said, str) and said
              else "meta.imu (simulated)" if meta.get("simulated") else "meta.imu")
    return out, origin


def config_with_spec(cfg, meta, fields=SPEC_FIELDS, markov=False) -> tuple:
    """``cfg`` (a pydantic configuration) with the ``fields`` it does not set taken from
    ``meta['imu']`` (:func:`spec_from_meta`), and ``{field: origin}`` for each of them
    (``config``, ``meta.imu (documented)`` ..., ``default``)."""
    spec, origin = spec_from_meta(meta, markov=markov)
    upd, src = fields_not_set(cfg, fields, spec, origin)
    return (cfg.model_copy(update=upd) if upd else cfg), src


def fields_not_set(cfg, fields, values: dict, origin: str) -> tuple:
    """``(update, source)`` for the ``fields`` of configuration ``cfg``: a field the user set
    keeps its value (source ``config``); one they did not set takes ``values[field]`` where
    there is one (source ``origin``, e.g. ``meta.imu (documented)``), else keeps its default
    (``default``). ``update`` holds only the fields taken from ``values``."""
    src, upd = {}, {}
    for f in fields:
        if f in cfg.model_fields_set:
            src[f] = "config"
        elif f in values:
            upd[f], src[f] = values[f], origin
        else:
            src[f] = "default"
    return upd, src


#: the IMU fields ``noise_preset: matched`` takes from ``meta['imu']``
IMU_SPEC_FIELDS = ("gyro_drift_deg_h", "gyro_arw_deg_sqrt_h", "accel_bias_ug",
                   "accel_vrw_ug_sqrt_hz")
#: the bias random walks a filter with random-constant biases takes from a Gauss-Markov spec
#: (:func:`markov_as_random_walk`)
MARKOV_RW_FIELDS = ("gyro_bias_rw_deg_h_sqrt_h", "accel_bias_rw_ug_sqrt_h")


def constant_bias_imu_spec(cfg, meta, matched: bool) -> tuple:
    """``(cfg, config_source)`` of a filter whose biases are random constants plus a random walk
    (``dr-kf``, ``od-velocity-kf``, ``sins-dr``: one rule for all three): with ``matched``, the
    :data:`IMU_SPEC_FIELDS` it does not set from ``meta['imu']`` (:func:`_imu_spec_meta`,
    :func:`config_with_spec`) and the :data:`MARKOV_RW_FIELDS` from the spec's Gauss-Markov
    parts (:func:`markov_as_random_walk`); without, every field as configured."""
    cfg, src = config_with_spec(cfg, _imu_spec_meta(meta) if matched else {}, IMU_SPEC_FIELDS)
    upd, s_rw = fields_not_set(cfg, MARKOV_RW_FIELDS,
                               *(markov_as_random_walk(meta) if matched else ({}, "")))
    src.update(s_rw)
    return (cfg.model_copy(update=upd) if upd else cfg), src


#: the prior [arcmin] of the IMU's mounting in the vehicle where ``meta.yaml`` has no
#: ``vehicle_mounting_arcmin`` (a real log: a phone or a retrofitted IMU may sit degrees off the
#: direction of travel, comma2k19's 3.8 deg in pitch; ``process`` and the filters with mounting
#: states under ``noise_preset: matched``, :func:`unknown_installation_priors`)
UNKNOWN_MOUNTING_SIGMA_ARCMIN = 300.0
#: the prior [ppm] of a velocity sensor's scale factor where its spec gives none (a CAN speed
#: is the tyre's rolling radius: comma2k19's reads 0.6 % low)
UNKNOWN_SCALE_SIGMA_PPM = 10000.0
#: the keys of a sensor spec that state its scale factor
SCALE_SPEC_KEYS = ("scale_factor_ppm", "scale_factor_sigma_ppm", "scale_markov_sigma_ppm")


def unknown_installation_priors(cfg, meta, scale=None) -> tuple:
    """``(update, source)``: the priors of an installation ``meta.yaml`` does not describe, for
    the fields of ``cfg`` the user did not set (:func:`fields_not_set`).

    * ``mount_sigma_arcmin`` (where ``cfg`` has it) :data:`UNKNOWN_MOUNTING_SIGMA_ARCMIN` when
      ``meta`` has no ``vehicle_mounting_arcmin``; where it has one but the filter does not
      take it as its nominal mounting (``dr-kf`` and ``od-velocity-kf`` estimate the whole
      mounting from zero, as paper 000 does; ``od-kf`` and the paper 003 filters unless
      ``mounting_from_meta``), at least its largest angle, so the prior covers what the
      filter must find (session 20: the simulated phone drive, the IMU pitched 228 arcmin,
      ran ``dr-kf`` and ``od-velocity-kf`` from the 20 arcmin default; across a 35 s speed
      gap, seeds 0-2, they ended 12-21 times their sigma, 424-757 m off; with the prior
      covering it, 2.6-3.7x and 10-23 m; every shipped scenario's mounting is within the
      defaults, 15 arcmin at most);
    * ``mount_rw_arcmin_sqrt_s`` (where ``cfg`` has it) from ``meta.vehicle.
      mounting_rw_arcmin_sqrt_s`` (:func:`mounting_rw_from_meta`): an IMU ``meta.yaml`` says is
      not fixed in its vehicle gets mounting angles that wander (issue 15, session 22: on
      the PSINS MEMS log, whose platform rolls by +-32 deg in the vehicle, ``dr-kf`` and
      ``od-velocity-kf`` with constant angles took the roll as information that separates
      attitude from mounting and ended 5.6-6.9 times their sigma; with the random walk the
      importer derives from the dataset's README, within 3);
    * ``scale``: ``{sensor: {field: value}}``, each sensor's scale-factor fields set to the
      values given when its spec ``meta['sensors'][sensor]`` states no scale factor
      (:data:`SCALE_SPEC_KEYS`; no spec at all counts as none).

    Why (issue 15, session 19): the filters' defaults are paper 000's and 003's, an IMU
    installed and surveyed to 20-30 arcmin and a sensor scale known to 1000 ppm. On the
    simulated phone drive (``reproductions.real.comma_like_scenario``, the IMU pitched 3.8 deg
    in the car, 11 times the 20 arcmin prior) ``dr-kf``'s East tilt ended -28 arcmin off on
    average over 10 runs, final-attitude NEES 7.02 (band 2.02-4.16); with a 300 arcmin prior
    2.56. On comma2k19 (no mounting and no speed scale in its ``meta.yaml``)
    ``od-velocity-kf`` ended 96 m off at a 24 m sigma."""
    meta = meta if isinstance(meta, dict) else {}
    upd, src = {}, {}
    if "mount_sigma_arcmin" in type(cfg).model_fields:
        given = meta.get("vehicle_mounting_arcmin")
        if given is None:
            u, s = fields_not_set(cfg, ("mount_sigma_arcmin",),
                                  {"mount_sigma_arcmin": UNKNOWN_MOUNTING_SIGMA_ARCMIN},
                                  "meta.yaml has no vehicle_mounting_arcmin")
        else:
            largest = _largest_angle_arcmin(given)
            cover = ({"mount_sigma_arcmin": largest}
                     if not getattr(cfg, "mounting_from_meta", False)
                     and largest > cfg.mount_sigma_arcmin else {})
            u, s = fields_not_set(cfg, ("mount_sigma_arcmin",), cover,
                                  "covers meta.yaml vehicle_mounting_arcmin, which the filter "
                                  "estimates from zero")
        upd.update(u)
        src.update(s)
    if "mount_rw_arcmin_sqrt_s" in type(cfg).model_fields:
        u, s = fields_not_set(cfg, ("mount_rw_arcmin_sqrt_s",), mounting_rw_from_meta(meta),
                              "meta.vehicle.mounting_rw_arcmin_sqrt_s")
        upd.update(u)
        src.update(s)
    sensors = meta.get("sensors") if isinstance(meta.get("sensors"), dict) else {}
    for name, fields in (scale or {}).items():
        spec = sensors.get(name) if isinstance(sensors.get(name), dict) else {}
        if any(spec.get(k) is not None for k in SCALE_SPEC_KEYS):
            continue
        u, s = fields_not_set(cfg, tuple(fields), dict(fields),
                              f"meta.sensors.{name} states no scale factor")
        upd.update(u)
        src.update(s)
    return upd, src


def mounting_rw_from_meta(meta) -> dict:
    """``{"mount_rw_arcmin_sqrt_s": value}`` from ``meta['vehicle']
    ['mounting_rw_arcmin_sqrt_s']`` (an IMU that turns in its vehicle: the mounting angles a
    random walk, :func:`unknown_installation_priors`), ``{}`` without one;
    :class:`~inmotion.errors.BadInput` for a value that is not a finite number >= 0."""
    veh = meta.get("vehicle") if isinstance(meta, dict) else None
    if not isinstance(veh, dict) or veh.get("mounting_rw_arcmin_sqrt_s") is None:
        return {}
    v = veh["mounting_rw_arcmin_sqrt_s"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
            np.isfinite(v) and v >= 0):
        raise BadInput(f"meta vehicle.mounting_rw_arcmin_sqrt_s: a finite number >= 0 "
                       f"[arcmin/sqrt(s)], got {v!r}"[:200])
    return {"mount_rw_arcmin_sqrt_s": float(v)}


def _largest_angle_arcmin(given) -> float:
    """The largest absolute angle [arcmin] of ``meta['vehicle_mounting_arcmin']`` (three
    numbers; :class:`~inmotion.errors.BadInput` otherwise)."""
    try:
        a = np.asarray(given, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise BadInput(f"meta vehicle_mounting_arcmin: three numbers [arcmin], got {given!r}"
                       [:200]) from None
    if not np.all(np.isfinite(a)):
        raise BadInput(f"meta vehicle_mounting_arcmin: not finite: {a.tolist()}")
    return float(np.max(np.abs(a)))


def unknown_dk_prior(cfg, meta, sensor: str) -> tuple:
    """``(update, source)`` of :func:`unknown_installation_priors` for a filter whose scale
    state is ``dk`` (``dr-kf``, ``od-velocity-kf``, ``sins-dr``: one rule): a
    :data:`UNKNOWN_SCALE_SIGMA_PPM` random constant where ``sensor``'s spec states no scale
    factor (and the mounting prior where the filter has one)."""
    return unknown_installation_priors(
        cfg, meta, {sensor: {"dk_sigma_ppm": UNKNOWN_SCALE_SIGMA_PPM, "dk_tau_s": float("inf")}})


#: what a method without mounting states does with the mounting, and what the user can do
MOUNTING_IGNORED = "takes the IMU's axes as the vehicle's and has no mounting states"
MOUNTING_ADVICE = ("give the mounting (meta.yaml or the configuration), or estimate it with a "
                   "speed sensor (od-kf, ldv-kf, fkf, dr-kf)")


def unknown_mounting_warning(method: str, meta, configured=None,
                             mounting_from_meta: bool = True, ignored: str = MOUNTING_IGNORED,
                             advice: str = MOUNTING_ADVICE) -> "str | None":
    """The warning of a method without mounting states (``nhc-kf``; ``sins-dr`` with
    ``estimate_mounting: false``, whose default adds them there since session 20) run where the
    IMU's mounting in the vehicle is given neither in the configuration (``configured``, None
    when not set) nor in ``meta.yaml`` (``vehicle_mounting_arcmin``, read with
    ``mounting_from_meta``): it then takes the IMU's axes as the vehicle's, so a mounting of a
    few degrees goes into its level, heading and velocity, and its sigma does not cover that
    (issue 15, session 18). Measured with ``--init truth`` on comma2k19 (a phone mounted 3.8
    deg in pitch, 0.8 in yaw, ``reproductions.real.reference_calibration``): ``nhc-kf`` 358
    arcmin off in level at a 20 arcmin sigma and 10.9 m/s in velocity (with the reference's
    mounting in ``meta``: 33 arcmin at 42, 0.17 m/s; its NHC NIS 1.26 and 0.15 per degree of
    freedom, so the NIS warning does not see it); ``sins-dr`` 1247 arcmin off in heading at
    71 and 182 m after 1 km at 23 m. None where the mounting is given."""
    if configured is not None:
        return None
    given = isinstance(meta, dict) and meta.get("vehicle_mounting_arcmin") is not None
    if mounting_from_meta and given:
        return None
    return (f"the vehicle's mounting is not given (meta.yaml vehicle_mounting_arcmin"
            + ("" if mounting_from_meta else ", mounting_from_meta false")
            + f"): {method} {ignored}, "
            "so a mounting of a few degrees goes into the level, the heading and the velocity "
            "(comma2k19's 3.8 deg pitch: nhc-kf 358 arcmin off in level at a 20 arcmin sigma); "
            f"the attitude 1-sigma is kept at least {UNKNOWN_MOUNTING_SIGMA_ARCMIN:.0f} arcmin, "
            f"the unknown mounting's prior; {advice}")


def floor_unknown_mounting(sol, floor_arcmin: float = UNKNOWN_MOUNTING_SIGMA_ARCMIN) -> None:
    """Keep the reported 1-sigma of ``sol`` at least what the unknown mounting's prior
    ``m`` (``floor_arcmin``) leaves: for a method without mounting states run where the
    mounting is not given (:func:`unknown_mounting_warning` fired). Its vehicle constraint or
    forward speed is taken in the IMU's axes, so the mounting's pitch and yaw go one to one
    into what it finds, and nothing in its filter sees them:

    * attitude (``phi_E``, ``phi_N``, ``phi_U``): ``m`` (session 19: comma2k19, the phone
      pitched 3.8 deg, ``nhc-kf`` 271 arcmin off in the East tilt at a 31 arcmin sigma,
      ``usque`` 405 at 34);
    * velocity and position (session 20): the velocity is held along the IMU's forward axis,
      a yaw mounting ``gamma`` off the direction of travel, so the horizontal velocity and the
      track turn by ``gamma`` (first order: the error is ``gamma`` times the velocity, and the
      displacement from the start ``d = [d_N, d_E]``, turned by 90 deg): ``vN >= m |v_E|``,
      ``vE >= m |v_N|``, ``north >= m |d_E|``, ``east >= m |d_N|``; the pitch mounting tilts
      the velocity out of the level the same way, ``vU >= m |v|`` and ``h >= m s`` (``s``
      the path length). Measured on the PSINS MEMS log (the MEMS about 4.8 deg off the
      direction of travel, ``nhc-kf`` with its defaults from the reference): 216 m off at a
      50 m sigma (4.4x) before."""
    m = np.radians(floor_arcmin / 60.0)
    floors = {k: m for k in ("phi_E", "phi_N", "phi_U")}
    if len(sol.t):
        d_n, d_e = earth.local_ne_offsets(sol.lat, sol.lon, sol.lat[0], sol.lon[0], sol.h[0])
        v = np.asarray(sol.vel_n, dtype=float)          # [vE, vN, vU]
        speed = np.linalg.norm(v, axis=1)
        path = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1])
                                                * np.diff(sol.t))])
        floors.update({"vN": m * np.abs(v[:, 0]), "vE": m * np.abs(v[:, 1]),
                       "vU": m * speed, "north": m * np.abs(d_e), "east": m * np.abs(d_n),
                       "h": m * path})
    for k, floor in floors.items():
        if k in sol.sigma:
            sol.sigma[k] = np.maximum(sol.sigma[k], floor)


def note_unknown_mounting(sol, method: str, meta, configured=None,
                          mounting_from_meta: bool = True, **wording) -> None:
    """Where the mounting is not given (:func:`unknown_mounting_warning`, ``wording`` its
    ``ignored`` / ``advice``): the warning added to ``sol.info['warnings']`` and the sigma
    floored (:func:`floor_unknown_mounting`: attitude, velocity, position). The one rule of ``nhc-kf``, ``sins-dr``
    and the USQUE family."""
    w = unknown_mounting_warning(method, meta, configured, mounting_from_meta, **wording)
    if w is not None:
        sol.info["warnings"] = [*(sol.info.get("warnings") or []), w]
        floor_unknown_mounting(sol)


def markov_as_random_walk(meta) -> tuple[dict, str]:
    """``({field: value}, origin)``: for a filter whose biases are random constants plus a
    random walk (``dr-kf``, ``od-velocity-kf``, ``sins-dr``), the Gauss-Markov parts of
    ``meta['imu']`` (1-sigma ``s``, correlation time ``tau`` [s]) as the random walk of the
    same short-term growth, ``q = 2 s^2 / tau``: ``gyro_bias_rw_deg_h_sqrt_h = s sqrt(2 /
    tau) 60`` [deg/h/sqrt(h)] and ``accel_bias_rw_ug_sqrt_h`` likewise (issue 15, session 18).
    The stationary ``s^2`` is already in the constant's prior (:func:`spec_from_meta` folds
    it); over a run much longer than ``tau`` the walk over-bounds the Gauss-Markov part (whose
    variance stays at ``s^2``), so the sigma errs on the honest side. Without it these filters
    took a wandering bias for a constant: on :func:`inmotion.reproductions.real.
    comma_like_scenario` (a phone IMU: 110 deg/h constant, 50 deg/h Gauss-Markov over 30 s;
    20 runs from the truth, band 2.02-4.16) final-attitude NEES 21.39 (od-velocity-kf), 23.63
    (dr-kf), 26.39 (sins-dr); with it 3.19, 6.87 (still above: open), 1.80 (conservative)."""
    spec, origin = spec_from_meta(meta, markov=True)
    out = {}
    for sig, tau, field in (("gyro_markov_deg_h", "gyro_markov_tau_s",
                             "gyro_bias_rw_deg_h_sqrt_h"),
                            ("accel_markov_ug", "accel_markov_tau_s", "accel_bias_rw_ug_sqrt_h")):
        if spec.get(sig) and spec.get(tau):
            out[field] = float(spec[sig] * np.sqrt(2.0 / spec[tau]) * 60.0)
    return out, f"{origin}: Gauss-Markov part as a random walk"


def sensor_spec_fields(meta, sensor: str) -> tuple[dict, str]:
    """``({field: value}, origin)``: the velocity sensor's forward noise and scale-factor model
    from ``meta['sensors'][sensor]``, as the fields of :class:`OdVelocityKfConfig`.

    ``velocity_noise_m_s``: the sensor's speed at a measurement epoch, as
    :func:`inmotion.core.deadreckoning.speed_on_epochs` forms it on the sample times. A speed
    output is one sample: ``noise_m_s`` (plus the quantization of a speed from two counts).
    A distance output gives interval mean speeds placed at the interval midpoints; at a sample
    time the interpolated speed is the mean of the two intervals around it, i.e. the distance
    over two sample periods ``2 / rate_hz`` divided by it, whose 1-sigma is
    :func:`inmotion.align.aided_kf.sensor_noise_from_meta`'s displacement form over that
    interval, ``sqrt(noise_m_s^2 / 2 + 2 q^2 rate_hz^2 / 48)`` (``q = 1 / pulses_per_m``): an
    LDV's 0.01 m/s reads 0.0071 m/s there.

    ``dk_sigma_ppm``, ``dk_tau_s``: paper 000 eq. 3 models the scale factor as a first-order
    Markov process; a spec with ``scale_markov_sigma_ppm`` and ``scale_markov_tau_s`` (the
    simulator's radar) gives it, a constant part ``scale_factor_sigma_ppm`` folded into its
    sigma (root sum of squares: the prior is right, the process noise then over-states the
    wander, on the safe side); a spec with only ``scale_factor_sigma_ppm`` (LDV, odometer: a
    per-run constant) gives a random constant, ``dk_tau_s = inf``. A stated mean error
    ``scale_factor_ppm`` is folded into the constant's sigma too (the DR runs at scale 1, so
    the state ``dk`` must hold it). Modelled as a 300 s Markov
    of 1000 ppm, the LDV's 500 ppm constant left the level sigma twice the error (issue 15).
    Fields the spec does not give are left out."""
    meta = meta if isinstance(meta, dict) else {}
    sensors = meta.get("sensors") if isinstance(meta.get("sensors"), dict) else {}
    spec = sensors.get(sensor)
    if not isinstance(spec, dict):
        return {}, ""
    out = {}
    rate = spec.get("rate_hz")
    distance = sensor == "odometer" or spec.get("output") == "distance"
    if rate and spec.get("noise_m_s") is not None:
        fwd, _, origin = sensor_noise_from_meta(
            meta, sensor, 2.0 / float(rate), "displacement" if distance else "velocity")
        if fwd:
            out["velocity_noise_m_s"] = fwd
    else:
        origin = sensor_noise_from_meta(meta, sensor, 1.0, "velocity")[2]
    const = float(np.hypot(float(spec.get("scale_factor_sigma_ppm") or 0.0),
                           float(spec.get("scale_factor_ppm") or 0.0)))
    mk, tau = float(spec.get("scale_markov_sigma_ppm") or 0.0), spec.get("scale_markov_tau_s")
    if mk > 0 and tau:
        out["dk_sigma_ppm"], out["dk_tau_s"] = float(np.hypot(const, mk)), float(tau)
    elif "scale_factor_sigma_ppm" in spec or "scale_factor_ppm" in spec:
        out["dk_sigma_ppm"], out["dk_tau_s"] = const, float("inf")
    return out, origin


def _imu_spec_meta(meta):
    """``meta`` as an IMU specification: a simulated IMU with ``constant_errors: fixed`` (the
    simulator's default) carries in ``drift_deg_h`` and ``bias_ug`` the run's actual errors.
    Given per axis (a list: a run's own draw, as paper 000's reproduction draws them and writes
    them so) they are no specification and are dropped (the priors keep the configuration's).
    Given as one figure for every axis (a scenario's own figure, e.g. ``tests/test_process.py``'s
    drives) they are kept as the 1-sigma, as ``parked-kf`` and the paper 003 filters
    (:func:`inmotion.align.parked_kf.spec_from_meta`) take them: the errors' size is exactly
    that, and the field defaults (0.03 deg/h, 100 ug) may be far off it. Measured (issue 15,
    ``inmotion process`` on the methods' own matched presets): dropping them gave a 1 deg/h,
    300 ug IMU the priors of a 0.03 deg/h, 100 ug one (along-track velocity at the stops of
    the stop-and-go radar drive 3 sigma off), and a 0.005 deg/h IMU's dr-kf the 0.03 deg/h prior
    whose heading sigma never reached process's 10 arcmin hand-over. A noise density of zero (a
    simulation with the white noise switched off, paper 000's noise-off study) is no filter
    setting either (no process noise on the attitude and velocity): dropped too, the
    configuration's kept."""
    imu = meta.get("imu") if isinstance(meta, dict) else None
    if not isinstance(imu, dict):
        return meta
    drop = {"gyro": {"arw_deg_sqrt_h"}, "accel": {"vrw_ug_sqrt_hz", "vrw_m_s_sqrt_h"}}
    if imu.get("constant_errors") == "fixed":
        drop["gyro"].add("drift_deg_h")
        drop["accel"].add("bias_ug")
    imu = dict(imu)
    for part, keys in drop.items():
        if isinstance(imu.get(part), dict):
            imu[part] = {k: v for k, v in imu[part].items()
                         if not (k in keys and (np.ndim(v) > 0 if k in ("drift_deg_h",
                                                                        "bias_ug")
                                                else not np.any(np.asarray(v or 0.0, float))))}
    return dict(meta, imu=imu)
