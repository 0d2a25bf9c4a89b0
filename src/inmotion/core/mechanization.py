"""Strapdown inertial navigation (SINS) mechanization on angle and velocity increments.

The algorithm (Savage 1998, "Strapdown inertial navigation integration algorithm design";
Yan Gongmin's PSINS), one update per IMU row, 100-200 Hz increments in:

* attitude by the rotation vector with the two-sample (previous-interval) coning correction,
  ``phi_b = dth + dth_prev x dth / 12``, and the navigation-frame rotation
  ``zeta = omega_in_n dt`` from latitude, height and velocity extrapolated to the interval
  midpoint: ``q(k) = q(-zeta) (x) q(k-1) (x) q(phi_b)``;
* velocity with the rotation term ``dth x dv / 2`` and two-sample sculling
  ``(dth_prev x dv + dv_prev x dth) / 12``, the n-frame rotation ``(I - [zeta x]/2)``, and the
  second-order rotation terms that make a constant-rate interval exact to second order
  (:func:`inmotion.core._kernels.sins_step` derives them),
  gravity (WGS-84 normal gravity, :mod:`inmotion.core.earth`) and Coriolis
  ``(2 omega_ie + omega_en) x v`` at the midpoint;
* latitude, longitude, height by the trapezoid of the velocities at both ends.

The first row after the start has no previous increments: the coning and sculling corrections
are then zero (exact for constant rates), never computed from garbage.

Optional barometric damping of the vertical channel (``damping="baro"``), a second-order loop
on the height difference ``dh = h - h_baro``::

    h  <- h  - k_h dh dt,        vU <- vU - k_v dh dt,
    k_h = 2 zeta_d / tau,        k_v = 1 / tau^2 + 2 g / R,   zeta_d = 1 (critical damping)

The error dynamics ``dh'' + k_h dh' + (k_v - 2 g / R) dh = 0`` then have a double pole at
``-1/tau``: an initial height error ``dh0`` decays as ``dh0 (1 - t/tau) exp(-t/tau)`` (the
loop feeds the height directly, hence the sign; a test checks this curve). The
``2 g / R`` term cancels the vertical channel's instability (``dg/dh = -2 g / R``). Default
``tau = 10 s`` (:data:`BARO_TAU_S`); a noisy barometer wants a longer one.

Time convention (docs/ARCHITECTURE.md): IMU row ``k`` holds the increments over
``(t[k-1], t[k]]``; the state at ``t[k]`` is the state after row ``k``.
"""
from __future__ import annotations

import numpy as np

from .. import _aot
from . import _kernels as K
from . import earth
from .bundle import BaroData, ImuData, regroup
from .rotations import euler_from_quat, quat_from_rotvec, quat_multiply
from .solution import NavState, Solution
from ..errors import BadInput

__all__ = ["strapdown", "Strapdown", "baro_gains", "BARO_TAU_S"]

#: default time constant [s] of the barometric height-damping loop
BARO_TAU_S = 10.0
#: rows per chunk in the batch functions (bounds the temporaries; outputs are what grows)
CHUNK_ROWS = 65536


def baro_gains(tau: float, lat: float = 0.0) -> tuple[float, float]:
    """Gains ``(k_h [1/s], k_v [1/s^2])`` of the critically damped second-order baro loop.

    ``k_h = 2 / tau``, ``k_v = 1 / tau^2 + 2 g / R`` with ``g`` and ``R = sqrt(R_M R_N)`` at
    ``lat`` [rad]; the closed loop has a double pole at ``-1 / tau`` [1/s].
    """
    if not tau > 0:
        raise BadInput(f"baro damping time constant must be > 0 s, got {tau}")
    r_m, r_n = earth.radii(lat)
    return 2.0 / tau, 1.0 / tau ** 2 + 2.0 * earth.gravity(lat, 0.0) / np.sqrt(r_m * r_n)


