"""Paper 000's simulation (sec. 5), re-created as a Monte Carlo and set beside the paper.

Yang, Xi, Yang, Xue, *An Alignment Method for SINS Assisted by Doppler Radar on a Vehicle-Borne
Moving Base*, Sensors 2019. Experiments (shipped scenarios): trajectory 1 (``paper000_traj1``),
trajectory 2 (``paper000_traj2``), trajectory 1 with side slips and jumps
(``paper000_traj1_slip``); each aligned over ``runs`` Monte Carlo runs of 600 s with the
settings of :data:`SETTINGS`: ``dr-kf`` with Z2 (the non-holonomic measurement) and without;
``paper_world``, the world paper 000's printed F describes (the DR's gyros without the drift,
the filter's DR attitude rows without ``-C_b^n eps``; it reproduces the paper's up accuracy,
which shared gyros cannot reach); and the velocity-matching baseline ``od-velocity-kf``.
Trajectory 1 adds eq. 37 as printed (``with_Z2_paper_H2``) and a rerun with the IMU's white
noise off (``with_Z2_imu_white_noise_off``: what limits the mounting angle gamma).

Per run (all draws from one ``numpy.random.Generator`` seeded by ``(seed, experiment, run)``):

* gyro drift and accelerometer bias per axis from N(0, 0.03 deg/h) and N(0, 100 ug) (the
  paper's "constant drift 0.03 deg/h", "bias 1e-4 g" read as 1-sigma of per-run random
  constants: a fixed value would give every run the same deterministic error and no Monte
  Carlo); the noises, radar scale-factor Markov process and baro noise from the scenario;
* the coarse-alignment error per axis from N(0, 1 deg) and the initial horizontal position
  error per axis from N(0, 15 m) (the paper: 1 deg, 15 m); the DR starts with the same errors.

Reported per experiment and Z2 setting, over the runs: the misalignment estimation error
(estimate minus truth, DESIGN ``phi``) after convergence as the paper states it, max |error|
over the last 100 s and its standard deviation over the last 100 s, median and 95th percentile
over runs; the mounting-angle estimates; the NEES of the misalignment (3 dof) averaged over runs
against its two-sided 95 % chi-square band; figures of the error curves with the filter's
3-sigma; and an observability analysis of the mounting angles.

Mounting angles: the shipped scenarios mount the IMU in the vehicle with paper 000's
installation angles, ``vehicle_mounting_arcmin = A = (3', 10', 5')``, ``C_v^b = exp([A x])``
(docs/ARCHITECTURE.md "Vehicle frame and mounting"): the vehicle and the radar move along the
vehicle's forward axis, which is ``[-gamma, 1, alpha]`` in the IMU frame, exactly the geometry
of eq. 9-11. The truth attitude is the IMU's. The non-holonomic constraint then holds in the
vehicle frame: ``dr-kf``'s default NHC rows carry the mounting columns; trajectory 1 is also run
with eq. 37 as printed (``with_Z2_paper_H2``), which ignores them.

Cost (issue 3: 50 runs of the three experiments under 2 minutes on 2 cores): each run
simulates its bundle once (about 0.3 CPU-s) and aligns it with every setting (``dr-kf`` on the
one numba SINS / DR engine, about 0.11 CPU-s per 600 s setting; trajectory 1 simulates a
second, noise-free bundle), about 1 CPU-s per run in all; a worker process starts in about
1 s (imports and numba cache). Measured with ``benchmarks/bench_dr_kf.py --reproduce-runs 50``:
81 s wall on 2 cores, 152 CPU-s in the runs (2026-11-22).
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from ..estimation import chi2

from ..core.bundle import row_at_or_after
from .common import run_tasks

__all__ = ["reproduce", "run_one", "EXPERIMENTS", "PAPER", "observability",
           "gyrocompass_heading_limit"]

ARCMIN = np.pi / 180.0 / 60.0

#: experiment -> shipped scenario
EXPERIMENTS = {"traj1": "paper000_traj1", "traj2": "paper000_traj2",
               "traj1_slip": "paper000_traj1_slip"}

#: the filter settings compared in each experiment
SETTINGS = {"with_Z2": {"use_nhc": True}, "without_Z2": {"use_nhc": False},
            # the world paper 000's printed F describes: the DR's gyros have no drift (a
            # simulation-only oracle removes the run's drawn drift from the DR's rows) and the
            # filter's DR attitude rows have no -C_b^n eps; see _report
            "paper_world": {"use_nhc": True, "dr_sees_gyro_drift": False, "paper_world": True},
            # the classic baseline: SINS minus the radar's velocity (+ NHC), no DR attitude
            "od_velocity_kf": {"use_nhc": True, "method": "od-velocity-kf"}}
SETTINGS_EXTRA = {"traj1": {"with_Z2_paper_H2": {"use_nhc": True, "nhc_mount_terms": False}}}

#: paper 000 sec. 5 figures [arcmin]: (E, N, U) accuracy "better than", and the steady-state STD
PAPER = {("traj1", "with_Z2"): ((0.5, 0.4, 3.2), (0.04, 0.02, 1.79)),
         ("traj1", "without_Z2"): ((0.4, 0.5, 9.8), (None, None, None)),
         ("traj2", "with_Z2"): ((0.3, 0.4, 3.4), (0.11, 0.16, 2.19)),
         ("traj1_slip", "with_Z2"): ((0.5, 0.4, 3.5), (0.19, 0.23, 2.57))}
# the paper's figures come from its own (paper-world) simulation: set them beside that too
PAPER.update({(exp, "paper_world"): PAPER[(exp, "with_Z2")]
              for exp in ("traj1", "traj2", "traj1_slip")})


def _scenario(name, rng):
    """The shipped scenario with this run's gyro drift and accelerometer bias drawn."""
    from ..sim.scenario import find_scenario, load_scenario
    sc = load_scenario(find_scenario(name)).model_dump()
    sc["imu"]["constant_errors"] = "fixed"
    sc["imu"]["gyro"]["drift_deg_h"] = list(rng.normal(0.0, 0.03, 3))
    sc["imu"]["accel"]["bias_ug"] = list(rng.normal(0.0, 100.0, 3))
    return sc


