"""dr-kf's velocity sigma at stops against its error (issue 15): the radar stop-and-go drive
of ``tests/test_process.py`` (two stops, 30 s and 40 s), ``dr-kf`` run with the truth's stop
windows (1 s margins, as ``test_radar_filters_take_zero_velocity_updates_at_stops``) or
through ``inmotion process`` (its own detected stops, ``--process``); per seed the mean of
``(error / sigma)^2`` of the along-track and cross-track velocity over the output rows inside
the stops (``sigma^2`` from the East / North sigma, cross-covariance left out), at every row
(10 Hz) and at the 2 Hz measurement epochs, and over the first 3 s of each stop; then the
mean over seeds with its 95 % interval (Student t over seeds: rows within a stop are
correlated, seeds are not). A consistent filter has 1. Usage (repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/stop_sigma_dr_kf.py [SEEDS] [--process] [--radar-hz HZ]

About 10-20 s a seed.
"""
import argparse
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from test_process import _nav_errors, _stop_and_go, scenario  # noqa: E402

from inmotion.align.dr_kalman import run_dr_kf  # noqa: E402
from inmotion.core.solution import NavState  # noqa: E402
from inmotion.process import run_process  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("seeds", nargs="?", type=int, default=30)
ap.add_argument("--process", action="store_true")
ap.add_argument("--radar-hz", type=float, default=None)
a = ap.parse_args()
IMU = {"gyro_drift_deg_h": 1.0, "accel_bias_ug": 300.0, "gyro_arw_deg_sqrt_h": 0.05,
       "accel_vrw_ug_sqrt_hz": 30.0}
rows = []
for seed in range(a.seeds):
    d = scenario(["radar"], speed0=10.0, drift_deg_h=1.0, arw=0.05, bias_ug=300.0, vrw=30.0)
    d["segments"] = _stop_and_go(seed, segments_only=True)
    if a.radar_hz:
        d["sensors"]["radar"]["rate_hz"] = a.radar_hz
    b = simulate(load_scenario(d), np.random.default_rng(seed))
    still = np.flatnonzero(np.linalg.norm(b.truth.vel_n, axis=1) < 1e-3)
    cut = np.flatnonzero(np.diff(still) > 1)
    wins = [[float(b.truth.t[i]) + 1.0, float(b.truth.t[j]) - 1.0]
            for i, j in zip(np.r_[still[0], still[cut + 1]], np.r_[still[cut], still[-1]])]
    init = NavState.from_truth(b.truth)
    if a.process:
        sol = run_process(b, {"zupt": True}, init, {"source": "truth", "has_attitude": True,
                                                    "heading_sigma_deg": 0.1,
                                                    "tilt_sigma_deg": 0.05})
    else:
        sol = run_dr_kf(b, {**IMU, "stops_s": wins}, init)
    _, dv, _, sv, stopped = _nav_errors(sol, b.truth)
    inside = stopped if a.process else np.any([(sol.t >= s) & (sol.t <= e) for s, e in wins],
                                              axis=0)
    k = np.searchsorted(b.truth.t, sol.t)
    sn, cs = np.sin(b.truth.euler[k, 2]), np.cos(b.truth.euler[k, 2])
    along = (sn * dv[:, 0] + cs * dv[:, 1]) ** 2 / (sn ** 2 * sv[:, 0] ** 2 + cs ** 2 * sv[:, 1] ** 2)
    cross = (cs * dv[:, 0] - sn * dv[:, 1]) ** 2 / (cs ** 2 * sv[:, 0] ** 2 + sn ** 2 * sv[:, 1] ** 2)
    on2 = np.abs(sol.t * 2 - np.round(sol.t * 2)) < 1e-6
    st = np.flatnonzero(inside)
    starts = sol.t[np.r_[st[0], st[np.flatnonzero(np.diff(st) > 1) + 1]]]
    early = inside & np.any([(sol.t >= s) & (sol.t < s + 3.0) for s in starts], axis=0)
    r = {"seed": seed, "along": float(along[inside].mean()),
         "along_2hz": float(along[inside & on2].mean()), "along_first_3s": float(along[early].mean()),
         "cross": float(cross[inside].mean()),
         "sigma_along_mm_s": float(1e3 * np.sqrt(sn ** 2 * sv[:, 0] ** 2 + cs ** 2 * sv[:, 1] ** 2)[inside].mean())}
    rows.append(r)
    print(json.dumps(r), flush=True)
from scipy import stats  # noqa: E402
for key in ("along", "along_2hz", "along_first_3s", "cross"):
    v = np.array([r[key] for r in rows])
    h = stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / np.sqrt(len(v))
    print(f"{key:15s} mean over {len(v)} seeds {v.mean():.3f} (95 % {v.mean() - h:.3f}-"
          f"{v.mean() + h:.3f}); seeds 0-9 {v[:10].min():.2f}-{v[:10].max():.2f}, "
          f"10-{len(v) - 1} {v[10:].min():.2f}-{v[10:].max():.2f}")
