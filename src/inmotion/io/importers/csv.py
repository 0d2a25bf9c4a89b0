"""Any CSV log, described by a small YAML mapping (``docs/importers.md`` has the reference and
an example).

The mapping names the columns, their units, the IMU axes on the vehicle, and whether the IMU
columns are rates (integrated to increments over each real interval by
:func:`inmotion.io.resample.rates_to_increments`) or already increments. Every sensor may come
from the main CSV or from its own file with its own time column (a sensor on its own clock).

Blank cells: in a shared file a sensor sampled more slowly than the IMU leaves its cells blank
in the rows where it has no sample; those rows are skipped for that sensor. IMU cells may not
be blank. A cell that holds text that is not a number is bad input (file, row, time).

Attitude conventions of a reference (``truth.attitude.convention``):

* ``design``: columns ``[pitch, roll, yaw]`` already in the DESIGN convention;
* ``ned-frd-zyx``: columns ``[roll, pitch, yaw]``, aerospace ZYX of a Forward-Right-Down body
  in North-East-Down (KF-GINS, most INS outputs), converted through the DCM
  (:func:`.axes.design_euler_from_ned_rpy`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Literal, Optional

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, ValidationError, field_validator

from ...core.bundle import Bundle, ImuData, SpeedData, Truth, VELOCITY_SENSORS
from ...core.earth import G0
from ...errors import BadInput
from ..resample import check_times, find_gaps, rates_to_increments
from .axes import C_b_src, design_euler_from_ned_rpy, ned_to_enu
from .tables import existing_file

__all__ = ["CsvMapping", "load_mapping", "import_csv", "UNITS"]

_D = np.pi / 180.0
#: unit name -> factor to SI, per quantity
UNITS = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "gyro_rate": {"rad/s": 1.0, "deg/s": _D, "deg/h": _D / 3600.0},
    "gyro_increment": {"rad": 1.0, "deg": _D},
    "accel_rate": {"m/s^2": 1.0, "m/s2": 1.0, "g": G0},
    "accel_increment": {"m/s": 1.0},
    "speed": {"m/s": 1.0, "km/h": 1.0 / 3.6, "mph": 0.44704},
    "distance": {"m": 1.0},
    "angle": {"rad": 1.0, "deg": _D},
    "length": {"m": 1.0, "ft": 0.3048},
}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class TimeSpec(_Strict):
    column: str
    unit: str = "s"


class Vec3Spec(_Strict):
    columns: list[str]
    unit: str

    @field_validator("columns")
    @classmethod
    def _three(cls, v):
        if len(v) != 3:
            raise ValueError(f"needs 3 columns, got {len(v)}")
        return v


class ScalarSpec(_Strict):
    column: str
    unit: str


class ImuSpec(_Strict):
    kind: Literal["rate", "increment"]
    gyro: Vec3Spec
    accel: Vec3Spec
    axes: list[str]
    integration: Literal["trapezoid", "cubic"] = "trapezoid"
    file: Optional[str] = None
    time: Optional[TimeSpec] = None


class SpeedSpec(_Strict):
    column: str
    unit: str = "m/s"
    kind: Literal["v", "ds"] = "v"
    file: Optional[str] = None
    time: Optional[TimeSpec] = None


class VelocitySpec(_Strict):
    columns: list[str]
    frame: Literal["enu", "ned"]
    unit: str = "m/s"


class AttitudeSpec(_Strict):
    columns: list[str]
    unit: str = "deg"
    convention: Literal["design", "ned-frd-zyx"]


class TruthSpec(_Strict):
    lat: ScalarSpec
    lon: ScalarSpec
    h: ScalarSpec
    velocity: VelocitySpec
    attitude: AttitudeSpec
    file: Optional[str] = None
    time: Optional[TimeSpec] = None


class CsvMapping(_Strict):
    """The YAML mapping (see ``docs/importers.md``)."""

    name: Optional[str] = None
    delimiter: str = ","
    time: TimeSpec
    imu: ImuSpec
    odometer: Optional[SpeedSpec] = None
    radar: Optional[SpeedSpec] = None
    ldv: Optional[SpeedSpec] = None
    truth: Optional[TruthSpec] = None
    initial_position: Optional[dict] = None


def load_mapping(mapping) -> tuple[CsvMapping, Optional[Path]]:
    """The mapping from a YAML file path or a dict; ``(mapping, its folder or None)``."""
    where = None
    if isinstance(mapping, dict):
        raw = mapping
    else:
        where = existing_file(mapping, "CSV mapping file")
        from ..safe_yaml import load_yaml_file
        raw = load_yaml_file(where, "CSV mapping", invalid="not valid YAML")
        if not isinstance(raw, dict):
            raise BadInput("mapping must be a YAML dictionary", where)
    try:
        m = CsvMapping.model_validate(raw)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(x) for x in err["loc"])
        raise BadInput(f"mapping: {loc}: {err['msg']}", where) from None
    return m, (where.parent if where is not None else None)


def _factor(quantity, unit, where):
    table = UNITS[quantity]
    if unit not in table:
        raise BadInput(f"mapping: unit {unit!r} not known for {quantity.replace('_', ' ')}; "
                       f"use {', '.join(table)}", where)
    return table[unit]


class _Table:
    """One CSV file read once, its columns fetched as numbers with row/time in errors."""

    def __init__(self, path, delimiter, time_spec, where):
        self.path = existing_file(path, "CSV file")
        try:
            self.df = pd.read_csv(self.path, sep=delimiter, dtype=str, skipinitialspace=True)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
            raise BadInput(f"not a readable CSV ({str(exc).strip()})", self.path) from None
        self.t = self.column(time_spec.column, _factor("time", time_spec.unit, where),
                             blank_ok=False, with_time=False)

    def column(self, name, factor, blank_ok, with_time=True) -> np.ndarray:
        if name not in self.df.columns:
            raise BadInput(f"no column {name!r} (has {', '.join(self.df.columns)})", self.path)
        raw = self.df[name]
        x = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
        blank = raw.isna().to_numpy() | (raw.astype(str).str.strip() == "").to_numpy()
        bad = (~np.isfinite(x) & ~blank) | (blank & (not blank_ok))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            time = float(self.t[i]) if with_time and np.isfinite(self.t[i]) else None
            what = "blank" if blank[i] else f"{raw.iloc[i]!r} is not a finite number"
            raise BadInput(f"column {name!r}: {what}", self.path, row=i + 1, time=time)
        return x * factor


class _Files:
    """The CSV tables of one import, each read once."""

    def __init__(self, source, mapping: CsvMapping, mapping_dir, where):
        self.source, self.m, self.where = Path(source), mapping, where
        self.base = mapping_dir if mapping_dir is not None else self.source.parent
        self._cache = {}

    def get(self, spec) -> _Table:
        path = self.source if spec.file is None else self.base / spec.file
        tspec = spec.time or self.m.time
        key = (str(path), tspec.column, tspec.unit)
        if key not in self._cache:
            self._cache[key] = _Table(path, self.m.delimiter, tspec, self.where)
        return self._cache[key]


def _imu(files, spec: ImuSpec, where):
    tab = files.get(spec)
    t = check_times(tab.t, tab.path, "IMU time")
    q = spec.kind
    w = np.column_stack([tab.column(c, _factor(f"gyro_{q}", spec.gyro.unit, where), False)
                         for c in spec.gyro.columns])
    f = np.column_stack([tab.column(c, _factor(f"accel_{q}", spec.accel.unit, where), False)
                         for c in spec.accel.columns])
    C = C_b_src(spec.axes, where)
    gaps = find_gaps(t)
    if q == "increment":
        return ImuData(t, w @ C.T, f @ C.T), gaps
    order = 2 if spec.integration == "trapezoid" else 4
    t_out, dtheta = rates_to_increments(t, w @ C.T, order=order, gaps=gaps)
    _, dvel = rates_to_increments(t, f @ C.T, order=order, gaps=gaps)
    return ImuData(t_out, dtheta, dvel), gaps


def _speed(files, spec: SpeedSpec, sensor, where):
    tab = files.get(spec)
    qty = "speed" if spec.kind == "v" else "distance"
    x = tab.column(spec.column, _factor(qty, spec.unit, where), blank_ok=True)
    keep = np.isfinite(x)
    if keep.sum() < 2:
        raise BadInput(f"{sensor}: fewer than 2 samples in column {spec.column!r}", tab.path)
    t = check_times(tab.t[keep], tab.path, f"{sensor} time")
    return SpeedData(t, v=x[keep]) if spec.kind == "v" else SpeedData(t, ds=x[keep])


def _truth(files, spec: TruthSpec, where):
    tab = files.get(spec)
    lat = tab.column(spec.lat.column, _factor("angle", spec.lat.unit, where), True)
    keep = np.isfinite(lat)
    t = check_times(tab.t[keep], tab.path, "truth time")

    def col(name, qty, unit):
        x = tab.column(name, _factor(qty, unit, where), True)[keep]
        if not np.isfinite(x).all():
            i = int(np.flatnonzero(~np.isfinite(x))[0])
            raise BadInput(f"truth column {name!r} blank where latitude is given", tab.path,
                           time=float(t[i]))
        return x

    for key, n in (("velocity", spec.velocity.columns), ("attitude", spec.attitude.columns)):
        if len(n) != 3:
            raise BadInput(f"mapping: truth.{key}.columns needs 3 columns", where)
    lon = col(spec.lon.column, "angle", spec.lon.unit)
    h = col(spec.h.column, "length", spec.h.unit)
    vel = np.column_stack([col(c, "speed", spec.velocity.unit) for c in spec.velocity.columns])
    vel_n = ned_to_enu(vel) if spec.velocity.frame == "ned" else vel
    att = np.column_stack([col(c, "angle", spec.attitude.unit) for c in spec.attitude.columns])
    if spec.attitude.convention == "ned-frd-zyx":
        euler = design_euler_from_ned_rpy(att[:, 0], att[:, 1], att[:, 2])
    else:
        euler = att
    return Truth(t, lat[keep], lon, h, vel_n, euler)


def import_csv(source, *, mapping, name=None) -> Bundle:
    """Read a CSV log described by a YAML mapping into a :class:`Bundle`.

    Parameters
    ----------
    source : the main CSV file (sensors without their own ``file`` are read from it)
    mapping : path of the YAML mapping, or the mapping as a dict
    name : bundle name (default: the mapping's ``name``, else the CSV's stem)

    Raises
    ------
    BadInput
        Missing file or column, unknown unit or axis word, invalid mapping, non-numeric cell,
        time not increasing.
    """
    if mapping is None:
        raise BadInput("the csv format needs a mapping (--mapping FILE)")
    m, mapping_dir = load_mapping(mapping)
    where = mapping if not isinstance(mapping, dict) else "mapping"
    files = _Files(existing_file(source, "CSV file"), m, mapping_dir, where)
    imu, gaps = _imu(files, m.imu, where)
    sensors = {s: _speed(files, getattr(m, s), s, where)
               for s in VELOCITY_SENSORS if getattr(m, s) is not None}
    truth = _truth(files, m.truth, where) if m.truth is not None else None
    meta = {"name": name or m.name or Path(source).stem,
            "source": {"format": "csv", "file": str(source),
                       "mapping": str(mapping) if not isinstance(mapping, dict) else "dict",
                       "imu": m.imu.kind + ("" if m.imu.kind == "increment"
                                            else f" ({m.imu.integration})")},
            "imu_axes": {"source": list(m.imu.axes), "to": "b = [right, forward, up]"}}
    if truth is not None:
        meta["initial_position"] = {"lat_deg": float(np.rad2deg(truth.lat[0])),
                                    "lon_deg": float(np.rad2deg(truth.lon[0])),
                                    "h_m": float(truth.h[0])}
    elif m.initial_position is not None:
        meta["initial_position"] = dict(m.initial_position)
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    return Bundle(imu=imu, meta=meta, truth=truth, **sensors)
