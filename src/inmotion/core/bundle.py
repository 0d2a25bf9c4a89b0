"""One drive in memory: the sensors' data and, where known, the truth, all in SI units.

This is the in-memory twin of the bundle folder of ``docs/bundle.md``. Files (degrees,
CSV/Parquet, validation) are the business of :mod:`inmotion.io.bundle`; here every angle is
in rad, latitude and longitude in rad, and every array is float64 on one time base ``t`` [s].

Methods take a :class:`Bundle` and never read files.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import rotations

__all__ = ["ImuData", "SpeedData", "BaroData", "Truth", "Bundle", "VELOCITY_SENSORS",
           "regroup"]

#: the forward-velocity sensors a bundle may carry, by file name
VELOCITY_SENSORS = ("radar", "ldv", "odometer")


def _as_1d(name, x):
    x = np.ascontiguousarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {x.shape}")
    return x


def _as_n3(name, x, n):
    x = np.ascontiguousarray(x, dtype=float)
    if x.shape != (n, 3):
        raise ValueError(f"{name} must have shape ({n}, 3), got {x.shape}")
    return x


@dataclass
class ImuData:
    """Angle increments ``dtheta`` [rad] and velocity increments ``dvel`` [m/s] in b, (N, 3),
    each over the interval ending at ``t`` [s] (N,)."""

    t: np.ndarray
    dtheta: np.ndarray
    dvel: np.ndarray

    def __post_init__(self):
        self.t = _as_1d("imu.t", self.t)
        self.dtheta = _as_n3("imu.dtheta", self.dtheta, len(self.t))
        self.dvel = _as_n3("imu.dvel", self.dvel, len(self.t))

    @property
    def dt(self) -> float:
        """Median sample period [s]."""
        return float(np.median(np.diff(self.t)))

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "ImuData":
        m = _mask(self.t, start, end)
        return ImuData(self.t[m], self.dtheta[m], self.dvel[m])


@dataclass
class SpeedData:
    """A forward-velocity sensor: speed ``v`` [m/s] at ``t``, or distance increments ``ds`` [m]
    over the interval ending at ``t``; at least one of the two is given."""

    t: np.ndarray
    v: Optional[np.ndarray] = None
    ds: Optional[np.ndarray] = None

    def __post_init__(self):
        self.t = _as_1d("t", self.t)
        if self.v is None and self.ds is None:
            raise ValueError("a velocity sensor needs 'v' or 'ds'")
        if self.v is not None:
            self.v = _as_1d("v", self.v)
        if self.ds is not None:
            self.ds = _as_1d("ds", self.ds)

    def speed(self) -> np.ndarray:
        """Speed [m/s]: ``v`` if given, else ``ds`` over its interval (first interval: the next)."""
        if self.v is not None:
            return self.v
        dt = np.diff(self.t)
        dt = np.concatenate([dt[:1], dt]) if len(dt) else np.ones(1)
        return self.ds / dt

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "SpeedData":
        m = _mask(self.t, start, end)
        return SpeedData(self.t[m], None if self.v is None else self.v[m],
                         None if self.ds is None else self.ds[m])

    def dropout(self, start: float, end: float) -> "SpeedData":
        """The sensor without its samples strictly between ``start`` and ``end`` [s]: a
        dropout, as a gap the methods see (``velocity_aided.READS_SPEED``). Speeds are kept
        as they are; for distance increments the first sample after the gap carries the
        distance over it (a pulse counter keeps counting)."""
        keep = (self.t <= start) | (self.t >= end)
        if self.ds is None:
            return SpeedData(self.t[keep], v=self.v[keep])
        d = np.cumsum(self.ds)[keep]
        return SpeedData(self.t[keep], None if self.v is None else self.v[keep],
                         np.concatenate([d[:1], np.diff(d)]))


@dataclass
class BaroData:
    """Barometric altitude ``h`` [m] at ``t`` [s]."""

    t: np.ndarray
    h: np.ndarray

    def __post_init__(self):
        self.t = _as_1d("baro.t", self.t)
        self.h = _as_1d("baro.h", self.h)

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "BaroData":
        m = _mask(self.t, start, end)
        return BaroData(self.t[m], self.h[m])


@dataclass
class Truth:
    """Reference trajectory: ``lat, lon`` [rad], ``h`` [m], ``vel_n`` ENU [m/s] (N, 3),
    ``euler`` = ``[pitch, roll, yaw]`` [rad] (N, 3), at ``t`` [s]."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    vel_n: np.ndarray
    euler: np.ndarray
    #: cumulative 3-D path length [m] at each row, measured along the full-rate table, when
    #: these rows are a subset of it (a table read in chunks keeps only the rows that the
    #: errors at the output epochs need: :meth:`inmotion.io.bundle_stream.TruthStream.reduced`);
    #: None: the rows themselves are the full table
    path_length_m: Optional[np.ndarray] = None

    def __post_init__(self):
        self.t = _as_1d("truth.t", self.t)
        n = len(self.t)
        self.lat, self.lon, self.h = (_as_1d(k, getattr(self, k)) for k in ("lat", "lon", "h"))
        self.vel_n = _as_n3("truth.vel_n", self.vel_n, n)
        self.euler = _as_n3("truth.euler", self.euler, n)
        if self.path_length_m is not None:
            self.path_length_m = _as_1d("truth.path_length_m", self.path_length_m)

    @property
    def C_nb(self) -> np.ndarray:
        return rotations.dcm_from_euler(self.euler)

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "Truth":
        m = _mask(self.t, start, end)
        return Truth(self.t[m], self.lat[m], self.lon[m], self.h[m], self.vel_n[m], self.euler[m],
                     None if self.path_length_m is None else self.path_length_m[m])

    def at(self, t: float) -> dict:
        """The truth row at time ``t`` (the first at or after ``t``, :func:`row_at_or_after`);
        used by ``--init truth``."""
        i = int(row_at_or_after(self.t, t))
        return dict(t=self.t[i], lat=self.lat[i], lon=self.lon[i], h=self.h[i],
                    vel_n=self.vel_n[i].copy(), euler=self.euler[i].copy())