def run_one(task) -> dict:
    """One Monte Carlo run of one experiment: simulate, align with each setting, summarize.

    ``task = (experiment, run_index, seed)``. Returns 1 Hz series (error, sigma, NEES, mount
    estimates) and the last-100-s statistics per setting. Trajectory 1 is also simulated a
    second time with the same constants but no IMU white noise (``NOISE_FREE_LABEL``), which
    shows what limits the mounting angle gamma.
    """
    from ..core import earth
    from ..core.rotations import dcm_from_rotvec, quat_from_dcm
    from ..core.solution import NavState
    from ..sim import simulate

    exp, i, seed = task
    cpu0 = time.process_time()
    rng = np.random.default_rng([seed, list(EXPERIMENTS).index(exp), i])
    sc = _scenario(EXPERIMENTS[exp], rng)
    bundle = simulate(sc, rng)
    tr = bundle.truth
    eps_b = np.deg2rad(np.array(sc["imu"]["gyro"]["drift_deg_h"])) / 3600.0
    att_err = rng.normal(0.0, np.deg2rad(1.0), 3)
    pos_err = rng.normal(0.0, 15.0, 2)
    r_m, r_n = earth.radii(tr.lat[0])
    C0 = dcm_from_rotvec(-att_err) @ tr.C_nb[0]      # C_computed = exp(-[phi x]) C_true
    init = NavState(tr.t[0], tr.lat[0] + pos_err[0] / (r_m + tr.h[0]),
                    tr.lon[0] + pos_err[1] / ((r_n + tr.h[0]) * np.cos(tr.lat[0])), tr.h[0],
                    tr.vel_n[0], quat_from_dcm(C0))
    settings = dict(SETTINGS, **SETTINGS_EXTRA.get(exp, {}))
    out = {"experiment": exp, "run": i,
           "mount_truth": np.deg2rad(np.array(sc["vehicle_mounting_arcmin"]) / 60.0),
           "gyrocompass_phi_U": gyrocompass_heading_limit(tr.C_nb[-1] @ eps_b, tr.lat[-1])}
    for label, cfg in settings.items():
        cfg = dict(cfg)
        offset = -eps_b if cfg.pop("paper_world", False) else None
        out[label] = _align(bundle, cfg, init, offset)
    if exp == "traj1":
        quiet = _without_white_noise(sc)
        bundle_q = simulate(quiet, np.random.default_rng([seed, 99, i]))
        out[NOISE_FREE_LABEL] = _align(bundle_q, SETTINGS["with_Z2"], init, None)
    out["cpu_s"] = time.process_time() - cpu0
    return out


