"""Bundle folders on disk: read with validation, write in CSV or Parquet.

A bundle is a folder holding one drive (``shared/DESIGN.md``, "The bundle")::

    meta.yaml                 name, initial position, sensor specs (human units), faults, files
    imu.csv|imu.parquet       t, dtheta_x, dtheta_y, dtheta_z [rad], dvel_x, dvel_y, dvel_z [m/s]
    radar.*                   t, v [m/s]
    ldv.*, odometer.*         t and ds [m] or v [m/s]
    baro.*                    t, h [m]
    truth.*                   t, lat, lon [deg], h [m], vE, vN, vU [m/s], pitch, roll, yaw [deg]

In memory (:class:`inmotion.core.bundle.Bundle`) everything is SI; the only unit conversion
at this edge is degrees <-> rad for the truth's latitude, longitude and Euler angles.

``meta.yaml`` layout (what :func:`write_bundle` writes and :func:`read_bundle` understands;
keys not listed are kept as they are)::

    name: paper002_drive
    initial_position: {lat_deg: 34.2, lon_deg: 108.9, h_m: 400.0}    # needed if no truth
    initial_attitude: {pitch_deg: 0, roll_deg: 0, yaw_deg: 45}       # optional (--init meta)
    initial_velocity: {vE_m_s: 0, vN_m_s: 0, vU_m_s: 0}              # optional, default rest
    sensors:                                # human units, with the unit in every key
      imu: {rate_hz: 100, gyro_drift_deg_h: 0.01, ...}
      radar: {rate_hz: 10, lever_arm_m: [0, 1.2, -0.5], mounting_deg: [0.1, 0, 0.2], ...}
    faults: [...]                           # as the simulator lists them
    files: {imu: imu.csv, radar: radar.csv, truth: truth.csv}

The simulator's spelling is understood too (:func:`meta_initial`): top-level ``lat_deg,
lon_deg, h_m``, ``initial_attitude_deg: {pitch, roll, yaw}`` and ``files`` as a list of table
names (``[imu, truth, radar]``: each must exist in one format).

Validation (each failure is one :class:`inmotion.errors.BadInput` naming file, row and time)
----------------------------------------------------------------------------------------------
- missing folder, ``meta.yaml``, ``imu`` table, a file that ``meta.yaml`` lists, or a required
  column; a table present as both CSV and Parquet; malformed YAML;
- non-numeric, NaN or infinite values in a used column; an empty table;
- time not strictly increasing;
- values that cannot be in the declared units (limits in :data:`LIMITS`): an angular rate
  from ``dtheta`` above 50 rad/s (no vehicle gyro measures that), a specific force from
  ``dvel`` above 100 g, a speed above 150 m/s, a barometric height outside -1 km .. 20 km,
  truth latitude beyond +-90 deg or pitch beyond +-90 deg;
- units that do not add up: a mean specific force far from gravity (``dvel`` not in m/s), a
  truth whose positions and velocities describe different distances (lat/lon in rad), a turn
  rate above 3 rad/s sustained over a second (``dtheta`` in degrees), an IMU rate outside
  5 Hz .. 100 kHz (time not in seconds), a time column stored as timestamps;
- clocks that do not match (:func:`check_clocks`): a table with no sample inside the IMU's
  time span (another clock), or spanning more than 50 times the IMU's (another time unit);
- an IMU table of fewer than 2 rows; ``meta.yaml`` keys of the wrong type (``sensors`` not a
  mapping, ``faults`` not a list ...); a half-written folder (:mod:`inmotion.io.safe_write`).

:func:`check_bundle` makes the same checks on a bundle in memory (an importer's output, the
simulator's), naming its source.

Gaps (a time step longer than ``max_gap_periods`` = 5 median sample periods):

- in the IMU table a gap is an **error**: IMU row k is the increment over ``(t[k-1], t[k]]``,
  and a missing stretch of increments is motion the mechanization can never recover; silently
  integrating across it would corrupt attitude and velocity. Pass ``allow_imu_gaps=True`` to
  accept such data (the row after the gap is then taken as the increment over the whole gap).
- in velocity-sensor, barometer and truth tables a gap is a **warning**
  (:class:`BundleGapWarning`): sensor dropouts are a normal event (and a simulated fault); the
  aiding methods simply have no measurement during the gap, dead reckoning holds the last speed
  (see :mod:`inmotion.core.deadreckoning`). :func:`find_gaps` lists them for ``inmotion info``.

CSV is written with the shortest repr that round-trips float64 exactly (:func:`write_csv`), so
a CSV write -> read is exact up to the degrees <-> rad conversion (about 1e-16 relative); Parquet
is exact.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from ..core.bundle import (BaroData, Bundle, ImuData, SpeedData, Truth, VELOCITY_SENSORS)
from ..core.earth import G0, radii
from ..errors import BadInput
from .safe_write import atomic_write, refuse_partial, staged_folder

if TYPE_CHECKING:                      # pandas is imported where a table is read or written
    from collections.abc import Mapping

    import pandas as pd

__all__ = ["read_bundle", "write_bundle", "find_gaps", "Gap", "BundleGapWarning", "LIMITS",
           "TABLES", "read_meta", "meta_initial", "atomic_write", "write_csv", "arrow_table",
           "numpy_to_arrow", "arrow_to_numpy", "check_bundle",
           "check_imu", "check_clocks"]

#: the tables a bundle may hold, in write order
TABLES = ("imu",) + VELOCITY_SENSORS + ("baro", "truth")
#: table file suffixes understood, and the format name each means
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}

IMU_COLUMNS = ("t", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z")
TRUTH_COLUMNS = ("t", "lat", "lon", "h", "vE", "vN", "vU", "pitch", "roll", "yaw")

#: physical limits beyond which a value cannot be in the declared unit
LIMITS = {
    "gyro_rate_rad_s": 50.0,            # ~2900 deg/s: beyond any vehicle gyro's range
    "specific_force_m_s2": 100.0 * G0,  # 100 g
    "speed_m_s": 150.0,                 # 540 km/h: no land vehicle
    "baro_h_m": (-1000.0, 20000.0),
    "imu_rate_hz": (5.0, 100000.0),     # outside: time not in seconds
    "sustained_rate_rad_s": 3.0,        # turn rate averaged over 1 s (170 deg/s)
    "clock_span_ratio": 50.0,           # a table spanning 50x the IMU's time: other units
}

#: rows per Parquet row group written (:func:`write_bundle`)
PARQUET_ROW_GROUP = 65536
#: compression of the Parquet tables written (:func:`write_bundle`; plain encoding, no
#: dictionary)
PARQUET_COMPRESSION = "lz4"

#: a step longer than this many median sample periods is a gap
MAX_GAP_PERIODS = 5.0


class BundleGapWarning(UserWarning):
    """A velocity-sensor, barometer or truth table has a gap (reported, not an error)."""


@dataclass(frozen=True)
class Gap:
    """A time step longer than the gap threshold: ``table`` rows ``row - 1`` -> ``row``
    (1-based data rows), from ``t_start`` to ``t_end`` [s], ``periods`` median periods long."""

    table: str
    row: int
    t_start: float
    t_end: float
    periods: float

    @property
    def duration_s(self) -> float:
        return self.t_end - self.t_start


# --------------------------------------------------------------------------- reading

def bundle_folder(path) -> Path:
    """``path`` as a bundle folder that exists and is whole (not a staged or interrupted
    write); :class:`BadInput` otherwise. Both readers (:func:`read_bundle`,
    :func:`inmotion.io.bundle_stream.open_bundle`) start here."""
    folder = Path(path)
    if not folder.exists():
        raise BadInput("bundle folder does not exist", file=folder)
    if not folder.is_dir():
        raise BadInput("a bundle must be a folder", file=folder)
    refuse_partial(folder, "bundle")
    return folder


def read_bundle(path, *, max_gap_periods: float = MAX_GAP_PERIODS,
                allow_imu_gaps: bool = False, truth_in_chunks: bool = False) -> Bundle:
    """Read and validate a bundle folder.

    Parameters
    ----------
    path : str or Path
        The bundle folder.
    max_gap_periods : float
        A time step longer than this many median sample periods is a gap.
    allow_imu_gaps : bool
        Accept gaps in the IMU table instead of raising (see the module docstring).
    truth_in_chunks : bool
        Open the truth table for reading in chunks
        (:class:`inmotion.io.bundle_stream.TruthStream`: ``t``, ``at``, ``window``,
        ``reduced``) instead of loading it, for a run that reads the truth only for the
        errors of its result (the command line's ``process``: the truth is the largest
        table of a simulated bundle, and memory would grow with the log); its rows are read
        and checked when :meth:`~inmotion.io.bundle_stream.TruthStream.reduced` reads them.

    Returns
    -------
    Bundle
        SI inside; ``meta`` is the content of ``meta.yaml``.

    Raises
    ------
    BadInput
        On the first problem found, naming the file, the row and the time.
    """
    folder = bundle_folder(path)
    meta = read_meta(folder)
    files = _locate_tables(folder, meta)
    if "imu" not in files:
        raise BadInput("missing IMU table (imu.csv or imu.parquet)", file=folder)
    # one table at a time: a DataFrame lives only while its arrays are made
    imu = _imu_from(_read_table(files["imu"]), files["imu"])
    _check_gaps("imu", imu.t, files["imu"], max_gap_periods, error=not allow_imu_gaps)
    speeds = {}
    for name in VELOCITY_SENSORS:
        if name in files:
            speeds[name] = _speed_from(_read_table(files[name]), files[name],
                                       need_v=(name == "radar"))
            _check_gaps(name, speeds[name].t, files[name], max_gap_periods, error=False)
    baro = truth = None
    if "baro" in files:
        baro = _baro_from(_read_table(files["baro"]), files["baro"])
        _check_gaps("baro", baro.t, files["baro"], max_gap_periods, error=False)
    if "truth" in files and truth_in_chunks:
        from .bundle_stream import CHUNK_ROWS, TruthStream, _Table
        truth = TruthStream(_Table(files["truth"], CHUNK_ROWS), max_gap_periods)
    elif "truth" in files:
        truth = _truth_from(_read_table(files["truth"]), files["truth"])
        _check_gaps("truth", truth.t, files["truth"], max_gap_periods, error=False)
    if truth is None:
        _check_initial_position(meta, folder / "meta.yaml")
    bundle = Bundle(imu=imu, meta=meta, baro=baro, truth=truth, **speeds)
    check_clocks(bundle, files)
    return bundle


def check_clocks(bundle: Bundle, files=None) -> None:
    """Every other table must share the IMU's clock and time unit: some of its samples
    inside the IMU's span, and a span not 50 times longer than the IMU's.
    ``files`` maps table names to what to call them in messages."""
    t_imu = bundle.imu.t
    a, b = float(t_imu[0]), float(t_imu[-1])
    for name in TABLES[1:]:
        x = getattr(bundle, name)
        if x is None or len(x.t) == 0:
            continue
        where = (files or {}).get(name, name)
        t0, t1 = float(x.t[0]), float(x.t[-1])
        if t1 < a or t0 > b:
            raise BadInput(f"its times {t0:.6g} .. {t1:.6g} s have no sample inside the IMU's "
                           f"{a:.6g} .. {b:.6g} s: another clock, or another time unit?",
                           file=where)
        ratio = LIMITS["clock_span_ratio"]     # (a table may cover a short part of the drive)
        if len(x.t) > 2 and b - a > 0 and (t1 - t0) / (b - a) > ratio:
            raise BadInput(f"its times span {t1 - t0:.6g} s but the IMU's span {b - a:.6g} s: "
                           "are both in seconds?", file=where)


def read_meta(folder) -> dict:
    """The parsed ``meta.yaml`` of a bundle folder (a mapping), or :class:`BadInput`."""
    p = Path(folder) / "meta.yaml"
    if not p.is_file():
        raise BadInput("missing meta.yaml (a bundle needs at least 'name')", file=p)
    from .safe_yaml import load_yaml_file
    meta = load_yaml_file(p, "YAML")
    if meta is None:
        meta = {}
    if not isinstance(meta, dict):
        raise BadInput(f"must be a YAML mapping (key: value), got {type(meta).__name__}", file=p)
    for key, types, what in (("name", (str, int, float), "a text"),
                             ("sensors", (dict,), "a mapping of sensor specifications"),
                             ("faults", (list,), "a list of faults"),
                             ("initial_position", (dict,), "a mapping {lat_deg, lon_deg, h_m}"),
                             ("initial_attitude", (dict,), "a mapping {pitch_deg, roll_deg, "
                                                           "yaw_deg}"),
                             ("initial_velocity", (dict,), "a mapping {vE_m_s, vN_m_s, vU_m_s}"),
                             ("vehicle_mounting_arcmin", (list,), "a list of 3 angles")):
        v = meta.get(key)
        if v is not None and (not isinstance(v, types) or isinstance(v, bool)):
            raise BadInput(f"{key!r} must be {what}, got {_short(v)}", file=p)
    return meta


def _short(v, n=60) -> str:
    r = repr(v)
    return r if len(r) <= n else r[:n] + "..."


def _locate_tables(folder: Path, meta: dict) -> dict:
    """``{table: path}`` of the tables present; checks files listed in meta exist."""
    found = {}
    for name in TABLES:
        cands = [folder / f"{name}{s}" for s in SUFFIXES if (folder / f"{name}{s}").is_file()]
        if len(cands) > 1:
            raise BadInput(f"table {name!r} present twice ({', '.join(c.name for c in cands)}); "
                           "keep one", file=folder)
        if cands:
            found[name] = cands[0]
    listed = meta.get("files") or {}
    if isinstance(listed, (list, tuple)):
        listed = {Path(str(f)).stem: str(f) for f in listed}
    if not isinstance(listed, dict):
        raise BadInput("'files' must list table names or map them to file names",
                       file=folder / "meta.yaml")
    for name, fname in listed.items():
        fname = str(fname)
        if Path(fname).suffix:                 # a file name: that file must be there
            p = folder / fname
            if folder.resolve() not in p.resolve().parents:
                raise BadInput(f"'files' lists {fname!r} for {name!r}, outside the bundle "
                               "folder; a bundle's tables live in its folder",
                               file=folder / "meta.yaml")
            if not p.is_file():
                raise BadInput(f"missing file {fname!r} that meta.yaml lists for {name!r}",
                               file=p)
            if name in TABLES:
                found[name] = p
        elif name not in found:                # a table name: any format will do
            raise BadInput(f"missing table {name!r} ({name}.csv or {name}.parquet) that "
                           "meta.yaml lists", file=folder / f"{name}.csv")
    return found


class _ArrowColumns:
    """A Parquet table's columns ``{name: pyarrow.Array}``, read with pyarrow alone (pandas
    costs a third of a second of a command's start-up); what :func:`_columns` reads. Each
    column is read from the file when it is asked for (the last one kept), so reading a
    table holds one column in Arrow's buffers at a time, not the whole table beside its
    numpy copy (issue 13: a 100 Hz hour is 20 MB of IMU and 30 MB of truth). Its columns
    come out as writable float64 copies, as pandas gave them (a table read in chunks,
    :mod:`inmotion.io.bundle_stream`, gets read-only views of Arrow's buffers)."""

    copy_values = True

    def __init__(self, pf, names: dict, path):
        self._pf, self._names, self._path = pf, names, path   # names: stripped -> the file's
        self._last = (None, None)

    @property
    def columns(self) -> list:
        return list(self._names)

    def __contains__(self, name) -> bool:
        return name in self._names

    def __iter__(self):
        return iter(self._names)

    def __getitem__(self, name):
        if self._last[0] != name:
            if name not in self._names:
                raise KeyError(name)
            try:
                col = self._pf.read(columns=[self._names[name]], use_threads=False).column(0)
                self._last = (name, col.combine_chunks())
            except Exception as e:
                raise cannot_read(e, self._path) from None
        return self._last[1]


def _read_parquet(path: Path) -> _ArrowColumns:
    import pyarrow.parquet as pq
    pf = pq.ParquetFile(path)                  # (pq.read_table imports pyarrow.dataset)
    if pf.metadata.num_rows == 0:
        raise BadInput("table has no data rows", file=path)
    return _ArrowColumns(pf, {str(n).strip(): str(n) for n in pf.schema_arrow.names
                              if not re.fullmatch(r"__index_level_\d+__", str(n))}, path)


def _read_table(path: Path) -> "pd.DataFrame | _ArrowColumns":
    fmt = SUFFIXES.get(path.suffix)
    if fmt == "parquet":
        try:
            return _read_parquet(path)
        except BadInput:
            raise
        except Exception as e:
            raise cannot_read(e, path) from None
    import pandas as pd
    try:
        df = pd.read_csv(path, skipinitialspace=True)
    except Exception as e:
        raise cannot_read(e, path) from None
    df.columns = [str(c).strip() for c in df.columns]
    if len(df) == 0:
        raise BadInput("table has no data rows", file=path)
    return df


def cannot_read(e: Exception, path) -> BadInput:
    """The :class:`BadInput` for a table file that its reader (pandas, pyarrow) refuses."""
    if isinstance(e, (ValueError, OSError)):      # pandas' parser errors are ValueErrors
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        return BadInput(f"cannot read table: {msg}", file=path)
    # pyarrow raises its own exception types on corrupt files
    return BadInput(f"cannot read table: {type(e).__name__}: {e}", file=path)


def missing_columns(has, names, path) -> None:
    """:class:`BadInput` naming the columns of ``names`` not in ``has``."""
    missing = [c for c in names if c not in has]
    if missing:
        raise BadInput(f"missing column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(missing)} (has: {', '.join(has)})", file=path)


def _columns(df: pd.DataFrame, names, path: Path) -> dict:
    """The named columns as float64 arrays, validated finite and numeric."""
    missing_columns(list(df.columns), names, path)
    t = _numeric(df, "t", path, None)
    out = {"t": t}
    for c in names:
        if c != "t":
            out[c] = _numeric(df, c, path, t)
    _check_increasing(t, path)
    return out


def _numeric(df, col, path, t, offset: int = 0):
    """Column ``col`` as finite float64, or BadInput at the first bad row (``offset``: rows of
    the table before ``df``'s first, for a table read in chunks). ``df[col]`` is a pandas
    Series (CSV) or a pyarrow array (Parquet: numbers go straight to numpy without pandas;
    any other type through pandas, for the same message)."""
    if hasattr(df[col], "type"):
        return _arrow_numeric(df, col, path, t, offset)
    import pandas as pd
    s = df[col]
    if pd.api.types.is_datetime64_any_dtype(s) or pd.api.types.is_timedelta64_dtype(s):
        raise BadInput(f"column {col!r} holds {s.dtype} timestamps; write plain numbers in "
                       "seconds", file=path)
    if pd.api.types.is_bool_dtype(s):
        raise BadInput(f"column {col!r} holds true/false values, not numbers", file=path)
    x = pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(x)
    if bad.any():
        i = int(np.argmax(bad))
        raw = s.iloc[i]
        what = ("NaN or empty" if raw is None or (isinstance(raw, float) and math.isnan(raw))
                or str(raw).strip() == "" else _short(raw, 40))
        kind = "not a finite number" if _is_number(raw) else "not a number"
        tt = None if t is None or not np.isfinite(t[i]) else float(t[i])
        raise BadInput(f"column {col!r}: value {what} is {kind}", file=path, row=offset + i + 1,
                       time=tt)
    return x


def _arrow_numeric(frame, col, path, t, offset):
    """:func:`_numeric` of a pyarrow column."""
    import pyarrow.types as pat
    x = frame[col]
    if not (pat.is_floating(x.type) or pat.is_integer(x.type)):
        return _numeric({col: x.to_pandas()}, col, path, t, offset)
    raw = arrow_to_numpy(x)                            # nulls -> NaN
    v = raw.astype(float, copy=getattr(frame, "copy_values", False))
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad))
        what = "NaN or empty" if np.isnan(raw[i]) else _short(raw[i], 40)
        tt = None if t is None or not np.isfinite(t[i]) else float(t[i])
        raise BadInput(f"column {col!r}: value {what} is not a finite number", file=path,
                       row=offset + i + 1, time=tt)
    return v


