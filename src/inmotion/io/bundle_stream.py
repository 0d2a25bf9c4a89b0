"""A bundle folder read in chunks: the command line's run path for methods that stream.

:func:`read_bundle` loads every table whole, so a run's memory grows with the log (about
70 MiB per hour of a 100 Hz drive with truth). :func:`open_bundle` checks the same things,
reads the same files and answers the same questions, but holds only what does not grow with
the log:

* the IMU and truth tables (100 Hz, the bulk of a bundle) stay on disk. Opening reads their
  time columns once (the median period, the IMU rate, gaps and the clocks need the whole
  column) and keeps only the span; their rows are read in chunks of :data:`CHUNK_ROWS` when a
  method runs (:meth:`BundleStream.imu_rows_after`: the pieces a streaming method feeds to its
  filter) and, for the truth, when the errors are written (:meth:`TruthStream.reduced`: only
  the rows the errors at the output epochs need);
* velocity-sensor and barometer tables (10 Hz, two columns: under a megabyte per hour) are
  read whole, as :func:`read_bundle` reads them, but chunk by chunk with no pandas; a
  velocity sensor faster than :data:`STREAM_SENSOR_RATE_HZ` with more rows than a chunk (an
  LDV at 100 Hz: 5.5 MiB per hour) is checked chunk by chunk when the bundle is opened and
  stays on disk (:class:`SpeedStream`): the aided filters and ``dead_reckon_rows`` resample
  it chunk by chunk (:func:`inmotion.core.deadreckoning.speed_resampler`), other readers get
  its columns read whole when they ask (not kept).

Parquet is read with ``pyarrow`` (``ParquetFile.iter_batches``), CSV with pandas in chunks.

Validation is :func:`read_bundle`'s, made per chunk, with row numbers counted over the whole
table: a bad value in the third chunk raises one :class:`BadInput` naming the file, the row
and the time. Checks that need the whole table (median period, gaps, clocks) run when the
bundle is opened; those that need all rows of a column (the mean specific force, the truth's
position-velocity agreement) run when the last chunk has been read, before any result is
written. A file with one fault gives :func:`read_bundle`'s message; with several faults the
first found in reading order is reported (:func:`read_bundle` checks column by column).
Rows after ``--end`` are still read and checked.

:class:`BundleStream` has the attributes methods and the command line use of a
:class:`~inmotion.core.bundle.Bundle` (``meta``, ``name``, ``radar`` ... ``baro``,
``velocity_sensor``, ``window``, ``imu.t``, ``truth.t``, ``truth.at``); methods that stream
their input (``sins-dr``, ``dr-kf``, ``od-velocity-kf``) take their rows from
:meth:`BundleStream.imu_rows_after`, as they take them from
:meth:`inmotion.core.bundle.Bundle.imu_rows_after` in memory, so both give the same result.
"""
from __future__ import annotations

import threading
from collections import namedtuple
from pathlib import Path
from typing import Optional

import numpy as np

from ..core.bundle import (VELOCITY_SENSORS, Bundle, ImuData, SpeedData, Truth,
                           row_at_or_after)
from .._read_ahead import READ_AHEAD, one_malloc_arena, read_ahead  # noqa: F401 (re-exported)
from ..errors import BadInput
from . import bundle as B

__all__ = ["open_bundle", "BundleStream", "TruthStream", "TruthReducer", "SpeedStream",
           "CHUNK_ROWS", "STREAM_SENSOR_RATE_HZ"]

#: rows per chunk read from the IMU and truth tables
CHUNK_ROWS = 65536
#: rows per chunk of the truth table read by :class:`TruthReducer`'s thread (it runs beside
#: the method: two such chunks, the current one and the next one's first row, in memory)
TRUTH_THREAD_ROWS = 16384


# --------------------------------------------------------------------------- one table

def _parquet_reader(path, memory_pool=None, **options):
    """An open ``pyarrow._parquet.ParquetReader`` of the file ``path`` (``options``: those of
    its ``open``, e.g. ``buffer_size``, ``pre_buffer``): the reader ``pyarrow.parquet.
    ParquetFile`` wraps, made without importing ``pyarrow.parquet``, whose import of Arrow's
    file systems (S3, GCS, Azure, TLS) costs 0.02 s of CPU in every command-line run; through
    ``ParquetFile`` if this pyarrow has no such reader."""
    try:
        from pyarrow._parquet import ParquetReader
        reader = ParquetReader(memory_pool) if memory_pool is not None else ParquetReader()
    except (ImportError, AttributeError, TypeError):
        import pyarrow.parquet as pq
        return pq.ParquetFile(path, memory_pool=memory_pool, **options).reader
    reader.open(str(path), **options)
    return reader