def _state_vector(s: NavState) -> np.ndarray:
    x = np.empty(K.NX)
    x[[K.LAT, K.LON, K.H]] = s.lat, s.lon, s.h
    x[K.VE:K.VU + 1] = s.vel_n
    x[K.Q0:K.Q3 + 1] = s.q_nb
    return x


def _check_rows(dtheta, dvel, t):
    dtheta = np.ascontiguousarray(dtheta, dtype=float).reshape(-1, 3)
    dvel = np.ascontiguousarray(dvel, dtype=float).reshape(-1, 3)
    t = np.ascontiguousarray(t, dtype=float).reshape(-1)
    if not (len(dtheta) == len(dvel) == len(t)):
        raise BadInput(f"imu chunk: dtheta ({len(dtheta)}), dvel ({len(dvel)}) and t ({len(t)}) "
                       "must have the same number of rows")
    return dtheta, dvel, t


def _check_finite(arr, t, name, what, row0=0):
    """BadInput naming the first row of ``arr`` (rows = samples) that holds NaN or inf."""
    k = _aot.first_nonfinite_row(arr if arr.ndim == 2 else arr.reshape(-1, 1))
    if k >= 0:
        raise BadInput(f"{name} is not finite ({arr[k]})", file=what, row=row0 + k + 1,
                       time=float(t[k]))


def _check_baro(baro: BaroData):
    if len(baro.t) < 2:
        raise BadInput(f"barometer damping needs at least 2 samples, got {len(baro.t)}",
                       file="baro")
    _check_time(baro.t, "baro")
    _check_finite(baro.h, baro.t, "h", "baro")


def _check_time(t, what):
    """BadInput at the first sample time that is not finite or not after the one before."""
    k = _aot.first_not_increasing(t)
    if k >= 0:
        if not np.isfinite(t[k]):
            raise BadInput(f"t is not finite ({t[k]})", file=what, row=k + 1)
        raise BadInput(f"time not strictly increasing (previous t={t[k - 1]:.6g} s)",
                       file=what, row=k + 1, time=float(t[k]))


def typical_period(t) -> float:
    """Median sample period [s] of the first 65536 intervals (no log-sized temporary)."""
    return float(np.median(np.diff(t[:65537])))


def _intervals(t, t_prev, what, row0=0):
    """Interval lengths ``t[k] - t[k-1]`` [s] with ``t[-1] = t_prev``; must be > 0 and finite.
    ``row0`` rows came before ``t`` (for the row number in the message)."""
    dt = np.empty(len(t))
    k = _aot.call("time_steps", K.time_steps, t, float(t_prev), dt)
    if k >= 0:
        before = t_prev if k == 0 else t[k - 1]
        raise BadInput(f"time not strictly increasing (previous t={before:.6g} s)",
                       file=what, row=row0 + k + 1, time=float(t[k]))
    return dt


_NAN = np.full(1024, np.nan)
_NO_ROWS, _NO_X = np.empty(0, dtype=np.int64), np.empty((0, K.NX))


def _nan_row(m):
    """A read-only row of ``m`` NaNs (no reference height), reused between calls."""
    global _NAN
    if len(_NAN) < m:
        _NAN = np.full(m, np.nan)
    return _NAN[:m]


def _out_buffers(m, out_stride):
    """Output buffers for a chunk of ``m`` rows (shared empty ones when nothing is output)."""
    if out_stride <= 0:
        return _NO_ROWS, _NO_X
    n_max = m // out_stride + 1
    return np.empty(n_max, dtype=np.int64), np.empty((n_max, K.NX))


