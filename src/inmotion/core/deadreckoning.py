"""Dead reckoning from the gyros and a forward-velocity sensor (paper 002, "DRS").

Attitude by the same equivalent-rotation-vector update as the SINS (two-sample coning, the
navigation frame's rotation from the DR's own position and velocity; the kernel is shared,
:func:`inmotion.core._kernels.attitude_update`). Velocity, paper 002 eq. 8 (paper 000 eq. 8)::

    v_n = C_b^n C_m^b [0, u, 0],      u = v - u_b . (omega_eb_b x l_b)

and position from distance increments (paper 002 eq. 12-19: the distance travelled over the
interval, resolved in n with the attitude, moves latitude, longitude and height)::

    dS_n = C_b^n(k-1/2) C_m^b [0, ds_imu, 0],      ds_imu = ds - u_b . (dtheta_eb x l_b)

``m`` is the frame the vehicle moves along (forward axis y): the vehicle frame v of
docs/ARCHITECTURE.md ("Vehicle frame and mounting"), paper 000's radar frame, so
``C_bm = C_m^b = C_v^b`` and ``u_b = C_m^b [0, 1, 0]`` is the vehicle's forward axis in b. As
the project's vehicle model has it, the IMU point moves along ``u_b`` (no sideways or vertical
velocity) and a sensor at the lever arm ``l_b`` (IMU to sensor, in b) reads the forward
component of its own velocity over ground, ``v = u + u_b . (omega_eb_b x l_b)`` (an outer wheel
in a turn reads more): the lever-arm term is removed from the speed and from the distance
(``dtheta_eb = dtheta - C_n^b omega_ie_n dt``). A sensor's own beam misalignment relative to v
is second order (a cosine) and not modelled here.

This is paper 000's model (eq. 8-11): a mounting angle left out of ``C_bm`` is a first-order
heading or pitch error of the DR (``dV_n = (V_n x) C_b^n A``), which the alignment filters
estimate.

Distance increments: a sensor that gives ``ds`` is used as such (its cumulative distance is
interpolated linearly to the IMU epochs); one that gives only ``v`` is integrated by the
trapezoid first. The sensor runs on its own rate; its distance is interpolated to the IMU
epochs, never extrapolated: IMU rows before the sensor's first sample or after its last get no
distance and zero speed (the position is held, up to the lever-arm term of a rotation) and are
counted in ``Solution.info``. Across a
gap in the sensor's data (longer than ``max_gap``) the distance is interpolated between the
samples on either side (the distance a ``ds`` sensor reports after a gap covers the gap) and the
rows are counted too.

``scale`` multiplies the sensor's output (``ds`` and ``v``): with a sensor reading
``(1 + dk)`` times the truth, ``scale = 1 / (1 + dk)`` corrects it.
"""
from __future__ import annotations

import numpy as np

from .. import _aot
from . import _kernels as K
from .bundle import ImuData, SpeedData, regroup
from .mechanization import (CHUNK_ROWS, _check_finite, _check_time, _correct, _first_row,
                            _intervals, _KernelStream, _out_buffers, _SolutionBuilder,
                            typical_period)
from .solution import NavState, Solution
from ..errors import BadInput

__all__ = ["dead_reckon", "DeadReckoner", "speed_on_epochs", "speed_resampler"]


def _check_mounting(C_bm, lever_arm_b, scale):
    C = np.eye(3) if C_bm is None else np.asarray(C_bm, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)):
        raise BadInput(f"C_bm (sensor-to-body mounting matrix) must be a finite 3x3 matrix, "
                       f"got shape {C.shape}")
    if np.abs(C @ C.T - np.eye(3)).max() > 1e-6 or np.linalg.det(C) < 0:
        raise BadInput("C_bm (sensor-to-body mounting matrix) is not a rotation matrix "
                       f"(|C C^T - I| = {np.abs(C @ C.T - np.eye(3)).max():.3g}, "
                       f"det = {np.linalg.det(C):.6g})")
    l_b = np.zeros(3) if lever_arm_b is None else np.asarray(lever_arm_b, dtype=float)
    if l_b.shape != (3,) or not np.all(np.isfinite(l_b)):
        raise BadInput(f"lever_arm_b must be 3 finite numbers [m], got {l_b!r}")
    if not (np.isfinite(scale) and scale > 0):
        raise BadInput(f"scale must be a finite number > 0, got {scale}")
    return np.ascontiguousarray(C), np.ascontiguousarray(l_b), float(scale)