@dataclass
class Bundle:
    """One drive. ``meta`` is the content of ``meta.yaml`` (human units, as in the file)."""

    imu: ImuData
    meta: dict = field(default_factory=dict)
    radar: Optional[SpeedData] = None
    ldv: Optional[SpeedData] = None
    odometer: Optional[SpeedData] = None
    baro: Optional[BaroData] = None
    truth: Optional[Truth] = None

    @property
    def name(self) -> str:
        return str(self.meta.get("name", "unnamed"))

    def velocity_sensor(self, which: Optional[str] = None) -> tuple[str, SpeedData]:
        """The named forward-velocity sensor, or the first present of radar, ldv, odometer."""
        names = [which] if which else list(VELOCITY_SENSORS)
        for n in names:
            if n not in VELOCITY_SENSORS:
                raise ValueError(f"unknown velocity sensor {n!r}; choose from {VELOCITY_SENSORS}")
            if getattr(self, n) is not None:
                return n, getattr(self, n)
        raise ValueError(f"bundle {self.name!r} has no velocity sensor"
                         + (f" {which!r}" if which else f" (looked for {', '.join(names)})"))

    def imu_rows_after(self, t0: float, min_rows: int = 2):
        """``(n_rows, period_s, pieces, first_row)``: the number of IMU rows after ``t0`` [s]
        (a 1 us tolerance, :func:`inmotion.core.mechanization.start_row`; :class:`BadInput`
        when fewer than ``min_rows``), the median IMU period [s], the rows as one piece
        ``[(t, dtheta, dvel)]`` and the index of the first of them in the table. A bundle
        read in chunks (:class:`inmotion.io.bundle_stream.BundleStream`) answers the same with
        its rows in pieces as they are read; methods that stream their input take either."""
        from .mechanization import start_row
        imu = self.imu
        k0 = start_row(imu.t, t0, min_rows)
        return (len(imu.t) - k0, float(np.median(np.diff(imu.t))),
                [(imu.t[k0:], imu.dtheta[k0:], imu.dvel[k0:])], k0)

    def load_window(self, start: Optional[float] = None, end: Optional[float] = None,
                    truth: bool = False) -> "Bundle":
        """The drive cut to ``start <= t <= end`` [s] with its IMU rows in memory: here
        :meth:`window` (``truth``: ignored, in memory already); a bundle read in chunks
        (:meth:`inmotion.io.bundle_stream.BundleStream.load_window`) reads only the rows of
        the window (the truth's too with ``truth``). A method that needs a window's IMU rows
        as arrays takes them from it."""
        return self.window(start, end)

    def window(self, start: Optional[float] = None, end: Optional[float] = None) -> "Bundle":
        """The same drive cut to ``start <= t <= end`` [s] (None: open)."""
        def cut(x):
            return None if x is None else x.window(start, end)
        return Bundle(self.imu.window(start, end), dict(self.meta), cut(self.radar), cut(self.ldv),
                      cut(self.odometer), cut(self.baro), cut(self.truth))


def row_at_or_after(t_all, t, tol_s: float = 0.0):
    """Index into the increasing time base ``t_all`` [s] of the first sample at or after
    ``t - tol_s`` (``t`` [s] scalar or array), clipped to ``[0, len(t_all) - 1]``: a time past
    the end gives the last row. ``tol_s`` [s] absorbs rounding of times that are meant to fall
    on a sample. Returns a numpy integer (array for an array ``t``)."""
    return np.clip(np.searchsorted(t_all, np.asarray(t) - tol_s), 0, len(t_all) - 1)


def _mask(t, start, end):
    m = np.ones(len(t), dtype=bool)
    if start is not None:
        m &= t >= start
    if end is not None:
        m &= t <= end
    return m


def regroup(pieces, size: int):
    """Consecutive row blocks (tuples of arrays of equal length) regrouped into blocks of
    exactly ``size`` rows (the last may be shorter). A block inside one piece is a view of
    it; one that spans pieces is copied together. Memory: one block, whatever the log's
    length."""
    held, n_held = [], 0
    for piece in pieces:
        n = len(piece[0])
        a = 0
        while a < n:
            take = min(size - n_held, n - a)
            held.append(tuple(x[a:a + take] for x in piece))
            n_held += take
            a += take
            if n_held == size:
                yield _join(held)
                held, n_held = [], 0
    if n_held:
        yield _join(held)


def _join(parts):
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(len(parts[0])))