class _Table:
    """One table file, read in chunks of rows; every chunk checked as :func:`read_bundle`
    checks the whole table (numeric, finite, time strictly increasing)."""

    def __init__(self, path: Path, chunk_rows: int, system_pool: bool = False):
        self.path = path
        self.chunk_rows = max(2, int(chunk_rows))
        self.parquet = B.SUFFIXES.get(path.suffix) == "parquet"
        try:
            if self.parquet:
                # a buffered stream of the column chunks, not each chunk whole in memory;
                # system_pool: Arrow's buffers from malloc, not its default pool (below)
                pool = None
                if system_pool:
                    import pyarrow as pa
                    pool = pa.system_memory_pool()
                self._pf = _parquet_reader(path, pool, buffer_size=1 << 20, pre_buffer=False)
                raw = [str(c) for c in self._pf.schema_arrow.names]
                n = self._pf.metadata.num_rows
            else:
                import pandas as pd
                raw = [str(c) for c in pd.read_csv(path, nrows=0, skipinitialspace=True).columns]
                n = None
        except Exception as e:
            raise B.cannot_read(e, path) from None
        self.raw = {c.strip(): c for c in raw}
        self.columns = list(self.raw)
        self._t = None          # the time column, kept from opening until rows are read
        if n == 0:
            raise BadInput("table has no data rows", file=path)

    def _frames(self, names, first_row: int = 0, chunk_rows: Optional[int] = None):
        """Raw chunks ``(offset, {name: column})`` (pyarrow arrays or pandas Series);
        ``first_row``: a Parquet file skips the row groups that end before it (the first
        chunk yielded may still start before it)."""
        try:
            if self.parquet:
                md = self._pf.metadata
                groups, offset, start = [], 0, None
                for g in range(md.num_row_groups):
                    n = md.row_group(g).num_rows
                    if offset + n > first_row:
                        groups.append(g)
                        start = offset if start is None else start
                    offset += n
                if not groups:
                    return
                offset = start
                cols = [self._pf.column_name_idx(self.raw[c]) for c in names]
                for batch in self._pf.iter_batches(chunk_rows or self.chunk_rows, groups,
                                                   column_indices=cols, use_threads=False):
                    yield offset, {c: batch.column(i) for i, c in enumerate(names)}
                    offset += batch.num_rows
            else:
                import pandas as pd
                offset = 0
                for df in pd.read_csv(self.path, skipinitialspace=True,
                                      chunksize=chunk_rows or self.chunk_rows):
                    df.columns = [str(c).strip() for c in df.columns]
                    yield offset, {c: df[c] for c in names}
                    offset += len(df)
        except BadInput:
            raise
        except Exception as e:
            raise B.cannot_read(e, self.path) from None

    def chunks(self, names, rows=None, chunk_rows: Optional[int] = None):
        """Yield ``(offset, {name: float64 array})``: the named columns (``t`` first) of
        consecutive chunks, ``offset`` rows before each; BadInput at the first bad row.
        ``rows = (a, b)``: only the table's rows ``a <= row < b`` (a time-filtered read:
        the chunks that hold them are read and checked, Parquet row groups before ``a``
        skipped, reading stops after ``b``); ``chunk_rows``: rows per chunk (default the
        table's)."""
        names = ("t",) + tuple(c for c in names if c != "t")
        B.missing_columns(self.columns, names, self.path)
        self._t = None          # reading rows: the time column is not kept meanwhile
        a, b = (0, None) if rows is None else (int(rows[0]), int(rows[1]))
        seen, t_prev = 0, None
        for offset, frame in self._frames(names, a, chunk_rows):
            n = len(frame["t"])
            if n == 0:
                continue
            if b is not None and offset >= b:
                break
            if offset + n <= a:
                continue
            if rows is not None:            # the part of the chunk inside the rows asked for
                lo, hi = max(a - offset, 0), n if b is None else min(b - offset, n)
                frame = {c: (v.iloc[lo:hi] if hasattr(v, "iloc") else v[lo:hi])
                         for c, v in frame.items()}
                offset += lo
            t = B._numeric(frame, "t", self.path, None, offset)
            out = {"t": t}
            for c in names[1:]:
                out[c] = B._numeric(frame, c, self.path, t, offset)
            B._check_increasing(t, self.path, offset, t_prev)
            yield offset, out
            seen += len(t)
            t_prev = t[-1]
        if seen == 0 and rows is None:
            raise BadInput("table has no data rows", file=self.path)

    def read(self, names) -> dict:
        """The named columns whole (a small table)."""
        parts = [c for _, c in self.chunks(names)]
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}

    def times(self) -> np.ndarray:
        """The ``t`` column whole, checked. Kept for the questions asked before a method runs
        (rate, clocks, window, start); forgotten when rows are read, read again after."""
        if self._t is not None:
            return self._t
        B.missing_columns(self.columns, ("t",), self.path)
        if not self.parquet:
            t = self.read(("t",))["t"]
        else:
            # chunk by chunk into one array: Arrow holds one chunk at a time, not the whole
            # column twice (read, then combined), which its allocator would keep afterwards
            t = np.empty(self._pf.metadata.num_rows)
            for offset, c in self.chunks(("t",)):
                t[offset:offset + len(c["t"])] = c["t"]
        self._t = t
        return t


# --------------------------------------------------------------------------- the IMU

class _Times:
    """What a method or the command line asks of a table's time base: ``.t`` (read from the
    file on each use, windowed; nothing is kept)."""

    def __init__(self, table: _Table, window):
        self._table, self._window = table, window

    @property
    def t(self) -> np.ndarray:
        return self._span()[0]

    @property
    def dt(self) -> float:
        """Median sample period [s] of the (windowed) times, as :attr:`ImuData.dt`."""
        return float(np.median(np.diff(self.t)))

    def _span(self):
        """``(t, w0)``: the windowed times (a view of the whole column) and the index of the
        first of them in the whole table (``_mask`` of an increasing column is one run)."""
        t = self._table.times()
        w0, w1 = _window_rows(t, self._window)
        return t[w0:w1], w0

    def _span_rows(self) -> tuple:
        """``(w0, w1)``: the rows ``w0 <= row < w1`` of :meth:`_span`, the time column read
        chunk by chunk unless it is kept (not held whole: :class:`TruthReducer`'s thread)."""
        if self._table._t is not None:
            return _window_rows(self._table._t, self._window)
        lo, hi = self._window
        a = b = n = 0
        for _, c in self._table.chunks(("t",)):       # checked increasing across chunks
            t = c["t"]
            n += len(t)
            if lo is not None:
                a += int(np.searchsorted(t, lo, side="left"))
            if hi is not None:
                b += int(np.searchsorted(t, hi, side="right"))
        return (0 if lo is None else a), max(0 if lo is None else a, n if hi is None else b)


class _TimesOf(_Times):
    """``.t`` / ``.dt`` of a time base given as an array (a wrapper's IMU, no rows)."""

    def __init__(self, t):
        self._t_all = t

    def _span(self):
        return self._t_all, 0


