"""The numba engine behind ``od-kf``, ``ldv-kf``, ``nhc-kf`` and ``fkf`` (paper 003 sec. 2.3, 3.1,
3.2.2): one SINS as the common reference, up to two velocity-sensor sub-filters and a
vehicle-constraint filter, chi-square residual FDI and reconfiguration, federated fusion.

Per IMU row (:func:`_run_chunk`): the increments, less the fed-back gyro drift and
accelerometer bias, drive the SINS (:func:`inmotion.core._kernels.sins_step`); the SINS
displacement ``sum v dt``, each sensor's displacement ``sum C_b^n (C_v^b0 [0, ds, 0] -
[dtheta_nb x] l)`` and its distance part, and the body rotation ``dtheta_nb`` are accumulated
for the displacement-increment measurement (:mod:`inmotion.estimation.aiding_rows`).

Per filter epoch (``step`` rows): ``F`` from the shared error model
(:func:`inmotion.estimation.error_model._fill_F`, the 15 SINS states; the sensor states are
random constants, eq. 25-26) at the SINS state with the epoch's mean specific force; every
local filter is predicted (:func:`inmotion.estimation.kalman._predict_kernel`) with its own
``Q_c`` (the SINS part scaled by ``1 / beta_i``, eq. 33-35).

Per measurement epoch (``meas_every`` filter epochs), for each channel ``c`` present:

1. residual ``r = z - H x`` and ``lambda = r^T (H P H^T + R)^-1 r`` (eq. 40-41, computed by
   the sequential Joseph update of :func:`inmotion.estimation.kalman.sequential_joseph`,
   whose NIS equals the batch statistic for a diagonal ``R``);
2. FDI (eq. 42, Table 1): a healthy channel with ``lambda > T`` is declared faulty and isolated
   (its update is not applied; event "detected"); an isolated channel keeps being tested and
   returns after ``return_tests`` consecutive tests with ``lambda <= T`` (event "returned");
3. healthy channels are updated; the barometric height updates every local filter with
   ``R / beta_i`` (shared information) and the NHC filter with ``R``.

The vehicle-constraint filter (15 states, eq. 27-31) runs alongside on the same SINS with the
NHC rows (and baro) and is the output when every channel is isolated (Table 1, "OD and LDV
faults").

Global estimate: the fusion of eq. 36 over the healthy channels' SINS states
(:func:`inmotion.estimation.federated.fuse_kernel`), one channel alone, or the NHC filter.
Every ``fuse_every`` filter epochs (the main-filter period; always a measurement epoch) the
global estimate is fed back into the common SINS (attitude, velocity, position; drift and bias
into the IMU compensation) and subtracted from every local filter's SINS states. This keeps
each local filter an estimate of the error of the *corrected* SINS, and is not a reset of its
information: the local covariances are left alone (non-reset mode, beta_m = 0). Sensor states
(``dk``, ``mount``, ``lever``) are estimated only, never fed back.

Reconfiguration in non-reset mode: the local filters are never reset to the global
estimate, so their SINS estimates differ (within their covariances, which are 1 / beta
times inflated); when a channel is isolated the output moves from the fused estimate to the
remaining channel's, a step of that difference (tens of arc-minutes of heading early in a
drive, while heading is still poorly observed; see ``reproduce_003`` Figure 13). This is the
price of the paper's fault-tolerant structure: a faulty channel never contaminates another.

Memory: rows are processed in chunks; outputs (at ``out_every`` epochs), the test-statistic
series (per measurement epoch) and the event list are the only arrays that grow.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from ..core import _kernels as K
from ..estimation import error_model as em
from ..estimation.aiding_rows import _displacement_rows, _nhc_rows, _velocity_rows
from ..estimation.federated import fuse_kernel
from ..estimation.kalman import _predict_kernel
from ..estimation.kalman import sequential_joseph
from ..estimation.nav_ops import compensated_row, correct_nav as _correct_nav, dcm_of_q

__all__ = ["EVENT_DETECTED", "EVENT_RETURNED", "EVENT_MODE", "MODE_NAMES", "NS", "NSUB",
           "Engine"]

NS = 15        #: SINS error states common to all local filters (phi, dv, dp, eps, nabla)
NSUB = 21      #: states of a velocity-sensor sub-filter
EVENT_DETECTED, EVENT_RETURNED, EVENT_MODE = 1, 2, 3
#: output modes: which filter gives the global estimate
MODE_NAMES = {0: "fused", 1: "channel 0 alone", 2: "channel 1 alone", 3: "nhc", 4: "sins"}
#: offsets handed to error_model._fill_F (phi, dv, dp, eps, nabla, phi_D, dp_D, mount, dk)
_F_OFFS = (0, 3, 6, 9, 12, -1, -1, -1, -1)
#: offsets of aiding_rows' kernels (phi, dv, dk, mount, lever) in the sub-filter layout
_ROW_OFFS = (0, 3, 15, 16, 18)
CHUNK_ROWS = 16384


@numba.njit(cache=True)
def _mode(healthy, present, have_nhc, nhc_only):
    """Global-estimate source (Table 1)."""
    if nhc_only:
        return 3
    n_ok = 0
    last = -1
    for c in range(healthy.shape[0]):
        if present[c] and healthy[c]:
            n_ok += 1
            last = c
    if n_ok >= 2:
        return 0
    if n_ok == 1:
        return 1 + last
    return 3 if have_nhc else 4


@numba.njit(cache=True)
def _global(mode, X, P, healthy, present, xn, Pn, x_g, P_g):
    """The global SINS error estimate and covariance of ``mode`` into ``x_g``, ``P_g``."""
    if mode == 0:
        use = healthy & present
        fuse_kernel(X, P, use, NS, x_g, P_g)
    elif mode == 1 or mode == 2:
        c = mode - 1
        x_g[:] = X[c, :NS]
        P_g[:, :] = P[c, :NS, :NS]
    elif mode == 3:
        x_g[:] = xn
        P_g[:, :] = Pn
    else:
        x_g[:] = 0.0


@numba.njit(cache=True)
def _log(ev, n_ev, t, chan, kind, value):
    i = n_ev[0]
    if i < ev.shape[0]:
        ev[i, 0] = t
        ev[i, 1] = chan
        ev[i, 2] = kind
        ev[i, 3] = value
    n_ev[0] = i + 1


@numba.njit(cache=True)
def _run_chunk(ends, t, dtheta, dvel, dt, ds, v, h_baro,
               xs, ms, bias_g, bias_a, fed_back,
               X, P, Qc, present, healthy, normal_run, lever, C_vb0, sig, form,
               beta, xn, Pn, Qn, have_nhc, nhc_only, sig_nhc, sig_baro,
               thr, return_tests, acc, acc_D, acc_W, bad, state_i,
               meas_every, fuse_every, out_every,
               out_t, out_x, out_sig, out_states, out_sensor, out_sensor_sig, out_mode,
               lam_t, lam, ev, n_ev, counts):
    """One chunk of IMU rows (module docstring). ``state_i`` = [epoch, n_out, n_lam, mode]
    (int64, updated in place); ``acc`` = [T, P_E, P_N, P_U, th_x, th_y, th_z] accumulators of
    the current measurement interval; ``acc_D``, ``acc_W`` (C, 3) per channel;
    ``bad`` (C,): a row of the interval was not covered by the sensor (no measurement);
    ``counts`` (C, 3): tests, exceedances while healthy, updates."""
    C = X.shape[0]
    nan = np.nan
    a = 0
    xw = np.empty(NSUB)
    Pw = np.empty((NSUB, NSUB))
    xwn = np.empty(NS)
    Pwn = np.empty((NS, NS))
    x_g = np.zeros(NS)
    P_g = np.zeros((NS, NS))
    F = np.zeros((NSUB, NSUB))
    H = np.zeros((3, NSUB))
    z = np.zeros(3)
    r = np.zeros(3)
    Hn = np.zeros((3, NS))
    zn = np.zeros(3)
    rn = np.zeros(3)
    Hb = np.zeros((1, NSUB))
    Hbn = np.zeros((1, NS))
    Hb[0, 8] = 1.0
    Hbn[0, 8] = 1.0
    zb = np.zeros(1)
    rb = np.zeros(1)
    xb = np.empty(NSUB)
    Pb = np.empty((NSUB, NSUB))
    for e in range(ends.shape[0]):
        b = ends[e]
        sum_dt = 0.0
        f_sum = np.zeros(3)
        th_ep = np.zeros(3)
        for k in range(a, b):
            dth, dvl = compensated_row(dtheta, dvel, k, dt[k], bias_g, bias_a)
            v_old = (xs[K.VE], xs[K.VN], xs[K.VU])
            K.sins_step(xs, ms, dth, dvl, dt[k], nan, 0.0, 0.0)
            ms[K.M_COUNT] += 1.0
            Cnb = dcm_of_q(xs[K.Q0:K.Q3 + 1])
            w_in = K.omega_ie_n(xs[K.LAT])
            w_en = K.omega_en_n(xs[K.LAT], xs[K.H], (xs[K.VE], xs[K.VN], xs[K.VU]))
            th_nb = np.empty(3)
            for i in range(3):
                s = 0.0
                for j in range(3):
                    s += Cnb[j, i] * (w_in[j] + w_en[j])
                th_nb[i] = dth[i] - s * dt[k]
                th_ep[i] += th_nb[i]
                acc[4 + i] += th_nb[i]
                acc[1 + i] += 0.5 * (v_old[i] + xs[K.VE + i]) * dt[k]
                f_sum[i] += dvl[i]
            acc[0] += dt[k]
            for c in range(C):
                if not present[c]:
                    continue
                if math.isnan(ds[c, k]):     # not covered by the sensor (start, gap)
                    bad[c] = True
                    continue
                w_b = C_vb0[:, 1] * ds[c, k]
                lv = lever[c]
                cr = np.array([th_nb[1] * lv[2] - th_nb[2] * lv[1],
                               th_nb[2] * lv[0] - th_nb[0] * lv[2],
                               th_nb[0] * lv[1] - th_nb[1] * lv[0]])
                wn = Cnb @ w_b
                dn = Cnb @ (w_b - cr)
                for i in range(3):
                    acc_W[c, i] += wn[i]
                    acc_D[c, i] += dn[i]
            sum_dt += dt[k]
        # ---- predict
        Cnb = dcm_of_q(xs[K.Q0:K.Q3 + 1])
        fb = f_sum / sum_dt
        f_n = Cnb @ fb
        F[:, :] = 0.0
        em._fill_F(F, _F_OFFS, xs[K.LAT], xs[K.H], xs[K.VE:K.VU + 1].copy(), Cnb, f_n,
                   0.0, True, True)
        for c in range(C):
            if present[c]:
                xc = X[c]
                Pc = P[c]
                _predict_kernel(xc, Pc, F, Qc[c], sum_dt)
        if have_nhc:
            _predict_kernel(xn, Pn, np.ascontiguousarray(F[:NS, :NS]), Qn, sum_dt)
        state_i[0] += 1
        epoch = state_i[0]
        t_now = t[b - 1]
        # ---- measure
        if epoch % meas_every == 0:
            T = acc[0]
            C_bn = np.ascontiguousarray(Cnb.T)
            vel = xs[K.VE:K.VU + 1].copy()
            w_nb = th_ep / sum_dt
            hb = h_baro[b - 1]
            for c in range(C):
                if not present[c] or bad[c] or math.isnan(v[c, b - 1]):
                    continue
                H[:, :] = 0.0
                if form[c] == 1:          # displacement increment, b frame
                    dP = acc[1:4]
                    for i in range(3):
                        zz = 0.0
                        for j in range(3):
                            zz += C_bn[i, j] * (dP[j] - acc_D[c, j])
                        z[i] = zz
                        r[i] = (sig[c, i] * T) ** 2
                    _displacement_rows(H, _ROW_OFFS, C_bn, T, C_bn @ acc_D[c],
                                       C_bn @ acc_W[c], acc[4:7].copy())
                else:                     # velocity, n frame
                    w_b = C_vb0[:, 1] * v[c, b - 1]
                    lv = lever[c]
                    cr = np.array([w_nb[1] * lv[2] - w_nb[2] * lv[1],
                                   w_nb[2] * lv[0] - w_nb[0] * lv[2],
                                   w_nb[0] * lv[1] - w_nb[1] * lv[0]])
                    u_b = w_b - cr
                    vs = Cnb @ u_b
                    for i in range(3):
                        z[i] = vel[i] - vs[i]
                        r[i] = sig[c, i] ** 2
                    _velocity_rows(H, _ROW_OFFS, Cnb, w_b, u_b, w_nb)
                if healthy[c]:
                    ok, lam_c = sequential_joseph(X[c], P[c], z, H, r, 0, 3, thr, xw, Pw)
                else:             # isolated: tested on a copy, never updated
                    ok, lam_c = sequential_joseph(X[c].copy(), P[c].copy(), z, H, r, 0, 3,
                                                  thr, xw, Pw)
                if state_i[2] < lam.shape[0]:
                    lam[state_i[2], c] = lam_c
                counts[c, 0] += 1
                if healthy[c]:
                    if not ok:
                        counts[c, 1] += 1
                        healthy[c] = False
                        normal_run[c] = 0
                        _log(ev, n_ev, t_now, c, EVENT_DETECTED, lam_c)
                    else:
                        counts[c, 2] += 1
                else:
                    if ok:
                        # a faulty channel is not updated until it has returned
                        normal_run[c] += 1
                        if normal_run[c] >= return_tests:
                            healthy[c] = True
                            _log(ev, n_ev, t_now, c, EVENT_RETURNED, lam_c)
                    else:
                        normal_run[c] = 0
                if not math.isnan(hb):
                    zb[0] = xs[K.H] - hb
                    rb[0] = sig_baro ** 2 / beta[c]
                    sequential_joseph(X[c], P[c], zb, Hb, rb, 0, 1, 0.0, xb, Pb)
            if have_nhc:
                C_vn = np.ascontiguousarray(C_vb0.T @ C_bn)
                Hn[:, :] = 0.0
                _nhc_rows(Hn, 0, 3, C_vn, vel)
                vv = C_vn @ vel
                zn[0] = vv[0]
                zn[1] = vv[2]
                rn[0] = sig_nhc ** 2
                rn[1] = sig_nhc ** 2
                sequential_joseph(xn, Pn, zn, Hn, rn, 0, 2, 0.0, xwn, Pwn)
                if not math.isnan(hb):
                    zb[0] = xs[K.H] - hb
                    rb[0] = sig_baro ** 2
                    sequential_joseph(xn, Pn, zb, Hbn, rb, 0, 1, 0.0, xwn, Pwn)
            if state_i[2] < lam_t.shape[0]:
                lam_t[state_i[2]] = t_now
            state_i[2] += 1
            new_mode = _mode(healthy, present, have_nhc, nhc_only)
            if new_mode != state_i[3]:
                _log(ev, n_ev, t_now, -1, EVENT_MODE, new_mode)
                state_i[3] = new_mode
            for i in range(7):
                acc[i] = 0.0
            acc_D[:, :] = 0.0
            acc_W[:, :] = 0.0
            bad[:] = False
            # ---- main filter: fuse and feed back
            if epoch % fuse_every == 0 and state_i[3] != 4:
                _global(state_i[3], X, P, healthy, present, xn, Pn, x_g, P_g)
                _correct_nav(xs, ms, x_g[0:3], x_g[3:6], x_g[6:9], True)
                for i in range(3):
                    bias_g[i] += x_g[9 + i]
                    bias_a[i] += x_g[12 + i]
                for i in range(NS):
                    fed_back[i] += x_g[i]
                    for c in range(C):
                        X[c, i] -= x_g[i]
                    if have_nhc:
                        xn[i] -= x_g[i]
        # ---- output
        if epoch % out_every == 0 and state_i[1] < out_t.shape[0]:
            io = state_i[1]
            _global(state_i[3], X, P, healthy, present, xn, Pn, x_g, P_g)
            out_t[io] = t_now
            xo = xs.copy()
            mo = ms.copy()
            _correct_nav(xo, mo, x_g[0:3], x_g[3:6], x_g[6:9], True)
            out_x[io] = xo
            for i in range(NS):
                out_sig[io, i] = math.sqrt(max(P_g[i, i], 0.0))
                out_states[io, i] = fed_back[i] + x_g[i]
            for c in range(C):
                for i in range(NSUB - NS):
                    out_sensor[io, c, i] = X[c, NS + i]
                    out_sensor_sig[io, c, i] = math.sqrt(max(P[c, NS + i, NS + i], 0.0))
            out_mode[io] = state_i[3]
            state_i[1] += 1
        a = b


class Engine:
    """Streaming driver of :func:`_run_chunk` (see the module docstring).

    Parameters
    ----------
    x0 : (NX,) initial SINS kernel state;  mem0 : (NMEM,) its step memory
    channels : list of dicts, one per velocity sensor: ``speed`` (SpeedData), ``name``,
        ``lever_b`` (3,) m, ``sigma_m_s`` (3,) 1-sigma per row (m/s; for the displacement form
        the row noise is ``sigma T``), ``form`` ``"velocity"`` or ``"displacement"``,
        ``beta`` (sharing factor), ``P0`` (21, 21) and ``Qc`` (21, 21) unscaled.
    C_vb0 : (3, 3) nominal vehicle mounting;  nhc : dict or None: ``P0``, ``Qc`` (15, 15),
        ``sigma_m_s``; ``nhc_only`` makes the NHC filter the output (``nhc-kf``).
    baro_sigma_m : float;  threshold : chi-square ``T_lambda`` (0: no FDI)
    return_tests : consecutive normal tests before a channel returns
    step, meas_every, fuse_every, out_every : IMU rows per filter epoch; filter epochs per
        measurement, per main-filter fusion / feedback (a multiple of ``meas_every``), per
        output row.
    """

    def __init__(self, x0, mem0, channels, C_vb0, nhc, baro_sigma_m, threshold,
                 return_tests, step, meas_every, fuse_every, out_every, nhc_only=False,
                 max_events=100000):
        C = max(len(channels), 1)
        self.xs = np.array(x0, dtype=float)
        self.ms = np.array(mem0, dtype=float)
        self.bias_g = np.zeros(3)
        self.bias_a = np.zeros(3)
        self.fed_back = np.zeros(NS)
        self.channels = channels
        self.X = np.zeros((C, NSUB))
        self.P = np.zeros((C, NSUB, NSUB))
        self.Qc = np.zeros((C, NSUB, NSUB))
        self.present = np.zeros(C, dtype=np.bool_)
        self.healthy = np.ones(C, dtype=np.bool_)
        self.normal_run = np.zeros(C, dtype=np.int64)
        self.lever = np.zeros((C, 3))
        self.sig = np.ones((C, 3))
        self.form = np.zeros(C, dtype=np.int64)
        self.beta = np.ones(C)
        for c, ch in enumerate(channels):
            beta = float(ch["beta"])
            self.present[c] = True
            self.beta[c] = beta
            P0 = np.array(ch["P0"], dtype=float)
            Q = np.array(ch["Qc"], dtype=float)
            P0[:NS, :NS] /= beta                      # eq. 33-35: SINS part shared
            Q[:NS, :NS] /= beta
            self.P[c] = P0
            self.Qc[c] = Q
            self.lever[c] = ch["lever_b"]
            self.sig[c] = ch["sigma_m_s"]
            self.form[c] = 1 if ch["form"] == "displacement" else 0
        self.C_vb0 = np.ascontiguousarray(C_vb0, dtype=float)
        self.have_nhc = nhc is not None
        self.nhc_only = bool(nhc_only)
        self.xn = np.zeros(NS)
        self.Pn = np.array(nhc["P0"], dtype=float) if nhc else np.eye(NS)
        self.Pn0 = self.Pn.copy()
        self.Qn = np.array(nhc["Qc"], dtype=float) if nhc else np.zeros((NS, NS))
        self.sig_nhc = float(nhc["sigma_m_s"]) if nhc else 1.0
        self.sig_baro = float(baro_sigma_m)
        self.thr = float(threshold)
        self.return_tests = int(return_tests)
        self.step, self.meas_every = int(step), int(meas_every)
        self.fuse_every, self.out_every = int(fuse_every), int(out_every)
        self.acc = np.zeros(7)
        self.acc_D = np.zeros((C, 3))
        self.acc_W = np.zeros((C, 3))
        self.bad = np.zeros(C, dtype=np.bool_)
        self.state_i = np.zeros(4, dtype=np.int64)
        self.state_i[3] = _mode(self.healthy, self.present, self.have_nhc, self.nhc_only)
        self.ev = np.zeros((max_events, 4))
        self.n_ev = np.zeros(1, dtype=np.int64)
        self.counts = np.zeros((C, 3), dtype=np.int64)

    def run(self, t, dtheta, dvel, t_prev, h_baro=None, progress=None, speed_on_epochs=None):
        """Process IMU rows ``t`` (after ``t_prev``); returns a dict of output arrays."""
        n = len(t)
        n_ep = -(-n // self.step)
        C = self.X.shape[0]
        n_out = n_ep // self.out_every + 1
        n_lam = n_ep // self.meas_every + 1
        out = {"t": np.empty(n_out), "x": np.empty((n_out, K.NX)), "sigma": np.empty((n_out, NS)),
               "states": np.empty((n_out, NS)),
               "sensor": np.zeros((n_out, C, NSUB - NS)),
               "sensor_sigma": np.zeros((n_out, C, NSUB - NS)),
               "mode": np.zeros(n_out, dtype=np.int64)}
        lam_t = np.full(n_lam, np.nan)
        lam = np.full((n_lam, C), np.nan)
        chunk = max(1, CHUNK_ROWS // self.step) * self.step
        for a in range(0, n, chunk):
            b = min(a + chunk, n)
            tc = t[a:b]
            edges = np.concatenate([[t_prev if a == 0 else t[a - 1]], tc])
            ds = np.zeros((C, b - a))
            v = np.zeros((C, b - a))
            for c, ch in enumerate(self.channels):
                ds[c], v[c], unc, gap = speed_on_epochs(ch["speed"], edges, what=ch["name"])
                ds[c][unc | gap] = np.nan         # no measurement over these rows
                v[c][unc | gap] = np.nan
            hb = h_baro(tc) if h_baro is not None else np.full(b - a, np.nan)
            ends = np.arange(self.step, b - a + self.step, self.step)
            ends[-1] = b - a
            _run_chunk(ends.astype(np.int64), tc, np.ascontiguousarray(dtheta[a:b]),
                       np.ascontiguousarray(dvel[a:b]), np.diff(edges), ds, v, hb,
                       self.xs, self.ms, self.bias_g, self.bias_a, self.fed_back,
                       self.X, self.P, self.Qc, self.present, self.healthy, self.normal_run,
                       self.lever, self.C_vb0, self.sig, self.form, self.beta,
                       self.xn, self.Pn, self.Qn, self.have_nhc, self.nhc_only,
                       self.sig_nhc, self.sig_baro, self.thr, self.return_tests,
                       self.acc, self.acc_D, self.acc_W, self.bad, self.state_i,
                       self.meas_every, self.fuse_every, self.out_every,
                       out["t"], out["x"], out["sigma"], out["states"], out["sensor"],
                       out["sensor_sigma"], out["mode"], lam_t, lam, self.ev, self.n_ev,
                       self.counts)
            if progress is not None:
                progress(b / n)
        m = int(self.state_i[1])
        res = {k: val[:m] for k, val in out.items()}
        k = int(min(self.state_i[2], len(lam_t)))
        res["lambda_t"], res["lambda"] = lam_t[:k], lam[:k]
        ne = int(min(self.n_ev[0], len(self.ev)))
        res["events"] = self.ev[:ne].copy()
        res["events_dropped"] = int(self.n_ev[0] - ne)
        return res