def _is_number(raw):
    try:
        float(raw)
        return True
    except (TypeError, ValueError):
        return False


def _check_increasing(t, path, offset: int = 0, t_prev=None):
    """``t`` strictly increasing; ``t_prev``: the time of the row before ``t[0]`` (a table read
    in chunks), ``offset``: the rows before ``t[0]``."""
    if t_prev is not None:
        t = np.concatenate([[t_prev], t])
        offset -= 1
    if len(t) > 1:
        bad = np.diff(t) <= 0
        if bad.any():
            i = int(np.argmax(bad)) + 1
            raise BadInput(f"time not strictly increasing (previous row t={t[i - 1]:.9g} s)",
                           file=path, row=offset + i + 1, time=float(t[i]))


def _row_dt(t):
    """Per-row interval length [s]; row 0 takes the median period."""
    if len(t) < 2:
        return np.ones_like(t)
    d = np.diff(t)
    return np.concatenate([[np.median(d)], d])


def row_norm(x, y=None, z=None) -> np.ndarray:
    """Euclidean norm of each row of an (N, 3) array ``x``, or of the rows of the columns
    ``x, y, z``: ``np.linalg.norm(x, axis=1)`` bit for bit (numpy sums a row's three squares
    left to right; ``tests/test_bundle_stream.py`` holds it to that), at a sixth of its cost
    (numpy's reduction over a length-3 axis is slow)."""
    if y is None:
        s = x * x
        return np.sqrt(s[:, 0] + s[:, 1] + s[:, 2])
    return np.sqrt(x * x + y * y + z * z)