class _ImuChecks:
    """:func:`inmotion.io.bundle.check_imu`'s per-row checks made chunk by chunk: angular
    rate and specific force limits, the turn rate over every second (a window of one second
    carried across chunks, the cumulative sums carried exactly), the mean specific force at
    the end."""

    def __init__(self, path, period: float, t0: float, t1: float, t_last: float):
        self.path, self.period = path, period
        self.t_prev = None
        self.f_sum, self.rows = 0.0, 0
        self.sustained = t_last - t0 >= 1.0          # as _check_sustained_rate
        self.tt = np.array([t0 - (t1 - t0)])         # its time and cumulative-angle rows,
        self.c = np.zeros((1, 3))                    # from the first not yet checked
        self.r = np.zeros(1)                         # and each row's |dtheta| / its step
        self.g0 = 0                                  # its index in the whole table's

    def add(self, offset, t, dtheta, dvel):
        if self.t_prev is None:                      # _row_dt: row 0 takes the median period
            d = np.concatenate([[self.period], np.diff(t)])
        else:
            d = np.diff(t, prepend=self.t_prev)
        norm = B.row_norm(dtheta)
        B._check_limit(norm / d, B.LIMITS["gyro_rate_rad_s"],
                       "angular rate |dtheta|/dt =", "rad/s", self.path, t, offset)
        f = B.row_norm(dvel) / d
        B._check_limit(f, B.LIMITS["specific_force_m_s2"], "specific force |dvel|/dt =",
                       "m/s^2", self.path, t, offset)
        self.f_sum += float(np.sum(f))
        self.rows += len(t)
        self.t_prev = t[-1]
        if self.sustained:
            self._sustained(t, dtheta, norm)

    def _sustained(self, t, dtheta, norm):
        """The windows of one second that end in the rows ``t`` (``norm``: ``|dtheta|`` of each
        row). Over a window the angle turned is at most the sum of its rows' ``|dtheta|``, so
        when no row of the carried and new rows turns faster than 0.99 of the limit over its
        own step (the windows' steps: ``tt``'s), no window can exceed it and the window rates
        are not computed (rounding of the cumulative sums is far below the 1 % margin);
        otherwise every window's rate is, as :func:`inmotion.io.bundle._check_sustained_rate`
        computes it."""
        c_new = np.cumsum(np.vstack([self.c[-1:], dtheta]), axis=0)[1:]
        r_new = norm / np.diff(t, prepend=self.tt[-1])
        self.tt = np.concatenate([self.tt, t])
        self.c = np.vstack([self.c, c_new])
        self.r = np.concatenate([self.r, r_new])
        tt, c = self.tt, self.c
        limit = B.LIMITS["sustained_rate_rad_s"]
        if np.max(self.r[1:]) < 0.99 * limit:            # no window can exceed the limit
            done = int(np.searchsorted(tt + 1.0, tt[-1], side="right"))
            j = None
        else:
            j = np.searchsorted(tt, tt + 1.0)
            done = int(np.searchsorted(j, len(tt)))      # j is non-decreasing
        if done and j is not None:
            jd = j[:done]
            dc, dt = c[jd] - c[:done], tt[jd] - tt[:done]
            # rows that may exceed the limit, found without a square root or a division
            # (|dc|^2 against (0.99 limit dt)^2: a margin far above rounding), then the rate of
            # those alone as _check_sustained_rate computes it: the same rows fail, with the
            # same value
            near = np.flatnonzero(np.einsum("ij,ij->i", dc, dc) > (0.99 * limit * dt) ** 2)
            rate = np.linalg.norm(dc[near], axis=1) / dt[near]
            over = rate > limit
            if over.any():
                m = int(np.argmax(over))
                k = int(near[m])
                # _check_sustained_rate's row and time: t row min(k, n - 1) = tt row k + 1
                raise B.sustained_rate_error(float(rate[m]), self.path, self.g0 + k + 1,
                                             float(tt[k + 1]))
        if done:
            self.tt, self.c, self.r = tt[done:], c[done:], self.r[done:]
            self.g0 += done

    def finish(self):
        if self.rows:
            B._check_gravity_mean(self.f_sum / self.rows, self.path)


class _ImuTable(_Times):
    """The IMU table: opened (time column checked whole), its rows read in chunks."""

    COLUMNS = B.IMU_COLUMNS

    def __init__(self, table: _Table, max_gap_periods: float, allow_imu_gaps: bool):
        super().__init__(table, (None, None))
        path = table.path
        B.missing_columns(table.columns, self.COLUMNS, path)
        t = table.times()
        if len(t) < 2:
            raise BadInput(f"the IMU table has {len(t)} row; it needs at least 2 (one interval)",
                           file=path, row=1, time=float(t[0]))
        self.period = float(np.median(np.diff(t)))
        lo, hi = B.LIMITS["imu_rate_hz"]
        if not lo <= 1.0 / self.period <= hi:
            raise BadInput(f"IMU rate {1.0 / self.period:.4g} Hz (median step "
                           f"{self.period:.4g}) is outside {lo:g} .. {hi:g} Hz: is t in "
                           "seconds?", file=path)
        B._check_gaps("imu", t, path, max_gap_periods, error=not allow_imu_gaps,
                      period=self.period)
        self.t_ends = (float(t[0]), float(t[1]), float(t[-1]))    # first, second, last
        self.path = path

    def chunks(self):
        """Yield ``(t, dtheta, dvel)`` chunks, every row checked."""
        chk = _ImuChecks(self.path, self.period, *self.t_ends)
        for offset, c in self._table.chunks(self.COLUMNS):
            dtheta = np.column_stack([c["dtheta_x"], c["dtheta_y"], c["dtheta_z"]])
            dvel = np.column_stack([c["dvel_x"], c["dvel_y"], c["dvel_z"]])
            chk.add(offset, c["t"], dtheta, dvel)
            yield c["t"], dtheta, dvel
        chk.finish()

    def rows(self, a: int, b: int) -> ImuData:
        """The table's rows ``a <= row < b`` in memory, read from the chunks that hold them
        (:meth:`pieces`) and checked as :meth:`chunks` checks them: the rate and
        specific-force limits per row (the first row's interval from the row before it), the
        turn rate over every second inside the rows, the mean specific force over them. Rows
        outside are neither read nor checked."""
        n = len(self._table.times())
        a, b = max(0, int(a)), min(n, int(b))
        if b - a < 1:
            return ImuData(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)))
        t = np.empty(b - a)
        dtheta, dvel = np.empty((b - a, 3)), np.empty((b - a, 3))
        i = 0
        for tc, dth, dvl in self.pieces(a, b):
            j = i + len(tc)
            t[i:j], dtheta[i:j], dvel[i:j] = tc, dth, dvl
            i = j
        return ImuData(t, dtheta, dvel)

    def pieces(self, a: int, b: int):
        """Yield the table's rows ``a <= row < b`` as ``(t, dtheta, dvel)`` pieces, a chunk at
        a time (a time-filtered read, :meth:`_Table.chunks` with ``rows``), checked as
        :meth:`rows` says, the checks that need all of them made after the last piece."""
        t_all = self._table.times()
        n = len(t_all)
        a, b = max(0, int(a)), min(n, int(b))
        if b - a < 1:
            return
        first = (float(t_all[a]), float(t_all[min(a + 1, n - 1)]), float(t_all[b - 1]))
        t_before = float(t_all[a - 1]) if a > 0 else None
        del t_all
        chk = _ImuChecks(self.path, self.period, *first)
        chk.t_prev, chk.g0 = t_before, a
        for offset, c in self._table.chunks(self.COLUMNS, rows=(a, b)):
            dtheta = np.column_stack([c["dtheta_x"], c["dtheta_y"], c["dtheta_z"]])
            dvel = np.column_stack([c["dvel_x"], c["dvel_y"], c["dvel_z"]])
            chk.add(offset, c["t"], dtheta, dvel)
            yield c["t"], dtheta, dvel
        chk.finish()


