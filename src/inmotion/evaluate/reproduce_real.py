"""Results on the two real drives of ``shared/data/real`` (issue 9): the first pieces, those
that need only methods that exist today.

What this computes
------------------
comma2k19 (60 s highway, phone IMU, CAN speed)
    Dead reckoning (``dr``: gyro attitude + CAN speed) started from the reference pose at the
    first IMU epoch, against the reference positions; three runs:

    * ``raw``: CAN speed as it is, sensor axis taken along the IMU's forward axis;
    * ``scale (README)``: CAN speed divided by 0.994, the README's "about 0.6 % low";
    * ``scale + mounting (from reference)``: the scale and the pitch / yaw mounting angles
      measured from the reference itself (:func:`reference_calibration`). These are **not
      estimates**: they are what a perfect estimator of the odometer scale and mounting
      (issue 7's odometer/NHC filter, not written yet) could at best give, an upper bound.

    Pure inertial navigation (``sins``) from the same start is the baseline without aiding.
EMS (511 s city drive, 20 Hz MEMS, no odometer)
    Dead reckoning with a **pseudo-odometer made from the reference speed** (the norm of the
    reference velocity): not an independent sensor, so its position error only shows what the
    gyros' attitude drift does to a perfectly scaled speed. Started from the reference at the
    end of the still period (:func:`still_period_end`); once with the raw gyros, once with the
    gyro bias measured over the still period removed (:func:`still_gyro_bias`). ``sins`` with
    the same bias removed, from the same start, is the baseline without aiding.

Not done yet (reported in the results under ``not_done``): level attitude from in-motion coarse
alignment and the odometer/NHC filter (scale and mounting estimation) on comma2k19; INS with NHC
only on EMS. Observability with these sensors (also in the results): level attitude is
observable from the specific force once the vehicle's acceleration is known from the speed
sensor; heading is not observable by gyrocompassing with consumer gyros (biases of ~100 to
1000 deg/h against an Earth rate of 15 deg/h), so it is started from the reference; odometer
scale and pitch / yaw mounting are observable from the speed against the INS velocity when the
attitude is known, but not with DR alone.

Run ``python -m inmotion.evaluate.reproduce_real -o DIR`` (writes ``real_results.json``,
``real_table.md``, ``real_position_error.png``).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..core import earth
from ..core.bundle import Bundle, ImuData, SpeedData
from ..core.solution import NavState
from ..errors import BadInput
from ..io.importers import import_log
from ..navigate.pure import DrConfig, SinsConfig, run_dr, run_sins
from .metrics import error_series, interpolate_truth

__all__ = ["default_data_root", "reference_calibration", "run_comma2k19", "run_ems",
           "still_period_end", "still_gyro_bias", "reproduce_real", "README_CAN_SCALE",
           "STILL_SPEED_M_S"]

#: CAN speed over reference speed stated by the data README ("about 0.6 % low")
README_CAN_SCALE = 0.994
#: the EMS still period ends when the reference speed first exceeds this [m/s]
STILL_SPEED_M_S = 0.05

NOT_DONE = [
    "comma2k19: level attitude from in-motion coarse alignment (methods in progress)",
    "comma2k19: odometer/NHC filter estimating odometer scale and pitch/yaw mounting (issue 7)",
    "EMS: INS with NHC only, and with the reference-speed pseudo-odometer (needs the issue 7 "
    "filter); here only DR with the pseudo-odometer",
]
OBSERVABILITY = {
    "level attitude": "observable: specific force minus the acceleration known from the speed",
    "heading": "not observable by gyrocompassing with consumer gyros (bias 100-1000 deg/h vs "
               "Earth rate 15 deg/h); started from the reference",
    "odometer scale, pitch/yaw mounting": "observable from speed vs INS velocity with known "
                                           "attitude (filter of issue 7); not with DR alone",
    "roll mounting, lever arm along forward": "not observable from a forward speed",
}


def default_data_root() -> Path:
    """``../shared/data/real`` from the repository root (this file is src/inmotion/evaluate)."""
    return Path(__file__).resolve().parents[3].parent / "shared" / "data" / "real"


def reference_calibration(bundle: Bundle, min_speed=3.0) -> dict:
    """Odometer scale and mounting angles measured against the reference (an oracle).

    The direction of travel in b is ``v_b = C_n^b v_n``; with the sensor frame m's forward axis
    ``C_m^b [0, 1, 0] = exp([A x]) [0, 1, 0] ~ [-gamma, 1, alpha]`` (the convention of
    :func:`inmotion.navigate.pure.mounting_matrix`), ``alpha = atan2(v_bz, v_by)`` (pitch)
    and ``gamma = atan2(-v_bx, v_by)`` (yaw); medians over the epochs faster than
    ``min_speed``. The scale is the median of odometer speed over reference speed.

    Returns
    -------
    dict with ``scale`` (odometer / reference), ``pitch_mount_deg``, ``yaw_mount_deg``.
    """
    tr = bundle.truth
    v_b = np.einsum("kji,kj->ki", tr.C_nb, tr.vel_n)
    speed = np.linalg.norm(tr.vel_n, axis=1)
    moving = speed > min_speed
    alpha = np.median(np.arctan2(v_b[moving, 2], v_b[moving, 1]))
    gamma = np.median(np.arctan2(-v_b[moving, 0], v_b[moving, 1]))
    odo = bundle.odometer
    inside = moving & (tr.t >= odo.t[0]) & (tr.t <= odo.t[-1])
    ratio = np.interp(tr.t[inside], odo.t, odo.speed()) / speed[inside]
    return {"scale": float(np.median(ratio)), "pitch_mount_deg": float(np.degrees(alpha)),
            "yaw_mount_deg": float(np.degrees(gamma))}


def _init_from_truth(bundle: Bundle, t0: float) -> NavState:
    tr = interpolate_truth(bundle.truth, [t0])
    return NavState.from_euler(t0, tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0], tr.euler[0])


def _run(label, run, bundle, config, init, note=""):
    t0 = time.perf_counter()
    sol = run(bundle, config, init)
    wall = time.perf_counter() - t0
    e = error_series(sol, bundle.truth)
    dist = float(e.distance_m.iloc[-1])
    row = {"run": label, "note": note, "duration_s": float(e.t.iloc[-1] - e.t.iloc[0]),
           "distance_m": dist,
           "final_horizontal_m": float(e.horizontal_m.iloc[-1]),
           "max_horizontal_m": float(e.horizontal_m.max()),
           "final_horizontal_pct_distance": 100.0 * float(e.horizontal_m.iloc[-1]) / dist,
           "final_vertical_m": float(e.vertical_m.iloc[-1]),
           "final_yaw_arcmin": float(e.yaw_arcmin.iloc[-1]),
           "final_level_arcmin": float(np.hypot(e.phi_E_arcmin.iloc[-1],
                                                e.phi_N_arcmin.iloc[-1])),
           "run_s": wall}
    return row, e


def run_comma2k19(bundle: Bundle) -> tuple[list, dict, dict]:
    """The comma2k19 runs (module docstring): ``(rows, error series by run, calibration)``."""
    init = _init_from_truth(bundle, bundle.imu.t[0])
    cal = reference_calibration(bundle)
    mount_arcmin = (cal["pitch_mount_deg"] * 60.0, 0.0, cal["yaw_mount_deg"] * 60.0)
    runs = [
        ("dr raw", run_dr, DrConfig(sensor="odometer"), "CAN speed as is, mounting not estimated"),
        ("dr scale (README)", run_dr, DrConfig(sensor="odometer",
                                               speed_scale=1.0 / README_CAN_SCALE),
         "CAN / 0.994 (README), mounting not estimated"),
        ("dr scale + mounting (from reference)", run_dr,
         DrConfig(sensor="odometer", speed_scale=1.0 / cal["scale"],
                  mounting_arcmin=mount_arcmin),
         "oracle: values measured from the reference, not estimated (upper bound)"),
        ("sins", run_sins, SinsConfig(), "pure inertial, no aiding"),
    ]
    rows, series = [], {}
    for label, fn, cfg, note in runs:
        row, e = _run(label, fn, bundle, cfg, init, note)
        rows.append(row)
        series[label] = e
    return rows, series, cal


def ems_pseudo_odometer(bundle: Bundle) -> SpeedData:
    """Speed [m/s] = norm of the reference velocity at the reference times: NOT an
    independent sensor (it inherits the reference's errors and has no scale error)."""
    return SpeedData(bundle.truth.t, v=np.linalg.norm(bundle.truth.vel_n, axis=1))


def still_period_end(bundle: Bundle, max_speed=STILL_SPEED_M_S) -> float:
    """End [s] of the initial still period: the first reference epoch faster than
    ``max_speed`` (the data README's "nearly still for the first 3.6 s" is loose: the
    reference speed passes 0.05 m/s at 2.45 s and 0.1 m/s at 2.75 s)."""
    speed = np.linalg.norm(bundle.truth.vel_n, axis=1)
    fast = np.flatnonzero(speed > max_speed)
    if len(fast) == 0 or fast[0] < 2:
        raise BadInput(f"no still period at the start (reference speed <= {max_speed} m/s)")
    return float(bundle.truth.t[fast[0]])


def still_gyro_bias(bundle: Bundle, t_end: float) -> np.ndarray:
    """Gyro bias [rad/s] in b from the still period ``t <= t_end``: the mean measured rate
    minus the Earth rate resolved in b with the reference attitude at the start,
    ``b_g = mean(dtheta / dt) - C_n^b omega_ie^n``. The Earth-rate term (15 deg/h) is small
    against consumer biases (hundreds of deg/h) and needs only a rough attitude."""
    imu = bundle.imu
    dt = np.diff(np.concatenate([[imu.t[0] - imu.dt], imu.t]))
    still = imu.t <= t_end
    w_mean = imu.dtheta[still].sum(axis=0) / dt[still].sum()
    return w_mean - bundle.truth.C_nb[0].T @ earth.omega_ie_n(bundle.truth.lat[0])


def _compensated(bundle: Bundle, gyro_bias) -> Bundle:
    imu = bundle.imu
    dt = np.diff(np.concatenate([[imu.t[0] - imu.dt], imu.t]))
    out = bundle.window()
    out.imu = ImuData(imu.t, imu.dtheta - gyro_bias[None, :] * dt[:, None], imu.dvel)
    return out


def run_ems(bundle: Bundle) -> tuple[list, dict, dict]:
    """The EMS runs (module docstring): ``(rows, error series by run, still-period info)``."""
    t_still = still_period_end(bundle)
    bias = still_gyro_bias(bundle, t_still)
    raw = bundle.window(t_still, None)
    raw.odometer = ems_pseudo_odometer(raw)
    comp = _compensated(raw, bias)
    init = _init_from_truth(raw, raw.imu.t[0])
    runs = [
        ("dr pseudo-odometer", run_dr, raw, DrConfig(sensor="odometer"),
         "speed from the reference (not an independent sensor); raw gyros"),
        ("dr pseudo-odometer + still gyro bias", run_dr, comp, DrConfig(sensor="odometer"),
         "as above, gyro bias from the still period removed"),
        ("sins + still gyro bias", run_sins, comp, SinsConfig(), "pure inertial, no aiding"),
    ]
    rows, series = [], {}
    for label, fn, b, cfg, note in runs:
        row, e = _run(label, fn, b, cfg, init, note)
        rows.append(row)
        series[label] = e
    info = {"still_end_s": t_still, "gyro_bias_deg_h": [float(x) for x in np.degrees(bias) * 3600]}
    return rows, series, info


def _figure(series_by_drive: dict) -> Figure:
    fig = Figure(figsize=(11, 4), layout="constrained")
    axes = fig.subplots(1, len(series_by_drive), squeeze=False)[0]
    for ax, (drive, series) in zip(axes, series_by_drive.items()):
        for label, e in series.items():
            ax.plot(e.distance_m, e.horizontal_m, label=label, lw=1.0)
        ax.set_yscale("log")
        ax.set_xlabel("distance travelled [m]")
        ax.set_ylabel("horizontal position error [m]")
        ax.set_title(drive, loc="left", fontsize=10)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    return fig


def _table(results: dict) -> str:
    lines = []
    for drive, res in results["drives"].items():
        lines += [f"### {drive}", "",
                  "| run | distance m | final horiz. m | % dist | max horiz. m | final vert. m "
                  "| final yaw arcmin | final level arcmin | run s | note |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
        for r in res["runs"]:
            lines.append(f"| {r['run']} | {r['distance_m']:.0f} | {r['final_horizontal_m']:.1f} "
                         f"| {r['final_horizontal_pct_distance']:.2f} | {r['max_horizontal_m']:.1f} "
                         f"| {r['final_vertical_m']:.1f} | {r['final_yaw_arcmin']:.1f} "
                         f"| {r['final_level_arcmin']:.1f} | {r['run_s']:.2f} | {r['note']} |")
        if "still_period" in res:
            sp = res["still_period"]
            lines += ["", f"Still period up to {sp['still_end_s']:.2f} s; gyro bias there "
                      f"[deg/h]: {', '.join(f'{x:.0f}' for x in sp['gyro_bias_deg_h'])} (x, y, z "
                      "in b). The vertical error is against a placeholder reference height "
                      "(meaningless)."]
        if "reference_calibration" in res:
            c = res["reference_calibration"]
            lines += ["", f"Measured from the reference (oracle, not estimated): odometer scale "
                      f"{c['scale']:.4f} ({100 * (1 - c['scale']):.2f} % low; README: about "
                      f"0.6 %), pitch mounting {c['pitch_mount_deg']:.2f} deg, yaw mounting "
                      f"{c['yaw_mount_deg']:.2f} deg."]
        lines.append("")
    lines += ["Not done yet:", ""] + [f"- {x}" for x in results["not_done"]]
    lines += ["", "Observability with these sensors:", ""]
    lines += [f"- {k}: {v}" for k, v in results["observability"].items()]
    return "\n".join(lines) + "\n"


def reproduce_real(out_dir, data_root=None) -> dict:
    """Run the real-drive pieces, write ``real_results.json``, ``real_table.md`` and
    ``real_position_error.png`` to ``out_dir``; return the results dict."""
    root = Path(data_root) if data_root is not None else default_data_root()
    if not root.is_dir():
        raise BadInput("real data folder not found", root)
    comma = import_log("comma2k19", root / "comma2k19_rav4_60s")
    ems = import_log("ems", root / "ems_toronto_511s" / "ems_data_for_lc.mat")
    c_rows, c_series, cal = run_comma2k19(comma)
    e_rows, e_series, still = run_ems(ems)
    results = {"drives": {"comma2k19_rav4_60s": {"runs": c_rows, "reference_calibration": cal},
                          "ems_toronto_511s": {"runs": e_rows, "still_period": still}},
               "not_done": NOT_DONE, "observability": OBSERVABILITY}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "real_results.json").write_text(json.dumps(results, indent=2))
    (out / "real_table.md").write_text(_table(results))
    _figure({"comma2k19 (60 s)": c_series, "EMS (after the still period)": e_series}).savefig(
        out / "real_position_error.png", dpi=90)
    return results


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--out", required=True, help="output folder")
    p.add_argument("--data", default=None, help="folder of the real drives")
    a = p.parse_args(argv)
    results = reproduce_real(a.out, a.data)
    print(_table(results))


if __name__ == "__main__":
    main()
