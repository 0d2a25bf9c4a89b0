"""Issue 15, comma2k19: can the CAN wheel speeds give the phone's z gyro bias to the ~20 deg/h
that the yaw-mounting and calibrated dead-reckoning targets need? (session 18: no.)

The rear axle is not steered, so its wheels' speed difference is a yaw rate,
``omega_w = (v_RR - v_RL) / track`` (``track`` = 1.60 m, a 2018 RAV4's rear track). A tyre
radius mismatch ``eps`` between the two wheels adds ``eps v / track``, proportional to the
speed, while a gyro bias is constant; the segment's speed spans 9.8-19.8 m/s, so the least
squares fit ``omega_gyro,z - omega_w = b + e v`` over the reference intervals separates them.
Printed: ``b`` over the whole segment against the gyro's error measured from the reference
(:func:`inmotion.reproductions.real.gyro_and_reference_rates`), its sensitivity to the
track, and per window (the fitted ``e`` kept) the two side by side: the windows' scatter is
the wheel estimate's own error.

Measured (session 18): the whole segment gives 100 deg/h against the reference's 109; but the
10 s windows differ from the reference's by +257, -43, -144, -230, +108 deg/h (the 30 s
halves by +23, -43), so over 60 s the wheel estimate's error is about 190 / sqrt(5) = 85
deg/h: the 9 deg/h agreement on the segment is luck, not the 20 deg/h the targets need. The
front (steered) axle gives 406 deg/h. A track off by 5 cm moves ``b`` by 8 deg/h.

Run (from the repository root): ``PYTHONPATH=src python benchmarks/comma_wheel_gyro_bias.py``
(about 2 s).
"""
from __future__ import annotations

import numpy as np

from inmotion.io.importers import import_log
from inmotion.io.importers.comma2k19 import read_signal
from inmotion.reproductions import real as rr

#: a 2018 Toyota RAV4's rear track [m] (the maker's figure, 1.57-1.61 by trim)
TRACK_M = 1.60
#: the wheel order of ``processed_log/CAN/wheel_speed`` (data README)
FL, FR, RL, RR = range(4)
DEG_H = np.degrees(1.0) * 3600.0


def interval_means(t_ref, t, x):
    """Means of the signal ``x(t)`` (trapezoid) over each interval of ``t_ref``."""
    area = np.concatenate([[0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))])
    return np.diff(np.interp(t_ref, t, area)) / np.diff(t_ref)


def rates(root):
    """``(t_mid, gyro_z, reference_z, wheel_speeds (n, 4), speed)`` on the reference
    intervals [s, rad/s, m/s], b's z up, inside the span every signal covers (1 s margin)."""
    b = import_log("comma2k19", root)
    imu = b.imu
    t, w_imu, w_ref = rr.gyro_and_reference_rates(b)
    w_gyro = w_imu[:, 2]
    tw, wheels = read_signal(root / "processed_log" / "CAN" / "wheel_speed", 4)
    ts, speed = read_signal(root / "processed_log" / "CAN" / "speed", 1)
    wm = np.column_stack([interval_means(t, tw, wheels[:, i]) for i in range(4)])
    v = interval_means(t, ts, speed[:, 0])
    mid = 0.5 * (t[1:] + t[:-1])
    keep = ((mid > max(tw[0], ts[0], imu.t[0]) + 1.0)
            & (mid < min(tw[-1], ts[-1], imu.t[-1]) - 1.0))
    return mid[keep], w_gyro[keep], w_ref[keep, 2], wm[keep], v[keep]


def fit_bias(w_gyro, w_wheel, v):
    """``(b, e)`` of ``w_gyro - w_wheel = b + e v`` by least squares [rad/s, rad/m]."""
    A = np.column_stack([np.ones(len(v)), v])
    (b, e), *_ = np.linalg.lstsq(A, w_gyro - w_wheel, rcond=None)
    return float(b), float(e)


def main():
    root = rr.default_data_root() / "comma2k19_rav4_60s"
    t, wg, wr, wm, v = rates(root)
    ref = float(np.mean(wg - wr))
    print(f"speed {v.min():.1f}-{v.max():.1f} m/s; gyro z error from the reference, mean over "
          f"the segment: {ref * DEG_H:.0f} deg/h")
    for axle, (left, right) in (("rear", (RL, RR)), ("front (steered)", (FL, FR))):
        b, e = fit_bias(wg, (wm[:, right] - wm[:, left]) / TRACK_M, v)
        print(f"{axle} axle, track {TRACK_M} m: b = {b * DEG_H:.0f} deg/h "
              f"(tyre term {e * TRACK_M:.2e} of the speed)")
    for track in (TRACK_M - 0.05, TRACK_M + 0.05):
        b, _ = fit_bias(wg, (wm[:, RR] - wm[:, RL]) / track, v)
        print(f"rear axle, track {track:.2f} m: b = {b * DEG_H:.0f} deg/h")
    w_wheel = (wm[:, RR] - wm[:, RL]) / TRACK_M
    _, e = fit_bias(wg, w_wheel, v)
    for window in (10.0, 30.0):
        k = ((t - t[0]) // window).astype(int)
        print(f"{window:.0f} s windows (the segment's tyre term kept): reference / wheels, deg/h")
        for i in range(int(k.max()) + 1):
            m = k == i
            if m.sum() < 0.8 * window * 20.0:      # the reference is 20 Hz
                continue
            r = np.mean(wg[m] - wr[m]) * DEG_H
            w = np.mean(wg[m] - w_wheel[m] - e * v[m]) * DEG_H
            print(f"  from {i * window:4.0f} s: {r:5.0f} / {w:5.0f}  (wheels - reference "
                  f"{w - r:+5.0f})")


if __name__ == "__main__":
    main()
