"""Issue 15 diagnostic: which displacement row of od-kf moves the heading, and through which
cross-covariance. od-kf (no NHC fallback, no barometer, detection off) runs on
``tests/consistency_mc.py``'s drive without its turn (cruise 20 s, accelerate to 14 m/s at
0.5 m/s^2, cruise 40 s; the odometer at 20,000 pulses/m) fed one measurement interval at a
time, with its fill logging the rows ``z``, ``H``, ``r`` it hands the engine and the
smoother's record giving ``P`` predicted at each update; the engine's sequential scalar
update is redone here and checked against the recorded estimate. Usage (repository root)::

    INMOTION_AOT=0 PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/heading_rows.py SEED [T0 T1] [CONFIG_JSON]

Prints per update in ``[T0, T1]`` (default 25-50 s) the heading error against truth and its
sigma, and per row (0 lateral, 1 along / length, 2 vertical) the innovation ``nu`` and the
heading's correction ``K_psi nu`` [arcmin]; then over the window the sum of each row's
heading correction split by the state block whose covariance with the heading carries it
(``K_psi nu = sum_blocks P_psi,blk h_blk nu / s``).

``nees RUNS VAR_SCALE``: the final-attitude NEES (detection on) of od-kf with both settings
on this drive and on it without the acceleration (cruise 60 s at the start speed), with
``aided_kf.LENGTH_VAR_SCALE`` = ``VAR_SCALE``. Measured (10 runs, band 1.68-4.70): at 1
7.92 (per run 21.9, 3.0, 2.2, 7.1, 3.7, 7.5, 11.2, 8.2, 10.8, 3.6), without the acceleration
2.53; at 4 3.14 (7.9, 0.0, 2.2, 3.6, 3.6, 3.2, 5.0, 1.5, 2.6, 1.5), without it 1.93.

Monte Carlo mode (``mc RUNS TIMES [CONFIG_JSON]``, seeds 100..): at each time in ``TIMES``
(comma-separated) the filter's correlation of the heading with the along-track velocity and
the scale (mean over the runs) against the sample correlation of the true errors, and the
NEES of the heading, the along-track velocity, the scale and their pairs with the filter's
full covariance; per window (2-20, 20-28, 28-48, 48-80 s) and row the normalized
innovations' mean, mean square, the RMS of the per-run means (white noise: ``1 / sqrt(n)``
times the RMS) and autocovariance at lags 1, 2, 5, 10. ``CONFIG_JSON`` adds to the
configuration, with ``mean_mode`` / ``var_scale`` setting ``aided_kf.LENGTH_MEAN_MODE`` /
``LENGTH_VAR_SCALE`` (here 0 and 1 unless given: the form before helper h15nees5, the
figures below) and ``accelerate: false`` dropping the acceleration; the trace mode takes
the same keys.

Measured (issue 15, helper h15nees5; both settings, detection off). ``heading_rows.py 100``:
the heading error -1.41' (sigma 19.98') at 25 s, -20.56' (7.74') at 47 s; the heading's
corrections over 25-50 s: row 0 (lateral) +1.65', row 1 (length) +15.56', row 2 +0.06'; row
1's through the heading's covariance with the velocity +407.2' and the scale -393.2' (the
row reads ``T dv_along - d dk``); 20 successive intervals (30-41 s) of row 1's innovation of
one sign (-2e-5 .. -1.2e-4 m at sigmas 2.7e-4 .. 1.2e-4 m). The correlation builds in the
acceleration (-0.01 at 20.5 s, -0.63 at 28 s) and is right: ``mc 20 30,36,47,80`` the filter
-0.54, -0.50, +0.02, +0.32 with the along-track velocity, the true errors -0.77, -0.80,
-0.18, +0.28 (with the scale -0.50, -0.47, +0.04, +0.32 against -0.73, -0.69, -0.12, +0.33);
heading NEES (1 dof, band 0.48-1.71) 1.14, 1.66, 2.73, 4.21; heading, velocity and scale (3
dof) 7.44, 6.88, 12.21, 19.87 (the filter holds velocity and scale 1.00 correlated, the
errors 0.91-0.99). Row 1's normalized innovation over 28-48 s: mean square 0.142,
autocovariance +0.041, +0.053, +0.022, +0.023 at lags 1, 2, 5, 10, per-run means' RMS 0.140
(white noise of that mean square: 0.060; 48-80 s: 0.467, +0.048, +0.104, -0.010, +0.011,
0.208 against 0.085): an error repeated over about 5 intervals. The rows 0 and 2 carry the
constraint violation's own correlation (lag 1 about 0.5 of the mean square) at a mean square
of 0.3-0.6. With ``'{"mean_mode": 1}'`` (the second-order mean out of the innovation) the
heading NEES 1.27, 1.54, 1.64, 3.16, row 1 as coloured (28-48 s: 0.105, lag 2 +0.047, RMS
0.161); with ``'{"var_scale": 4}'`` (the code's :data:`aided_kf.LENGTH_VAR_SCALE` since) 0.90,
0.89, 0.79, 0.81, 3 dof 2.33, 2.72, 3.18, 4.78, the filter's correlations -0.38, -0.45,
-0.06, +0.54 against -0.77, -0.82, -0.13, +0.58.
"""
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from consistency_mc import ARCMIN, drive_003  # noqa: E402
from test_consistency_nees import PRIOR, START_SIGMA_DEG  # noqa: E402