# --------------------------------------------------------------------------- a long sensor

#: a velocity sensor sampled faster than this [Hz] with more rows than a chunk (:data:`CHUNK_ROWS`)
#: stays on disk (:class:`SpeedStream`); slower ones (radar, odometer at 10 Hz: under a
#: megabyte per hour) are read whole
STREAM_SENSOR_RATE_HZ = 20.0


class SpeedStream:
    """A long velocity-sensor table (an LDV at 100 Hz: 5.5 MiB per hour) on disk, with what
    methods ask of a :class:`~inmotion.core.bundle.SpeedData`: ``t`` (the time column, kept
    as :meth:`_Table.times` keeps it), ``v`` and ``ds`` (read whole when asked, not kept:
    ``None`` for a column the table does not have), ``speed()``, ``window()``, ``load()``
    (the rows as a :class:`SpeedData` in memory) and ``samples()``, the chunked source
    :class:`inmotion.core.deadreckoning._SpeedOnEpochs` resamples from (the aided filters'
    feed, :func:`inmotion.align.aided_kf._feed`, and ``dead_reckon_rows``), which holds a
    chunk of rows at a time. Every row was checked when the bundle was opened
    (:func:`open_bundle`), as :func:`read_bundle` checks them."""

    def __init__(self, table: _Table, cols: tuple, window=(None, None)):
        self._table, self._cols, self._window = table, tuple(cols), window

    def _rows(self):
        """``(a, b)``: the table's rows inside the window."""
        return _window_rows(self._table.times(), self._window)

    @property
    def t(self) -> np.ndarray:
        a, b = self._rows()
        return self._table.times()[a:b]

    def _read(self, names) -> dict:
        """The columns ``names`` of the (windowed) rows, read chunk by chunk into arrays."""
        a, b = self._rows()
        out = {k: np.empty(b - a) for k in names}
        for offset, c in self._table.chunks(names, rows=(a, b)):
            for k in names:
                out[k][offset - a:offset - a + len(c[k])] = c[k]
        return out

    def _column(self, name):
        return self._read((name,))[name] if name in self._cols else None

    @property
    def v(self):
        return self._column("v")

    @property
    def ds(self):
        return self._column("ds")

    def load(self) -> SpeedData:
        """The (windowed) rows in memory."""
        cols = self._read(self._cols)
        return SpeedData(cols["t"], v=cols.get("v"), ds=cols.get("ds"))

    def speed(self) -> np.ndarray:
        return self.load().speed()

    def window(self, start=None, end=None) -> "SpeedStream":
        return SpeedStream(self._table, self._cols, _intersect(self._window, (start, end)))

    def samples(self) -> "_SpeedSamples":
        return _SpeedSamples(self)


class _SpeedSamples:
    """The samples of a :class:`SpeedStream` as :class:`inmotion.core.deadreckoning.
    _WholeSamples` gives them from memory (same indices, same values), from a buffer of the
    rows read so far and not yet passed: ``locate`` reads forward as far as it needs, and
    forgets the rows before the ``lo`` it returns (the caller asks only forward in time)."""

    def __init__(self, stream: SpeedStream):
        t = stream._table.times()
        self._a, b = stream._rows()
        self.n = b - self._a
        if self.n < 2:
            raise BadInput(f"need at least 2 samples, got {self.n}", file=stream._table.path)
        ts = t[self._a:b]
        self.t_first, self.t_last = ts[0], ts[-1]
        from ..core.mechanization import typical_period
        self._period = typical_period(ts)
        del t, ts
        self._cols = stream._cols
        self._it = stream._table.chunks(self._cols, rows=(self._a, b))
        self._base = 0                      # the sample index of the buffer's first row
        self._keep = 0                      # rows before it may be forgotten
        self._buf = {k: np.zeros(0) for k in self._cols}

    def typical_period(self) -> float:
        return self._period

    def _read(self):
        """One more chunk into the buffer; False at the end of the rows."""
        try:
            _, c = next(self._it)
        except StopIteration:
            return False
        self._buf = {k: np.concatenate([self._buf[k], c[k]]) for k in self._cols}
        return True

    def locate(self, t0, t1):
        n = self.n
        if self._keep > self._base:         # forget the rows before the last call's lo
            cut = self._keep - self._base
            self._buf = {k_: v[cut:] for k_, v in self._buf.items()}
            self._base = self._keep
        while True:                         # the rows up to two past the first >= t1
            tb = self._buf["t"]
            k = int(np.searchsorted(tb, t1, side="left"))
            if self._base + len(tb) >= n or len(tb) >= k + 2 or not self._read():
                break
        if self._base > 0 and len(tb) and tb[0] > t0:
            raise RuntimeError("sensor samples asked for before those already passed")
        lo = int(np.clip(self._base + np.searchsorted(tb, t0, side="right") - 2, 0, n - 2))
        hi = int(np.clip(self._base + k + 2, lo + 2, n))
        while self._base + len(self._buf["t"]) < hi and self._read():
            pass
        self._keep = lo     # (the caller still sums the distance from its last lo to this)
        return lo, hi

    def seg(self, lo, hi):
        if lo < self._base:
            raise RuntimeError("sensor samples asked for before those already passed")
        i, j = lo - self._base, hi - self._base
        b = self._buf
        return b["t"][i:j], b["v"][i:j] if "v" in b else None, b["ds"][i:j] if "ds" in b \
            else None


def _in_memory(x):
    """A sensor as a :class:`SpeedData` (a :class:`SpeedStream`'s rows read)."""
    return x.load() if isinstance(x, SpeedStream) else x


# --------------------------------------------------------------------------- the truth

