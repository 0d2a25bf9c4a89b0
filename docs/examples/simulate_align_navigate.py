"""Worked example 1: simulate a drive, align in motion, navigate, evaluate, plot.

A ten-minute drive with a navigation-grade IMU and a Doppler radar. No initial attitude is
given: ``mimada-dual`` (paper 004) finds it while driving, ``dr-kf`` (paper 000) refines it,
``sins-dr`` (paper 002) navigates from where the alignment ended. Every stage is compared with
the simulator's truth; the errors are plotted to ``OUTDIR/errors.png``.

Run: ``python docs/examples/simulate_align_navigate.py OUTDIR`` (about ten seconds once
numba's cache is warm). ``tests/test_docs.py`` runs it.
"""
import argparse
import json
from pathlib import Path

import numpy as np

from inmotion import registry
from inmotion.core.solution import NavState
from inmotion.evaluate import plots
from inmotion.core.metrics import error_series, errors_block
from inmotion.io.result import write_result
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

SCENARIO = {
    "name": "example_drive",
    "start": {"lat_deg": 34.246, "lon_deg": 108.91, "h_m": 380.0, "heading_deg": 30.0,
              "speed_m_s": 0.0},
    "segments": [
        {"kind": "rest", "duration_s": 10},
        {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 1.0},
        {"kind": "cruise", "duration_s": 60},
        {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
        {"kind": "cruise", "duration_s": 60},
        {"kind": "turn", "angle_deg": -60, "rate_deg_s": 4},
        {"kind": "cruise", "duration_s": 100},
        {"kind": "turn", "angle_deg": 120, "rate_deg_s": 6},
        {"kind": "cruise", "duration_s": 100},
        {"kind": "turn", "angle_deg": -90, "rate_deg_s": 5},
        {"kind": "cruise", "duration_s": 150},
    ],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.002},
            "accel": {"bias_ug": 50.0, "vrw_ug_sqrt_hz": 10.0}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.05,
                          "scale_markov_sigma_ppm": 1000.0, "scale_markov_tau_s": 300.0}},
}

#: (stage, method, start s, end s): moving from 10 s on
STAGES = (("coarse", "mimada-dual", 20.0, 100.0),
          ("fine", "dr-kf", 100.0, 400.0),
          ("navigate", "sins-dr", 400.0, None))


def run_stage(bundle, method, start, end, init):
    """Run one method on the window [start, end] from ``init``; return its Solution."""
    run, Config = registry.get(method).load()
    return run(bundle.window(start, end), Config(), init)


def main(out_dir, seed=1):
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    bundle = simulate(load_scenario(SCENARIO), np.random.default_rng(seed))
    # the coarse alignment needs position and velocity only: take them from truth at its start
    state = NavState.from_truth(bundle.truth, STAGES[0][2])
    summary = {}
    for stage, method, start, end in STAGES:
        sol = run_stage(bundle, method, start, end, state)
        truth = bundle.truth.window(start, end)
        err = error_series(sol, truth)
        block = errors_block(err)
        write_result(sol, out / f"{stage}-{method}", truth=truth)
        summary[stage] = {"method": method, "heading_arcmin": block["final"]["phi_U_arcmin"],
                          "level_arcmin": float(np.hypot(block["final"]["phi_E_arcmin"],
                                                         block["final"]["phi_N_arcmin"])),
                          "horizontal_m": block["final"]["horizontal_m"],
                          "distance_m": block["distance_m"]}
        state = sol.final_state()                  # the next stage starts where this one ended
    fig = plots.error_curves(err["t"].to_numpy(), {c: err[c].to_numpy() for c in err.columns},
                             {}, title="sins-dr after in-motion alignment: errors against truth")
    fig.savefig(out / "errors.png", dpi=80)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    for stage, s in summary.items():
        print(f"{stage:9s} {s['method']:12s} heading {s['heading_arcmin']:8.2f} arcmin  "
              f"level {s['level_arcmin']:6.2f} arcmin  horizontal {s['horizontal_m']:8.2f} m "
              f"over {s['distance_m'] / 1000:.2f} km")
    return summary


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir")
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args()
    main(a.out_dir, a.seed)
