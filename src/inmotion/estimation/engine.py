"""One streaming closed-loop error-state Kalman filter: SINS (+ optional dead reckoner),
a :class:`~inmotion.estimation.layout.Layout`, the one shared error model, and measurement
plug-ins (:mod:`inmotion.estimation.measurements`).

Streaming, in the style of KF-GINS's ``addImuData`` / ``addGnssData``::

    f = ErrorStateFilter(init, layout, model, P0, [ForwardVelocity(...), Nhc(...)])
    f.add_measurement("sensor_velocity", t, [speed])    # queued until the IMU reaches t
    f.add_imu(t_rows, dtheta, dvel)                     # mechanization, predict, updates
    f.state(), f.sigma(), f.estimate()
    snap = f.snapshot(); ...; f.restore(snap)

A batch run is this streaming API fed from a bundle in chunks; there is no second code path.

What happens per IMU row and per filter epoch (one numba loop, :func:`_advance`):

1. the row, less the fed-back gyro drift and accelerometer bias estimates
   (:func:`~inmotion.estimation.nav_ops.compensated_row`), drives the SINS
   (:func:`inmotion.core._kernels.sins_step`) and, when the filter has a dead reckoner, the DR
   (:func:`inmotion.core._kernels.dr_step`) with the velocity sensor's distance and speed over
   the row. The DR integrates the SINS's compensated gyro rows, or, with
   ``dr_sees_gyro_drift=False`` (paper 000's printed F), the raw rows; a caller may hand the
   DR its own gyro rows (``dtheta_dr``: a second gyro triad, or a simulation study);
2. after ``step_rows`` rows (a filter epoch) ``F`` is built at the SINS state with the epoch's
   mean specific force (:func:`inmotion.estimation.error_model._fill_F`) and ``x, P`` are
   predicted over the epoch (second-order transition, trapezoid ``Q_d``); the process noise
   is the model's ``G q G^T`` plus, with a DR, the random walk of the DR position driven by
   the velocity sensor's white noise (``dr_position_m2_s``, isotropic in E, N, U);
3. every queued measurement sample whose time is at or before the epoch's end is applied, in
   queue order (time, then the order of adding), by a gated sequential scalar Joseph update
   (:func:`inmotion.estimation.kalman.sequential_joseph`); its NIS is counted per kind. A
   sample is therefore applied at the end of the first filter epoch that ends at or after its
   time (a latency below one epoch; none when samples fall on epoch ends, as in a batch run);
4. feedback: after every ``feedback_every``-th epoch that applied samples, the blocks of the
   feedback policy are fed back (closed loop: attitude, velocity, position of the SINS and
   DR, drift and bias into the IMU compensation; open loop: none; partial: a chosen subset)
   and zeroed; sensor states (``mount``, ``dk``, ``lever``) are estimated only;
5. every ``out_every``-th epoch an output row is written: the SINS corrected by the estimate
   not yet fed back, ``sigma``, the states (fed back plus current) and the ``phi`` covariance.

The whole filter state lives in the arrays of :class:`_State`, so :meth:`snapshot` /
:meth:`restore` are copies, and a run split anywhere continues bit-identically.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np

from ..core import _kernels as K
from ..core.solution import NavState
from . import error_model as em
from .kalman import _predict_kernel, sequential_joseph
from .layout import DP, DP_D, DV, EPS, NABLA, PHI, PHI_D, Layout
from .measurements import AUX_SIZE, Measurement, fill_function
from .nav_ops import compensated_row, correct_nav, corrected_sins, dcm_of_q

__all__ = ["ErrorStateFilter", "FEEDBACK_BLOCKS", "MAX_MEASUREMENTS"]

#: measurement kinds one filter can hold (the compiled loop takes a fixed-length tuple)
MAX_MEASUREMENTS = 8
#: the blocks a feedback policy can feed back
FEEDBACK_BLOCKS = ("phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D")

# acc: epoch accumulators [rows, sum_dt, f_sum x3, w_sum x3]
_A_ROWS, _A_DT, _A_F, _A_W = 0, 1, 2, 5
# ints: [epochs, update epochs]
_I_EPOCHS, _I_UPDATES = 0, 1

#: the filter's mutable state, arrays only (updated in place by the numba loop)
_State = namedtuple("_State", "xs ms xd md x P fed_back bias_g bias_a acc ints used rejected "
                              "nis_sum dof_sum t_end")
#: the filter's constants
_Const = namedtuple("_Const", "offs offs9 Qc q_dr_m2_s inv_tau_dk dr_eps grav_grad with_dr "
                              "step out_every fb_mask feedback_every C_bm l_b gates params "
                              "dofs")
#: the output buffers of one call
_Out = namedtuple("_Out", "t xs sigma states cov_phi n")


@fill_function
def _noop_fill(xs, xd, aux, data, p, offs, z, H, r):
    return 0


# ----------------------------------------------------------------------------- the loop
@numba.njit(cache=True)
def _feed_back(S, C):
    """Closed loop (the policy's blocks): correct both systems, move drift and bias into the
    IMU compensation, accumulate what was fed back, zero those states."""
    x, offs, m = S.x, C.offs, C.fb_mask
    zero3 = np.zeros(3)
    phi = x[offs[PHI]:offs[PHI] + 3] if m[PHI] else zero3
    dv = x[offs[DV]:offs[DV] + 3] if m[DV] else zero3
    dp = x[offs[DP]:offs[DP] + 3] if m[DP] else zero3
    correct_nav(S.xs, S.ms, phi, dv, dp, True)
    if C.with_dr and (m[PHI_D] or m[DP_D]):
        o_phiD, o_dpD = offs[PHI_D], offs[DP_D]
        phiD = x[o_phiD:o_phiD + 3] if m[PHI_D] else zero3
        dpD = x[o_dpD:o_dpD + 3] if m[DP_D] else zero3
        correct_nav(S.xd, S.md, phiD, dv, dpD, False)
    for i in range(3):
        if m[EPS] and offs[EPS] >= 0:
            S.bias_g[i] += x[offs[EPS] + i]
        if m[NABLA] and offs[NABLA] >= 0:
            S.bias_a[i] += x[offs[NABLA] + i]
    for blk in (PHI, DV, DP, EPS, NABLA, PHI_D, DP_D):
        o = offs[blk]
        if o < 0 or not m[blk]:
            continue
        for i in range(3):
            S.fed_back[o + i] += x[o + i]
            x[o + i] = 0.0


@numba.njit(cache=True)
def _dr_position_noise(Q, Qc, o_dpD, lat, h, q_m2_s):
    """``Q = Qc`` plus the DR position random walk ``q_m2_s`` [m^2/s] on ``dp_D`` (rad, rad,
    m); ``Qc`` alone without a DR block (``o_dpD < 0``)."""
    Q[:, :] = Qc
    if o_dpD < 0:
        return
    r_m, r_n = K.radii(lat)
    Q[o_dpD, o_dpD] += q_m2_s / (r_m + h) ** 2
    Q[o_dpD + 1, o_dpD + 1] += q_m2_s / ((r_n + h) * math.cos(lat)) ** 2
    Q[o_dpD + 2, o_dpD + 2] += q_m2_s


@numba.njit(cache=True)
def _write_output(S, C, O, t_now):
    i = O.n[0]
    if i >= O.t.shape[0]:
        return
    O.t[i] = t_now
    corrected_sins(O.xs[i], S.xs, S.x, C.offs)
    n = S.x.shape[0]
    o_phi = C.offs[PHI]
    for p in range(n):
        O.sigma[i, p] = math.sqrt(max(S.P[p, p], 0.0))
        O.states[i, p] = S.fed_back[p] + S.x[p]
    for a in range(3):
        for b in range(3):
            O.cov_phi[i, a, b] = S.P[o_phi + a, o_phi + b]
    O.n[0] = i + 1


@numba.njit(cache=True)
def _epoch_end(S, C, fills, t_now, qt, qj, qd, qi, O, F, Q, aux, z, H, r, xw, Pw):
    """Close a filter epoch: predict, apply the due samples, feed back, output. Returns the
    next queue index."""
    sum_dt = S.acc[_A_DT]
    C_S = dcm_of_q(S.xs[K.Q0:K.Q3 + 1])
    f_b = np.empty(3)
    for i in range(3):
        f_b[i] = S.acc[_A_F + i] / sum_dt
    f_n = C_S @ f_b
    F[:, :] = 0.0
    em._fill_F(F, C.offs9, S.xs[K.LAT], S.xs[K.H], S.xs[K.VE:K.VU + 1].copy(), C_S, f_n,
               C.inv_tau_dk, C.dr_eps, C.grav_grad)
    _dr_position_noise(Q, C.Qc, C.offs[DP_D] if C.with_dr else -1, S.xs[K.LAT], S.xs[K.H],
                       C.q_dr_m2_s)
    _predict_kernel(S.x, S.P, F, Q, sum_dt)
    S.ints[_I_EPOCHS] += 1
    S.t_end[0] = t_now
    aux[0] = t_now
    for i in range(3):
        aux[1 + i] = S.acc[_A_W + i] / sum_dt
        aux[4 + i] = f_b[i]
    applied = False
    while qi < qt.shape[0] and qt[qi] <= t_now:
        j = qj[qi]
        m_max = C.dofs[j]
        for a in range(m_max):
            z[a] = 0.0
            r[a] = 0.0
            for b in range(H.shape[1]):
                H[a, b] = 0.0
        m = fills[j](S.xs, S.xd, aux, qd[qi], C.params[j], C.offs, z, H, r)
        applied = True
        if m > 0:
            ok, nis = sequential_joseph(S.x, S.P, z, H, r, 0, m, C.gates[j], xw, Pw)
            if ok:
                S.used[j] += 1
                S.nis_sum[j] += nis
                S.dof_sum[j] += m
            else:
                S.rejected[j] += 1
        qi += 1
    if applied:
        S.ints[_I_UPDATES] += 1
        if C.feedback_every > 0 and S.ints[_I_UPDATES] % C.feedback_every == 0:
            _feed_back(S, C)
    if S.ints[_I_EPOCHS] % C.out_every == 0:
        _write_output(S, C, O, t_now)
    for i in range(S.acc.shape[0]):
        S.acc[i] = 0.0
    return qi


@numba.njit(cache=True)
def _advance(S, C, fills, t, dtheta, dvel, dt, ds, v, dth_dr, qt, qj, qd, O, flush):
    """Run IMU rows ``t`` (M,) through the filter (module docstring); ``ds``, ``v`` (M,) the
    DR's sensor distance and speed per row, ``dth_dr`` (M, 3) the DR's own gyro rows or an
    empty (0, 3) array; ``qt``, ``qj``, ``qd`` the queued samples (time, kind, data).
    ``flush``: close a partial last epoch. Returns the number of queued samples consumed."""
    n = S.x.shape[0]
    F = np.zeros((n, n))
    Q = np.zeros((n, n))
    aux = np.zeros(AUX_SIZE)
    dmax = 1
    for j in range(C.dofs.shape[0]):
        dmax = max(dmax, C.dofs[j])
    z = np.zeros(dmax)
    H = np.zeros((dmax, n))
    r = np.zeros(dmax)
    xw = np.empty(n)
    Pw = np.empty((n, n))
    nan = np.nan
    own_dr_gyro = dth_dr.shape[0] > 0
    qi = 0
    for k in range(t.shape[0]):
        dth, dvl = compensated_row(dtheta, dvel, k, dt[k], S.bias_g, S.bias_a)
        K.sins_step(S.xs, S.ms, dth, dvl, dt[k], nan, 0.0, 0.0)
        S.ms[K.M_COUNT] += 1.0
        if C.with_dr:
            if own_dr_gyro:
                if C.dr_eps:
                    g = (dth_dr[k, 0] - S.bias_g[0] * dt[k], dth_dr[k, 1] - S.bias_g[1] * dt[k],
                         dth_dr[k, 2] - S.bias_g[2] * dt[k])
                else:
                    g = (dth_dr[k, 0], dth_dr[k, 1], dth_dr[k, 2])
            elif C.dr_eps:
                g = dth
            else:           # the printed model's DR has no drift: nothing is compensated
                g = (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2])
            K.dr_step(S.xd, S.md, g, ds[k], v[k], dt[k], C.C_bm, C.l_b)
            S.md[K.M_COUNT] += 1.0
        S.acc[_A_ROWS] += 1.0
        S.acc[_A_DT] += dt[k]
        for i in range(3):
            S.acc[_A_F + i] += dvl[i]
            S.acc[_A_W + i] += dth[i]
        if S.acc[_A_ROWS] >= C.step:
            qi = _epoch_end(S, C, fills, t[k], qt, qj, qd, qi, O, F, Q, aux, z, H, r, xw, Pw)
    if flush and S.acc[_A_ROWS] > 0:
        qi = _epoch_end(S, C, fills, t[t.shape[0] - 1], qt, qj, qd, qi, O, F, Q, aux, z, H,
                        r, xw, Pw)
    return qi


# ----------------------------------------------------------------------------- the filter
def _feedback_mask(feedback, layout):
    if feedback == "closed":
        blocks = FEEDBACK_BLOCKS
    elif feedback == "open":
        blocks = ()
    else:
        blocks = tuple(feedback)
        bad = [b for b in blocks if b not in FEEDBACK_BLOCKS]
        if bad:
            raise ValueError(f"feedback blocks must be among {FEEDBACK_BLOCKS}, got {bad}")
    mask = np.zeros(len(layout.offsets()), dtype=np.bool_)
    names = ("phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D")
    for b in blocks:
        mask[(PHI, DV, DP, EPS, NABLA, PHI_D, DP_D)[names.index(b)]] = True
    return mask


class ErrorStateFilter:
    """Streaming closed-loop error-state Kalman filter (see the module docstring).

    Parameters
    ----------
    init : NavState
        Start of the SINS (and of the DR).
    layout : Layout
        The error state; must hold ``phi, dv, dp``; ``phi_D, dp_D`` make the filter run a
        dead reckoner beside the SINS.
    model : error_model.ErrorModel
        On ``layout``: ``F`` (the one shared builder) and ``Q_c``.
    P0 : (n, n) initial covariance, in the layout's SI units.
    measurements : list of Measurement
        At most :data:`MAX_MEASUREMENTS`, with distinct names; applied in this order when
        samples share a time.
    step_rows : int
        IMU rows per filter epoch (a predict per epoch).
    feedback : ``"closed"``, ``"open"`` or a list of blocks of :data:`FEEDBACK_BLOCKS`
        (partial feedback).
    feedback_every : int
        Epochs with applied samples per feedback.
    out_every : int
        Filter epochs per output row of :meth:`add_imu`.
    dr_mounting : (3, 3) ``C_m^b`` of the DR's velocity sensor (identity by default).
    dr_lever_arm_m : (3,) IMU-to-sensor lever arm in b [m] (zeros by default).
    dr_position_m2_s : float
        DR position random-walk density [m^2/s] (the sensor's white noise integrated).

    Attributes
    ----------
    layout, model, measurements, init
    """

    def __init__(self, init: NavState, layout: Layout, model: em.ErrorModel, P0,
                 measurements, *, step_rows: int = 1, feedback="closed", feedback_every: int = 1,
                 out_every: int = 1, dr_mounting=None, dr_lever_arm_m=None,
                 dr_position_m2_s: float = 0.0):
        for name in ("phi", "dv", "dp"):
            if name not in layout:
                raise ValueError(f"the filter needs block {name!r} in the layout")
        if model.layout is not layout and tuple(model.layout.names) != tuple(layout.names):
            raise ValueError("the error model is built on another layout")
        measurements = list(measurements)
        if len(measurements) > MAX_MEASUREMENTS:
            raise ValueError(f"at most {MAX_MEASUREMENTS} measurement kinds per filter, got "
                             f"{len(measurements)}")
        names = [m.name for m in measurements]
        if len(set(names)) != len(names):
            raise ValueError(f"measurement names must be distinct, got {names}")
        with_dr = "phi_D" in layout
        for m in measurements:
            if not isinstance(m, Measurement):
                raise TypeError(f"not a Measurement: {m!r}")
            if m.needs_dr and not with_dr:
                raise ValueError(f"measurement {m.name!r} needs the DR blocks phi_D, dp_D")
            m.check(layout)
        n = layout.n
        P0 = np.array(P0, dtype=float)
        if P0.shape != (n, n):
            raise ValueError(f"P0 must be ({n}, {n}) for {layout!r}, got {P0.shape}")
        if int(step_rows) < 1 or int(out_every) < 1 or int(feedback_every) < 1:
            raise ValueError("step_rows, out_every and feedback_every must be >= 1")
        self.init = init
        self.layout = layout
        self.model = model
        self.measurements = measurements
        self._index = {m.name: j for j, m in enumerate(measurements)}
        self.step = int(step_rows)
        self.out_every = int(out_every)
        x0 = _kernel_state(init)
        fb_mask = _feedback_mask(feedback, layout)
        C_bm = np.eye(3) if dr_mounting is None else np.array(dr_mounting, dtype=float)
        l_b = np.zeros(3) if dr_lever_arm_m is None else np.array(dr_lever_arm_m, dtype=float)
        if C_bm.shape != (3, 3) or l_b.shape != (3,):
            raise ValueError("dr_mounting must be (3, 3) and dr_lever_arm_m (3,)")
        n_par = max([len(m.params()) for m in measurements] + [1])
        params = np.zeros((MAX_MEASUREMENTS, n_par))
        for j, m in enumerate(measurements):
            p = np.asarray(m.params(), dtype=float)
            params[j, :len(p)] = p
        self._data_size = max([m.data_size for m in measurements] + [1])
        offs = layout.offsets()
        self._C = _Const(
            offs=offs, offs9=tuple(int(o) for o in em._offsets(layout)),
            Qc=np.ascontiguousarray(model.Qc()), q_dr_m2_s=float(dr_position_m2_s),
            inv_tau_dk=1.0 / model.noise.dk_tau, dr_eps=bool(model.dr_sees_gyro_drift),
            grav_grad=bool(model.gravity_gradient), with_dr=with_dr, step=self.step,
            out_every=self.out_every, fb_mask=fb_mask,
            feedback_every=int(feedback_every) if fb_mask.any() else 0,
            C_bm=np.ascontiguousarray(C_bm), l_b=l_b,
            gates=np.array([m.gate for m in measurements]
                           + [0.0] * (MAX_MEASUREMENTS - len(measurements))),
            params=params,
            dofs=np.array([m.dof for m in measurements]
                          + [0] * (MAX_MEASUREMENTS - len(measurements)), dtype=np.int64))
        self._fills = tuple([m.fill for m in measurements]
                            + [_noop_fill] * (MAX_MEASUREMENTS - len(measurements)))
        M = MAX_MEASUREMENTS
        self._S = _State(
            xs=x0.copy(), ms=K.new_memory(), xd=x0.copy(), md=K.new_memory(),
            x=np.zeros(n), P=P0, fed_back=np.zeros(n), bias_g=np.zeros(3),
            bias_a=np.zeros(3), acc=np.zeros(8), ints=np.zeros(2, dtype=np.int64),
            used=np.zeros(M, dtype=np.int64), rejected=np.zeros(M, dtype=np.int64),
            nis_sum=np.zeros(M), dof_sum=np.zeros(M, dtype=np.int64),
            t_end=np.array([float(init.t)]))
        self.t = float(init.t)           #: time of the last IMU row processed [s]
        self.rows = 0                    #: IMU rows processed
        self._qt = np.zeros(0)
        self._qj = np.zeros(0, dtype=np.int64)
        self._qd = np.zeros((0, self._data_size))
        self._pending = []

    # -- input ---------------------------------------------------------------------------
    def add_measurement(self, name: str, t, data=None):
        """Queue one sample (``t`` a float) or many (``t`` (K,), ``data`` (K, size)) of the
        measurement ``name``; each is applied at the end of the first filter epoch that ends
        at or after its time [s]."""
        try:
            j = self._index[name]
        except KeyError:
            raise KeyError(f"no measurement {name!r} in this filter; it has "
                           f"{', '.join(self._index) or 'none'}") from None
        size = self.measurements[j].data_size
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"{name}: t must be a time or a 1-D array of times")
        if size == 0:
            d = np.zeros((len(t), 0))
        else:
            d = np.asarray(data, dtype=float).reshape(len(t), size)
        if not np.all(np.isfinite(t)):
            raise ValueError(f"{name}: sample times must be finite")
        block = np.zeros((len(t), self._data_size))
        block[:, :size] = d
        self._pending.append((t, np.full(len(t), j, dtype=np.int64), block))

    def _merge_pending(self):
        if not self._pending:
            return
        ts = [self._qt] + [p[0] for p in self._pending]
        js = [self._qj] + [p[1] for p in self._pending]
        ds = [self._qd] + [p[2] for p in self._pending]
        self._pending = []
        t = np.concatenate(ts)
        order = np.argsort(t, kind="stable")
        self._qt = np.ascontiguousarray(t[order])
        self._qj = np.ascontiguousarray(np.concatenate(js)[order])
        self._qd = np.ascontiguousarray(np.concatenate(ds)[order])

    def add_imu(self, t, dtheta, dvel, *, ds=None, speed=None, dtheta_dr=None,
                flush: bool = False, max_out: int | None = None) -> dict:
        """Process IMU rows: mechanization, a predict per ``step_rows`` rows, the queued
        samples that fall due, feedback.

        Parameters
        ----------
        t : (M,) s, after the last row processed;  dtheta, dvel : (M, 3) rad, m/s increments
            in b over the interval ending at ``t``
        ds, speed : (M,) the DR's velocity-sensor distance [m] over each row and speed [m/s]
            at ``t`` (required when the filter has a DR)
        dtheta_dr : (M, 3) rad, the DR's own gyro rows (default: the SINS's)
        flush : close a partial last epoch (the end of a run)
        max_out : output rows to make room for (default: all this call can write)

        Returns
        -------
        dict of the output rows written (every ``out_every``-th epoch): ``t`` (R,),
        ``x_sins`` (R, 10) kernel states corrected by the estimate not yet fed back,
        ``sigma`` (R, n), ``states`` (R, n) (fed back plus current), ``cov_phi`` (R, 3, 3).
        """
        t = np.ascontiguousarray(t, dtype=float).reshape(-1)
        m = len(t)
        dtheta = np.ascontiguousarray(dtheta, dtype=float).reshape(m, 3)
        dvel = np.ascontiguousarray(dvel, dtype=float).reshape(m, 3)
        if m and not t[0] > self.t:
            raise ValueError(f"IMU rows must follow the last one processed (t={self.t:.6f} s); "
                             f"got t={t[0]:.6f} s")
        if self._C.with_dr:
            if ds is None or speed is None:
                raise ValueError("this filter runs a dead reckoner: add_imu needs ds and speed")
            ds = np.ascontiguousarray(ds, dtype=float).reshape(m)
            speed = np.ascontiguousarray(speed, dtype=float).reshape(m)
        else:
            ds = speed = np.zeros(m)
        dth_dr = (np.zeros((0, 3)) if dtheta_dr is None
                  else np.ascontiguousarray(dtheta_dr, dtype=float).reshape(m, 3))
        dt = np.diff(np.concatenate([[self.t], t])) if m else np.zeros(0)
        self._merge_pending()
        n_ep = (int(self._S.acc[0]) + m) // self.step + 1
        cap = n_ep // self.out_every + 1 if max_out is None else int(max_out)
        n = self.layout.n
        O = _Out(t=np.empty(cap), xs=np.empty((cap, K.NX)), sigma=np.empty((cap, n)),
                 states=np.empty((cap, n)), cov_phi=np.empty((cap, 3, 3)),
                 n=np.zeros(1, dtype=np.int64))
        used = _advance(self._S, self._C, self._fills, t, dtheta, dvel, dt, ds, speed, dth_dr,
                        self._qt, self._qj, self._qd, O, bool(flush))
        if used:
            self._qt, self._qj, self._qd = self._qt[used:], self._qj[used:], self._qd[used:]
        if m:
            self.t = float(t[-1])
            self.rows += m
        k = int(O.n[0])
        return {"t": O.t[:k], "x_sins": O.xs[:k], "sigma": O.sigma[:k],
                "states": O.states[:k], "cov_phi": O.cov_phi[:k]}

    def flush(self) -> dict:
        """Close a partial filter epoch (predict over it, apply what fell due); the outputs
        written, as :meth:`add_imu`."""
        return self.add_imu(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)),
                            ds=np.zeros(0), speed=np.zeros(0), flush=True)

    # -- output --------------------------------------------------------------------------
    def output_now(self) -> dict:
        """One output row of the current state (the same fields as :meth:`add_imu`'s)."""
        n = self.layout.n
        O = _Out(t=np.empty(1), xs=np.empty((1, K.NX)), sigma=np.empty((1, n)),
                 states=np.empty((1, n)), cov_phi=np.empty((1, 3, 3)),
                 n=np.zeros(1, dtype=np.int64))
        _write_output(self._S, self._C, O, self.t)
        return {"t": O.t, "x_sins": O.xs, "sigma": O.sigma, "states": O.states,
                "cov_phi": O.cov_phi}

    def state(self) -> NavState:
        """The navigation solution now: the SINS corrected by the estimate not yet fed back."""
        x = self.output_now()["x_sins"][0]
        return NavState(self.t, x[K.LAT], x[K.LON], x[K.H], x[K.VE:K.VU + 1].copy(),
                        x[K.Q0:K.Q3 + 1].copy())

    def covariance(self) -> np.ndarray:
        """``P`` (n, n), a copy, in the layout's SI units."""
        return self._S.P.copy()

    def sigma(self) -> dict:
        """``{state element: 1-sigma}`` in SI (``layout.names``)."""
        return self.layout.as_dict(np.sqrt(np.maximum(np.diagonal(self._S.P), 0.0)))

    def estimate(self) -> dict:
        """``{state element: fed back + current estimate}`` in SI: the accumulated error
        estimate (sensor errors such as ``eps_x``, ``mount_z``, ``dk``)."""
        return self.layout.as_dict(self._S.fed_back + self._S.x)

    @property
    def x(self) -> np.ndarray:
        """The current error-state estimate (not yet fed back), a copy."""
        return self._S.x.copy()

    @property
    def epochs(self) -> int:
        return int(self._S.ints[_I_EPOCHS])

    def kernel_states(self):
        """``(xs, xd, aux)``: copies of the SINS and DR kernel states and the last epoch's
        ``aux`` (:data:`inmotion.estimation.measurements.AUX_SIZE`) for a measurement's
        :meth:`~inmotion.estimation.measurements.Measurement.rows`."""
        S = self._S
        aux = np.zeros(AUX_SIZE)
        aux[0] = self.t
        aux[1:4] = S.ms[K.M_WIB:K.M_WIB + 3]
        aux[4:7] = S.ms[K.M_FB:K.M_FB + 3]
        return S.xs.copy(), S.xd.copy(), aux

    def counts(self) -> dict:
        """Per measurement: samples used, rejected by the gate, and mean NIS per degree of
        freedom (``None`` before any)."""
        S = self._S
        res = {}
        for j, m in enumerate(self.measurements):
            dof = int(S.dof_sum[j])
            res[m.name] = {"used": int(S.used[j]), "rejected": int(S.rejected[j]),
                           "nis_per_dof": float(S.nis_sum[j] / dof) if dof else None}
        return res

    def nis_sums(self) -> dict:
        """Per measurement: ``(sum of NIS, degrees of freedom used)`` (for pooled NIS)."""
        S = self._S
        return {m.name: (float(S.nis_sum[j]), int(S.dof_sum[j]))
                for j, m in enumerate(self.measurements)}

    # -- checkpoints ---------------------------------------------------------------------
    def snapshot(self) -> dict:
        """A copy of the whole filter state (nav systems, estimate, covariance, compensation,
        epoch accumulators, counters, queued samples); :meth:`restore` returns to it."""
        self._merge_pending()
        return {"S": _State(*(a.copy() for a in self._S)), "t": self.t, "rows": self.rows,
                "queue": (self._qt.copy(), self._qj.copy(), self._qd.copy())}

    def restore(self, snap: dict):
        """Return to a :meth:`snapshot` of this filter (its arrays are copied again, so one
        snapshot can be restored many times)."""
        for dst, src in zip(self._S, snap["S"]):
            dst[...] = src
        self.t = float(snap["t"])
        self.rows = int(snap["rows"])
        qt, qj, qd = snap["queue"]
        self._qt, self._qj, self._qd = qt.copy(), qj.copy(), qd.copy()
        self._pending = []


def _kernel_state(s: NavState) -> np.ndarray:
    x = np.empty(K.NX)
    x[K.LAT], x[K.LON], x[K.H] = s.lat, s.lon, s.h
    x[K.VE:K.VU + 1] = s.vel_n
    x[K.Q0:K.Q3 + 1] = s.q_nb
    return x
