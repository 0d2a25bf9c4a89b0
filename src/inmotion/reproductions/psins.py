"""The two PSINS logs of ``shared/data/real`` in ``inmotion reproduce real`` (issue 15).

Ring-laser-gyro IMU, parked (``psins_rlg_parked_1847s``)
    No attitude reference: the vehicle is parked, so position and zero velocity are exact and
    attitude is judged against what theory allows for the sensor grade (:func:`parked_limits`):
    heading ``drift / (omega_ie cos L)`` (0.01-0.03 deg/h documented: 2.8-8.3 arcmin at
    34.25 N), level ``bias / g`` (100 ug: 0.34 arcmin). The log is cut into 300 s windows
    (:data:`RLG_WINDOW_S`); on each, the integral methods (``coarse-inertial`` parked,
    ``imada-vb``, ``imada-dual``, ``mimada-dual``, ``oba``, the last four with the parked
    vehicle's known zero speed as the velocity sensor, :func:`with_zero_speed`) and
    ``parked-kf`` started :data:`RLG_START_ERROR_DEG` deg off in heading from
    ``coarse-inertial``'s answer at the window's start. Every method shares the same bias
    errors (the theory limits), so each is shown against the integral methods' consensus
    (their mean, :func:`consensus`) and against the limits, with its own sigma beside it. The
    report explains, from statistics of the log's specific force, why ``parked-kf``'s former
    model (the last IMU row's specific force in F) failed here (module docstring of
    :mod:`inmotion.align.parked_kf`).

MEMS + FOG reference, moving (``psins_fog_mems_moving_100s``)
    There is no odometer: a pseudo-odometer is made from the FOG reference's speed with a
    stated scale error and noise (:func:`mems_pseudo_odometer`; not an independent sensor).
    Coarse methods over the whole 100 s and the fine methods that start from a coarse
    answer (``fine-mux``, ``adaptive``), against the reference, each with its sigma where it
    reports one. With gyro biases up to 200 deg/h (the author's ``eb0``) the heading is not
    observable by gyrocompassing (``drift / (omega_ie cos L)`` is radians); the level limit is
    ``bias / g`` (7 mg: 25 arcmin).
"""
from __future__ import annotations

import time

import numpy as np

from .. import registry
from ..core import earth, rotations
from ..core.bundle import Bundle, SpeedData
from ..core.solution import NavState
from ..core.metrics import interpolate_truth

__all__ = ["RLG_WINDOW_S", "RLG_START_ERROR_DEG", "PARKED_INTEGRAL", "parked_limits",
           "with_zero_speed", "consensus", "run_psins_rlg", "mems_pseudo_odometer",
           "run_psins_mems", "psins_rows", "report_lines", "figure_parked",
           "specific_force_diagnostics"]

ARCMIN = np.pi / 180.0 / 60.0
RLG_WINDOW_S = 300.0
RLG_START_ERROR_DEG = 2.0
#: the integral (attitude-determination) methods that apply to a parked vehicle
PARKED_INTEGRAL = ("coarse-inertial", "imada-vb", "imada-dual", "mimada-dual", "oba")
#: parked-kf runs: label -> (configuration, heading start error [deg])
PARKED_KF_RUNS = {"parked-kf": ({}, RLG_START_ERROR_DEG),
                  "parked-kf from 30'": ({}, 0.5)}
#: pseudo-odometer on the MEMS log: scale error and white noise (stated, seeded)
MEMS_ODO_SCALE = 1.005
MEMS_ODO_NOISE_M_S = 0.05
MEMS_ODO_RATE_HZ = 10.0
MEMS_COARSE = ("coarse-inertial", "imada-vb", "mimada-dual", "oba")
MEMS_FINE = ("fine-mux", "adaptive")


def _spec(meta, part, key):
    d = ((meta or {}).get("imu") or {}).get(part) or {}
    return d.get(key)