def _check_speed(speed: SpeedData, what: str):
    if len(speed.t) < 2:
        raise BadInput(f"need at least 2 samples, got {len(speed.t)}", file=what)
    _check_time(speed.t, what)
    for name in ("v", "ds"):
        val = getattr(speed, name)
        if val is not None:
            k = _aot.first_nonfinite_row(val.reshape(-1, 1))
            if k >= 0:
                raise BadInput(f"{name} is not a finite number ({val[k]})", file=what,
                               row=k + 1, time=float(speed.t[k]))


class _WholeSamples:
    """A sensor's samples in memory, as :class:`_SpeedOnEpochs` reads them: ``n``, the first
    and last times, ``locate`` (the samples around a stretch of time) and ``seg`` (the
    samples ``lo .. hi - 1``: views). A sensor read in chunks gives the same from a buffer
    (:meth:`inmotion.io.bundle_stream.SpeedStream.samples`)."""

    def __init__(self, speed: SpeedData):
        self.speed = speed
        self.n = len(speed.t)
        self.t_first, self.t_last = speed.t[0], speed.t[-1]

    def typical_period(self) -> float:
        return typical_period(self.speed.t)

    def locate(self, t0, t1):
        """``(lo, hi)``: one sample before the last sample <= ``t0`` and one after the first
        sample >= ``t1`` (at least two samples)."""
        ts, n = self.speed.t, self.n
        lo = int(np.clip(np.searchsorted(ts, t0, side="right") - 2, 0, n - 2))
        hi = int(np.clip(np.searchsorted(ts, t1, side="left") + 2, lo + 2, n))
        return lo, hi

    def seg(self, lo, hi):
        sp = self.speed
        return (sp.t[lo:hi], None if sp.v is None else sp.v[lo:hi],
                None if sp.ds is None else sp.ds[lo:hi])


class _SpeedOnEpochs:
    """A velocity sensor resampled to IMU epochs, one chunk of epochs per call
    (see :func:`speed_on_epochs`).

    Calls normally come in time order; the sensor's cumulative distance is then carried from
    call to call, so every temporary is the size of the chunk's stretch of sensor data, never
    of the whole log (a call going back in time sums again from the first sample; a sensor
    read in chunks, ``speed`` with a ``samples()`` method, only goes forward).
    """

    def __init__(self, speed: SpeedData, max_gap: float | None = None, what: str = "speed"):
        if hasattr(speed, "samples"):       # read in chunks: the rows were checked on reading
            self.src = speed.samples()
        else:
            _check_speed(speed, what)
            self.src = _WholeSamples(speed)
        self.max_gap = (5.0 * self.src.typical_period() if max_gap is None
                        else float(max_gap))
        self._j = 0             # the sensor sample whose cumulative distance is carried
        self._dist = 0.0        # cumulative distance [m] at sample _j (0 at sample 0)

    @staticmethod
    def _increments(tl, vl, dsl):
        """Distance [m] of the sensor intervals ending at the samples ``1 ..`` of a segment."""
        if dsl is not None:
            return dsl[1:]
        return 0.5 * (vl[1:] + vl[:-1]) * np.diff(tl)

    def _distance_at(self, j):
        """Cumulative distance [m] at sensor sample ``j``."""
        if j < self._j:
            self._j, self._dist = 0, 0.0
        self._dist += float(np.sum(self._increments(*self.src.seg(self._j, j + 1))))
        self._j = j
        return self._dist

    def __call__(self, t):
        src = self.src
        # the sensor samples around the chunk: one before the last sample <= t[0] and one after
        # the first sample >= t[-1] (the speed of a ds sensor is interpolated between midpoints)
        lo, hi = src.locate(t[0], t[-1])
        d0 = self._distance_at(lo)
        tl, vl, dsl = src.seg(lo, hi)
        dist = np.empty(hi - lo)
        dist[0] = d0
        dist[1:] = dist[0] + np.cumsum(self._increments(tl, vl, dsl))
        ds = np.diff(np.interp(t, tl, dist))
        if vl is not None:
            v = np.interp(t[1:], tl, vl)
        else:   # interval mean speeds, placed at the interval midpoints, interpolated
            v = np.interp(t[1:], 0.5 * (tl[1:] + tl[:-1]), dsl[1:] / np.diff(tl))
        uncovered = (t[:-1] < src.t_first - 1e-9) | (t[1:] > src.t_last + 1e-9)
        ds[uncovered] = 0.0
        v[uncovered] = 0.0
        gap = np.diff(tl) > self.max_gap
        if not gap.any():           # no gap among these samples (the rule: half the cost)
            return ds, v, uncovered, np.zeros(len(t) - 1, dtype=bool)
        # gaps_upto[j]: how many of the intervals (tl[i-1], tl[i]], i = 1..j, are gaps;
        # the IMU interval (ta, tb] overlaps the sensor intervals j_a..j_b
        gaps_upto = np.concatenate([[0], np.cumsum(gap)])
        last = len(tl) - 1
        j_a = np.clip(np.searchsorted(tl, t[:-1], side="right"), 1, last)
        j_b = np.clip(np.searchsorted(tl, t[1:], side="left"), 1, last)
        in_gap = (j_b >= j_a) & (gaps_upto[j_b] - gaps_upto[j_a - 1] > 0)
        return ds, v, uncovered, in_gap