#: trajectory 1 with Z2, the IMU's white noise (angle and velocity random walk) switched off
NOISE_FREE_LABEL = "with_Z2_imu_white_noise_off"


def _without_white_noise(sc: dict) -> dict:
    """The run's scenario with the gyro ARW and accelerometer VRW set to zero (the drawn
    constant drift and bias, the radar and the baro unchanged)."""
    quiet = json.loads(json.dumps(sc))
    quiet["imu"]["gyro"]["arw_deg_sqrt_h"] = 0.0
    quiet["imu"]["accel"]["vrw_ug_sqrt_hz"] = 0.0
    return quiet


def _align(bundle, cfg: dict, init, dr_gyro_offset) -> dict:
    """Run ``dr-kf`` (or the setting's ``method``, ``od-velocity-kf``) with one setting and
    keep its 1 Hz series and last-100-s statistics."""
    from ..align.dr_kalman import run_dr_kf, run_od_velocity_kf
    from ..core.rotations import misalignment
    tr = bundle.truth
    cfg = dict(cfg, keep_covariance=True)
    t0 = time.perf_counter()
    if cfg.pop("method", "dr-kf") == "od-velocity-kf":
        sol = run_od_velocity_kf(bundle, cfg, init)
    else:
        sol = run_dr_kf(bundle, cfg, init, dr_gyro_offset_rad_s=dr_gyro_offset)
    wall = time.perf_counter() - t0
    idx = row_at_or_after(tr.t, sol.t, 1e-9)
    phi = misalignment(sol.C_nb, tr.C_nb[idx])    # the IMU's attitude (truth is b's)
    nees = np.einsum("ki,kij,kj->k", phi, np.linalg.inv(sol.info["cov_phi"]), phi)
    keep = np.flatnonzero(np.isclose(sol.t - sol.t[0], np.round(sol.t - sol.t[0]), atol=1e-6))
    last = sol.t > sol.t[-1] - 100.0
    sig = np.stack([sol.sigma[k] for k in ("phi_E", "phi_N", "phi_U")], -1)
    mount = np.stack([sol.states[k] for k in ("mount_x", "mount_y", "mount_z")], -1)
    msig = np.stack([sol.states["sigma_" + k] for k in ("mount_x", "mount_y", "mount_z")], -1)
    return {"t": sol.t[keep] - sol.t[0], "phi": phi[keep], "sigma": sig[keep],
            "nees": nees[keep], "mount": mount[keep], "mount_sigma": msig[keep],
            "max_abs_last100": np.max(np.abs(phi[last]), axis=0),
            "std_last100": np.std(phi[last], axis=0),
            "final": phi[-1], "wall_s": wall,
            "rejected": sol.info["measurements_rejected"]}


def gyrocompass_heading_limit(eps_n, lat):
    """Steady-state heading misalignment [rad] that an east gyro drift leaves on a straight drive.

    In the phi_E row of F, ``phi_E_dot = -(Omega cos L + vE / R) phi_U - eps_E + ...``: with the
    tilt held by the velocity measurements, ``phi_U`` settles where the Earth rate it feigns
    cancels the east drift, ``phi_U = -eps_E / (Omega cos L)`` (gyrocompassing; ``eps_n`` is
    the drift resolved in n [rad/s]). No velocity or attitude-difference measurement of
    paper 000 separates the two on a straight road.
    """
    from ..core import earth
    return float(-eps_n[0] / (earth.OMEGA_IE * np.cos(lat)))