def parked_limits(meta: dict, lat: float) -> dict:
    """Theory limits of a parked alignment [arcmin] from the documented spec in ``meta['imu']``:
    heading ``drift / (omega_ie cos L)`` (for each end of ``drift_range_deg_h`` if given),
    level ``bias / g``."""
    drift = _spec(meta, "gyro", "drift_range_deg_h") or [_spec(meta, "gyro", "drift_deg_h")]
    drift = [float(np.max(np.abs(np.atleast_1d(d)))) for d in drift if d is not None]
    bias = float(np.max(np.abs(np.atleast_1d(_spec(meta, "accel", "bias_ug") or 0.0))))
    w = earth.OMEGA_IE * np.cos(lat)
    heading = [np.radians(d) / 3600.0 / w / ARCMIN for d in drift]
    return {"drift_deg_h": drift, "bias_ug": bias, "heading_arcmin": heading,
            "heading_limit_arcmin": max(heading) if heading else float("nan"),
            "level_limit_arcmin": bias * 1e-6 / ARCMIN}


def with_zero_speed(bundle: Bundle, rate_hz: float = 10.0) -> Bundle:
    """The parked bundle with an in-memory odometer reading 0 (the known speed of a parked
    vehicle), so that the velocity-aided attitude-determination methods apply."""
    t = bundle.imu.t
    step = max(1, int(round(1.0 / (rate_hz * bundle.imu.dt))))
    b = Bundle(bundle.imu, dict(bundle.meta), truth=bundle.truth)
    b.odometer = SpeedData(t[::step].copy(), v=np.zeros(len(t[::step])))
    return b


def consensus(Cs) -> np.ndarray:
    """The mean attitude of nearly equal DCMs: the first rotated by the mean misalignment."""
    phis = np.array([rotations.misalignment(C, Cs[0]) for C in Cs])
    return rotations.correct_attitude(Cs[0], phis.mean(axis=0))


def _run(name, bundle, config, init):
    run, cls = registry.get(name).load()
    t0 = time.perf_counter()
    sol = run(bundle, cls(**config), init)
    return sol, time.perf_counter() - t0


def _C_last(sol):
    return rotations.dcm_from_euler(sol.euler[-1])


def _C_start(sol):
    a = sol.info["attitude_start_deg"]
    return rotations.dcm_from_euler(np.radians([a["pitch"], a["roll"], a["yaw"]]))


def _sigmas(sol):
    s = sol.sigma or {}
    if "phi_U" not in s:
        return None, None
    return (float(s["phi_U"][-1]) / ARCMIN,
            float(np.hypot(s["phi_E"][-1], s["phi_N"][-1])) / ARCMIN)


def _att_row(label, window, sol, C_ref, wall, note=""):
    C = _C_last(sol)
    phi = rotations.misalignment(C, C_ref) / ARCMIN
    e = np.degrees(sol.euler[-1])
    sig_h, sig_l = _sigmas(sol)
    return {"run": label, "window_s": list(window), "yaw_deg": float(e[2]),
            "pitch_deg": float(e[0]), "roll_deg": float(e[1]),
            "heading_dev_arcmin": float(phi[2]), "level_dev_arcmin": float(np.hypot(*phi[:2])),
            "sigma_heading_arcmin": sig_h, "sigma_level_arcmin": sig_l, "run_s": wall,
            "note": note}


def specific_force_diagnostics(bundle: Bundle, window_s: float = RLG_WINDOW_S,
                               filter_rate_hz: float = 10.0,
                               heading_error_deg: float = RLG_START_ERROR_DEG) -> dict:
    """Why the last row's specific force broke ``parked-kf`` (issue 15), in numbers, over the
    first ``window_s`` of a parked log: the horizontal specific force (in b, the base is
    nearly level) per IMU row and per filter step [m/s^2], the lag-1 correlation of the
    last-row values from one filter epoch to the next, the rms of the model's spurious
    velocity ``cumsum(f_last dt_step)`` over the window [m/s], and the true heading signal
    ``g omega_ie cos L psi T^2 / 2`` of a ``heading_error_deg`` error at its end [m/s]."""
    bw = bundle.window(None, float(bundle.imu.t[0]) + window_s)
    dt = bw.imu.dt
    step = max(1, int(round(1.0 / (filter_rate_hz * dt))))
    f = bw.imu.dvel[:, :2] / dt
    n = len(f) // step * step
    f_step = bw.imu.dvel[:n, :2].reshape(-1, step, 2).sum(axis=1) / (step * dt)
    f_last = f[step - 1:n:step]
    f_last = f_last - f_last.mean(axis=0)
    lag1 = [float(np.mean(f_last[:-1, j] * f_last[1:, j]) / f_last[:, j].var())
            for j in range(2)]
    walk = np.cumsum(f_last * step * dt, axis=0)
    lat = np.radians(bundle.meta["initial_position"]["lat_deg"])
    signal = (earth.G0 * earth.OMEGA_IE * np.cos(lat) * np.radians(heading_error_deg)
              * window_s ** 2 / 2.0)
    return {"f_row_rms_m_s2": f.std(axis=0).tolist(),
            "f_step_rms_m_s2": f_step.std(axis=0).tolist(),
            "lag1_corr_last_row": lag1, "spurious_velocity_rms_m_s": walk.std(axis=0).tolist(),
            "heading_signal_m_s": float(signal), "window_s": window_s,
            "heading_error_deg": heading_error_deg}