from inmotion.align import aided_kf as ak  # noqa: E402
from inmotion.core import _kernels as K  # noqa: E402
from inmotion.core.metrics import error_series  # noqa: E402
from inmotion.core.solution import NavState  # noqa: E402
from inmotion.estimation import engine as eng  # noqa: E402
from inmotion.estimation import measurements as ms  # noqa: E402
from inmotion.estimation.aiding_rows import SUB_LAYOUT  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

N = SUB_LAYOUT.n
NLOG = 1 + 6 + 3 * N
WINDOWS = ((2.0, 20.0), (20.0, 28.0), (28.0, 48.0), (48.0, 80.0))
BLOCKS = [(b, SUB_LAYOUT[b]) for b in ("phi", "dv", "dp", "eps", "nabla", "dk", "mount", "lever")]


def straight_drive(ppm=20000.0, accelerate=True):
    d = drive_003().model_dump(mode="json", exclude_none=True)
    d["segments"] = [{"kind": "cruise", "duration_s": 20}]
    if accelerate:
        d["segments"].append({"kind": "accelerate", "to_speed_m_s": 14, "accel_m_s2": 0.5})
    d["segments"].append({"kind": "cruise", "duration_s": 40})
    d["sensors"]["odometer"]["pulses_per_m"] = ppm
    return load_scenario(d)


def logging_fill(fill, log0):
    inner = ms.dispatcher(fill)
    i_t = ms.AUX_T
    n = N

    def f(xs, xd, aux, acc, data, p, offs, z, H, r):
        m = inner(xs, xd, aux, acc, data, p, offs, z, H, r)
        p[log0] = aux[i_t] if m == 3 else -1.0
        for i in range(3):
            p[log0 + 1 + i] = z[i]
            p[log0 + 4 + i] = r[i]
            for c in range(n):
                p[log0 + 7 + n * i + c] = H[i, c]
        return m

    return ms.fill_function(f)


LOGS, RECS = [], []


def install(mean_mode=0, var_scale=1.0):
    ak.LENGTH_MEAN_MODE = int(mean_mode)
    ak.LENGTH_VAR_SCALE = float(var_scale)
    orig_channel = ak._channel

    def channel(*a, **k):
        lf, meas = orig_channel(*a, **k)
        base = np.asarray(meas.params(), float)
        meas.fill = logging_fill(meas.fill, len(base))
        meas.params = lambda: np.r_[base, np.zeros(NLOG)]
        meas._log0 = len(base)
        return lf, meas
    ak._channel = channel
    orig_add = eng.ErrorStateFilter.add_imu

    def add_imu(self, *a, **k):
        o = orig_add(self, *a, **k)
        m = self.measurements[0]
        l0 = m._log0
        LOGS.append(self._C.params[0, l0:l0 + NLOG].copy())
        if "record" in o:
            RECS.append({kk: np.array(v) for kk, v in o["record"].items()})
        return o
    eng.ErrorStateFilter.add_imu = add_imu
    ak.CHUNK_ROWS = 1        # one epoch a chunk (max(1, ..) * step): every update logged