class TruthStream(_Times):
    """The truth table of a bundle read in chunks: ``.t`` and ``.at(t)`` (the start of a
    method, ``--init truth``) as :class:`~inmotion.core.bundle.Truth` has them, and
    :meth:`reduced` for the errors of a result."""

    def __init__(self, table: _Table, max_gap_periods: float, window=(None, None)):
        super().__init__(table, window)
        B.missing_columns(table.columns, B.TRUTH_COLUMNS, table.path)
        self.path = table.path
        if window == (None, None):
            B._check_gaps("truth", table.times(), table.path, max_gap_periods, error=False)

    def window(self, start, end) -> "TruthStream":
        new = TruthStream.__new__(TruthStream)
        new.__dict__.update(self.__dict__)
        new._window = _intersect(self._window, (start, end))
        return new

    def _rows(self, chunk_rows: Optional[int] = None):
        """Yield ``(offset, Truth, dh, steps)`` chunks of the whole table, every row checked;
        ``steps`` (:func:`inmotion.io.bundle.truth_steps`) and ``dh`` (the height steps) are
        those from the row before the chunk (none before the first) through the chunk, so that
        step ``i - 1 + (offset > 0)`` ends at the chunk's row ``i``; at the end the check of
        positions against velocities over the whole table."""
        from_pos = from_vel = 0.0
        prev = None
        n = 0
        for offset, c in self._table.chunks(B.TRUTH_COLUMNS, chunk_rows=chunk_rows):
            tr = B.truth_rows(c, self.path, offset)
            both = tr if prev is None else _Steps(*(np.concatenate([getattr(prev, f),
                                                                     getattr(tr, f)])
                                                    for f in _Steps._fields))
            steps = B.truth_steps(both)
            if len(both.t) > 1:
                p, v = B.truth_distances(both, steps)
                from_pos, from_vel = from_pos + p, from_vel + v
            prev = _Steps(*(getattr(tr, f)[-1:] for f in _Steps._fields))
            n += len(tr.t)
            yield offset, tr, np.diff(both.h), steps
        if n >= 3:
            B.check_truth_distances(from_pos, from_vel, self.path)

    def load(self) -> Truth:
        """The (windowed) rows in memory as a :class:`Truth`, read from the chunks that hold
        them and checked per row as :func:`read_bundle` checks them (the positions-against-
        velocities check of the whole table is not made: it needs every row)."""
        times, w0 = self._span()
        n = len(times)
        del times
        parts = [B.truth_rows(c, self.path, off)
                 for off, c in self._table.chunks(B.TRUTH_COLUMNS, rows=(w0, w0 + n))]
        if not parts:
            z = np.zeros(0)
            return Truth(z, z, z, z, np.zeros((0, 3)), np.zeros((0, 3)))
        return parts[0] if len(parts) == 1 else Truth(
            *(np.concatenate([getattr(p, f) for p in parts])
              for f in ("t", "lat", "lon", "h", "vel_n", "euler")))

    def at(self, t: float) -> dict:
        """The row at or after ``t`` [s] (:meth:`Truth.at`), read up to there."""
        times = self.t
        t_row = times[int(row_at_or_after(times, t))]
        del times
        for offset, c in self._table.chunks(B.TRUTH_COLUMNS):
            if c["t"][-1] >= t_row:
                return B.truth_rows(c, self.path, offset).at(t_row)
        raise RuntimeError("truth row not found")     # the time column says it is there

    def reduced(self, t_out) -> Truth:
        """The rows of the (windowed) truth that the errors at the times ``t_out`` [s] need,
        with the path length along all of them.

        For every output time the two rows around it (those :func:`numpy.interp` takes in
        :func:`inmotion.core.metrics.interpolate_truth`), the first and the last row; Euler
        angles and longitude unwrapped along all rows as :func:`numpy.unwrap` does on the
        whole table (the same floating-point operations, carried across chunks), and
        ``path_length_m`` summed along all rows as :func:`inmotion.core.metrics._path_length`
        sums it. The errors computed from these rows equal those from the whole table
        exactly when consecutive kept rows are less than 180 deg apart in every angle
        (output rows a second apart); otherwise up to rounding. Every row of the table is
        read and checked."""
        times, w0 = self._span()
        if len(times) == 0:
            return Truth(times, times, times, times, np.zeros((0, 3)), np.zeros((0, 3)))
        keep = _keep_rows(times, t_out) + w0
        w1 = w0 + len(times)
        del times
        return _joined(_kept_rows(self._rows(), keep, w0, w1))

    def reducer(self) -> "TruthReducer":
        """A :class:`TruthReducer`: :meth:`reduced` made in a thread while the output times
        arrive (a method's run), started at the first times fed."""
        return TruthReducer(self)


def _keep_rows(times, t_out) -> np.ndarray:
    """The rows of ``times`` (indices from 0) :meth:`TruthStream.reduced` keeps for the output
    times ``t_out``: the first and the last row and the two rows around each output time."""
    n = len(times)
    j = np.clip(np.searchsorted(times, np.asarray(t_out, dtype=float), side="right") - 1,
                0, n - 1)
    return np.unique(np.concatenate([[0, n - 1], j, np.minimum(j + 1, n - 1)]))


def _joined(parts) -> Truth:
    return Truth(*(np.concatenate([getattr(p, f) for p in parts])
                   for f in ("t", "lat", "lon", "h", "vel_n", "euler", "path_length_m")))


class _Stopped(Exception):
    """A :class:`TruthReducer`'s thread told to stop (or its output times out of order)."""