def _check_limit(values, limit, what, unit, path, t, offset: int = 0):
    over = ~(np.abs(values) <= limit)
    if over.any():
        i = int(np.argmax(over))
        raise BadInput(f"{what} {values[i]:.6g} {unit} is physically impossible "
                       f"(limit {limit:.6g} {unit}); check the units", file=path,
                       row=offset + i + 1, time=float(t[i]))


def _imu_from(df, path) -> ImuData:
    c = _columns(df, IMU_COLUMNS, path)
    dtheta = np.column_stack([c["dtheta_x"], c["dtheta_y"], c["dtheta_z"]])
    dvel = np.column_stack([c["dvel_x"], c["dvel_y"], c["dvel_z"]])
    check_imu(c["t"], dtheta, dvel, path)
    return ImuData(c["t"], dtheta, dvel)


def check_imu(t, dtheta, dvel, path) -> None:
    """Physical plausibility of IMU increments (see the module notes); BadInput naming
    ``path``, the row and the time."""
    if len(t) < 2:
        raise BadInput(f"the IMU table has {len(t)} row; it needs at least 2 (one interval)",
                       file=path, row=1, time=float(t[0]))
    period = float(np.median(np.diff(t)))
    lo, hi = LIMITS["imu_rate_hz"]
    if not lo <= 1.0 / period <= hi:
        raise BadInput(f"IMU rate {1.0 / period:.4g} Hz (median step {period:.4g}) is outside "
                       f"{lo:g} .. {hi:g} Hz: is t in seconds?", file=path)
    dt = _row_dt(t)
    _check_limit(row_norm(dtheta) / dt, LIMITS["gyro_rate_rad_s"],
                 "angular rate |dtheta|/dt =", "rad/s", path, t)
    _check_limit(row_norm(dvel) / dt, LIMITS["specific_force_m_s2"],
                 "specific force |dvel|/dt =", "m/s^2", path, t)
    _check_sustained_rate(t, dtheta, path)
    _check_gravity(row_norm(dvel) / dt, path)


