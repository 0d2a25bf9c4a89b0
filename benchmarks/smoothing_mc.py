"""Forward-only against forward-backward (RTS) smoothing, Monte Carlo against simulated truth.

Issue 14's demonstration: for each drive, ``--runs`` seeds (the bundle and the start error
drawn per seed: heading N(0, 1 deg), level N(0, 0.3 deg), and the method's prior set to
those sigmas, so that a consistent filter is possible), the same method run forward only and
with ``smooth=True``; per run:

* the heading error's RMS over the first 120 s of motion (where the forward filter has not
  converged) and over the rest;
* the horizontal position error at its worst point;
* the attitude NEES (3 dof) averaged over the run.

Printed: the mean over runs of each, forward and smoothed side by side, and the Monte Carlo
consistency test: at each output epoch the attitude NEES averaged over the runs, against the
95 % band of a chi-square(3 R) / R (R runs), and the fraction of epochs inside, below
(conservative) and above (overconfident) it.

Drives: paper 000 trajectory 1 (``dr-kf``, radar), paper 003's drive (``dr-kf`` with the
LDV as its velocity sensor, its noise set to the simulated LDV's, the filter's IMU noise and
priors and the LDV's scale-factor prior set to the simulated ones), paper 002's hour
(``sins-dr``, filter 10 Hz); and the banks of local filters of paper 003, smoothed with their
FDI kept (``aided_kf._smooth_bank``): ``fkf`` (odometer + LDV) on paper 003's drive and on
the same drive with the paper's injected OD / LDV faults, ``od-kf`` (odometer, NHC fallback)
on the faults drive; their IMU and scale-factor settings set to the simulated ones as well.

Paper 003's drive, why its smoothed NEES was out of band (issue 14): ``dr-kf`` ignored the
LDV's lever arm (1.2 m forward, 0.6 m down); in turns and pitch changes the LDV reads
``(omega x l)_forward`` (0.03 m/s in a 5 deg/s turn) on top of the speed, three times the
0.01 m/s noise the filter was told, and the tilt estimate (phi_E) absorbed it: per-axis
normalized squared error E 2.3 / N 0.7 / U 0.15 smoothed (4 runs) — overconfident in E,
hidden in the 3-dof sum by the heading's 7x too conservative sigma (dr-kf's default IMU
noise, 0.03 deg/h drift, against the simulated 0.005). Removing the lever arm from the
simulation brought E to 0.07; ``dr-kf`` now uses the sensor's lever arm from ``meta.yaml`` in
its DR (as ``sins-dr`` does). With the filter's IMU settings left at the defaults the NEES
is then far below the band (0.2 of 3: conservative), so the row sets them to the simulated
IMU's. Measured (10 runs): in band 55 % -> 100 % (forward -> smoothed), per axis 0.45 / 0.67
/ 0.69 -> 1.06 / 0.78 / 1.66.

The ``od-kf`` rows (odometer alone) stay overconfident, forward already (NEES 12.8 of 3,
north tilt 7.1): paper 003's sensor rows (``aiding_rows``, eq. 23-24 and the displacement
form) take the IMU velocity as ``C_v^b0 [0, v, 0] - omega x l``, the whole cross product,
while the odometer reads only the forward part of the velocity at the wheel (the simulator's
and the dead reckoner's model: the IMU moves along the vehicle's forward axis). The
lateral part ``-omega_z l_y`` of a wheel 1.5 m behind the IMU (0.13 m/s in a 5 deg/s turn)
then enters as a velocity the vehicle does not have. Measured on the forward filter (3 runs,
per axis E / N / U): lever arm [-0.8, -1.5, -0.9] m 2.31 / 6.49 / 2.59; [0, -1.5, 0] the
same; [-0.8, 0, -0.9] or none 0.15 / 0.47 / 0.63. In ``fkf`` the LDV's arm (1.2 m ahead)
gives the opposite lateral term and the fused estimate is in band. Not fixed here: it is a
change of the measurement rows (``estimation.measurements``, ``aiding_rows``) and of the
stored engine references.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/smoothing_mc.py [--runs N]
        [--hour-runs M]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from inmotion.align.aided_kf import run_fkf, run_od_kf
from inmotion.align.dr_kalman import run_dr_kf
from inmotion.core import earth, rotations
from inmotion.core.solution import NavState
from inmotion.navigate.sins_dr import run_sins_dr
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

ARCMIN = np.pi / 180 / 60
#: the start errors drawn (1-sigma, pitch / roll / heading) and each method told so (its prior)
TILT_DEG, HEADING_DEG = 0.3, 1.0
_DR_KF_PRIOR = {"init_tilt_sigma_deg": TILT_DEG, "init_heading_sigma_deg": HEADING_DEG}
#: paper003_drive.yaml's IMU (fixed constants: the drift and bias are 1-sigma values)
_P003_IMU = {"gyro_drift_deg_h": 0.005, "gyro_arw_deg_sqrt_h": 0.0005, "accel_bias_ug": 50.0,
             "accel_vrw_ug_sqrt_hz": 5.0}
#: paper 003's banks: its IMU, the OD's 2000 ppm and the LDV's 500 ppm scale factors
_P003_BANK = {**_P003_IMU, **_DR_KF_PRIOR, "od_scale_sigma_ppm": 2000.0,
              "ldv_scale_sigma_ppm": 500.0}
DRIVES = (("paper000_traj1", run_dr_kf, dict(_DR_KF_PRIOR)),
          # the LDV's noise as simulated (0.01 m/s; dr-kf's default 0.1 is the radar's), its
          # scale factor a constant of 500 ppm (a Markov process with a very long time)
          ("paper003_drive", run_dr_kf, {"velocity_sensor": "ldv", "velocity_noise_m_s": 0.01,
                                         "lateral_noise_m_s": 0.01, **_DR_KF_PRIOR,
                                         **_P003_IMU, "dk_sigma_ppm": 500.0,
                                         "dk_tau_s": 1e7}),
          ("paper002_hour", run_sins_dr, {"init_tilt_sigma_arcmin": 60 * TILT_DEG,
                                          "init_heading_sigma_arcmin": 60 * HEADING_DEG}),
          ("paper003_drive", run_fkf, dict(_P003_BANK)),
          ("paper003_faults", run_fkf, dict(_P003_BANK)),
          ("paper003_drive", run_od_kf, dict(_P003_BANK)),
          ("paper003_faults", run_od_kf, dict(_P003_BANK)))


def _errors(sol, truth):
    k = np.searchsorted(truth.t, sol.t)
    phi = np.array([rotations.misalignment(a, c) for a, c in zip(
        rotations.dcm_from_euler(sol.euler), rotations.dcm_from_euler(truth.euler[k]))])
    r_m, r_n = earth.radii(truth.lat[k])
    north = (sol.lat - truth.lat[k]) * (r_m + truth.h[k])
    east = (sol.lon - truth.lon[k]) * (r_n + truth.h[k]) * np.cos(truth.lat[k])
    sig = np.column_stack([sol.sigma[c] for c in ("phi_E", "phi_N", "phi_U")])
    moving = np.linalg.norm(truth.vel_n[k], axis=1) > 0.5
    return phi, np.hypot(north, east), sig, moving


def one(scenario, fn, cfg, seed):
    b = simulate(load_scenario(find_scenario(scenario)), np.random.default_rng(seed))
    rng = np.random.default_rng(10_000 + seed)
    err = np.radians([TILT_DEG, TILT_DEG, HEADING_DEG]) * rng.standard_normal(3)
    init = NavState.from_truth(b.truth, euler_error=err)
    row = {}
    for smooth in (False, True):
        sol = fn(b, {**cfg, "smooth": smooth}, init)
        phi, horiz, sig, moving = _errors(sol, b.truth)
        t_move = sol.t[np.argmax(moving)] if moving.any() else sol.t[0]
        early = (sol.t >= t_move) & (sol.t <= t_move + 120.0)
        late = sol.t > t_move + 120.0
        nees = np.sum((phi / sig) ** 2, axis=1)[1:]         # row 0: the prior
        row[smooth] = {"head_early": np.sqrt(np.mean(phi[early, 2] ** 2)) / ARCMIN,
                       "head_late": np.sqrt(np.mean(phi[late, 2] ** 2)) / ARCMIN,
                       "horiz_max": horiz.max(), "nees": nees.mean(), "series": nees,
                       "axes": ((phi / sig) ** 2)[1:].mean(0)}
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--hour-runs", type=int, default=4)
    ap.add_argument("--only", default="",
                    help="run only the rows whose 'scenario method' contains this text")
    args = ap.parse_args()
    from scipy.stats import chi2
    for scenario, fn, cfg in DRIVES:
        if args.only not in f"{scenario} {fn.__name__.replace('run_', '').replace('_', '-')}":
            continue
        runs = args.hour_runs if scenario == "paper002_hour" else args.runs
        t0 = time.perf_counter()
        rows = [one(scenario, fn, cfg, s) for s in range(runs)]
        print(f"{scenario} ({fn.__name__.replace('run_', '').replace('_', '-')}, {runs} runs, "
              f"{time.perf_counter() - t0:.0f} s)")
        for key, label in (("head_early", "heading RMS, first 120 s of motion [arcmin]"),
                           ("head_late", "heading RMS, after [arcmin]"),
                           ("horiz_max", "horizontal error at its worst point [m]"),
                           ("nees", "attitude NEES, mean over the run (3 dof)")):
            f = np.mean([r[False][key] for r in rows])
            s = np.mean([r[True][key] for r in rows])
            print(f"  {label:48s} forward {f:9.3f}   smoothed {s:9.3f}")
        ax = {k: np.mean([r[k]["axes"] for r in rows], axis=0) for k in (False, True)}
        print("  per axis (phi/sigma)^2, mean over runs and epochs, E / N / U:   forward "
              + " / ".join(f"{v:.2f}" for v in ax[False]) + "   smoothed "
              + " / ".join(f"{v:.2f}" for v in ax[True]))
        lo, hi = chi2.ppf(0.025, 3 * runs) / runs, chi2.ppf(0.975, 3 * runs) / runs
        for smooth in (False, True):
            n = min(len(r[smooth]["series"]) for r in rows)
            mean = np.mean([r[smooth]["series"][:n] for r in rows], axis=0)
            print(f"  epochs whose NEES averaged over the runs is in its 95 % band "
                  f"[{lo:.2f}, {hi:.2f}] ({'smoothed' if smooth else 'forward'}): "
                  f"{np.mean((mean >= lo) & (mean <= hi)):.0%} (below: {np.mean(mean < lo):.0%}, "
                  f"above: {np.mean(mean > hi):.0%})")


if __name__ == "__main__":
    main()