class TruthReducer:
    """:meth:`TruthStream.reduced` computed while a method runs (issue 13: the command line's
    hour, 2 cores): the output times are fed as the run makes them (:meth:`feed`, each
    chunk's, in increasing order), and a thread reads and checks the truth table chunk by
    chunk (:meth:`TruthStream._rows`, the same code), each chunk once the output times have
    passed the next chunk's first row, so that its kept rows are known; :meth:`result` returns
    what ``reduced(t_out)`` returns, array for array, for any ``t_out`` among the times fed
    (the thinned output of a method: a subset of its rows); otherwise (or if the times fed
    were not increasing) it calls :meth:`TruthStream.reduced` itself.

    The kept rows of a chunk are found from its own times: for an output time ``t`` after the
    previous chunk's last row and before the next chunk's first, the row at or before it is
    the chunk's first row plus ``searchsorted(chunk times, t, 'right') - 1``, as
    :func:`_keep_rows` finds it in the whole column (the clipping at the first and the last
    row included). So the thread holds two truth chunks of :data:`TRUTH_THREAD_ROWS` rows (the
    current one and the next, read for its first row) and the times fed not yet passed, not
    the table's time column: memory does not grow with the log.
    A :class:`BadInput` of the table is raised by :meth:`result`, as it was raised, in the
    caller's thread; :meth:`close` stops the thread (a failed run)."""

    def __init__(self, truth: "TruthStream"):
        self._truth = truth
        self._cond = threading.Condition()
        self._fed = []                   # the output times fed, not yet passed by the thread
        self._all = []                   # every time fed (result(): t_out among them?)
        self._last = -np.inf             # the last time fed
        self._ordered = True
        self._done = self._stop = False
        self._out = None                 # (parts, kept rows, w0, w1) or an exception
        self._thread = None
        self._next_first = None          # the next chunk's first time (None: no next chunk)
        self._w = (0, 0)
        #: :meth:`result` called :meth:`TruthStream.reduced` (times not fed, or not in order)
        self.fell_back = False

    def feed(self, t) -> None:
        """Output times ``t`` [s] of the run, after those fed before."""
        t = np.array(t, dtype=float).reshape(-1)
        if len(t) == 0:
            return
        with self._cond:
            if not (t[0] >= self._last and bool(np.all(np.diff(t) >= 0))):
                self._ordered = False
            self._fed.append(t)
            self._all.append(t)
            self._last = max(self._last, float(t[-1]))
            self._cond.notify_all()
        if self._thread is None:
            one_malloc_arena()
            self._thread = threading.Thread(target=self._run, name="inmotion-truth",
                                            daemon=True)
            self._thread.start()

    def _peeked(self, rows):
        """The chunks of ``rows``, each yielded once the next one is read (its first time in
        :attr:`_next_first`; None after the last)."""
        cur = next(rows, None)
        while cur is not None:
            nxt = next(rows, None)
            self._next_first = None if nxt is None else float(nxt[1].t[0])
            yield cur
            cur = nxt

    def _keep_in(self, a: int, b: int, t_ab, t_prev) -> np.ndarray:
        """The kept rows (absolute, sorted) among the window's rows ``a <= row < b``, whose
        times are ``t_ab`` (``t_prev``: the window's row before, None at its start): waits
        until the output times have reached row ``b`` (or have all been fed)."""
        w0, w1 = self._w
        n = w1 - w0
        nxt = self._next_first if b < w1 else None      # row b's time (None: past the end)
        with self._cond:
            while not (self._stop or self._done or not self._ordered
                       or (nxt is not None and self._last >= nxt)):
                self._cond.wait()
            if self._stop or not self._ordered:
                raise _Stopped
            fed = np.concatenate(self._fed) if self._fed else np.zeros(0)
        ra = a - w0
        # the times whose row at or before lies in a - 1 .. b - 1 (and, with the chunk's
        # first row the window's second, those before the window: their rows are 0 and 1)
        lo = 0 if (t_prev is None or ra <= 1) else np.searchsorted(fed, t_prev, side="left")
        hi = len(fed) if nxt is None else np.searchsorted(fed, nxt, side="left")
        t = fed[lo:hi]
        j = np.clip(ra + np.searchsorted(t_ab, t, side="right") - 1, 0, n - 1)
        cand = np.concatenate([[0, n - 1], j, np.minimum(j + 1, n - 1)]) + w0
        with self._cond:                 # times before this chunk's last row are passed
            if len(t_ab) >= 2 or ra >= 1:
                rest = np.concatenate(self._fed) if self._fed else np.zeros(0)
                self._fed = [rest[np.searchsorted(rest, t_ab[-1], side="left"):]]
        return np.unique(cand[(cand >= a) & (cand < b)])

    def _run(self):
        rows = None
        try:
            self._w = w0, w1 = self._truth._span_rows()
            if w1 == w0:
                return                        # result(): reduced's own answer
            rows = self._truth._rows(min(self._truth._table.chunk_rows, TRUTH_THREAD_ROWS))
            kept = []
            parts = _kept_rows(self._peeked(rows), self._keep_in, *self._w, kept)
            self._out = (parts, np.concatenate(kept) if kept else np.zeros(0, dtype=int))
        except _Stopped:
            self._out = None
        except BaseException as e:          # noqa: BLE001 (raised by result())
            self._out = e
        finally:
            if rows is not None:
                rows.close()

    def _finish(self, stop: bool):
        with self._cond:
            self._done = True
            self._stop = self._stop or stop
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join()

    def result(self, t_out) -> Truth:
        """``TruthStream.reduced(t_out)`` (``t_out``: the output times of the result written)."""
        self._finish(stop=False)
        out, self._out = self._out, None
        if isinstance(out, BaseException):
            raise out
        t_out = np.asarray(t_out, dtype=float)
        fed = np.concatenate(self._all) if self._all else np.zeros(0)
        if out is None or not np.isin(t_out, fed).all():
            self.fell_back = True
            return self._truth.reduced(t_out)      # times the rows were not kept for
        parts, kept = out
        full = _joined(parts)
        w1 = self._w[1]
        # each time's row at or before it is the last kept row at or before it (it is kept)
        i = np.clip(np.searchsorted(full.t, t_out, side="right") - 1, 0, len(kept) - 1)
        j = kept[i]
        keep = np.unique(np.concatenate([[self._w[0], w1 - 1], j, np.minimum(j + 1, w1 - 1)]))
        sel = np.searchsorted(kept, keep)
        if not (np.all(sel < len(kept)) and np.array_equal(kept[np.minimum(sel, len(kept) - 1)],
                                                           keep)):
            self.fell_back = True                  # (not expected: the times were fed)
            return self._truth.reduced(t_out)
        if len(keep) == len(kept):
            return full
        return Truth(*(getattr(full, f)[sel] for f in
                       ("t", "lat", "lon", "h", "vel_n", "euler", "path_length_m")))

    def close(self) -> None:
        """Stop the thread (if any) and wait for it."""
        self._finish(stop=True)


def _kept_rows(rows, keep, w0, w1, kept=None):
    """:meth:`TruthStream.reduced`'s loop over the checked chunks ``rows`` (``(offset, Truth,
    dh, steps)``, :meth:`TruthStream._rows`): the kept rows ``keep`` of the window rows
    ``w0 .. w1 - 1``, unwrapped, with the path length, a :class:`Truth` per chunk. ``keep``:
    the rows (absolute, sorted), or a function ``keep(a, b, t, t_prev)`` giving those among
    the rows ``a <= row < b`` from their times ``t`` and the time of the row before (None at
    the window's start; :class:`TruthReducer`); ``kept``: a list the kept rows of each chunk
    are appended to."""
    parts = []
    prev, carry_e, carry_l, carry_s = None, np.zeros(3), 0.0, 0.0
    for offset, tr, dh, steps in rows:
        a, b = max(w0, offset), min(w1, offset + len(tr.t))
        if a >= b:
            continue
        i0, i1 = a - offset, b - offset
        tr = _take(tr, slice(i0, i1))
        euler, carry_e = _unwrap_carry(tr.euler, None if prev is None else prev.euler[-1],
                                       carry_e)
        lon, carry_l = _unwrap_carry(tr.lon, None if prev is None else prev.lon[-1],
                                     carry_l)
        # the steps ending at the rows i0 (unless the window starts there) .. i1 - 1
        j = (offset > 0) - 1
        s, carry_s = _path_carry(*(x[i0 + j + (prev is None):i1 + j]
                                   for x in (dh, *steps)), prev is None, carry_s)
        k = (keep(a, b, tr.t, None if prev is None else prev.t[-1]) if callable(keep)
             else keep[(keep >= a) & (keep < b)])
        if kept is not None:
            kept.append(k)
        k = k - a
        parts.append(Truth(tr.t[k], tr.lat[k], lon[k], tr.h[k], tr.vel_n[k], euler[k], s[k]))
        prev = _take(tr, slice(-1, None))
    return parts


