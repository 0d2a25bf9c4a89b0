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
"""
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from consistency_mc import ARCMIN, drive_003  # noqa: E402
from test_consistency_nees import PRIOR, START_SIGMA_DEG  # noqa: E402

from inmotion.align import aided_kf as ak  # noqa: E402
from inmotion.core.metrics import error_series  # noqa: E402
from inmotion.core.solution import NavState  # noqa: E402
from inmotion.estimation import engine as eng  # noqa: E402
from inmotion.estimation import measurements as ms  # noqa: E402
from inmotion.estimation.aiding_rows import SUB_LAYOUT  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

N = SUB_LAYOUT.n
NLOG = 1 + 6 + 3 * N
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


def install():
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
    install()
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
    for i in range(1, len(rec["t"])):
        t = round(float(rec["t"][i]), 6)
        if t not in logs or not (t0 <= t <= t1):
            continue
        lg = logs[t]
        z, r = lg[1:4], lg[4:7]
        H = lg[7:].reshape(3, N)
        x = rec["phi"][i] @ rec["x"][i - 1]
        P = rec["p_pred"][i].copy()
        line = []
        for row in range(3):
            h = H[row]
            Ph = P @ h
            s = h @ Ph + r[row]
            nu = z[row] - h @ x
            k = Ph / s
            for bn, sl in BLOCKS:
                tot[row][bn] += P[i_psi, sl] @ h[sl] * nu / s * ARCMIN
            x = x + k * nu
            P = P - np.outer(Ph, Ph) / s
            line.append(f"r{row} nu {nu:9.2e} s {np.sqrt(s):8.2e} Kpsi.nu {k[i_psi] * nu * ARCMIN:7.3f}")
        # the engine's estimate after the update (before feedback): record x plus this step's feedback
        fed = rec["fed"][i] - rec["fed"][i - 1]
        mism.append(abs(x[i_psi] - (rec["x"][i][i_psi] + fed[i_psi])) * ARCMIN)
        j = min(np.searchsorted(sol.t, t), len(sol.t) - 1)
        print(f"t {t:5.1f} psi err {e.phi_U_arcmin.iloc[j]:7.2f}/{sol.sigma['phi_U'][j] * ARCMIN:5.2f} "
              + " | ".join(line))
    print(f"max |redone - engine| heading {max(mism):.2e} arcmin over {len(mism)} updates")
    print("heading correction summed over the window, per row and carrying block [arcmin]:")
    for row in range(3):
        print(f"  row {row}: total {sum(tot[row].values()):8.3f}  " +
              " ".join(f"{bn} {v:8.3f}" for bn, v in tot[row].items()))


if __name__ == "__main__":
    seed = int(sys.argv[1])
    t0, t1 = (float(sys.argv[2]), float(sys.argv[3])) if len(sys.argv) > 3 else (25.0, 50.0)
    extra = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
    main(seed, t0, t1, extra)
