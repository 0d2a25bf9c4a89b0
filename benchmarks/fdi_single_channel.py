"""False-alarm rate of ``od-kf``'s and ``ldv-kf``'s residual test (issue 15): each method's one
channel on paper 003's simulated 10-minute drive (``benchmarks/fdi_calibration.py``'s drives,
starts drawn from the prior: ``--drawn-start``), the detection off and the statistics kept,
counted against the thresholds of the set rates 0.05 and 1e-3 (the statistic's model,
``aided_kf.residual_test_thresholds``), with and without the test covariance
(``test_covariance``, the engine's "Test covariance"); intervals: t over the runs' rates.

Usage: ``OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python benchmarks/fdi_single_channel.py
[RUNS]`` (default 20; about 2 min).

Measured 2026-12-03 (20 runs, seeds 1000-1019; mean statistic against the model's sum of
weights 2.00):

=========================  ==============  ================================  =====================
                           mean statistic  at 0.05                           at 1e-3
=========================  ==============  ================================  =====================
od-kf, without             2.078           4.48e-2 (3.99-4.96e-2)            7.09e-4 (3.9-10.3e-4)
od-kf, test covariance     2.115           4.78e-2 (4.25-5.31e-2)            7.92e-4 (4.7-11.1e-4)
ldv-kf, without            1.914           4.48e-2 (4.29-4.67e-2), excludes  6.67e-4 (3.2-10.2e-4)
ldv-kf, test covariance    2.000           5.10e-2 (4.78-5.42e-2)            8.76e-4 (3.2-14.3e-4)
=========================  ==============  ================================  =====================

So the test covariance is the default of od-kf and ldv-kf too (their detection is on by
default), as of fkf (``fdi_calibration.py``).
"""
import sys

import numpy as np

sys.path.insert(0, "benchmarks")
import fdi_calibration as fc  # noqa: E402

from inmotion.align.aided_kf import residual_test_thresholds, run_ldv_kf, run_od_kf  # noqa: E402
from inmotion.sim import simulate  # noqa: E402

RATES = (0.05, 1e-3)


def rates(run, channel, bundles, test_covariance):
    """Per set rate, the runs' exceedance rates; the pooled mean statistic; the model's mean."""
    ex = {a: [] for a in RATES}
    lam_all = []
    w = None
    for k, b in enumerate(bundles):
        sol = run(b, {"fdi": False, "keep_test_statistics": True, "noise_preset": "matched",
                      "test_covariance": test_covariance}, fc._init(b, k))
        lam = sol.info["test_statistics"]["lambda"][:, 0]
        lam = lam[np.isfinite(lam)]
        lam_all.append(lam)
        w = sol.info["residual_test_weights"]
        for a in RATES:
            ex[a].append(float(np.mean(lam > residual_test_thresholds(w, a)[channel])))
    return ex, float(np.concatenate(lam_all).mean()), float(sum(w[channel]["weights"]))


def main():
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    fc.DRAWN_START = True
    sc = fc._scenario()
    bundles = [simulate(sc, np.random.default_rng(1000 + k)) for k in range(runs)]
    for name, run, ch in (("od-kf", run_od_kf, "odometer"), ("ldv-kf", run_ldv_kf, "ldv")):
        for tc in (False, True):
            ex, mean, model = rates(run, ch, bundles, tc)
            out = []
            for a, r in ex.items():
                m, (lo, hi) = fc.run_level_ci(r)
                out.append(f"at {a}: {m:.2e} ({lo:.2e}-{hi:.2e})")
            print(f"{name} test_covariance={tc}: mean statistic {mean:.3f} (model {model:.3f}); "
                  + "; ".join(out), flush=True)


if __name__ == "__main__":
    main()