#: the truth columns :func:`inmotion.io.bundle.truth_distances` and the path length need
_Steps = namedtuple("_Steps", "t lat lon h vel_n")


def _take(tr: Truth, s) -> Truth:
    return Truth(tr.t[s], tr.lat[s], tr.lon[s], tr.h[s], tr.vel_n[s], tr.euler[s])


def _unwrap_carry(p, p_prev, carry):
    """:func:`numpy.unwrap` (period 2 pi) of a chunk ``p`` of a longer series: ``p_prev`` is
    the raw value before it (None: the series starts here), ``carry`` the running sum of the
    corrections; returns the unwrapped chunk and the new carry. numpy's own steps (NumPy 2
    ``unwrap``), so the result is bit for bit that of the whole series."""
    p = np.asarray(p, dtype=float)
    if not _has_jump(p, p_prev):            # every correction is 0: the sums stay ``carry``
        carry = np.asarray(carry, dtype=float) + 0.0     # (+0.0: as numpy's sum of zeros)
        if p_prev is None:
            out = p.copy()
            out[1:] = p[1:] + carry
            return out, carry
        return p + carry, carry
    q = p if p_prev is None else np.concatenate([np.asarray(p_prev, dtype=float)[None], p])
    dd = np.diff(q, axis=0)
    ddmod = np.mod(dd + np.pi, 2 * np.pi) - np.pi
    np.copyto(ddmod, np.pi, where=(ddmod == -np.pi) & (dd > 0))
    ph = ddmod - dd
    np.copyto(ph, 0, where=np.abs(dd) < np.pi)
    if p_prev is None:                      # the series' first value stays as it is
        cum = np.cumsum(np.concatenate([np.asarray(carry, dtype=float)[None], ph]), axis=0)
        out = p.copy()
        out[1:] = p[1:] + cum[1:]
        return out, cum[-1]
    cum = np.cumsum(np.concatenate([np.asarray(carry, dtype=float)[None], ph]), axis=0)[1:]
    return p + cum, cum[-1]


def _has_jump(p, p_prev) -> bool:
    """Whether a step of the series (``p_prev``, then ``p``, finite) is at least pi in size:
    ``(np.abs(np.diff(...)) >= pi).any()`` by two reductions, without copying the chunk."""
    if len(p) == 0:
        return False
    if p_prev is not None and (np.abs(p[0] - np.asarray(p_prev, dtype=float)) >= np.pi).any():
        return True
    if len(p) < 2:
        return False
    dd = np.diff(p, axis=0)
    return bool(dd.max() >= np.pi or dd.min() <= -np.pi)


def _path_carry(dh, north, dlon, rn_h, cos_lat, first: bool, carry: float):
    """:func:`inmotion.core.metrics._path_length`'s cumulative length at every row of a chunk,
    carried across chunks, from the chunk's steps (:func:`inmotion.io.bundle.truth_steps`, the
    height steps ``dh``): those ending at each of its rows, or with ``first`` (the series
    starts at the chunk's first row) at each row but the first. The same operations on the
    same values as ``_path_length``, so the same lengths bit for bit."""
    step = np.sqrt(north ** 2 + (_wrap_pi(dlon) * rn_h * cos_lat) ** 2 + dh ** 2)
    cum = np.cumsum(np.concatenate([[carry], step]))
    s = cum if first else cum[1:]
    return s, float(cum[-1])


def _wrap_pi(x):
    """:func:`inmotion.core.rotations.wrap_pi` bit for bit, without its floating-point modulo
    when every ``x + pi`` lies in ``(0, 2 pi)`` (steps of longitude between rows): numpy's
    ``%`` returns such a value unchanged."""
    w = x + np.pi
    if np.all(w > 0.0) and np.all(w < 2 * np.pi):
        return w - np.pi
    return w % (2 * np.pi) - np.pi


def _window_rows(t, window) -> tuple:
    """``(a, b)``: the rows ``a <= row < b`` of the increasing time column ``t`` [s] inside
    ``window = (start, end)`` (None: open; both ends included)."""
    lo, hi = window
    a = 0 if lo is None else int(np.searchsorted(t, lo, side="left"))
    b = len(t) if hi is None else int(np.searchsorted(t, hi, side="right"))
    return a, max(a, b)


def _intersect(w, v):
    lo = [x for x in (w[0], v[0]) if x is not None]
    hi = [x for x in (w[1], v[1]) if x is not None]
    return (max(lo) if lo else None, min(hi) if hi else None)


# --------------------------------------------------------------------------- the bundle

