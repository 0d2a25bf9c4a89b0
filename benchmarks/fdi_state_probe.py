"""Probe: fkf's residual test statistic against its model, split by the sub-filter's state
(issue 15). NEEDS the diagnostic engine patch ``benchmarks/fdi_state_probe.patch`` (``git
apply`` it, run with ``INMOTION_AOT=0``, then ``git checkout src/``): ``nis_log`` then
carries, per test, the ``H P H^T`` (3 x 3) and ``r`` (3) of the covariance the test used, the
test's kind (0 healthy, 1 isolated: the conditioned copy, 2 probation: the sub-filter's own
test, 3 probation: the conditioned copy after the own test failed) and the prior innovation
``z - H x`` (3); ``info["test_statistics"]["raw"]``. Not merged into the engine: it widens
``nis_log`` and the AOT extension would need a rebuild for a diagnostic.

Per fault-free drive of paper 003's reproduction (its seeding, ``SeedSequence(0)``, window 0,
coarse fault-tolerant start, ``PAPER_FKF``), ``fkf`` at 0.05 with ``return_test:
conditioned``, the detection on and off. Per test: the statistic ``lambda = nu^T S^-1 nu``,
and the exact model's exceedance probability given that test's ``S = H P H^T + R`` and the
weights: ``nu = H e + n``, ``e ~ N(0, P)`` (``P`` taken as honest), ``n``'s lateral and
vertical rows ``N(0, w r)``, its forward row the Gaussian share ``g r`` plus the quantization
(:func:`inmotion.align.aided_kf._quantization_density`); so ``lambda`` is a quadratic form in
``(e, n)`` whose law is the weighted sum of the eigenvalues of ``S^-1/2 (H P H^T + W R)
S^-1/2`` when ``n`` is Gaussian (mean ``tr(S^-1 (H P H^T + W R))``); with the quantization
computed by Monte Carlo (``--mc`` draws, common random numbers, the draws with ``H P H^T =
0`` as control variate, so the figure is ``rate + P(exact) - P(model)``), at the threshold
of the model that neglects ``H P H^T`` (``residual_test_thresholds``). ``--paired``: the
odometer's tests while isolated or on probation (detection on) against the same tests with
the detection off.

Usage: ``git apply benchmarks/fdi_state_probe.patch; INMOTION_AOT=0 OPENBLAS_NUM_THREADS=1
python benchmarks/fdi_state_probe.py [--runs 20] [--only 2,5,8,12] [--mc 4000] [--json F]
[--paired]; git checkout src/``.

Measured 2026-12-02 (``--runs 20 --mc 4000``, 77 s; ``--paired --only 2,5,8,12``, 20 s):

1. The test's covariance includes ``H P H^T``: :func:`inmotion.estimation.kalman.
   sequential_joseph` sums ``nu_i^2 / s_i`` with ``s_i = h P h^T + r_i`` (the batch
   ``nu^T S^-1 nu``). Its share of the forward row's ``S`` (median per drive, averaged):
   odometer healthy 4.6 %, young (first 60 s) 12.7 %, isolated (conditioned copy) 4.1 %,
   probation 9.3 %; LDV 6.1 %, 13.9 %, 7.0 %, 8.8 %. The exact law given ``S`` (``P``
   honest) puts the rate at 0.05 per state at: healthy 0.050, young 0.058-0.063, isolated
   0.050-0.051, probation 0.051-0.053; pooled, odometer 0.0507 off / 0.0506 on, LDV 0.0514
   / 0.0516. So the model's neglect of ``H P H^T`` moves the rate by < 1e-3 pooled, +1e-2
   at most in a young sub-filter's tests (whose ``P`` is pessimistic: observed young rates
   0.040-0.050, below both models); it is NOT the odometer's excess.
2. Observed, the same 20 drives (pooled; these reproduce the reproduction's figures):
   odometer off 0.0526 (healthy 0.053, young 0.047); on 0.0737: healthy 0.060 (17,029
   tests), young 0.040, isolated 0.131 (3,527 tests, mean statistic 1.94 against the exact
   model's 1.52), probation 0.155 (1,326 tests; by construction 0 for the own test and 0.90
   for the copy's, which is logged only when the own test failed). LDV off 0.0482, on 0.0507
   (isolated 0.051). Per drive the exact model is 0.048-0.054 while the observed odometer
   rate with the detection off runs from 0.005 to 0.154 (the quantization phase: the
   ``aided_kf`` notes).
3. The four drives (2, 5, 8, 12: odometer on / off 0.077 / 0.038, 0.116 / 0.043, 0.247 /
   0.117, 0.242 / 0.113; drives 3 and 17, off 0.154 and 0.112, are not doubled: 0.163,
   0.114). Paired by test (the same drive and times): while isolated or on probation
   (249, 338, 730, 720 tests) the exceedances are 0.173, 0.240, 0.304, 0.256 with the
   detection on against 0.044, 0.062, 0.141, 0.087 at the same tests with it off, at the
   same mean statistic (2.43 / 2.53, 2.72 / 2.58, 2.98 / 3.03, 2.66 / 2.67): the isolations
   fall in stretches whose statistic is high anyway (selection; drive-level mean 1.5-2.7),
   but what the isolation adds is spread, not mean (quantiles 10/50/90/95 %, drive 5: on
   0.63, 1.86, 6.13, 6.72; off 0.35, 2.72, 4.29, 4.77, threshold 4.65). With the detection
   off the forward error there is bounded (the two-valued quantization of a cruise: the 95 %
   quantile sits just under the threshold); isolated, the forward innovation carries an
   offset against the detection-off filter's of -0.19, -0.41, -0.22, +0.40 ``sqrt(r)``
   (spread 0.25-0.58; the lateral row's difference 0.03-0.08, 0.35 on drive 12), which
   lifts one of the two levels above the threshold and lowers the other. The forward
   innovation's spread over those tests with the detection off is 1.45-1.66 ``sqrt(r)``
   (the model: 1.0 plus ``H P H^T``'s few per cent), so these drives' odometer error is
   larger than the model's over those stretches whatever the detection does.
   Which state carries it (``--states --only 2,5,8,12``, 60 s, no patch: the odometer
   sub-filter's own states recorded every 0.5 s, detection on minus off over the off run's
   sigma): the scale factor ``dk``, mean -0.48, -0.70, -0.84, +0.61 sigma while isolated,
   the innovation offset's sign on all four drives, and of its size (``sigma`` 7.7e-5; 0.6
   sigma over the ~7 m of a 0.5 s interval at cruise is 0.3 mm, ``sqrt(r)`` of the forward
   displacement row about 1.45 mm: 0.2-0.3 ``sqrt(r)`` of the measured 0.19-0.41); mount
   ``x`` / ``z`` up to 0.46 / 0.90 sigma (``z`` acts on the lateral row: drive 12's 0.35).
   ``dk``'s offset is as large while healthy (-0.46, -0.67, -0.75, +0.37 sigma: an isolation
   leaves the scale factor behind and the odometer alone corrects it slowly) but shows
   little there (healthy forward offsets +0.01, -0.06, -0.09, +0.27 ``sqrt(r)``): the
   sub-filter's own velocity has absorbed it with the odometer's updates, while the
   conditioned copy takes its velocity from the LDV-based primaries, so its residual
   exposes ``dk``'s error whole. Not tested: a fix (e.g. the copy's ``dk`` conditioned too,
   or the isolated test's ``P`` given ``dk``'s lag).
   The lag structure (detection off, ``P(exceedance in the next 20 tests | exceedance)``):
   0.066, 0.081, 0.197, 0.154 against the drives' 0.038, 0.043, 0.117, 0.113 off rates;
   with the detection on 0.207, 0.269, 0.315, 0.275.

So a threshold from the exact law given ``S`` would not remove the excess (it would raise
the threshold by less than the Monte Carlo error of the rate).

4. Where ``dk``'s lag comes from (``--truth --only 5,8,2,12``, no patch; then with
   ``benchmarks/fdi_censoring.patch``; measured 2026-12-02, h15fdi5): against the drawn
   scale factor, the odometer sub-filter's ``(dk - dk_true) / sigma`` after the first 60 s,
   rms (mean), detection off / on: drive 2 0.40 (-0.13) / 0.72 (-0.60), drive 5 0.83 (-0.73)
   / 1.59 (-1.41), drive 8 0.54 (-0.32) / 1.21 (-0.85), drive 12 1.07 (+0.82) / 1.36
   (+1.10); drives 0, 1 (not in excess) 0.57 / 0.63, 0.65 / 0.61. So with the detection on
   the scale factor is *wrong*, by more than its sigma, not only behind the detection-off
   filter's: the sub-filter's ``P`` does not cover it, and no conditioning of the return
   test's copy on the healthy common states can (the healthy sub-filters have no estimate
   of the odometer's ``dk``). The mechanism is censoring: a rejected sample is the one whose
   quantization error is at the far level of the cruise's two (``aided_kf``'s notes), so the
   samples applied have a mean error of the other sign, which the scale factor takes up, and
   that lifts the far level further (feedback). The patch rejects an exceeding sample and
   changes nothing else (no isolation, no return test): exceedances off / gated 0.038 /
   0.159 (drive 2), 0.043 / 0.148 (5), 0.117 / 0.416 (8), 0.113 / 0.415 (12), ``dk`` rms
   0.61, 1.13, 5.25, 4.58 sigma. Isolate-and-return drops every sample of an isolation, of
   either level, which dilutes the selection, hence its smaller excess; any test that drops
   the odometer's exceeding samples at 0.05 has it.
   Tried (``benchmarks/fdi_condition_common.patch``: the copy's common states conditioned,
   its sensor states left, the covariance of that gain): odometer 6.95e-2 (over drives
   3.83e-2-0.101) against 7.37e-2, LDV 4.87e-2, faults at 0.05 19, 15, 20, 18 of 20, 1e-3
   unchanged (``fdi_calibration.py --runs 0 --detection-on-runs 20 --return-test
   conditioned``, 307 s): within the Monte Carlo error, not adopted.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from inmotion.align.aided_kf import _quantization_density, residual_test_thresholds
from inmotion.align.multiplex import MuxConfig, coarse_fault_tolerant, first_covered, start_state
from inmotion.reproductions import paper003 as P
from inmotion.sim import simulate

CH = ("odometer", "ldv")
KINDS = ("healthy", "isolated (conditioned copy)", "probation, own", "probation, copy")


def drive(r, runs, seed=0):
    ss = np.random.SeedSequence(seed).spawn(runs)[r]
    rng = np.random.default_rng(ss.spawn(4)[0])
    d = simulate(P._scenario("paper003_drive", extend=True), rng)
    t0 = first_covered(d, 0.0)
    win = d.window(None, t0 + P.WINDOW_S)
    _, C0 = coarse_fault_tolerant(win, MuxConfig(), None, t0, t0 + P.WINDOW_S)
    return win, start_state(d, C0, t0, None), t0


def exact_tail(raw, wmod, thr, mc, rng):
    """Per test, P(lambda > thr) for nu = H e + n given its H P H^T and r (Monte Carlo)."""
    w = np.asarray(wmod["weights"], float)
    g = wmod["gauss_fraction"]
    a = wmod.get("quantization_alpha", 0.0)
    if a > 1e-9:
        t, pr = _quantization_density(float(round(a, 9)), int(wmod.get("quantization_samples", 5)))
        qd = rng.choice(t, size=mc, p=pr) * rng.choice([-1.0, 1.0], size=mc)
    else:                                      # triangular, unit variance
        b = np.sqrt(6.0)
        qd = b * (rng.uniform(size=mc) - rng.uniform(size=mc)) / np.sqrt(2.0)
    z = rng.standard_normal((mc, 3))
    zs = rng.standard_normal((mc, 3))
    nstd = np.stack([np.sqrt(w[0]) * zs[:, 0],
                     np.sqrt(g) * zs[:, 1] + np.sqrt(max(1 - g, 0)) * qd,
                     np.sqrt(w[2]) * zs[:, 2]], 1)
    Hs = raw[:, 3:12].reshape(-1, 3, 3)
    r = raw[:, 12:15]
    S = Hs + r[:, :, None] * np.eye(3)[None]
    Si = np.linalg.inv(S)
    ev, V = np.linalg.eigh(0.5 * (Hs + np.swapaxes(Hs, 1, 2)))
    Lh = V * np.sqrt(np.clip(ev, 0.0, None))[:, None, :]
    out = np.empty(len(raw))
    for k in range(0, len(raw), 200):
        sl = slice(k, k + 200)
        nu = np.einsum("tij,mj->tmi", Lh[sl], z) + nstd[None] * np.sqrt(r[sl])[:, None, :]
        q = np.einsum("tmi,tij,tmj->tm", nu, Si[sl], nu)
        out[sl] = np.mean(q > thr, axis=1)
    # control variate: the same draws with H P H^T = 0 (the model the threshold is of)
    p0 = float(np.mean(np.sum(nstd * nstd, 1) > thr))
    wr = r * np.array([w[0], 1.0, w[2]])[None]
    mean_exact = np.einsum("tii->t", Si @ (Hs + wr[:, :, None] * np.eye(3)[None]))
    return out - p0, mean_exact


def paired(r, runs, rate):
    """The odometer's tests while isolated or on probation with the detection on, against the
    same tests (same drive, same times) with it off: exceedances, mean and quantiles."""
    win, start, t0 = drive(r, runs)
    out = {}
    for det in (False, True):
        ex = {"keep_test_statistics": True, "false_alarm_rate": rate, "return_test": "conditioned"}
        if not det:
            ex["fdi"] = False
        sol = P._fine(win, start, "fkf", ex)
        raw = sol.info["test_statistics"]["raw"]
        thr = residual_test_thresholds(sol.info["residual_test_weights"], rate)["odometer"]
        x = raw[raw[:, 1] == 0]
        out[det] = (x[:, 0], x[:, 2], x[:, 15].astype(int), x[:, 17] / np.sqrt(x[:, 13]))
    (ta, loff, _, foff), (tb, lon, kon, fon) = out[False], out[True]
    assert np.allclose(ta, tb)
    iso = kon > 0
    q = [0.1, 0.5, 0.9, 0.95]
    print(f"drive {r}, odometer, threshold {thr:.2f}: while isolated/probation ({iso.sum()} tests)"
          f" on {np.mean(lon[iso] > thr):.3f} (mean {lon[iso].mean():.2f}, quantiles "
          f"{np.round(np.quantile(lon[iso], q), 2)}), off at the same tests "
          f"{np.mean(loff[iso] > thr):.3f} (mean {loff[iso].mean():.2f}, "
          f"{np.round(np.quantile(loff[iso], q), 2)}); healthy on {np.mean(lon[~iso] > thr):.3f}"
          f" off {np.mean(loff[~iso] > thr):.3f}; forward innovation / sqrt(r) while isolated: "
          f"off sd {foff[iso].std():.2f}, on - off mean {np.mean(fon[iso] - foff[iso]):+.2f} sd "
          f"{np.std(fon[iso] - foff[iso]):.2f}", flush=True)


def _run_recorded(win, start, det, rate):
    """``fkf`` with each local's ``X`` and ``P`` recorded every 50 IMU rows (0.5 s;
    :func:`fdi_return_probe.recording_locals`): ``(records (t, xs, X, P), solution)``."""
    from fdi_return_probe import recording_locals
    ex = {"keep_test_statistics": True, "false_alarm_rate": rate, "return_test": "conditioned"}
    if not det:
        ex["fdi"] = False
    with recording_locals() as rec:
        sol = P._fine(win, start, "fkf", ex)
    return rec, sol


def states(r, runs, rate):
    """The odometer sub-filter's own states (scale factor, mount) with the detection on against
    the same drive's with it off, in units of the latter's sigma, while isolated and healthy."""
    from fdi_return_probe import isolated_mask

    from inmotion.align.aided_kf import NS
    win, start, _ = drive(r, runs)
    a, _ = _run_recorded(win, start, False, rate)
    b, sol = _run_recorded(win, start, True, rate)
    iso = isolated_mask(sol, np.array([x[0] for x in b]), "odometer")
    Xa, Xb = np.array([x[2][0] for x in a]), np.array([x[2][0] for x in b])
    sa = np.sqrt(np.array([np.diag(x[3][0]) for x in a]))
    for i, nm in enumerate(("dk", "mount_x", "mount_z")):
        k = NS + i
        d = (Xb[:, k] - Xa[:, k]) / sa[:, k]
        print(f"drive {r} {nm}: (on - off) / sigma_off while isolated ({iso.sum()} records) mean "
              f"{d[iso].mean():+.2f} rms {np.sqrt(np.mean(d[iso] ** 2)):.2f}; healthy mean "
              f"{d[~iso].mean():+.2f} rms {np.sqrt(np.mean(d[~iso] ** 2)):.2f}; sigma_off median "
              f"{np.median(sa[:, k]):.2e}", flush=True)


def truth(r, runs, rate):
    """The odometer sub-filter's scale factor ``dk`` against the drive's drawn one
    (``meta["simulated_errors"]``), in units of its own sigma, after the first 60 s, with the
    detection off and on, and the odometer's exceedances (every test's statistic, the
    rejected ones too). With ``benchmarks/fdi_censoring.patch`` applied "on" is a gate
    without isolation: an exceeding sample is rejected, nothing else changes."""
    from inmotion.align.aided_kf import NS
    win, start, _ = drive(r, runs)
    k = win.meta["simulated_errors"]["odometer"]["scale_factor_ppm"] * 1e-6
    for det in (False, True):
        a, sol = _run_recorded(win, start, det, rate)
        lam = sol.info["test_statistics"]["lambda"][:, 0]
        lam = lam[~np.isnan(lam)]
        thr = residual_test_thresholds(sol.info["residual_test_weights"], rate)["odometer"]
        t = np.array([x[0] for x in a])
        z = (np.array([x[2][0][NS] for x in a]) - k) / np.sqrt([x[3][0][NS, NS] for x in a])
        late = t - t[0] > 60.0
        print(f"drive {r} detection {'on ' if det else 'off'}: odometer exceedances "
              f"{np.mean(lam > thr):.3f} ({len(lam)} tests); (dk - dk_true) / sigma after 60 s "
              f"mean {z[late].mean():+.2f} rms {np.sqrt(np.mean(z[late] ** 2)):.2f}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--only", default="", help="comma list of drive indices")
    ap.add_argument("--mc", type=int, default=4000)
    ap.add_argument("--rate", type=float, default=0.05)
    ap.add_argument("--young-s", type=float, default=60.0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--paired", action="store_true", help="per drive, the odometer's tests "
                    "while isolated or on probation (detection on) against the same tests with "
                    "the detection off (:func:`paired`)")
    ap.add_argument("--states", action="store_true", help="the odometer sub-filter's own "
                    "states, detection on against off (:func:`states`; no patch needed)")
    ap.add_argument("--truth", action="store_true", help="the odometer sub-filter's dk against "
                    "the drawn truth, detection off and on (:func:`truth`; no patch needed)")
    args = ap.parse_args(argv)
    only = [int(x) for x in args.only.split(",") if x] or list(range(args.runs))
    if args.truth:
        for r in only:
            truth(r, args.runs, args.rate)
        return
    if args.states:
        for r in only:
            states(r, args.runs, args.rate)
        return
    if args.paired:
        for r in only:
            paired(r, args.runs, args.rate)
        return
    rng = np.random.default_rng(12345)
    res = {}
    for r in only:
        win, start, t0 = drive(r, args.runs)
        for det in (True, False):
            extra = {"keep_test_statistics": True, "false_alarm_rate": args.rate,
                     "return_test": "conditioned"}
            if not det:
                extra["fdi"] = False
            sol = P._fine(win, start, "fkf", extra)
            raw = sol.info["test_statistics"]["raw"]
            W = sol.info["residual_test_weights"]
            thr = residual_test_thresholds(W, args.rate)
            ev = sorted((e["t_s"], e["event"]) for e in sol.info["events"]
                        if e.get("channel") == "odometer")
            for c, ch in enumerate(CH):
                m = raw[:, 1].astype(int) == c
                x = raw[m]
                p, mex = exact_tail(x, W[ch], thr[ch], args.mc, rng)
                p = p + args.rate          # control variate: model's tail + the H P H^T excess
                lam = x[:, 2]
                kind = x[:, 15].astype(int)
                young = x[:, 0] - t0 < args.young_s
                cls = np.where(kind > 0, kind + 1, np.where(young, 0, 1))
                rec = {"tests": int(len(x)), "exceed": int(np.sum(lam > thr[ch])),
                       "expected_exact": float(p.sum()), "mean_lambda": float(lam.mean()),
                       "mean_exact": float(mex.mean()),
                       "model_mean": float(sum(W[ch]["weights"])), "by_state": {}}
                # share of H P H^T in S, forward row
                fr = x[:, 3 + 4] / (x[:, 3 + 4] + x[:, 13])
                for k, lab in enumerate(("young healthy", "healthy") + KINDS[1:]):
                    mk = cls == k
                    if mk.any():
                        rec["by_state"][lab] = {
                            "n": int(mk.sum()), "exceed": int(np.sum(lam[mk] > thr[ch])),
                            "expected_exact": float(p[mk].sum()),
                            "mean_lambda": float(lam[mk].mean()),
                            "mean_exact": float(mex[mk].mean()),
                            "hph_share_fwd_median": float(np.median(fr[mk]))}
                res[f"{r} {'on' if det else 'off'} {ch}"] = rec
                print(f"drive {r} {'on ' if det else 'off'} {ch:8s}: {rec['exceed']}/{rec['tests']}"
                      f" = {rec['exceed'] / rec['tests']:.3f}, exact model {rec['expected_exact'] / rec['tests']:.3f}"
                      f"; mean lambda {rec['mean_lambda']:.2f} exact {rec['mean_exact']:.2f}"
                      f" model {rec['model_mean']:.2f}; isolations {sum(1 for e in ev if e[1] == 'detected') if ch == 'odometer' and det else ''}",
                      flush=True)
                for lab, b in rec["by_state"].items():
                    print(f"     {lab:30s} n {b['n']:5d} exceed {b['exceed'] / b['n']:.3f}"
                          f" exact {b['expected_exact'] / b['n']:.3f} mean {b['mean_lambda']:.2f}"
                          f" exact-mean {b['mean_exact']:.2f} HPH share(fwd) {b['hph_share_fwd_median']:.3f}",
                          flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