class _KernelStream:
    """What the streaming SINS (:class:`Strapdown`) and the streaming dead reckoner
    (:class:`inmotion.core.deadreckoning.DeadReckoner`) share: the kernel state vector ``x``
    ``[lat, lon, h, vE, vN, vU, q0, q1, q2, q3]`` and memory, the time of the last row ``t`` [s],
    the row count, and the bookkeeping after a numba chunk loop."""

    def _start(self, init: NavState):
        self._x = _state_vector(init)
        self._mem = K.new_memory()
        self.t = float(init.t)
        self.rows = 0           #: rows processed so far (error messages count from here)

    def _finish_chunk(self, t, n, out_rows, out_x, out_stride):
        """After a kernel ran over the chunk with times ``t`` (M,) and filled ``n`` output rows:
        move ``t`` and the row count on; return ``(t_out, x_out)`` when ``out_stride > 0``."""
        if len(t):
            self.t = float(t[-1])
        self.rows += len(t)
        if out_stride > 0:
            return t[out_rows[:n]], out_x[:n]
        return None

    def state(self) -> NavState:
        """The current navigation state (a copy)."""
        x = self._x
        return NavState(self.t, x[K.LAT], x[K.LON], x[K.H], x[K.VE:K.VU + 1].copy(),
                        x[K.Q0:K.Q3 + 1].copy())

    @property
    def x(self) -> np.ndarray:
        """Copy of the kernel state vector ``[lat, lon, h, vE, vN, vU, q0, q1, q2, q3]``."""
        return self._x.copy()

    @property
    def omega_ib_b(self) -> np.ndarray:
        """Mean body rate [rad/s] over the last row (``dtheta / dt``); zeros before any row."""
        return self._mem[K.M_WIB:K.M_WIB + 3].copy()


class Strapdown(_KernelStream):
    """Streaming SINS for filters: advance over chunks, read the state, feed back corrections.

    Parameters
    ----------
    init : NavState
        Starting state at ``init.t``.
    baro_tau : float, optional
        Time constant [s] of the baro damping loop used when :meth:`run` gets ``h_baro``.

    Running the whole log in one chunk or in many gives bit-identical states.
    """

    def __init__(self, init: NavState, baro_tau: float = BARO_TAU_S):
        self._start(init)
        self.k_h, self.k_v = baro_gains(baro_tau, init.lat)

    # -- running
    def run(self, dtheta, dvel, t, h_baro=None, out_stride: int = 0):
        """Advance over M rows: ``dtheta`` [rad], ``dvel`` [m/s] (M, 3) in b, ``t`` (M,) [s].

        ``h_baro`` (M,) [m], optional: reference height at each row's time for the damping
        loop (NaN entries: no damping that row). With ``out_stride > 0`` returns
        ``(t_out, x_out)``: every ``out_stride``-th state (counted over the object's life) as
        rows of the kernel state vector ``[lat, lon, h, vE, vN, vU, q0, q1, q2, q3]``.
        """
        dtheta, dvel, t = _check_rows(dtheta, dvel, t)
        dt = _intervals(t, self.t, "imu", self.rows)
        _check_finite(dtheta, t, "dtheta", "imu", self.rows)
        _check_finite(dvel, t, "dvel", "imu", self.rows)
        if h_baro is None:
            h_ref = _nan_row(len(t))
        else:
            h_ref = np.ascontiguousarray(h_baro, dtype=float).reshape(-1)
            if len(h_ref) != len(t):
                raise BadInput(f"h_baro has {len(h_ref)} rows, the imu chunk {len(t)}")
        out_rows, out_x = _out_buffers(len(t), out_stride)
        n = _aot.call("sins_run", K.sins_run, self._x, self._mem, dtheta, dvel, dt, h_ref, self.k_h, self.k_v,
                       int(out_stride), out_rows, out_x)
        return self._finish_chunk(t, n, out_rows, out_x, out_stride)

    # -- reading (state(), x, omega_ib_b: _KernelStream)
    @property
    def f_b(self) -> np.ndarray:
        """Mean specific force [m/s^2] over the last row (``dvel / dt``); zeros before any row."""
        return self._mem[K.M_FB:K.M_FB + 3].copy()

    # -- feedback
    def correct(self, phi=None, dvel_n=None, dpos=None):
        """Closed-loop feedback of estimated errors (computed minus true).

        ``phi`` [rad]: misalignment, ``C_computed = (I - [phi x]) C_true``; the attitude
        becomes ``exp([phi x]) C_computed`` (``q <- q(phi) (x) q``). ``dvel_n`` [m/s] ENU is
        subtracted from the velocity, ``dpos = [dlat rad, dlon rad, dh m]`` from the position.
        The state one epoch back, kept for midpoint extrapolation, is shifted by the same
        amounts so that the correction is not extrapolated as motion.
        """
        _correct(self._x, self._mem, phi, dvel_n, dpos)