def run_psins_rlg(bundle: Bundle, window_s: float = RLG_WINDOW_S,
                  n_windows: int | None = None) -> dict:
    """Every parked method on each ``window_s`` window of the RLG log (module docstring)."""
    ini = bundle.meta["initial_position"]
    lat, lon, h = np.radians(ini["lat_deg"]), np.radians(ini["lon_deg"]), float(ini["h_m"])
    lim = parked_limits(bundle.meta, lat)
    t0, t1 = float(bundle.imu.t[0]) - bundle.imu.dt, float(bundle.imu.t[-1])
    starts = np.arange(t0, t1 - window_s + 1e-6, window_s)[:n_windows]
    rows, cons = [], []
    for w0 in starts:
        win = (float(w0), float(w0 + window_s))
        bw = bundle.window(*win)
        bz = with_zero_speed(bw)
        sols = {}
        for name in PARKED_INTEGRAL:
            cfg = ({"mode": "parked"} if name == "coarse-inertial"
                   else {"velocity_sensor": "odometer"})
            sols[name] = _run(name, bw if name == "coarse-inertial" else bz, cfg, None)
        C_ref = consensus([_C_last(s) for s, _ in sols.values()])
        cons.append(C_ref)
        for name, (sol, wall) in sols.items():
            rows.append(_att_row(name, win, sol, C_ref, wall,
                                 "integral method; no sigma" if name == "coarse-inertial"
                                 else "integral method, zero speed as the sensor; no sigma"))
        C0 = _C_start(sols["coarse-inertial"][0])
        for label, (cfg, dyaw) in PARKED_KF_RUNS.items():
            e = rotations.euler_from_dcm(C0)
            e[2] += np.radians(dyaw)
            init = NavState(float(bw.imu.t[0]), lat, lon, h, np.zeros(3),
                            rotations.quat_from_euler(e))
            sol, wall = _run("parked-kf", bw, cfg, init)
            rows.append(_att_row(label, win, sol, C_ref, wall,
                                 f"started {dyaw * 60:.0f} arcmin off in heading from "
                                 "coarse-inertial's start"))
    yaw = np.degrees([rotations.euler_from_dcm(C)[2] for C in cons])
    level_series = [rotations.misalignment(C, cons[0]) / ARCMIN for C in cons]
    summary = {}
    for label in list(PARKED_INTEGRAL) + list(PARKED_KF_RUNS):
        rr = [r for r in rows if r["run"] == label]
        dh = np.array([r["heading_dev_arcmin"] for r in rr])
        dl = np.array([r["level_dev_arcmin"] for r in rr])
        sh = [r["sigma_heading_arcmin"] for r in rr]
        summary[label] = {
            "max_abs_heading_dev_arcmin": float(np.abs(dh).max()),
            "max_level_dev_arcmin": float(dl.max()),
            "sigma_heading_arcmin": None if sh[0] is None else [float(min(sh)), float(max(sh))],
            "within_1p5_limits": bool(np.abs(dh).max() <= 1.5 * lim["heading_limit_arcmin"]
                                      and dl.max() <= 1.5 * lim["level_limit_arcmin"]),
            "sigma_covers_3x": None if sh[0] is None else bool(np.all(
                np.abs(dh) <= 3.0 * np.array(sh))),
        }
    return {"limits": lim, "window_s": window_s, "n_windows": int(len(starts)),
            "specific_force_diagnostics": specific_force_diagnostics(bundle, window_s),
            "consensus_yaw_deg": [float(x) for x in yaw],
            "consensus_yaw_spread_arcmin": float((yaw.max() - yaw.min()) * 60.0),
            "consensus_tilt_change_arcmin": [[float(p[0]), float(p[1])] for p in level_series],
            "runs": rows, "summary": summary}