def speed_on_epochs(speed: SpeedData, t: np.ndarray, max_gap: float | None = None,
                    what: str = "speed"):
    """A velocity sensor's distance increments and speed on the IMU epochs.

    Parameters
    ----------
    speed : SpeedData
        ``ds`` [m] over the interval ending at each ``t``, or speed ``v`` [m/s] at ``t``.
    t : (M + 1,) s
        IMU epochs: ``t[0]`` is the start, ``t[1:]`` the ends of the M intervals.
    max_gap : float, optional
        Sensor intervals longer than this [s] are gaps; default 5 median sensor periods
        (median over the first 65536 intervals).
    what : str
        The sensor's name for error messages (``radar``, ``ldv``, ``odometer``).

    Returns
    -------
    ds : (M,) m, distance over each IMU interval (0 where not covered by the sensor)
    v : (M,) m/s, speed at each interval's end (0 where not covered): ``v`` interpolated, or
        for a ``ds``-only sensor its interval mean speeds ``ds / dt`` placed at the interval
        midpoints and interpolated (second order; held in the last half interval)
    uncovered : (M,) bool, intervals not (entirely) inside the sensor's span
    in_gap : (M,) bool, intervals that overlap a sensor gap (distance interpolated across it)
    """
    return _SpeedOnEpochs(speed, max_gap, what)(np.asarray(t, dtype=float))


def speed_resampler(speed, max_gap: float | None = None, what: str = "speed"):
    """:func:`speed_on_epochs` for consecutive chunks of epochs: ``r = speed_resampler(...)``,
    then ``r(t)`` per chunk (``t`` (M + 1,) [s] as :func:`speed_on_epochs`' ``t``, the chunks
    in time order, each starting where the last ended) returns what :func:`speed_on_epochs`
    returns, with the sensor's cumulative distance carried from chunk to chunk (not summed
    again from the first sample: linear time in the log's length) and, for a sensor read in
    chunks (:class:`inmotion.io.bundle_stream.SpeedStream`), only a chunk's rows in memory.
    The distances differ from :func:`speed_on_epochs` on each chunk by rounding only (the
    cumulative distance is a sum of per-chunk sums). ``max_gap`` [s]: as
    :func:`speed_on_epochs` (default 5 median sensor periods)."""
    return _SpeedOnEpochs(speed, max_gap, what)


class DeadReckoner(_KernelStream):
    """Streaming dead reckoning: advance over chunks, read the state, feed back corrections.

    Parameters
    ----------
    init : NavState
        Starting state of the IMU point at ``init.t`` (its velocity seeds only the first
        transport-rate evaluation; afterwards the velocity comes from the sensor).
    C_bm : (3, 3), optional
        ``C_m^b = C_v^b``: the frame the vehicle moves along (forward y) to body. Identity by
        default.
    lever_arm_b : (3,), optional
        IMU-to-sensor lever arm [m] in b. Zero by default.
    scale : float
        Multiplies the sensor's output.
    """

    def __init__(self, init: NavState, C_bm=None, lever_arm_b=None, scale: float = 1.0):
        self.C_bm, self.l_b, self.scale = _check_mounting(C_bm, lever_arm_b, scale)
        self._start(init)

    def run(self, dtheta, t, ds, v, out_stride: int = 0):
        """Advance over M rows: gyro increments ``dtheta`` (M, 3) [rad] over the intervals
        ending at ``t`` (M,) [s], the sensor's distance ``ds`` (M,) [m] over the same intervals
        and its speed ``v`` (M,) [m/s] at ``t`` (see :func:`speed_on_epochs`). With
        ``out_stride > 0`` returns ``(t_out, x_out)`` as :meth:`Strapdown.run` does."""
        dtheta = np.ascontiguousarray(dtheta, dtype=float).reshape(-1, 3)
        t = np.ascontiguousarray(t, dtype=float).reshape(-1)
        ds = np.ascontiguousarray(ds, dtype=float).reshape(-1) * self.scale
        v = np.ascontiguousarray(v, dtype=float).reshape(-1) * self.scale
        if not (len(dtheta) == len(t) == len(ds) == len(v)):
            raise BadInput(f"dead-reckoning chunk: dtheta ({len(dtheta)}), t ({len(t)}), "
                           f"ds ({len(ds)}) and v ({len(v)}) must have the same number of rows")
        dt = _intervals(t, self.t, "imu", self.rows)
        _check_finite(dtheta, t, "dtheta", "imu", self.rows)
        _check_finite(ds, t, "ds", "speed", self.rows)
        _check_finite(v, t, "v", "speed", self.rows)
        out_rows, out_x = _out_buffers(len(t), out_stride)
        n = K.dr_run(self._x, self._mem, dtheta, ds, v, dt, self.C_bm, self.l_b,
                     int(out_stride), out_rows, out_x)
        return self._finish_chunk(t, n, out_rows, out_x, out_stride)

    def correct(self, phi=None, dpos=None):
        """Feedback of estimated DR errors (computed minus true): ``phi`` [rad] misalignment
        (DESIGN convention; ``q <- q(phi) (x) q``), ``dpos = [dlat rad, dlon rad, dh m]``
        subtracted from the position. The velocity follows from the sensor at the next row."""
        _correct(self._x, self._mem, phi, None, dpos)


