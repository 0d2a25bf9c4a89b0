"""Probe: fkf's residual test statistic split by row and by time under the defaults against
paper 003's rows (issue 15, helper h15split). NEEDS the diagnostic engine patch
``benchmarks/fdi_length_probe.patch`` (``git apply`` it, run with ``INMOTION_AOT=0``, then
``git checkout src/``): ``nis_log`` then carries per test the sequential terms ``nu_i^2 /
s_i`` of the lateral, length and vertical rows (their sum is the statistic), the length
row's update and test variances, and the sequential innovations. Not merged: it widens
``nis_log`` (the AOT extension would need a rebuild for a diagnostic).

Usage: ``git apply benchmarks/fdi_length_probe.patch; INMOTION_AOT=0 OPENBLAS_NUM_THREADS=1
PYTHONPATH=src python benchmarks/fdi_length_probe.py [--runs 4] [--drawn-start] [--config
JSON]; git checkout src/``. Prints per channel the statistic's mean, its rows' terms and,
per time window, the length row's term and the statistic for the configuration and for
paper 003's rows on the same drives (``benchmarks/fdi_calibration.py``'s drives and starts).

Measured 2026-12-02 (4 drives, seeds 1000-1003; the defaults with the split): the LDV's
statistic 0.49, 0.54, 1.13, 1.45, 1.47 over 0-30, 30-60, 60-120, 120-300, 300-600 s against
1.47, 1.50, 1.46, 1.46, 1.47 with paper 003's rows (the length row's term 0.04, 0.08, 0.67,
0.94, 0.97 against 1.02, 1.04, 0.99, 0.95, 0.97); with ``--drawn-start`` 0.05, 0.10, 0.67,
0.94, 0.97 against 1.09, 1.16, 1.45, 1.13, 0.98, and with the test's variance the sensor's
alone (the fill's ``r[4] = r[1]``) still 0.08, 0.22, 0.75, 0.95, 0.97: the early deflation
is of ``H P H^T``, not the test's variance. With ``--config '{"init_velocity_sigma_m_s":
0.005}'`` (the prior matched to the true-velocity start) 1.21, 1.43, 1.45, 1.46, 1.47 (the
length row 0.76, 0.98, 0.98, 0.95, 0.97).
"""
import argparse
import json
import sys

import numpy as np

sys.path.insert(0, "benchmarks")
import fdi_calibration as fc  # noqa: E402

from inmotion.align.aided_kf import run_fkf  # noqa: E402
from inmotion.sim import simulate  # noqa: E402

PAPER = {"exact_attitude_columns": False, "second_order_length": False}
WINDOWS = ((0, 30), (30, 60), (60, 120), (120, 300), (300, 601))


def raw_tests(extra, runs):
    sc = fc._scenario()
    rows = {0: [], 1: []}
    chans = None
    for k in range(runs):
        b = simulate(sc, np.random.default_rng(1000 + k))
        sol = run_fkf(b, {**extra, "fdi": False, "keep_test_statistics": True,
                          "noise_preset": "matched"}, fc._init(b, k))
        ts = sol.info["test_statistics"]
        if "raw" not in ts or ts["raw"].shape[1] < 11:
            raise SystemExit("apply benchmarks/fdi_length_probe.patch first (docstring)")
        chans = ts["channels"]
        for j in (0, 1):
            rows[j].append(ts["raw"][ts["raw"][:, 1] == j])
    return chans, {j: np.concatenate(v) for j, v in rows.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--drawn-start", action="store_true")
    ap.add_argument("--config", default="{}")
    a = ap.parse_args()
    fc.DRAWN_START = a.drawn_start
    extra = json.loads(a.config)
    chans, R = raw_tests(extra, a.runs)
    _, Q = raw_tests({**extra, **PAPER}, a.runs)
    for j, ch in enumerate(chans):
        r, q = R[j], Q[j]
        print(f"{ch}: statistic {r[:, 2].mean():.3f} (paper rows {q[:, 2].mean():.3f}); row "
              f"terms lateral, length, vertical {np.round(r[:, 3:6].mean(0), 3)} "
              f"({np.round(q[:, 3:6].mean(0), 3)})")
        for lo, hi in WINDOWS:
            k, kq = (r[:, 0] >= lo) & (r[:, 0] < hi), (q[:, 0] >= lo) & (q[:, 0] < hi)
            print(f"  {lo}-{hi} s: length row {r[k, 4].mean():.3f} ({q[kq, 4].mean():.3f}), "
                  f"statistic {r[k, 2].mean():.3f} ({q[kq, 2].mean():.3f}), update / test "
                  f"variance of the length row {np.mean(r[k, 6] / r[k, 7]):.2f}")


if __name__ == "__main__":
    main()