def _tasks(runs, seed):
    return [(exp, i, seed) for exp in EXPERIMENTS for i in range(runs)]


# -- observability -------------------------------------------------------------------------

def observability(seconds=300.0, speed_m_s=15.0, heading_deg=30.0, lat_deg=34.25, use_nhc=True,
                  nhc_mount_terms=True, step_s=0.5):
    """Which states a straight constant-speed drive makes observable (dr-kf's model).

    Builds the stacked observability matrix ``O = [H; H Phi; H Phi^2; ...]`` of the 25-state
    model linearized on a level straight drive (piecewise-constant system over ``seconds``),
    and for each state ``e_i`` the fraction of it in O's row space (the observable subspace),
    ``|P_row e_i|``: 1 fully observable, 0 unobservable. The mounting angle beta, about the
    forward axis, has identically zero columns in F and H (``[v x] C e_y = v x v = 0``), so its
    fraction is exactly 0.
    """
    from ..align.dr_kalman import LAYOUT_DR_KF as lay
    from ..core import earth
    from ..core.rotations import dcm_from_euler, quat_from_dcm
    from ..estimation import error_model as em
    from ..estimation import measurements as ms
    from ..estimation.kalman import discretize
    C = dcm_from_euler(np.array([0.0, 0.0, np.deg2rad(heading_deg)]))
    lat = np.deg2rad(lat_deg)
    pt = em.LinPoint(lat=lat, h=380.0, vel_n=C @ np.array([0.0, speed_m_s, 0.0]), C_nb=C,
                     f_n=np.array([0.0, 0.0, earth.gravity(lat, 380.0)]))
    model = em.ErrorModel(lay, em.ProcessNoise(dk_tau=300.0))
    Phi, _ = discretize(model.F(pt), np.zeros((lay.n, lay.n)), step_s)
    # the rows of dr-kf's measurement plug-ins at the drive's (error-free) state; the
    # velocity rows are in the DR body frame, a rotation that leaves the row space as it is
    xs = np.r_[lat, 0.0, 380.0, pt.vel_n, quat_from_dcm(C)]
    nav = (xs, xs.copy(), np.zeros(ms.AUX_SIZE))
    plugins = [(ms.SinsDrAttitude(1.0), None), (ms.SinsDrVelocity(1.0), None),
               (ms.Height(1.0), [380.0])]
    if use_nhc:
        plugins.append((ms.Nhc(1.0, mount_terms=nhc_mount_terms), None))
    rows = [m.rows(nav, data, lay)[1] for m, data in plugins]
    Hs = np.vstack(rows)
    # scale states to their priors so the SVD threshold means something physical
    scale = np.array([ARCMIN] * 3 + [0.1] * 3 + [15 / 6.4e6] * 2 + [15.0] + [0.03 * np.pi / 180 / 3600] * 3
                     + [1e-3] * 3 + [ARCMIN] * 3 + [15 / 6.4e6] * 2 + [15.0] + [ARCMIN] * 3 + [1e-3])
    blocks, M = [], np.eye(lay.n)
    for _ in range(int(seconds / step_s)):
        blocks.append(Hs @ M)
        M = Phi @ M
    O = np.vstack(blocks) * scale[None, :]
    O /= np.linalg.norm(O, axis=1, keepdims=True) + 1e-300
    U, s, Vt = np.linalg.svd(O, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-9))
    V = Vt[:rank]
    frac = np.linalg.norm(V, axis=0)          # |projection of e_i on the row space|
    col = np.linalg.norm(O, axis=0)
    return {"rank": rank, "n": lay.n,
            "observable_fraction": dict(zip(lay.names, frac.round(6).tolist())),
            "column_norm": dict(zip(lay.names, col.tolist()))}


# -- aggregation, figures, report ----------------------------------------------------------