def dead_reckon(imu: ImuData, speed: SpeedData, init: NavState, *, C_bm=None,
                lever_arm_b=None, scale: float = 1.0, out_stride: int = 1,
                max_gap: float | None = None) -> Solution:
    """Pure dead reckoning over a log.

    Parameters
    ----------
    imu : ImuData
        Gyro increments (``dvel`` is not used); rows with ``t > init.t`` are processed.
    speed : SpeedData
        The forward-velocity sensor (``ds`` preferred when given, else ``v``).
    init : NavState
        Start of the IMU point at ``init.t``.
    C_bm, lever_arm_b, scale : see :class:`DeadReckoner`.
    out_stride : int
        Output the initial state and then every ``out_stride``-th state.
    max_gap : float, optional
        Sensor gap threshold [s] (default 5 sensor periods).

    Returns
    -------
    Solution; ``info`` counts the IMU rows with no sensor coverage and inside sensor gaps.
    """
    k0 = _first_row(imu.t, init.t)
    return dead_reckon_rows(len(imu.t) - k0, [(imu.t[k0:], imu.dtheta[k0:])], speed, init,
                            C_bm=C_bm, lever_arm_b=lever_arm_b, scale=scale,
                            out_stride=out_stride, max_gap=max_gap, first_row=k0)


def dead_reckon_rows(n_rows: int, pieces, speed: SpeedData, init: NavState, *, C_bm=None,
                     lever_arm_b=None, scale: float = 1.0, out_stride: int = 1,
                     max_gap: float | None = None, first_row: int = 0) -> Solution:
    """:func:`dead_reckon` on the ``n_rows`` IMU rows after ``init.t`` given in ``pieces``
    (consecutive ``(t, dtheta, ...)`` blocks of any sizes, e.g. a log read in chunks); they
    are regrouped into :func:`dead_reckon`'s chunks, so the result does not depend on the
    pieces. ``first_row``: the index of the first row in the log, for error messages."""
    if int(out_stride) < 1:
        raise BadInput(f"out_stride must be >= 1, got {out_stride}")
    resample = _SpeedOnEpochs(speed, max_gap)
    dr = DeadReckoner(init, C_bm=C_bm, lever_arm_b=lever_arm_b, scale=scale)
    dr.rows = first_row         # error messages give the row of the whole log
    out = _SolutionBuilder(n_rows, int(out_stride), init.t, dr.x)
    n_uncovered, n_gap = 0, 0
    t_prev = init.t
    for block in regroup(pieces, CHUNK_ROWS):          # chunks: temporaries stay small
        t, dtheta = block[0], block[1]
        ds, v, uncovered, in_gap = resample(np.concatenate([[t_prev], t]))
        n_uncovered += int(uncovered.sum())
        n_gap += int(in_gap.sum())
        out.add(*dr.run(dtheta, t, ds, v, out_stride=int(out_stride)))
        t_prev = t[-1]
    info = {"method": "dead_reckon", "scale": float(scale), "rows": int(n_rows),
            "rows_without_speed": n_uncovered, "rows_in_speed_gaps": n_gap}
    return out.solution(info)