def main(seed, t0, t1, extra):
    verbose = extra.pop("verbose", True)
    install(extra.pop("mean_mode", 0), extra.pop("var_scale", 1.0))
    cfg = dict(PRIOR, fdi=False, nhc_fallback=False, use_baro=False, exact_attitude_columns=True,
               second_order_length=True, smooth=True)
    accelerate = extra.pop("accelerate", True)
    cfg.update(extra)
    rng = np.random.default_rng(seed)
    b = simulate(straight_drive(accelerate=accelerate), rng)
    err = np.radians(START_SIGMA_DEG) * rng.standard_normal(3)
    init = NavState.from_truth(b.truth, euler_error=err)
    ak.run_od_kf(b, cfg, init)
    logs = {round(float(lg[0]), 6): lg for lg in LOGS if lg[0] > 0}
    rec = {k: np.concatenate([r[k] for r in RECS]) for k in RECS[0]}
    # the forward filter's heading error against truth (a second run, not smoothed)
    LOGS.clear()
    RECS.clear()
    sol = ak.run_od_kf(b, dict(cfg, smooth=False), init)
    e = error_series(sol, b.truth)
    i_psi = SUB_LAYOUT["phi"].start + 2
    print(f"seed {seed}: start error {np.round(np.degrees(err) * 60, 2)} arcmin; "
          f"{len(logs)} updates logged, {len(rec['t'])} records")
    tot = {r_: {bn: 0.0 for bn, _ in BLOCKS} for r_ in range(3)}
    mism = []
    acc_c = [0.0, 0.0]
    for i, t, z, r, H, x, P in logged_updates(rec, logs):
        if not (t0 <= t <= t1):
            continue
        line = []
        Pprev = rec["p"][i - 1]
        vn = rec["xs"][i][K.VE:K.VE + 3]
        al = np.r_[vn[:2], 0.0] / np.linalg.norm(vn[:2])
        cr = np.array([al[1], -al[0], 0.0])         # right of the track (E, N, U)
        o_dv = SUB_LAYOUT["dv"].start
        Tdv = np.c_[al, cr, [0, 0, 1.0]]            # dv (n) -> along, across, up
        sd = np.sqrt(np.diag(P))

        def P_at(M):
            return M[i_psi, o_dv:o_dv + 3] @ Tdv[:, 0] * ARCMIN
        Pv = Tdv.T @ P[o_dv:o_dv + 3, o_dv:o_dv + 3] @ Tdv
        c_psi_v = (P[i_psi, o_dv:o_dv + 3] @ Tdv) / (sd[i_psi] * np.sqrt(np.diag(Pv)))
        o_dk = SUB_LAYOUT["dk"].start
        o_mz = SUB_LAYOUT["mount"].start + 1
        h1v = H[1, o_dv:o_dv + 3] @ Tdv
        corr_line = (f"   corr psi: v_al {c_psi_v[0]:+.2f} v_cr {c_psi_v[1]:+.2f} dk "
                     f"{P[i_psi, o_dk] / sd[i_psi] / sd[o_dk]:+.2f} mz "
                     f"{P[i_psi, o_mz] / sd[i_psi] / sd[o_mz]:+.2f}; corr v_al,dk "
                     f"{(Tdv[:, 0] @ P[o_dv:o_dv + 3, o_dk]) / np.sqrt(Pv[0, 0]) / sd[o_dk]:+.2f}"
                     f"; row1 dv cols al {h1v[0]:.3e} cr {h1v[1]:+.3e} up {h1v[2]:+.3e} dk "
                     f"{H[1, o_dk]:.3e}; sd v_al {np.sqrt(Pv[0, 0]):.2e} v_cr {np.sqrt(Pv[1, 1]):.2e}")
        for row in range(3):
            h = H[row]
            x_new, P_new, nu, s, Ph = scalar_update(x, P, h, z[row], r[row])
            k = Ph / s
            for bn, sl in BLOCKS:       # the heading's change, by the block carrying it
                tot[row][bn] += P[i_psi, sl] @ h[sl] * nu / s * ARCMIN
            x, P = x_new, P_new
            line.append(f"r{row} nu {nu:9.2e} s {np.sqrt(s):8.2e} Kpsi.nu {k[i_psi] * nu * ARCMIN:7.3f}")
        c_pred = P_at(rec["p_pred"][i]) - P_at(Pprev)
        c_upd = P_at(P) - P_at(rec["p_pred"][i])
        acc_c[0] += c_pred
        acc_c[1] += c_upd
        if verbose:
            print(f"   cov(psi, v_al) [arcmin m/s]: predict {c_pred:+.3e} update {c_upd:+.3e} now "
                  f"{P_at(P):+.3e}; row1 psi col {H[1, i_psi]:+.3e} H0 psi {H[0, i_psi]:+.3e} "
                  f"H0 dv {np.round(H[0, o_dv:o_dv + 3] @ Tdv, 5)}")
        # the engine's estimate after the update (before feedback): record x plus this step's feedback
        fed = rec["fed"][i] - rec["fed"][i - 1]
        mism.append(abs(x[i_psi] - (rec["x"][i][i_psi] + fed[i_psi])) * ARCMIN)
        j = min(np.searchsorted(sol.t, t), len(sol.t) - 1)
        print(f"t {t:5.1f} psi err {e.phi_U_arcmin.iloc[j]:7.2f}/{sol.sigma['phi_U'][j] * ARCMIN:5.2f} "
              + " | ".join(line))
        if verbose:
            print(corr_line)
    print(f"cov(psi, v_al) change summed: predict {acc_c[0]:+.3e} update {acc_c[1]:+.3e}")
    print(f"max |redone - engine| heading {max(mism):.2e} arcmin over {len(mism)} updates")
    print("heading correction summed over the window, per row and carrying block [arcmin]:")
    for row in range(3):
        print(f"  row {row}: total {sum(tot[row].values()):8.3f}  " +
              " ".join(f"{bn} {v:8.3f}" for bn, v in tot[row].items()))