def mems_pseudo_odometer(bundle: Bundle, scale: float = MEMS_ODO_SCALE,
                         noise_m_s: float = MEMS_ODO_NOISE_M_S, rate_hz: float = MEMS_ODO_RATE_HZ,
                         seed: int = 0) -> SpeedData:
    """A forward-speed sensor made from the reference: ``scale * |v_n| + noise`` at
    ``rate_hz`` on the reference's times (not an independent sensor; the README says so)."""
    tr = bundle.truth
    step = max(1, int(round(1.0 / (rate_hz * np.median(np.diff(tr.t))))))
    t = tr.t[::step]
    v = np.linalg.norm(tr.vel_n[::step], axis=1)
    rng = np.random.default_rng(seed)
    return SpeedData(t.copy(), v=scale * v + rng.normal(0.0, noise_m_s, len(t)))


def _truth_err(sol, truth, t=None):
    """Heading and level error [arcmin] of ``sol`` at its last row (or at ``t``) against truth."""
    k = -1 if t is None else int(np.argmin(np.abs(sol.t - t)))
    ref = interpolate_truth(truth, [float(sol.t[k])])
    C = rotations.dcm_from_euler(sol.euler[k])
    phi = rotations.misalignment(C, ref.C_nb[0])
    dyaw = rotations.wrap_pi(sol.euler[k][2] - ref.euler[0][2])
    u, u_ref = C[2, :], ref.C_nb[0][2, :]
    level = np.arctan2(np.linalg.norm(np.cross(u, u_ref)), u @ u_ref)
    return float(np.degrees(dyaw) * 60.0), float(level / ARCMIN), phi / ARCMIN


def run_psins_mems(bundle: Bundle) -> dict:
    """Coarse and fine methods on the MEMS log against the FOG reference (module docstring)."""
    b = Bundle(bundle.imu, dict(bundle.meta), truth=bundle.truth,
               odometer=mems_pseudo_odometer(bundle))
    tr = b.truth
    lat = float(tr.lat[0])
    bias_ug = np.max(np.abs(np.atleast_1d(_spec(b.meta, "accel", "bias_ug") or 0.0)))
    drift = np.max(np.abs(np.atleast_1d(_spec(b.meta, "gyro", "drift_deg_h") or 0.0)))
    lim = {"level_limit_arcmin": float(bias_ug * 1e-6 / ARCMIN),
           "heading_limit_deg": float(np.degrees(np.radians(drift) / 3600.0
                                                 / (earth.OMEGA_IE * np.cos(lat)))),
           "drift_deg_h": float(drift), "bias_ug": float(bias_ug)}
    init = NavState(float(tr.t[0]), tr.lat[0], tr.lon[0], tr.h[0], np.zeros(3),
                    rotations.quat_from_euler(tr.euler[0]))     # position only for coarse ones
    rows = []
    for name in MEMS_COARSE + MEMS_FINE:
        cfg = {"velocity_sensor": "odometer"} if name in ("imada-vb", "mimada-dual", "oba") \
            else {"mode": "moving", "velocity_sensor": "odometer"} if name == "coarse-inertial" \
            else {"coarse_window_s": 60.0, "fine_method": "od-kf"} if name == "fine-mux" \
            else {"fine_method": "od-kf"}
        try:
            sol, wall = _run(name, b, cfg, None if name in MEMS_FINE else init)
        except Exception as exc:                      # noqa: BLE001  (a report, not a test)
            rows.append({"run": name, "error": f"{type(exc).__name__}: {exc}"})
            continue
        dyaw, level, _ = _truth_err(sol, tr)
        sig_h, sig_l = _sigmas(sol)
        ratio = None
        if sig_h is not None:
            ratio = max(abs(dyaw) / max(sig_h, 1e-12), level / max(sig_l, 1e-12))
        row = {"run": name, "heading_err_arcmin": dyaw, "level_err_arcmin": level,
               "sigma_heading_arcmin": sig_h, "sigma_level_arcmin": sig_l,
               "error_over_sigma": ratio, "run_s": wall,
               "warnings": list(sol.info.get("warnings", []))}
        if "attitude_start_deg" in sol.info:          # the q-method's C_b^n(0) at the start
            ref = interpolate_truth(tr, [float(sol.info["t_start_s"])])
            C0 = _C_start(sol)
            u, u_ref = C0[2, :], ref.C_nb[0][2, :]
            row["start_level_err_arcmin"] = float(
                np.arctan2(np.linalg.norm(np.cross(u, u_ref)), u @ u_ref) / ARCMIN)
            row["start_heading_err_arcmin"] = float(np.degrees(rotations.wrap_pi(
                rotations.euler_from_dcm(C0)[2] - ref.euler[0][2])) * 60.0)
        rows.append(row)
    return {"limits": lim, "pseudo_odometer": {"scale": MEMS_ODO_SCALE,
                                               "noise_m_s": MEMS_ODO_NOISE_M_S,
                                               "rate_hz": MEMS_ODO_RATE_HZ, "seed": 0},
            "runs": rows}