def _check_sustained_rate(t, dtheta, path) -> None:
    """The turn rate over any whole second stays below ``LIMITS["sustained_rate_rad_s"]``
    (3 rad/s, 170 deg/s: no land vehicle turns that fast for a second; vibration averages out
    over the second). Increments in degrees read 57 times too large and trip it in a turn."""
    if t[-1] - t[0] < 1.0:
        return
    c = np.vstack([np.zeros((1, 3)), np.cumsum(dtheta, axis=0)])
    tt = np.concatenate([[t[0] - (t[1] - t[0])], t])
    j = np.searchsorted(tt, tt + 1.0)
    ok = j < len(tt)
    i = np.flatnonzero(ok)
    if not len(i):
        return
    rate = np.linalg.norm(c[j[i]] - c[i], axis=1) / (tt[j[i]] - tt[i])
    limit = LIMITS["sustained_rate_rad_s"]
    if (rate > limit).any():
        k = i[int(np.argmax(rate > limit))]
        r = float(rate[int(np.argmax(rate > limit))])
        raise sustained_rate_error(r, path, int(min(k, len(t) - 1)) + 1,
                                   float(t[min(k, len(t) - 1)]))


def sustained_rate_error(r: float, path, row: int, time: float) -> BadInput:
    """The :class:`BadInput` of :func:`_check_sustained_rate` (turn rate ``r`` [rad/s])."""
    limit = LIMITS["sustained_rate_rad_s"]
    return BadInput(f"the turn rate over one second is {r:.4g} rad/s ({np.degrees(r):.4g} "
                    f"deg/s), beyond any land vehicle (limit {limit:g} rad/s): are dtheta "
                    "increments in degrees instead of radians?", file=path, row=row, time=time)