def logged_updates(rec, logs):
    """Per logged update: ``(i, t, z, r, H, x, P)``, the record's index and time, the three
    rows and their noise variances, and the prior (``Phi x`` of the record before, the
    recorded predicted ``P``, a copy)."""
    for i in range(1, len(rec["t"])):
        t = round(float(rec["t"][i]), 6)
        if t in logs:
            lg = logs[t]
            yield (i, t, lg[1:4], lg[4:7], lg[7:].reshape(3, N),
                   rec["phi"][i] @ rec["x"][i - 1], rec["p_pred"][i].copy())


def scalar_update(x, P, h, z, r):
    """One scalar Kalman update (the engine's sequential form): ``(x, P, nu, s, P h)``."""
    Ph = P @ h
    s = h @ Ph + r
    nu = z - h @ x
    return x + Ph * nu / s, P - np.outer(Ph, Ph) / s, nu, s, Ph


def innovations(rec, logs):
    """``(t, nu, s)`` per update and row (3), the engine's sequential update redone."""
    out = []
    for _, t, z, r, H, x, P in logged_updates(rec, logs):
        nu_s = []
        for row in range(3):
            x, P, nu, s_, _ = scalar_update(x, P, H[row], z[row], r[row])
            nu_s.append((nu, s_))
        out.append((t, nu_s))
    return out


def run_logged(seed, cfg, accelerate=True):
    """One seed: ``(bundle, record, solution)`` of od-kf under ``cfg`` (smoothed run for the
    record, forward run for the solution)."""
    LOGS.clear()
    RECS.clear()
    rng = np.random.default_rng(seed)
    b = simulate(straight_drive(accelerate=accelerate), rng)
    err = np.radians(START_SIGMA_DEG) * rng.standard_normal(3)
    init = NavState.from_truth(b.truth, euler_error=err)
    ak.run_od_kf(b, dict(cfg, smooth=True), init)
    rec = {k: np.concatenate([r[k] for r in RECS]) for k in RECS[0]}
    logs = {round(float(lg[0]), 6): lg for lg in LOGS if lg[0] > 0}
    inn = innovations(rec, logs)
    sol = ak.run_od_kf(b, dict(cfg, smooth=False), init)
    return b, rec, sol, inn