def _aggregate(results, runs):
    summary = {}
    for exp in EXPERIMENTS:
        rs = [r for r in results if r["experiment"] == exp]
        labels = [k for k in rs[0] if isinstance(rs[0][k], dict)]
        for label in labels:
            mx = np.array([r[label]["max_abs_last100"] for r in rs]) / ARCMIN
            sd = np.array([r[label]["std_last100"] for r in rs]) / ARCMIN
            fin = np.array([r[label]["final"] for r in rs]) / ARCMIN
            mount = np.array([r[label]["mount"][-1] for r in rs]) / ARCMIN
            mount_err = mount - np.array([r["mount_truth"] for r in rs]) / ARCMIN
            msig0 = rs[0][label]["mount_sigma"][0] / ARCMIN
            msig = np.array([r[label]["mount_sigma"][-1] for r in rs]) / ARCMIN
            nees = np.array([r[label]["nees"] for r in rs])
            t = rs[0][label]["t"]
            R = len(rs)
            lo, hi = chi2.ppf([0.025, 0.975], 3 * R) / R
            mean_nees = nees.mean(axis=0)
            after = t >= 100.0
            gc = np.array([r["gyrocompass_phi_U"] for r in rs]) / ARCMIN
            summary[(exp, label)] = {
                "runs": R,
                "gyrocompass_limit_median_abs_arcmin": float(np.median(np.abs(gc))),
                "final_U_vs_gyrocompass_corr": float(np.corrcoef(gc, fin[:, 2])[0, 1]) if R > 2 else None,
                "final_U_minus_gyrocompass_rms_arcmin": float(np.sqrt(np.mean((fin[:, 2] - gc) ** 2))),
                "max_abs_last100_median_arcmin": np.median(mx, axis=0).tolist(),
                "max_abs_last100_p95_arcmin": np.percentile(mx, 95, axis=0).tolist(),
                "std_last100_median_arcmin": np.median(sd, axis=0).tolist(),
                "final_rms_arcmin": np.sqrt(np.mean(fin ** 2, axis=0)).tolist(),
                "mount_final_median_arcmin": np.median(mount, axis=0).tolist(),
                "mount_truth_arcmin": (rs[0]["mount_truth"] / ARCMIN).tolist(),
                "mount_error_median_abs_arcmin": np.median(np.abs(mount_err), axis=0).tolist(),
                "mount_error_p95_abs_arcmin": np.percentile(np.abs(mount_err), 95, axis=0).tolist(),
                "mount_sigma_final_over_prior": (np.median(msig, axis=0) / msig0).tolist(),
                "mount_sigma_final_median_arcmin": np.median(msig, axis=0).tolist(),
                "nees_band": [float(lo), float(hi)],
                "nees_mean_after_100s": float(mean_nees[after].mean()),
                "nees_fraction_in_band_after_100s": float(np.mean((mean_nees[after] >= lo)
                                                                  & (mean_nees[after] <= hi))),
                "wall_s_median": float(np.median([r[label]["wall_s"] for r in rs])),
                "rejected_median": {k: float(np.median([r[label]["rejected"].get(k, 0) for r in rs]))
                                    for k in rs[0][label]["rejected"]},
            }
    return summary