def _check_gravity(f, path):
    """The mean specific force of a land vehicle is gravity, ~9.8 m/s^2.

    A mean between 0.05 g and 0.5 g, or above 2 g, means the increments are not in m/s
    (``dvel`` in g*s gives ~1 m/s^2). A mean below 0.05 g is accepted: a log without
    accelerometers (zeros) can still feed dead reckoning.
    """
    _check_gravity_mean(float(np.mean(f)), path)


def _check_gravity_mean(mean: float, path) -> None:
    """:func:`_check_gravity` on the mean specific force [m/s^2] (of a table read in chunks)."""
    if 0.05 * G0 < mean < 0.5 * G0 or mean > 2.0 * G0:
        raise BadInput(f"mean specific force |dvel|/dt is {mean:.4g} m/s^2, but a vehicle on "
                       f"Earth feels ~{G0:.2f}: are dvel_x/y/z velocity increments in m/s?",
                       file=path)


def _speed_from(df, path, need_v) -> SpeedData:
    return speed_data(_columns(df, speed_columns(list(df.columns), path, need_v), path), path)


def speed_columns(has, path, need_v) -> tuple:
    """The columns a velocity-sensor table is read with (``has``: the file's columns)."""
    if need_v:
        return ("t", "v")                 # radar: speed only; a missing 'v' is reported later
    cols = tuple(k for k in ("v", "ds") if k in has)
    if not cols:
        raise BadInput(f"missing column: needs 'ds' or 'v' (has: {', '.join(has)})", file=path)
    return ("t",) + cols


def speed_data(c: dict, path) -> SpeedData:
    """A velocity sensor's checked columns (numeric, time increasing) -> :class:`SpeedData`,
    or BadInput at a speed no land vehicle reaches."""
    t = c["t"]
    if "v" in c:
        _check_limit(c["v"], LIMITS["speed_m_s"], "speed v =", "m/s", path, t)
    if "ds" in c:
        _check_limit(c["ds"] / _row_dt(t), LIMITS["speed_m_s"], "speed ds/dt =", "m/s", path, t)
    return SpeedData(t, v=c.get("v"), ds=c.get("ds"))


def _baro_from(df, path) -> BaroData:
    return baro_data(_columns(df, ("t", "h"), path), path)


def baro_data(c: dict, path) -> BaroData:
    """A barometer's checked columns -> :class:`BaroData`, or BadInput at an impossible
    height."""
    lo, hi = LIMITS["baro_h_m"]
    bad = (c["h"] < lo) | (c["h"] > hi)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadInput(f"barometric height {c['h'][i]:.6g} m outside {lo:g} .. {hi:g} m; "
                       "check the units", file=path, row=i + 1, time=float(c["t"][i]))
    return BaroData(c["t"], c["h"])


def _truth_from(df, path) -> Truth:
    truth = truth_rows(_columns(df, TRUTH_COLUMNS, path), path)
    _check_truth_consistency(truth, path)
    return truth