class BundleStream:
    """A bundle folder opened for reading in chunks (:func:`open_bundle`); see the module
    notes. ``radar``, ``ldv``, ``odometer``, ``baro`` are in memory (windowed);
    ``imu.t`` and ``truth.t`` are read from the files when asked."""

    name = Bundle.name
    velocity_sensor = Bundle.velocity_sensor

    def __init__(self, folder: Path, meta: dict, imu: _ImuTable, speeds: dict, baro,
                 truth: Optional[TruthStream], window=(None, None)):
        self.folder, self.meta = folder, meta
        self._imu = imu
        for s in VELOCITY_SENSORS:
            setattr(self, s, speeds.get(s))
        self.baro = baro
        self.truth = truth
        self._window = window

    @property
    def imu(self) -> _Times:
        return _Times(self._imu._table, self._window)

    def window(self, start=None, end=None) -> "BundleStream":
        """The same drive cut to ``start <= t <= end`` [s], as :meth:`Bundle.window`."""
        def cut(x):                 # (no window: the same arrays, not copies)
            return x if x is None or (start, end) == (None, None) else x.window(start, end)
        return BundleStream(self.folder, dict(self.meta), self._imu,
                            {s: cut(getattr(self, s)) for s in VELOCITY_SENSORS},
                            cut(self.baro), cut(self.truth), _intersect(self._window,
                                                                        (start, end)))

    def load_window(self, start=None, end=None, truth: bool = False) -> Bundle:
        """The drive cut to ``start <= t <= end`` [s] (and the stream's own window) as a
        :class:`Bundle` in memory, as :meth:`Bundle.load_window`: only the IMU rows inside
        are read (a time-filtered read, :meth:`_ImuTable.rows`: memory of the window, not of
        the log); the sensors and the barometer are the stream's, cut; the truth stays a
        :class:`TruthStream` (cut), read when asked, or with ``truth`` its window's rows are
        read into memory too (:meth:`TruthStream.load`)."""
        a, b = _window_rows(self._imu._table.times(), _intersect(self._window, (start, end)))
        cut = self.window(start, end)
        tr = cut.truth.load() if truth and cut.truth is not None else cut.truth
        return Bundle(self._imu.rows(a, b), dict(self.meta),
                      *(_in_memory(getattr(cut, s)) for s in VELOCITY_SENSORS), cut.baro, tr)

    def imu_rows_in_window(self, t0: float, min_rows: int = 2):
        """:meth:`imu_rows_after` reading only the window's rows, as :meth:`load_window`
        reads them (:meth:`_ImuTable.pieces`: rows outside the window neither read nor
        checked), a chunk at a time: for a method given a window (the coarse alignments,
        :func:`inmotion.align.attitude_determination.prepare`) that, in memory, was given
        :meth:`load_window`'s rows."""
        from ..core.mechanization import start_row
        t, w0 = _Times(self._imu._table, self._window)._span()
        k0 = start_row(t, t0, min_rows)
        period = float(np.median(np.diff(t)))
        n = len(t)
        del t

        def pieces():               # every row of the window read and checked, from row 0
            skip = k0
            for piece in self._imu.pieces(w0, w0 + n):
                if skip >= len(piece[0]):
                    skip -= len(piece[0])
                    continue
                yield tuple(x[skip:] for x in piece)
                skip = 0
        return n - k0, period, pieces(), w0 + k0

    def imu_rows_after(self, t0: float, min_rows: int = 2):
        """``(n_rows, period_s, pieces, first_row)`` as :meth:`Bundle.imu_rows_after`, the
        pieces read from the file as they are asked for (every row of the table is read and
        checked, also those outside the window)."""
        from ..core.mechanization import start_row
        t, w0 = _Times(self._imu._table, self._window)._span()
        k0 = start_row(t, t0, min_rows)
        whole = self._window == (None, None)         # the median period is known then
        period = self._imu.period if whole else float(np.median(np.diff(t)))
        n = len(t) - k0
        lo, hi = (t[k0], t[-1]) if n else (np.inf, -np.inf)
        del t

        def pieces():
            for t, dtheta, dvel in self._imu.chunks():
                a, b = np.searchsorted(t, lo), np.searchsorted(t, hi, side="right")
                if a < b:
                    yield t[a:b], dtheta[a:b], dvel[a:b]
        return n, period, pieces(), w0 + k0


def _speed_table(tb: _Table, cols):
    """A velocity sensor's table checked as :func:`inmotion.io.bundle.speed_data` checks it:
    read whole (a :class:`SpeedData`), or, when it is long and fast (more than
    rows than a chunk at more than :data:`STREAM_SENSOR_RATE_HZ`), checked chunk by
    chunk and kept on disk (a :class:`SpeedStream`)."""
    t = tb.times()
    n = len(t)
    d_med = float(np.median(np.diff(t))) if n > 1 else 1.0
    if n <= tb.chunk_rows or not d_med * STREAM_SENSOR_RATE_HZ < 1.0:
        del t
        return B.speed_data(tb.read(cols), tb.path)
    del t
    t_prev = None
    for offset, c in tb.chunks(cols):       # speed_data's limits, row by row
        d = (np.concatenate([[d_med], np.diff(c["t"])]) if t_prev is None
             else np.diff(c["t"], prepend=t_prev))
        if "v" in c:
            B._check_limit(c["v"], B.LIMITS["speed_m_s"], "speed v =", "m/s", tb.path,
                           c["t"], offset)
        if "ds" in c:
            B._check_limit(c["ds"] / d, B.LIMITS["speed_m_s"], "speed ds/dt =", "m/s",
                           tb.path, c["t"], offset)
        t_prev = c["t"][-1]
    return SpeedStream(tb, cols)


def open_bundle(path, *, max_gap_periods: float = B.MAX_GAP_PERIODS,
                allow_imu_gaps: bool = False, chunk_rows: Optional[int] = None) -> BundleStream:
    """Open a bundle folder for reading in chunks (see the module notes).

    Parameters
    ----------
    path : str or Path
        The bundle folder.
    max_gap_periods, allow_imu_gaps
        As :func:`inmotion.io.bundle.read_bundle`.
    chunk_rows : int, optional
        Rows per chunk read (default :data:`CHUNK_ROWS`).

    Returns
    -------
    BundleStream

    Raises
    ------
    BadInput
        As :func:`read_bundle`, for what can be checked before the rows are read; the rest
        when the rows are read.
    """
    folder = B.bundle_folder(path)
    chunk_rows = CHUNK_ROWS if chunk_rows is None else int(chunk_rows)
    meta = B.read_meta(folder)
    files = B._locate_tables(folder, meta)
    if "imu" not in files:
        raise BadInput("missing IMU table (imu.csv or imu.parquet)", file=folder)
    imu = _ImuTable(_Table(files["imu"], chunk_rows), max_gap_periods, allow_imu_gaps)
    speeds = {}
    for name in VELOCITY_SENSORS:
        if name in files:
            tb = _Table(files[name], chunk_rows)
            cols = B.speed_columns(tb.columns, tb.path, need_v=(name == "radar"))
            speeds[name] = _speed_table(tb, cols)
            B._check_gaps(name, speeds[name].t, tb.path, max_gap_periods, error=False)
    baro = truth = None
    if "baro" in files:
        tb = _Table(files["baro"], chunk_rows)
        baro = B.baro_data(tb.read(("t", "h")), tb.path)
        B._check_gaps("baro", baro.t, tb.path, max_gap_periods, error=False)
    if "truth" in files:
        # read beside the method's run by TruthReducer's thread: Arrow's buffers from malloc
        # (one arena, one_malloc_arena), not from Arrow's default pool (mimalloc), whose heap
        # for that thread raised the run's peak (paper 002's hour, sins-dr: peak RSS 210-213
        # MiB, 176-185 MiB with malloc, 168-174 MiB reading the truth after the run)
        truth = TruthStream(_Table(files["truth"], chunk_rows, system_pool=True),
                            max_gap_periods)
    if truth is None:
        B._check_initial_position(meta, folder / "meta.yaml")
    stream = BundleStream(folder, meta, imu, speeds, baro, truth)
    B.check_clocks(stream, files)
    return stream