def _figures(results, out: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    files = []
    for exp in EXPERIMENTS:
        rs = [r for r in results if r["experiment"] == exp]
        labels = [k for k in ("with_Z2", "without_Z2", "paper_world") if k in rs[0]]
        fig, axes = plt.subplots(3, len(labels), figsize=(6 * len(labels), 8), sharex=True,
                                 squeeze=False)
        for j, label in enumerate(labels):
            t = rs[0][label]["t"]
            for i, ax_name in enumerate("ENU"):
                ax = axes[i, j]
                for r in rs:
                    ax.plot(t, r[label]["phi"][:, i] / ARCMIN, lw=0.4, alpha=0.5)
                s3 = 3 * np.median([r[label]["sigma"][:, i] for r in rs], axis=0) / ARCMIN
                ax.plot(t, s3, "k--", lw=1.2, label="filter 3 sigma (median)")
                ax.plot(t, -s3, "k--", lw=1.2)
                lim = 4 * np.max(s3[t >= t[-1] - 100])
                ax.set_ylim(-lim, lim)
                ax.set_ylabel(f"phi_{ax_name} error [arcmin]")
                ax.grid(alpha=0.3)
                if i == 0:
                    ax.set_title(f"{exp}, {label} ({len(rs)} runs)")
            axes[2, j].set_xlabel("t [s]")
        axes[0, 0].legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        f = out / f"misalignment_{exp}.png"
        fig.savefig(f, dpi=80)
        plt.close(fig)
        files.append(f.name)
        # mounting angles and NEES
        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
        label = labels[0]
        t = rs[0][label]["t"]
        for i, c in enumerate("xyz"):
            m = np.array([r[label]["mount"][:, i] for r in rs]) / ARCMIN
            line, = axes[0].plot(t, np.median(m, axis=0), label=f"mount_{c} median")
            axes[0].axhline(rs[0]["mount_truth"][i] / ARCMIN, color=line.get_color(), ls=":")
            axes[0].fill_between(t, np.percentile(m, 2.5, axis=0), np.percentile(m, 97.5, axis=0),
                                 alpha=0.2)
        axes[0].set_title(f"{exp}, {label}: mounting estimates [arcmin] (95 % of runs; "
                          "dotted: truth)", fontsize=9)
        axes[0].legend(fontsize=8)
        axes[0].grid(alpha=0.3)
        R = len(rs)
        lo, hi = chi2.ppf([0.025, 0.975], 3 * R) / R
        for lab in labels:
            axes[1].plot(t, np.mean([r[lab]["nees"] for r in rs], axis=0), label=lab)
        axes[1].axhline(lo, color="k", ls="--")
        axes[1].axhline(hi, color="k", ls="--", label="95 % band")
        axes[1].set_yscale("log")
        axes[1].set_title(f"{exp}: misalignment NEES, mean of {R} runs (3 dof)")
        axes[1].legend(fontsize=8)
        axes[1].grid(alpha=0.3)
        fig.tight_layout()
        f = out / f"mount_nees_{exp}.png"
        fig.savefig(f, dpi=80)
        plt.close(fig)
        files.append(f.name)
    return files


def _fmt(v, nd=2):
    return "-" if v is None else f"{v:.{nd}f}"


def _cell(summary, exp, label, key, i):
    s = summary.get((exp, label))
    return "-" if s is None else f"{s[key][i]:.2f}"


def _paper_world_text(summary) -> list:
    """The section that sets the paper-world runs beside ours (measured figures filled in)."""
    L = ["## The paper's up figure comes from a DR without gyro drift", "",
         "Paper 000's printed F has no -C_b^n eps in the DR attitude rows: its DR platform does "
         "not see the gyro drift although SINS and DR integrate the same gyros. In a simulation "
         "built on that model the SINS-minus-DR attitude difference grows as the integral of "
         "the drift, which makes the drift, and through gyrocompassing the heading, observable. "
         "The setting `paper_world` re-creates that world: the run's drawn drift is removed from "
         "the DR's gyro rows only (an oracle that exists only in simulation) and the filter "
         "uses the printed F (`dr_sees_gyro_drift=False`). Median over runs of max |phi_U "
         "error| over the last 100 s [arcmin]:", "",
         "| experiment | paper | with_Z2 (shared gyros, derived F) | od_velocity_kf "
         "(velocity matching + NHC, no DR) | paper_world |", "| --- | --- | --- | --- | --- |"]
    for exp in EXPERIMENTS:
        paper = PAPER.get((exp, "with_Z2"), ((None,) * 3,))[0][2]
        L.append(f"| {exp} | {_fmt(paper, 1)} | "
                 f"{_cell(summary, exp, 'with_Z2', 'max_abs_last100_median_arcmin', 2)} | "
                 f"{_cell(summary, exp, 'od_velocity_kf', 'max_abs_last100_median_arcmin', 2)} | "
                 f"{_cell(summary, exp, 'paper_world', 'max_abs_last100_median_arcmin', 2)} |")
    L += ["", "The velocity-matching baseline sits near the same limit: with shared gyros the DR "
          "attitude adds no heading information, only the drift-free DR of the paper's "
          "simulation does. With real shared gyros the paper-world filter is not available (the DR sees the "
          "drift whatever F says), and no measurement of paper 000 beats the gyrocompassing "
          "limit above: the up accuracy the paper reports is a property of its simulation, not "
          "of the method. Our default keeps the derived F.", ""]
    return L


def _gamma_text(summary) -> list:
    """What limits gamma (traj1): the filter's own sigma and the noise-free-IMU rerun."""
    a = summary.get(("traj1", "with_Z2"))
    q = summary.get(("traj1", NOISE_FREE_LABEL))
    if a is None or q is None:
        return []
    return ["", f"gamma on trajectory 1 is limited by the IMU's white noise: its median "
            f"|error| is {a['mount_error_median_abs_arcmin'][2]:.2f}' (the filter's own 1-sigma, "
            f"{a['mount_sigma_final_median_arcmin'][2]:.2f}', is wider: it carries gamma's share "
            f"of the heading's gyrocompassing uncertainty), and the same runs re-simulated without the gyro ARW "
            f"and accelerometer VRW (constant drift and bias kept; `{NOISE_FREE_LABEL}`) give "
            f"{q['mount_error_median_abs_arcmin'][2]:.2f}'. Trajectory 2's turns and "
            f"accelerations separate gamma better "
            f"({_cell(summary, 'traj2', 'with_Z2', 'mount_error_median_abs_arcmin', 2)}').", ""]



def _report(summary, obs, files, runs, wall, out: Path, cpu=float("nan"), workers=1) -> str:
    L = ["# Paper 000 reproduced: dr-kf in-motion alignment, Monte Carlo", "",
         f"{runs} runs per experiment, 600 s each; wall time {wall:.0f} s with {workers} "
         f"worker(s), {cpu:.0f} CPU-s in the runs (simulation and filters; {cpu / max(workers, 1):.0f} s "
         "per worker on an unloaded machine). Errors are estimate "
         "minus truth of the misalignment (DESIGN phi), arc-minutes. 'max|err| 100 s' is the "
         "maximum absolute error over the last 100 s of a run (the paper's 'accuracy better "
         "than'), 'std 100 s' its standard deviation there; median and 95th percentile over runs.",
         "", "## Misalignment estimation error", "",
         "| experiment | setting | paper E / N / U | median max|err| 100 s E / N / U | "
         "p95 max|err| 100 s E / N / U | paper std | median std 100 s | NEES mean (95 % band) |",
         "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for (exp, label), s in summary.items():
        acc, std = PAPER.get((exp, label), ((None,) * 3, (None,) * 3))
        L.append(f"| {exp} | {label} | {' / '.join(_fmt(a, 1) for a in acc)} | "
                 f"{' / '.join(_fmt(a) for a in s['max_abs_last100_median_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in s['max_abs_last100_p95_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in std)} | "
                 f"{' / '.join(_fmt(a) for a in s['std_last100_median_arcmin'])} | "
                 f"{s['nees_mean_after_100s']:.2f} ({s['nees_band'][0]:.2f}-{s['nees_band'][1]:.2f}), "
                 f"{100 * s['nees_fraction_in_band_after_100s']:.0f} % of epochs in band |")
    L += ["", "## Why the up axis misses the paper's 3.2' on a straight road", "",
          "On a straight drive the heading misalignment settles where the Earth rate it feigns "
          "cancels the east gyro drift, phi_U = -eps_E / (Omega cos L) (gyrocompassing; "
          "0.03 deg/h 1-sigma at 34.25 N gives 8.3' 1-sigma). No measurement of paper 000 "
          "separates the two; the filter's own 1-sigma says so. Per run, the final phi_U error "
          "against this limit computed from the run's drawn drift:", "",
          "| experiment | setting | median |limit| | corr(final phi_U, limit) | "
          "rms(final phi_U - limit) |", "| --- | --- | --- | --- | --- |"]
    for (exp, label), s in summary.items():
        c = s["final_U_vs_gyrocompass_corr"]
        L.append(f"| {exp} | {label} | {s['gyrocompass_limit_median_abs_arcmin']:.2f} | "
                 f"{'-' if c is None else f'{c:.3f}'} | "
                 f"{s['final_U_minus_gyrocompass_rms_arcmin']:.2f} |")
    L += ["", "(trajectory 2 turns by 90 deg at 350 s: the drift's east component changes and "
          "the limit computed with the final heading applies only approximately.)", ""]
    L += _paper_world_text(summary)
    L += ["",
          "", "## Mounting angles (IMU in the vehicle, alpha / beta / gamma about x / y / z)",
          "", "Paper: alpha and gamma estimated close to 3' and 5', beta hardly estimated.", "",
          "| experiment | setting | truth | median estimate | median |error| | p95 |error| | "
          "filter sigma final | sigma final / prior |",
          "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for (exp, label), s in summary.items():
        L.append(f"| {exp} | {label} | {' / '.join(_fmt(a, 0) for a in s['mount_truth_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in s['mount_final_median_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in s['mount_error_median_abs_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in s['mount_error_p95_abs_arcmin'])} | "
                 f"{' / '.join(_fmt(a) for a in s.get('mount_sigma_final_median_arcmin', [None] * 3))} | "
                 f"{' / '.join(_fmt(a) for a in s['mount_sigma_final_over_prior'])} |")
    L += _gamma_text(summary)
    L += ["", "## Observability (straight drive at 15 m/s, 300 s, Z1 + Z2 with mounting columns "
          "+ baro)", "",
          f"Rank of the stacked observability matrix: {obs['rank']} of {obs['n']}. Fraction of "
          "each mounting angle in the observable subspace (1: observable, 0: not):", "",
          "| state | fraction | column norm |", "| --- | --- | --- |"]
    for k in ("mount_x", "mount_y", "mount_z", "phi_U", "eps_x", "dk"):
        L.append(f"| {k} | {obs['observable_fraction'][k]:.3f} | {obs['column_norm'][k]:.3g} |")
    L += ["", "beta (mount_y, about the forward axis) has identically zero columns: "
          "[v x] C_b^n e_y = v x v = 0 for a vehicle moving along its forward axis, in F and in "
          "every H row; its filter sigma stays at the prior (ratio 1.00 above). gamma (mount_z) "
          "and the heading phi_U share one direction that only gyrocompassing (and the turns and "
          "accelerations of a drive) separates: their fractions are equal and below 1.", "",
          "## Figures", ""] + [f"![{f}]({f})" for f in files]
    text = "\n".join(L) + "\n"
    (out / "report.md").write_text(text)
    return text


def reproduce(out_dir, runs=50, workers=2, seed=0, progress=True) -> dict:
    """Run the Monte Carlo and write ``report.md``, ``summary.json`` and PNG figures.

    Parameters
    ----------
    out_dir : folder to write into (created)
    runs : Monte Carlo runs per experiment
    workers : processes (``ProcessPoolExecutor``); 1 runs in this process
    seed : base seed; run ``i`` of experiment ``e`` uses ``default_rng([seed, e, i])``
    progress : show a tqdm progress bar

    Returns
    -------
    dict: the summary per ``"experiment/setting"``, the observability result, the files.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tasks = _tasks(runs, seed)
    t0 = time.perf_counter()
    results = run_tasks(run_one, tasks, workers, desc="paper 000 Monte Carlo",
                        progress=progress, chunksize=2)
    wall = time.perf_counter() - t0
    summary = _aggregate(results, runs)
    obs = observability()
    files = _figures(results, out)
    _report(summary, obs, files, runs, wall, out,
            cpu=float(sum(r["cpu_s"] for r in results)), workers=workers)
    cpu = float(sum(r["cpu_s"] for r in results))
    js = {"runs": runs, "seed": seed, "wall_s": wall, "cpu_s_total": cpu,
          "summary": {f"{e}/{l}": v for (e, l), v in summary.items()},
          "observability": obs, "figures": files}
    (out / "summary.json").write_text(json.dumps(js, indent=2))
    return js