def truth_rows(c: dict, path, offset: int = 0) -> Truth:
    """Truth columns in file units (checked numeric, time increasing) -> :class:`Truth` (SI),
    or BadInput at a latitude, pitch or speed beyond what a drive can have (``offset``: the
    rows before these, for a table read in chunks)."""
    t = c["t"]
    _check_limit(c["lat"], 90.0, "latitude", "deg", path, t, offset)
    _check_limit(c["pitch"], 90.0, "pitch", "deg", path, t, offset)
    vel_n = np.column_stack([c["vE"], c["vN"], c["vU"]])
    _check_limit(row_norm(c["vE"], c["vN"], c["vU"]), LIMITS["speed_m_s"], "speed |v| =", "m/s",
                 path, t, offset)
    euler = np.radians(np.column_stack([c["pitch"], c["roll"], c["yaw"]]))
    return Truth(t, np.radians(c["lat"]), np.radians(c["lon"]), c["h"], vel_n, euler)


def check_bundle(bundle: Bundle, source) -> None:
    """The checks :func:`read_bundle` makes on the files, made on a bundle in memory (an
    importer's output, before it is written): BadInput naming ``source`` and the table."""
    src = bundle.meta.get("source") if isinstance(bundle.meta.get("source"), dict) else {}

    def name(table):
        own = src.get(table)                   # the file an importer read this table from
        is_file = isinstance(own, str) and Path(own).suffix != "" and " " not in own
        return f"{own if is_file else source} ({table})"
    arrays = [("imu", "t", bundle.imu.t)]
    for tb in TABLES[1:]:
        x = getattr(bundle, tb)
        if x is not None:
            arrays.append((tb, "t", x.t))
    for tb, col, t in arrays:
        bad = ~np.isfinite(t)
        if bad.any():
            i = int(np.argmax(bad))
            raise BadInput(f"time {t[i]} is not a finite number", file=name(tb), row=i + 1)
        _check_increasing(t, name(tb))
    check_imu(bundle.imu.t, bundle.imu.dtheta, bundle.imu.dvel, name("imu"))
    for tb in VELOCITY_SENSORS:
        s = getattr(bundle, tb)
        if s is not None and s.v is not None:
            _check_limit(np.nan_to_num(s.v, nan=0.0), LIMITS["speed_m_s"], "speed v =", "m/s",
                         name(tb), s.t)
    tr = bundle.truth
    if tr is not None:
        for col, x in (("lat", tr.lat), ("lon", tr.lon), ("h", tr.h)):
            bad = ~np.isfinite(x)
            if bad.any():
                i = int(np.argmax(bad))
                raise BadInput(f"{col} is not a finite number", file=name("truth"), row=i + 1,
                               time=float(tr.t[i]))
        _check_limit(np.degrees(tr.lat), 90.0, "latitude", "deg", name("truth"), tr.t)
        _check_limit(np.degrees(tr.euler[:, 0]), 90.0, "pitch", "deg", name("truth"), tr.t)
        _check_truth_consistency(tr, name("truth"))
    check_clocks(bundle, {tb: name(tb) for tb in TABLES})
    meta_initial(bundle.meta, f"{source} (meta)")      # an initial latitude beyond +-90 deg


def _check_truth_consistency(truth: Truth, path):
    """Positions and velocities of the truth must describe the same motion.

    Compares the horizontal path length from the positions with the integral of the
    horizontal speed (trapezoid). Over a drive of more than 100 m a ratio outside 0.5 .. 2
    means a unit error: lat/lon in rad instead of degrees gives a ratio of 1/57.3.
    """
    if len(truth.t) < 3:
        return
    check_truth_distances(*truth_distances(truth), path)


def truth_steps(truth) -> tuple:
    """``(north, dlon, r_n + h, cos lat)`` of each step between consecutive truth rows
    (``truth``: anything with ``lat``, ``lon``, ``h``; values at the step's first row):
    ``north = dlat (R_M + h)`` [m], ``dlon`` [rad] not wrapped: the terms
    :func:`truth_distances` and the path length share (the path length as
    :func:`inmotion.core.metrics._path_length` computes it, which
    :meth:`inmotion.io.bundle_stream.TruthStream.reduced` carries chunk by chunk from these),
    computed once per chunk there."""
    lat0, h0 = truth.lat[:-1], truth.h[:-1]
    r_m, r_n = radii(lat0)
    return np.diff(truth.lat) * (r_m + h0), np.diff(truth.lon), r_n + h0, np.cos(lat0)


def truth_distances(truth, steps=None) -> tuple[float, float]:
    """``(from_pos, from_vel)`` [m]: the horizontal path length of the truth's positions and
    the trapezoid integral of its horizontal speed (:func:`_check_truth_consistency`; a table
    read in chunks adds them up chunk by chunk, each chunk with the row before it).
    ``steps``: :func:`truth_steps` of ``truth`` when the caller has them."""
    north, dlon, rn_h, cos_lat = truth_steps(truth) if steps is None else steps
    step = np.hypot(north, dlon * rn_h * cos_lat)
    speed = np.hypot(truth.vel_n[:, 0], truth.vel_n[:, 1])
    return (float(np.sum(step)),
            float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(truth.t))))


def check_truth_distances(from_pos: float, from_vel: float, path) -> None:
    """Over a drive of more than 100 m the two distances of :func:`truth_distances` agree
    within a factor of 2, or BadInput (a unit error)."""
    if max(from_pos, from_vel) > 100.0 and not 0.5 < from_pos / max(from_vel, 1e-9) < 2.0:
        raise BadInput(f"positions travel {from_pos:.6g} m but the velocities integrate to "
                       f"{from_vel:.6g} m: are lat/lon in degrees and vE/vN in m/s?", file=path)