def figure_parked(rlg: dict):
    """Heading and level of every parked method against the consensus, per window, with the
    theory limits as bands and parked-kf's 1-sigma as error bars (``real_psins_parked.png``)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4.5), layout="constrained")
    axes = fig.subplots(1, 2)
    lim = rlg["limits"]
    labels = list(rlg["summary"])
    for ax, key, sig_key, limit, title in (
            (axes[0], "heading_dev_arcmin", "sigma_heading_arcmin",
             lim["heading_limit_arcmin"], "heading - consensus"),
            (axes[1], "level_dev_arcmin", "sigma_level_arcmin", lim["level_limit_arcmin"],
             "level - consensus")):
        ax.axhspan(-1.5 * limit if key.startswith("heading") else 0.0, 1.5 * limit,
                   color="0.9", label="1.5 x theory limit")
        for i, label in enumerate(labels):
            rr = [r for r in rlg["runs"] if r["run"] == label]
            x = np.array([r["window_s"][0] for r in rr]) + 12.0 * (i - len(labels) / 2)
            y = np.array([r[key] for r in rr])
            sig = [r[sig_key] for r in rr]
            if sig[0] is None:
                ax.plot(x, y, "o", ms=3, label=label)
            else:
                ax.errorbar(x, y, yerr=np.array(sig, dtype=float), fmt="s", ms=3, capsize=2,
                            label=f"{label} (1 sigma)")
        ax.set_yscale("symlog", linthresh=1.0 if key.startswith("heading") else 0.1)
        ax.set_xlabel("window start [s]")
        ax.set_ylabel(f"{title} [arcmin]")
        ax.set_title(f"PSINS RLG parked: {title}", loc="left", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6)
    return fig


def psins_rows(rlg: dict | None, mems: dict | None) -> list:
    """``results.json`` rows (``quantity, reference, measured, unit, note``)."""
    rows = []
    if rlg:
        lim = rlg["limits"]
        for label, s in rlg["summary"].items():
            sig = s["sigma_heading_arcmin"]
            rows.append({"quantity": f"PSINS RLG parked, max abs(heading - consensus) over "
                                     f"{rlg['n_windows']} x {rlg['window_s']:.0f} s, {label}",
                         "reference": lim["heading_limit_arcmin"],
                         "measured": s["max_abs_heading_dev_arcmin"], "unit": "arcmin",
                         "note": f"reference: drift limit {lim['drift_deg_h'][-1]} deg/h / "
                                 f"(Omega cos L); sigma "
                                 + ("none" if sig is None else f"{sig[0]:.1f}-{sig[1]:.1f}")
                                 + f"; level dev {s['max_level_dev_arcmin']:.2f} arcmin "
                                   f"(limit {lim['level_limit_arcmin']:.2f})"})
    if mems:
        for r in mems["runs"]:
            if "error" in r:
                continue
            sig = r["sigma_level_arcmin"]
            rows.append({"quantity": f"PSINS MEMS level error vs FOG, {r['run']}",
                         "reference": mems["limits"]["level_limit_arcmin"],
                         "measured": r["level_err_arcmin"], "unit": "arcmin",
                         "note": f"reference: accel bias / g; heading error "
                                 f"{r['heading_err_arcmin'] / 60:.1f} deg; sigma "
                                 + ("none" if sig is None else
                                    f"level {sig:.1f}', heading "
                                    f"{r['sigma_heading_arcmin'] / 60:.2f} deg; error / "
                                    f"sigma {r['error_over_sigma']:.2f}")
                                 + ("; warns: outside the coarse envelope"
                                    if any("outside its envelope" in str(w)
                                           for w in r.get("warnings", [])) else "")})
    return rows


def _yes(x):
    return "-" if x is None else ("yes" if x else "NO")


def _div(x, d):
    return None if x is None else x / d


def _f(x, nd=2):
    return "-" if x is None else f"{x:.{nd}f}"


def report_lines(rlg: dict | None, mems: dict | None) -> list:
    """The report's PSINS sections (markdown lines)."""
    lines = []
    if rlg:
        lim = rlg["limits"]
        lines += ["## PSINS ring-laser-gyro IMU, parked 1847 s", "",
                  f"{rlg['n_windows']} windows of {rlg['window_s']:.0f} s. No attitude "
                  "reference: each method against the integral methods' consensus at the "
                  "window's end (every method shares the bias errors), and the consensus "
                  "against the theory limits for the documented sensor: heading "
                  + ", ".join(f"{h:.1f}" for h in lim["heading_arcmin"])
                  + f" arcmin for drift {lim['drift_deg_h']} deg/h, level "
                    f"{lim['level_limit_arcmin']:.2f} arcmin for {lim['bias_ug']:.0f} ug. "
                    f"Consensus heading by window [deg]: "
                  + ", ".join(f"{y:.4f}" for y in rlg["consensus_yaw_deg"])
                  + f" (spread {rlg['consensus_yaw_spread_arcmin']:.1f} arcmin).", "",
                  "| method | max abs heading - consensus arcmin | heading sigma arcmin "
                  "| max level - consensus arcmin | within 1.5x limits | 3 sigma covers |",
                  "| --- | ---: | ---: | ---: | --- | --- |"]
        for label, s in rlg["summary"].items():
            sig = s["sigma_heading_arcmin"]
            lines.append(f"| {label} | {s['max_abs_heading_dev_arcmin']:.2f} | "
                         + ("-" if sig is None else f"{sig[0]:.1f}-{sig[1]:.1f}")
                         + f" | {s['max_level_dev_arcmin']:.2f} | "
                           f"{'yes' if s['within_1p5_limits'] else 'NO'} | "
                           f"{_yes(s['sigma_covers_3x'])} |")
        lines += ["", "Per window (parked-kf rows started off in heading from coarse-inertial's "
                  "start):", "",
                  "| window s | method | yaw deg | pitch deg | roll deg | heading dev ' | "
                  "sigma ' | level dev ' | level sigma ' |",
                  "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        for r in rlg["runs"]:
            lines.append(f"| {r['window_s'][0]:.0f}-{r['window_s'][1]:.0f} | {r['run']} | "
                         f"{r['yaw_deg']:.4f} | {r['pitch_deg']:.4f} | {r['roll_deg']:.4f} | "
                         f"{r['heading_dev_arcmin']:.2f} | {_f(r['sigma_heading_arcmin'], 1)} | "
                         f"{r['level_dev_arcmin']:.2f} | {_f(r['sigma_level_arcmin'])} |")
        d = rlg["specific_force_diagnostics"]
        lines += ["", "Before issue 15, parked-kf's error model took the last 10 ms IMU row's "
                  "specific force (see `inmotion.align.parked_kf`); started 2 deg off it ended "
                  "33-106 arcmin from the integral methods on these windows with a heading "
                  "sigma of 2.6-3.3 arcmin (measured with that model on 2026-12-01). Why, over "
                  "the first "
                  f"{d['window_s']:.0f} s: the horizontal specific force is "
                  + "/".join(f"{x:.3f}" for x in d["f_row_rms_m_s2"])
                  + " m/s^2 rms (x/y) per 10 ms row (engine vibration and 125 ug*s "
                    "quantization) but "
                  + "/".join(f"{x:.3f}" for x in d["f_step_rms_m_s2"])
                  + " over a 0.1 s filter step; the last-row values at successive filter "
                    "epochs are uncorrelated (lag-1 "
                  + "/".join(f"{x:.2f}" for x in d["lag1_corr_last_row"])
                  + "; the simulator's 25 Hz vibration alternates, -1), so the model's "
                    "`int f_N phi_U dt` random-walks to "
                  + "/".join(f"{x:.2f}" for x in d["spurious_velocity_rms_m_s"])
                  + f" m/s rms against a true heading signal of {d['heading_signal_m_s']:.2f}"
                    f" m/s from a {d['heading_error_deg']:g} deg error: the filter takes "
                    "noise for heading information, its heading sigma collapses and the "
                    "estimate stalls. The engine's F takes the epoch mean.", ""]
    if mems:
        lim = mems["limits"]
        po = mems["pseudo_odometer"]
        lines += ["## PSINS MEMS IMU with FOG reference, moving 100 s", "",
                  f"Pseudo-odometer from the FOG speed (scale {po['scale']}, noise "
                  f"{po['noise_m_s']} m/s at {po['rate_hz']:.0f} Hz, seed {po['seed']}; **not "
                  "an independent sensor**). Limits: level "
                  f"{lim['level_limit_arcmin']:.0f} arcmin from the accelerometer bias "
                  f"({lim['bias_ug']:.0f} ug / g) for an instantaneous gravity fit, and "
                  f"{lim['drift_deg_h'] * 50 / 60:.0f} arcmin from the gyro drift over half "
                  f"the 100 s window ({lim['drift_deg_h']:.0f} deg/h x 50 s) for the integral "
                  "methods; heading not observable (drift / (Omega_ie cos L) = "
                  f"{lim['heading_limit_deg']:.0f} deg).", "",
                  "Errors at the end of the 100 s (the coarse methods' answer propagated by "
                  f"the gyros: {lim['drift_deg_h']:.0f} deg/h x 100 s is "
                  f"{lim['drift_deg_h'] / 36:.1f} deg) and, for the coarse methods, of their "
                  "answer C_b^n(0) at the start.", "",
                  "| method | heading err deg | heading sigma deg | level err arcmin | "
                  "level sigma arcmin | error / sigma | start heading err deg | "
                  "start level err arcmin | warnings |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
        for r in mems["runs"]:
            if "error" in r:
                lines.append(f"| {r['run']} | failed: {r['error']} | | | | | |")
                continue
            sh = r["sigma_heading_arcmin"]
            lines.append(f"| {r['run']} | {r['heading_err_arcmin'] / 60:.2f} | "
                         f"{_f(None if sh is None else sh / 60)} | {r['level_err_arcmin']:.1f} | "
                         f"{_f(r['sigma_level_arcmin'], 1)} | {_f(r['error_over_sigma'], 1)} | "
                         f"{_f(_div(r.get('start_heading_err_arcmin'), 60))} | "
                         f"{_f(r.get('start_level_err_arcmin'), 1)} | "
                         f"{'; '.join(map(str, r['warnings'])) or '-'} |")
        lines += ["", "Before issue 15's envelope check (commit 6acb97a) `fine-mux` ended "
                  "114 arcmin off in level with a 1.2 arcmin sigma and 50 deg off in heading "
                  "with a 0.09 deg sigma, `adaptive` 123 arcmin (sigma 1.0) and 47 deg (sigma "
                  "0.04 deg): a confident wrong answer. Now the coarse stage's envelope from "
                  "the documented drift and bias (`multiplex.coarse_envelope`) sets the fine "
                  "prior (heading unknown, start velocity correlated with the attitude), the "
                  "reported sigma is kept at what the IMU allows (level bias / g per axis, "
                  "heading unknown) and the summary warns.", ""]
    return lines