def _correct(x, mem, phi, dvel_n, dpos):
    """Shared by :class:`Strapdown` and the dead reckoner."""
    if phi is not None:
        q = quat_multiply(quat_from_rotvec(np.asarray(phi, dtype=float).reshape(3)),
                          x[K.Q0:K.Q3 + 1])
        x[K.Q0:K.Q3 + 1] = q / np.linalg.norm(q)
    if dvel_n is not None:
        dv = np.asarray(dvel_n, dtype=float).reshape(3)
        x[K.VE:K.VU + 1] -= dv
        mem[K.M_V_OLD:K.M_V_OLD + 3] -= dv
    if dpos is not None:
        dp = np.asarray(dpos, dtype=float).reshape(3)
        x[K.LAT] -= dp[0]
        x[K.LON] -= dp[1]
        x[K.H] -= dp[2]
        mem[K.M_LAT_OLD] -= dp[0]
        mem[K.M_H_OLD] -= dp[2]


def _first_row(t, init_t):
    """Index of the first row whose time is after ``init_t`` (with a 1 us tolerance)."""
    return int(np.searchsorted(t, init_t + 1e-6, side="left"))


def start_row(t, init_t, min_rows: int = 2) -> int:
    """:func:`_first_row` for a filter that needs at least ``min_rows`` IMU rows after its
    start: the index ``k0`` of the first row of ``t`` [s] after ``init_t`` [s]; raises
    :class:`BadInput` (file ``imu``) when fewer rows are left from there."""
    k0 = _first_row(t, init_t)
    if len(t) - k0 < min_rows:
        raise BadInput(f"no IMU rows after the start t={init_t:.6g} s", file="imu")
    return k0


def _baro_on_imu(baro: BaroData, t: np.ndarray, max_gap: float) -> np.ndarray:
    """Barometric height interpolated to the IMU times ``t``; NaN outside the baro's span and
    strictly inside gaps longer than ``max_gap`` [s] (never extrapolated)."""
    ts = baro.t
    h = np.interp(t, ts, baro.h)
    j = np.searchsorted(ts, t, side="left")              # ts[j-1] < t <= ts[j]
    inside = (t >= ts[0]) & (t <= ts[-1])
    jc = np.clip(j, 1, len(ts) - 1)
    on_sample = ts[np.clip(j, 0, len(ts) - 1)] == t
    in_gap = (ts[jc] - ts[jc - 1]) > max_gap
    h[~inside | (in_gap & ~on_sample)] = np.nan
    return h


class _SolutionBuilder:
    """Output arrays of a batch run, filled chunk by chunk (the chunk's quaternions are turned
    into Euler angles as they come, so only the output arrays grow with the log)."""

    def __init__(self, n_rows: int, out_stride: int, t0: float, x0: np.ndarray):
        n = n_rows // out_stride + 1
        self.t = np.empty(n)
        self.lla = np.empty((n, 3))
        self.vel_n = np.empty((n, 3))
        self.euler = np.empty((n, 3))
        self.n = 0
        self.add(np.array([t0]), x0[None, :])

    def add(self, t, x):
        i, m = self.n, len(t)
        self.t[i:i + m] = t
        self.lla[i:i + m] = x[:, [K.LAT, K.LON, K.H]]
        self.vel_n[i:i + m] = x[:, K.VE:K.VU + 1]
        self.euler[i:i + m] = euler_from_quat(x[:, K.Q0:K.Q3 + 1])
        self.n += m

    def solution(self, info) -> Solution:
        n = self.n
        return Solution(self.t[:n], self.lla[:n, 0], self.lla[:n, 1], self.lla[:n, 2],
                        self.vel_n[:n], self.euler[:n], info=info)