def meta_initial(meta: dict, path=None) -> dict:
    """The initial state ``meta.yaml`` gives, in its human units.

    Two spellings are understood: ``initial_position: {lat_deg, lon_deg, h_m}`` or top-level
    ``lat_deg, lon_deg, h_m`` (as the simulator writes); ``initial_attitude: {pitch_deg,
    roll_deg, yaw_deg}`` or ``initial_attitude_deg: {pitch, roll, yaw}``;
    ``initial_velocity: {vE_m_s, vN_m_s, vU_m_s}``.

    Returns
    -------
    dict
        ``lat_deg, lon_deg, h_m`` (None if absent), ``euler_deg`` ([pitch, roll, yaw] or None)
        and ``vel_n_m_s`` ([vE, vN, vU] or None). Values present but not numbers raise
        :class:`BadInput`.
    """
    pos = meta.get("initial_position")
    pos = pos if isinstance(pos, dict) else meta
    out = {k: _meta_number(pos, k, path) for k in ("lat_deg", "lon_deg", "h_m")}
    if out["lat_deg"] is not None and abs(out["lat_deg"]) > 90:
        raise BadInput(f"initial latitude {out['lat_deg']} deg is beyond +-90", file=path)
    att, keys = meta.get("initial_attitude"), ("pitch_deg", "roll_deg", "yaw_deg")
    if not isinstance(att, dict):
        att, keys = meta.get("initial_attitude_deg"), ("pitch", "roll", "yaw")
    out["euler_deg"] = ([_meta_number(att, k, path, 0.0) for k in keys]
                        if isinstance(att, dict) else None)
    vel = meta.get("initial_velocity")
    out["vel_n_m_s"] = ([_meta_number(vel, k, path, 0.0) for k in ("vE_m_s", "vN_m_s", "vU_m_s")]
                        if isinstance(vel, dict) else None)
    return out


def _meta_number(d, key, path, default=None):
    v = d.get(key, default)
    if v is None:
        return None
    if isinstance(v, bool) or not _is_number(v) or not math.isfinite(float(v)):
        raise BadInput(f"meta.yaml: {key} = {v!r} is not a finite number", file=path)
    return float(v)


def _check_initial_position(meta, path):
    ini = meta_initial(meta, path)
    if any(ini[k] is None for k in ("lat_deg", "lon_deg", "h_m")):
        raise BadInput("no truth table, so meta.yaml needs the initial position: "
                       "initial_position: {lat_deg, lon_deg, h_m}", file=path)


# --------------------------------------------------------------------------- gaps

def find_gaps(table: str, t, max_gap_periods: float = MAX_GAP_PERIODS,
              period: float | None = None) -> list[Gap]:
    """Steps of ``t`` [s] longer than ``max_gap_periods`` median periods, as :class:`Gap`
    (``period``: the median step when the caller has it)."""
    t = np.asarray(t, dtype=float)
    if len(t) < 3:
        return []
    d = np.diff(t)
    period = float(np.median(d)) if period is None else float(period)
    idx = np.flatnonzero(d > max_gap_periods * period)
    return [Gap(table, int(i) + 2, float(t[i]), float(t[i + 1]), float(d[i] / period))
            for i in idx]


def _check_gaps(table, t, path, max_gap_periods, error, period=None):
    gaps = find_gaps(table, t, max_gap_periods, period)
    if not gaps:
        return
    g = gaps[0]
    msg = (f"gap of {g.duration_s:.6g} s ({g.periods:.1f} sample periods) from t={g.t_start:.9g} s"
           + (f"; {len(gaps)} gaps in all" if len(gaps) > 1 else ""))
    if error:
        raise BadInput(msg + " (IMU increments are missing; read with allow_imu_gaps=True to "
                       "integrate across it)", file=path, row=g.row, time=g.t_end)
    warnings.warn(f"{path}: row {g.row}, t={g.t_end:.6g} s: {msg}", BundleGapWarning,
                  stacklevel=3)


# --------------------------------------------------------------------------- writing

def _frames(bundle: Bundle) -> dict:
    """``{table: DataFrame}`` in file units (degrees for the truth's angles)."""
    import pandas as pd
    imu = bundle.imu
    out = {"imu": pd.DataFrame({
        "t": imu.t, "dtheta_x": imu.dtheta[:, 0], "dtheta_y": imu.dtheta[:, 1],
        "dtheta_z": imu.dtheta[:, 2], "dvel_x": imu.dvel[:, 0], "dvel_y": imu.dvel[:, 1],
        "dvel_z": imu.dvel[:, 2]})}
    for name in VELOCITY_SENSORS:
        s = getattr(bundle, name)
        if s is not None:
            cols = {"t": s.t}
            if s.v is not None:
                cols["v"] = s.v
            if s.ds is not None:
                cols["ds"] = s.ds
            out[name] = pd.DataFrame(cols)
    if bundle.baro is not None:
        out["baro"] = pd.DataFrame({"t": bundle.baro.t, "h": bundle.baro.h})
    tr = bundle.truth
    if tr is not None:
        e = np.degrees(tr.euler)
        out["truth"] = pd.DataFrame({
            "t": tr.t, "lat": np.degrees(tr.lat), "lon": np.degrees(tr.lon), "h": tr.h,
            "vE": tr.vel_n[:, 0], "vN": tr.vel_n[:, 1], "vU": tr.vel_n[:, 2],
            "pitch": e[:, 0], "roll": e[:, 1], "yaw": np.mod(e[:, 2], 360.0)})
    return out


def write_bundle(bundle: Bundle, path, fmt: str = "csv") -> Path:
    """Write ``bundle`` as a bundle folder (created if missing).

    Parameters
    ----------
    bundle : Bundle
        SI inside; written with the truth's angles in degrees, yaw in [0, 360).
    path : str or Path
        The folder. Bundle tables already there (``imu.*``, ``radar.*`` ...) are replaced or,
        if this bundle lacks them, removed; other files are left alone.
    fmt : {"csv", "parquet"}

    Returns
    -------
    Path
        The folder. ``meta.yaml`` gets ``files`` set to the tables written.

    The folder is written whole or not at all (:func:`inmotion.io.safe_write.staged_folder`):
    the new content is built in a hidden sibling and swapped in by one rename, so a writer
    killed at any moment leaves either the old bundle, untouched, or the new one, complete.
    """
    if fmt not in ("csv", "parquet"):
        raise BadInput(f"unknown bundle format {fmt!r}; choose csv or parquet")
    suffix = ".csv" if fmt == "csv" else ".parquet"
    frames = _frames(bundle)
    with staged_folder(path, what="bundle") as folder:
        _write_tables(folder, frames, suffix, fmt, bundle)
    return Path(path)


