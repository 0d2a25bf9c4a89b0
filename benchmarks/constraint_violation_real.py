"""Real vehicles' violations of the vehicle constraint (issue 15): the body-frame lateral and
vertical velocity of a moving vehicle from the reference solutions of the real logs in
``shared/data/real`` (README there), measured to set the simulator's
``vehicle.constraint_violation`` and, through ``meta.yaml``, the lateral and vertical row
noise of paper 003's sensor sub-filters (:func:`inmotion.align.aided_kf.sensor_noise_from_meta`).

Per log, on the rows where the vehicle moves faster than 3 m/s:

1. ``v_b = C_n^b v_n`` from the reference attitude and velocity (importers' ``truth``);
2. the deterministic parts a filter models or the reference's mounting explains are fitted
   and removed by least squares, per axis: ``v_x = a v_y + d omega_z + c`` (lateral: a the
   reference's heading mounting in the vehicle, d the forward distance of the reference point
   from the point where the constraint holds, the rear axle), ``v_z = a v_y + d omega_x + c``
   (vertical; pitch mounting and the pitch-rate lever); ``omega`` from the attitude's rate;
3. what is left is the violation (plus the reference's own velocity and attitude errors, so
   an upper bound): its 1-sigma, its correlation time (lag where the autocorrelation first
   falls below 1/e), the 1-sigma of its mean over the filter's 0.5 s measurement interval
   (what a displacement row sees), and the 1-sigma of the difference of consecutive 0.5 s
   means over sqrt(2) (the fast part alone).

Logs: ``comma2k19_rav4_60s`` (20 Hz reference of an offline INS/GNSS/vision fusion, a car on a
highway), ``psins_fog_mems_moving_100s`` (10 Hz FOG INS; the FOG sits on the platform that
rolls by +-32 deg between 33 and 76 s, so the body is not the vehicle there: those rows are
left out), ``ems_toronto_511s`` (20 Hz, city; its reference vertical velocity is identically
zero, so its vertical figure is the pitch and the fit's, not a measurement).

Usage: ``PYTHONPATH=src python benchmarks/constraint_violation_real.py [--interval 0.5]``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from inmotion.core import rotations
from inmotion.io.importers import import_log
from inmotion.reproductions.real import default_data_root

LOGS = (("comma2k19", "comma2k19_rav4_60s", {}, None),
        ("psins", "psins_fog_mems_moving_100s/transfer_align_fog_mems.mat",
         {"mounting": "none"}, (30.0, 76.0)),
        ("ems", "ems_toronto_511s/ems_data_for_lc.mat", {}, None))
MIN_SPEED_M_S = 3.0


def body_velocity_and_rate(truth):
    """``(v_b, omega_nb_b)`` [m/s], [rad/s] at the truth rows: ``C_n^b v_n`` and the body
    rate from ``dC_b^n/dt = C_b^n [omega x]`` (central differences)."""
    C = rotations.dcm_from_euler(truth.euler)
    vb = np.einsum("nji,nj->ni", C, truth.vel_n)
    W = np.einsum("nji,njk->nik", C, np.gradient(C, truth.t, axis=0))
    return vb, np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)


def correlation_time_s(r, dt):
    """Lag [s] where the autocorrelation of ``r`` first falls below 1/e."""
    rc = r - r.mean()
    ac = np.correlate(rc, rc, "full")[len(rc) - 1:]
    below = np.nonzero(ac / ac[0] < np.exp(-1.0))[0]
    return float(below[0] * dt) if below.size else float("nan")


def measure(fmt, rel, opts, skip, interval_s, root=None):
    root = Path(root) if root is not None else default_data_root()
    b = import_log(fmt, root / rel, **opts)
    tr = b.truth
    vb, w = body_velocity_and_rate(tr)
    dt = float(np.median(np.diff(tr.t)))
    keep = vb[:, 1] > MIN_SPEED_M_S
    if skip is not None:
        rel_t = tr.t - tr.t[0]
        keep &= ~((rel_t >= skip[0]) & (rel_t <= skip[1]))
    out = {"log": rel.split("/")[0], "rows": int(keep.sum()), "dt_s": dt}
    for axis, col, rate_col in (("lateral", 0, 2), ("vertical", 2, 0)):
        A = np.stack([vb[:, 1], w[:, rate_col], np.ones_like(tr.t)], -1)[keep]
        coef, *_ = np.linalg.lstsq(A, vb[keep, col], rcond=None)
        r = vb[keep, col] - A @ coef
        # means over the interval, on runs of consecutive kept rows only
        k = max(1, int(round(interval_s / dt)))
        idx = np.nonzero(keep)[0]
        breaks = np.nonzero(np.diff(idx) > 1)[0] + 1
        means, diffs = [], []
        for seg in np.split(np.arange(len(r)), breaks):
            nb = len(seg) // k
            m = r[seg[:nb * k]].reshape(nb, k).mean(1) if nb else np.zeros(0)
            means.append(m)
            diffs.append(np.diff(m))
        means, diffs = np.concatenate(means), np.concatenate(diffs)
        out[axis] = {"mounting_rad": float(coef[0]), "lever_m": float(coef[1]),
                     "sigma_m_s": float(r.std()), "tau_s": correlation_time_s(r, dt),
                     "interval_mean_sigma_m_s": float(means.std()),
                     "fast_sigma_m_s": float(diffs.std() / np.sqrt(2.0))}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--interval", type=float, default=0.5, help="measurement interval [s]")
    args = ap.parse_args(argv)
    print(f"{'log':28s} {'axis':8s} {'sigma':>7s} {'tau':>6s} {'mean/T':>7s} {'fast':>7s}"
          f"  (m/s, s; T = {args.interval:g} s)")
    for fmt, rel, opts, skip in LOGS:
        res = measure(fmt, rel, opts, skip, args.interval)
        for axis in ("lateral", "vertical"):
            m = res[axis]
            print(f"{res['log']:28s} {axis:8s} {m['sigma_m_s']:7.4f} {m['tau_s']:6.2f} "
                  f"{m['interval_mean_sigma_m_s']:7.4f} {m['fast_sigma_m_s']:7.4f}"
                  f"   (fit: mounting {m['mounting_rad']:+.4f} rad, lever {m['lever_m']:+.2f} m;"
                  f" {res['rows']} rows at {res['dt_s']:g} s)")


if __name__ == "__main__":
    main()
