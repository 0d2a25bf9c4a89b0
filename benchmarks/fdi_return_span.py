"""Probe: ``fkf``'s ``return_span`` (issue 15) on paper 003's reproduction's fault-free drives.

Per drive (the reproduction's seeding, ``SeedSequence(0).spawn(runs)[r]``, window 0, coarse
fault-tolerant start, ``PAPER_FKF``, ``return_test: conditioned``) at ``--rate``: the
detection off, on, and on with ``return_span``: the odometer's and LDV's exceedances per test
(every test's statistic, the rejected ones too), the odometer sub-filter's ``(dk - dk_true) /
sigma`` after the first 60 s against the drawn scale factor (mean, rms), and with the span
the spans applied / rejected by their test and the longest applied.

Usage: ``OPENBLAS_NUM_THREADS=1 python benchmarks/fdi_return_span.py [--runs 20]
[--only 2,5,8,12] [--rate 0.05] [--config JSON] [--json FILE]``.

Measured 2026-12-02 (h15ret, ``--only 2,5,8,12,0,1``, ~110 s a drive): odometer exceedances
per test off / on / span, drive 2 0.038 / 0.077 / 0.038, 5 0.043 / 0.116 / 0.046, 8 0.117 /
0.247 / 0.109, 12 0.113 / 0.242 / 0.107, 0 0.008 / 0.009 / 0.008, 1 0.020 / 0.020 / 0.021;
``(dk - dk_true) / sigma`` rms 0.40 / 0.72 / 0.38, 0.83 / 1.59 / 1.07, 0.54 / 1.21 / 0.69,
1.07 / 1.36 / 0.93, 0.57 / 0.63 / 0.55, 0.65 / 0.61 / 0.91 (mean 0.68 / 1.02 / 0.76); spans
applied 41, 43, 119, 103, 9, 24, rejected 1, 2, 2, 3, 0, 0, the longest 2.0-3.5 s.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fdi_return_probe import recording_locals  # noqa: E402
from fdi_state_probe import drive  # noqa: E402

import inmotion.estimation.engine as E  # noqa: E402
from inmotion.align.aided_kf import NS, residual_test_thresholds  # noqa: E402
from inmotion.reproductions import paper003 as P  # noqa: E402


class _Keep:
    """Keeps the last ErrorStateFilter built (for its counts)."""

    def __enter__(self):
        self.f = None
        self.orig = E.ErrorStateFilter.__init__
        keep = self

        def init(obj, *a, **kw):
            keep.orig(obj, *a, **kw)
            keep.f = obj

        E.ErrorStateFilter.__init__ = init
        return self

    def __exit__(self, *exc):
        E.ErrorStateFilter.__init__ = self.orig


def one(win, start, rate, det, span, extra):
    ex = {"keep_test_statistics": True, "false_alarm_rate": rate, "return_test": "conditioned",
          "return_span": span, **extra}
    if not det:
        ex["fdi"] = False
    with _Keep() as kp, recording_locals() as rec:
        sol = P._fine(win, start, "fkf", ex)
    k = win.meta["simulated_errors"]["odometer"]["scale_factor_ppm"] * 1e-6
    lam = sol.info["test_statistics"]["lambda"]
    thr = residual_test_thresholds(sol.info["residual_test_weights"], rate)
    rates = []
    for c, ch in enumerate(("odometer", "ldv")):
        x = lam[:, c]
        x = x[~np.isnan(x)]
        rates.append(float(np.mean(x > thr[ch])))
    t = np.array([x[0] for x in rec])
    z = (np.array([x[2][0][NS] for x in rec]) - k) / np.sqrt([x[3][0][NS, NS] for x in rec])
    late = t - t[0] > 60.0
    cnt = kp.f.counts()["odometer"]
    return {"od": rates[0], "ldv": rates[1], "dk_mean": float(z[late].mean()),
            "dk_rms": float(np.sqrt(np.mean(z[late] ** 2))),
            "spans": (cnt.get("spans_applied"), cnt.get("spans_rejected"),
                      cnt.get("longest_span_s"))}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--only", default="")
    ap.add_argument("--rate", type=float, default=0.05)
    ap.add_argument("--config", default="{}")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    extra = json.loads(args.config)
    only = [int(x) for x in args.only.split(",") if x] or list(range(args.runs))
    res = {}
    for r in only:
        win, start, _ = drive(r, args.runs)
        row = {}
        for name, det, span in (("off", False, False), ("on", True, False),
                                ("span", True, True)):
            row[name] = o = one(win, start, args.rate, det, span, extra)
            print(f"drive {r} {name:4s}: OD {o['od']:.3f} LDV {o['ldv']:.3f}; (dk - dk_true) / "
                  f"sigma after 60 s mean {o['dk_mean']:+.2f} rms {o['dk_rms']:.2f}"
                  + (f"; spans applied {o['spans'][0]}, rejected {o['spans'][1]}, longest "
                     f"{o['spans'][2]:.1f} s" if span else ""), flush=True)
        res[r] = row
    for name in ("off", "on", "span"):
        od = np.array([res[r][name]["od"] for r in only])
        ld = np.array([res[r][name]["ldv"] for r in only])
        rms = np.array([res[r][name]["dk_rms"] for r in only])
        print(f"{name:4s}: OD mean {od.mean():.4f} LDV mean {ld.mean():.4f}, dk rms (mean over "
              f"drives) {rms.mean():.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