def _write_tables(folder: Path, frames: dict, suffix: str, fmt: str, bundle: Bundle) -> None:
    for name in TABLES:              # stale tables (other format, or a sensor this bundle lacks)
        for s in SUFFIXES:
            if name not in frames or s != suffix:
                (folder / f"{name}{s}").unlink(missing_ok=True)
    files = {}
    for name, df in frames.items():
        target = folder / f"{name}{suffix}"
        atomic_write(target, lambda p, df=df: _write_table(df, p, fmt))
        files[name] = target.name
    meta = _plain(dict(bundle.meta))
    meta.setdefault("name", bundle.name)
    meta["files"] = files
    text = yaml.safe_dump(meta, sort_keys=False, default_flow_style=None)
    atomic_write(folder / "meta.yaml", lambda p: Path(p).write_text(text))


def _write_table(df, p, fmt):
    if fmt == "csv":
        write_csv(df, p)
    else:
        # row groups of PARQUET_ROW_GROUP rows: a reader in chunks holds one group of the
        # columns it reads (pyarrow's default, a million rows, is 56 MB of IMU columns).
        # Plain-encoded, LZ4: a column of measured floats has hardly a repeated value, so
        # pyarrow's default dictionary encoding (tried, then given up page by page) and Snappy
        # only add work; measured on the 1 h drive of benchmarks/bench_engine.py (issue 13):
        # IMU 23.6 -> 18.8 MB and its rows read in 0.026 -> 0.012 s of CPU, truth 8.6 -> 7.4
        # MB and 0.025 -> 0.017 s, a time column 0.007 -> 0.002 s
        df.to_parquet(p, index=False, engine="pyarrow", row_group_size=PARQUET_ROW_GROUP,
                      compression=PARQUET_COMPRESSION, use_dictionary=False)


def write_csv(df: "pd.DataFrame | Mapping[str, np.ndarray]", path) -> None:
    """Write ``df`` as CSV: plain header, every float64 in its shortest round-trip form.

    ``df`` is a DataFrame or a mapping of column name to 1-D array (in column order; what a
    command-line run writes, so that it need not import pandas). Uses Arrow's CSV writer
    (five times faster than pandas' on 100 Hz hour-long tables); a float written and read back
    is bit-identical. NaN is written as an empty field.
    """
    import pyarrow.csv as pacsv
    table = arrow_table(df)
    with open(path, "wb") as f:
        f.write((",".join(map(str, table.column_names)) + "\n").encode())
        pacsv.write_csv(table, f, write_options=pacsv.WriteOptions(include_header=False))


def arrow_table(df: "pd.DataFrame | Mapping[str, np.ndarray]"):
    """A ``pyarrow.Table`` of a DataFrame (``from_pandas``, no index) or of a mapping of
    column name to 1-D array, NaN as null in both (as ``from_pandas`` does), so CSV and
    Parquet files are the same whichever a writer passes."""
    import pyarrow as pa
    if hasattr(df, "iloc"):                                            # a pandas DataFrame
        return pa.Table.from_pandas(df, preserve_index=False)
    names = [str(k) for k in df]
    return pa.Table.from_arrays([numpy_to_arrow(v) for v in df.values()], names=names)


def numpy_to_arrow(values):
    """A 1-D numeric or boolean numpy array as a ``pyarrow.Array`` built on its buffer, NaN as
    null (what ``pa.array(values, from_pandas=True)`` gives). Built from buffers because
    pyarrow's own conversions (``pa.array``, ``Array.to_numpy``) import pandas to ask whether
    the input is one of its types: a third of a second of every command-line run."""
    import pyarrow as pa
    v = np.ascontiguousarray(values)
    if v.ndim != 1 or v.dtype.kind not in "fiub":
        return pa.array(v, from_pandas=True)                           # anything else
    n, validity, nulls = len(v), None, 0
    if v.dtype.kind == "f":
        ok = ~np.isnan(v)
        nulls = n - int(np.count_nonzero(ok))
        if nulls:
            validity = pa.py_buffer(np.packbits(ok, bitorder="little"))
    if v.dtype.kind == "b":
        data, typ = pa.py_buffer(np.packbits(v, bitorder="little")), pa.bool_()
    else:
        data, typ = pa.py_buffer(v), pa.from_numpy_dtype(v.dtype)
    return pa.Array.from_buffers(typ, n, [validity, data], null_count=nulls)


def arrow_to_numpy(x) -> np.ndarray:
    """A numeric ``pyarrow.Array`` without nulls as a read-only numpy view of its buffer (what
    ``x.to_numpy()`` gives, without the pandas import that costs); others through
    ``to_numpy`` (nulls become NaN)."""
    import pyarrow.types as pat
    if x.null_count == 0 and (pat.is_floating(x.type) or pat.is_integer(x.type)):
        kind = "f" if pat.is_floating(x.type) else "i" if pat.is_signed_integer(x.type) else "u"
        dtype = np.dtype(f"{kind}{x.type.bit_width // 8}")
        return np.frombuffer(x.buffers()[1], dtype=dtype, count=len(x),
                             offset=x.offset * dtype.itemsize)
    return x.to_numpy(zero_copy_only=False)


def _plain(x):
    """``x`` with numpy scalars/arrays turned into plain Python, for YAML and JSON."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    return x