def monte_carlo(runs, times, extra):
    """The filter's correlation of the heading with the along-track velocity and the scale
    against the Monte Carlo's, and the NEES of ``(psi, v_al, dk)`` with the filter's full
    covariance, at ``times``."""
    install(extra.pop("mean_mode", 0), extra.pop("var_scale", 1.0))
    accelerate = extra.pop("accelerate", True)
    cfg = dict(PRIOR, fdi=False, nhc_fallback=False, use_baro=False, exact_attitude_columns=True,
               second_order_length=True)
    cfg.update(extra)
    i_psi = SUB_LAYOUT["phi"].start + 2
    o_dv = SUB_LAYOUT["dv"].start
    o_dk = SUB_LAYOUT["dk"].start
    out = {t: {"e": [], "P": []} for t in times}
    white = {}
    for k in range(runs):
        b, rec, sol, inn = run_logged(100 + k, cfg, accelerate)
        for w0, w1 in WINDOWS:
            y = np.array([[nu / np.sqrt(s_) for nu, s_ in ns] for t, ns in inn if w0 <= t <= w1])
            white.setdefault((w0, w1), []).append(y)
        e = error_series(sol, b.truth)
        dk_true = b.meta["simulated_errors"]["odometer"]["scale_factor_ppm"] * 1e-6
        for t in times:
            i = int(np.argmin(np.abs(rec["t"] - t)))
            j = int(np.argmin(np.abs(sol.t - rec["t"][i])))
            vn = rec["xs"][i][K.VE:K.VE + 3]
            al = np.r_[vn[:2], 0.0] / np.linalg.norm(vn[:2])
            Tm = np.zeros((3, SUB_LAYOUT.n))
            Tm[0, i_psi] = 1.0
            Tm[1, o_dv:o_dv + 3] = al
            Tm[2, o_dk] = 1.0
            Pt = Tm @ rec["p"][i] @ Tm.T
            ev = np.array([e.vE_m_s.iloc[j], e.vN_m_s.iloc[j], e.vU_m_s.iloc[j]])
            st = sol.states["od_dk"]
            dk_est = st[j + 1] if len(st) == len(sol.t) + 1 else st[j]
            out[t]["e"].append([e.phi_U_arcmin.iloc[j] / ARCMIN, ev @ al, dk_true - dk_est])
            out[t]["P"].append(Pt)
    print(f"{runs} runs, config {extra}, accelerate {accelerate}")
    for (w0, w1), ys in white.items():
        for row in range(3):
            yy = [y[:, row] for y in ys]
            allv = np.concatenate(yy)
            ac = {lag: np.mean([np.mean(y[lag:] * y[:-lag]) for y in yy]) for lag in (1, 2, 5, 10)}
            rmean = [np.mean(y) for y in yy]
            print(f"  row {row} normalized innovation {w0:.0f}-{w1:.0f} s: mean {allv.mean():+.3f} "
                  f"(per-run means' RMS {np.sqrt(np.mean(np.square(rmean))):.3f}, white: "
                  f"{1 / np.sqrt(len(yy[0])):.3f}) mean square {np.mean(allv ** 2):.3f}, "
                  "autocovariance " + " ".join(f"lag {k} {v:+.3f}" for k, v in ac.items()))
    for t in times:
        E = np.array(out[t]["e"])
        Ps = np.array(out[t]["P"])
        sd = np.sqrt(np.einsum("kii->ki", Ps))
        fc = Ps / (sd[:, :, None] * sd[:, None, :])
        sc = np.corrcoef(E.T)
        nees = {name: float(np.mean([E[k, ix] @ np.linalg.solve(Ps[k][np.ix_(ix, ix)], E[k, ix])
                                     for k in range(runs)]))
                for name, ix in (("psi", [0]), ("v_al", [1]), ("dk", [2]), ("psi,v_al", [0, 1]),
                                 ("psi,v_al,dk", [0, 1, 2]))}
        print(f"t {t:5.1f}: filter corr (mean) psi-v_al {fc[:, 0, 1].mean():+.2f} psi-dk "
              f"{fc[:, 0, 2].mean():+.2f} v_al-dk {fc[:, 1, 2].mean():+.2f} | Monte Carlo corr "
              f"psi-v_al {sc[0, 1]:+.2f} psi-dk {sc[0, 2]:+.2f} v_al-dk {sc[1, 2]:+.2f} | NEES "
              + " ".join(f"{kk} {v:.2f}" for kk, v in nees.items()), flush=True)


def straight_nees(runs, var_scale):
    """The final-attitude NEES (detection on, the benchmarks' default) of od-kf with both
    settings on the drive without its turn, with and without its acceleration."""
    from consistency_mc import final_nees
    ak.LENGTH_VAR_SCALE = var_scale
    for acc in (True, False):
        m, (lo, hi), v = final_nees("od-kf", dict(PRIOR, exact_attitude_columns=True,
                                                  second_order_length=True),
                                    straight_drive(accelerate=acc), runs, START_SIGMA_DEG)
        print(f"LENGTH_VAR_SCALE {var_scale:g} accelerate {acc}: mean NEES {m:.2f} band "
              f"[{lo:.2f}, {hi:.2f}] per run {np.round(v, 1).tolist()}", flush=True)


if __name__ == "__main__" and sys.argv[1] == "nees":
    straight_nees(int(sys.argv[2]), float(sys.argv[3]))
elif __name__ == "__main__" and sys.argv[1] == "mc":
    monte_carlo(int(sys.argv[2]), [float(x) for x in sys.argv[3].split(",")],
                json.loads(sys.argv[4]) if len(sys.argv) > 4 else {})
elif __name__ == "__main__":
    seed = int(sys.argv[1])
    t0, t1 = (float(sys.argv[2]), float(sys.argv[3])) if len(sys.argv) > 3 else (25.0, 50.0)
    extra = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
    main(seed, t0, t1, extra)