def strapdown(imu: ImuData, init: NavState, baro: BaroData | None = None, *,
              damping: str = "none", out_stride: int = 1,
              baro_tau: float = BARO_TAU_S) -> Solution:
    """Pure strapdown navigation over a log of increments.

    Parameters
    ----------
    imu : ImuData
        Increments in b; rows with ``t > init.t`` are processed.
    init : NavState
        Starting state at ``init.t``, normally an IMU epoch (``--init truth`` gives one); if it
        falls between rows, the first row's whole increments are taken over ``t[k] - init.t``.
    baro : BaroData, optional
        Barometric height, needed for ``damping="baro"``; linearly interpolated to the IMU
        times, not used outside its span or inside gaps longer than 5 of its periods (median
        over its first 65536 intervals).
    damping : {"none", "baro"}
        Vertical channel: free (unstable, ``cosh(sqrt(2 g / R) t)``) or baro-damped.
    out_stride : int
        Output the initial state and then every ``out_stride``-th state.
    baro_tau : float
        Damping loop time constant [s] (see the module docstring).

    Returns
    -------
    Solution with ``info`` holding the method name, damping and loop time constant.
    """
    k0 = _first_row(imu.t, init.t)
    return strapdown_rows(len(imu.t) - k0, [(imu.t[k0:], imu.dtheta[k0:], imu.dvel[k0:])],
                          init, baro, damping=damping, out_stride=out_stride,
                          baro_tau=baro_tau, first_row=k0)


def strapdown_rows(n_rows: int, pieces, init: NavState, baro: BaroData | None = None, *,
                   damping: str = "none", out_stride: int = 1, baro_tau: float = BARO_TAU_S,
                   first_row: int = 0) -> Solution:
    """:func:`strapdown` on the ``n_rows`` IMU rows after ``init.t`` given in ``pieces``
    (consecutive ``(t, dtheta, dvel)`` blocks of any sizes, e.g. a log read in chunks:
    :meth:`inmotion.core.bundle.Bundle.imu_rows_after`); they are regrouped into the chunks
    :func:`strapdown` uses, so the result does not depend on the pieces. ``first_row``: the
    index of the first row in the log, for error messages."""
    if damping not in ("none", "baro"):
        raise BadInput(f"damping must be 'none' or 'baro', got {damping!r}")
    if damping == "baro" and baro is None:
        raise BadInput("damping='baro' needs barometer data (no baro given)")
    if int(out_stride) < 1:
        raise BadInput(f"out_stride must be >= 1, got {out_stride}")
    max_gap = np.inf
    if damping == "baro":
        _check_baro(baro)
        max_gap = 5.0 * typical_period(baro.t)
    nav = Strapdown(init, baro_tau=baro_tau)
    nav.rows = first_row        # error messages give the row of the whole log
    out = _SolutionBuilder(n_rows, int(out_stride), init.t, nav.x)
    for t, dtheta, dvel in (b[:3] for b in regroup(pieces, CHUNK_ROWS)):
        h_ref = _baro_on_imu(baro, t, max_gap) if damping == "baro" else None
        out.add(*nav.run(dtheta, dvel, t, h_baro=h_ref, out_stride=int(out_stride)))
    info = {"method": "strapdown", "damping": damping,
            "baro_tau_s": baro_tau if damping == "baro" else None,
            "rows": int(n_rows)}
    return out.solution(info)
