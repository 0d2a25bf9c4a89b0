"""The text formats of the KF-GINS / OB_GINS family (i2Nav group, Wuhan University), both ways.

Formats (from the KF-GINS README and the awesome-gins-datasets README; columns separated by
spaces, tabs or commas, no header):

IMU file, 7 columns (8 in the OB_GINS IMU/odometer variant); or ``*.bin``: the same 7 values
as little-endian float64 records (awesome-gins-datasets)
    ``t`` GNSS seconds of week [s]; ``dtheta_x, dtheta_y, dtheta_z`` [rad];
    ``dvel_x, dvel_y, dvel_z`` [m/s]; increments over the interval ending at ``t``, in the IMU
    frame Forward-Right-Down (:data:`IMU_AXES`); optional 8th column: odometer forward speed
    [m/s] at ``t``.
Odometer file, 2 columns
    ``t`` [s of week], forward speed [m/s].
GNSS position file, 7 or 13 columns
    ``t`` [s of week], latitude [deg], longitude [deg], ellipsoidal height [m], then either
    position STD north, east, down [m] (7) or velocity north, east, down [m/s] and position and
    velocity STD (13).
Navigation result / reference ``.nav``, 11 columns
    GNSS week, seconds of week, latitude [deg], longitude [deg], ellipsoidal height [m],
    velocity north, east, down [m/s], roll, pitch, yaw [deg]: aerospace ZYX Euler angles of the
    FRD IMU frame in North-East-Down, yaw clockwise from North.

Times stay in GNSS seconds of week, the one time base of the bundle; a week rollover inside the
log (time dropping by more than half a week) is unwrapped by adding 604800 s.

inmotion has no GNSS aiding: the GNSS file, when given, only provides the initial position in
``meta`` (if there is no ``.nav`` reference) and is summarized in ``meta['gnss']``;
:func:`read_gnss` returns its rows for whoever wants them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ...core.bundle import Bundle, ImuData, SpeedData, Truth
from ...core.solution import Solution
from ...errors import BadInput
from ..resample import check_times, find_gaps
from .axes import C_b_src, FRD, design_euler_from_ned_rpy, ned_rpy_from_design_euler, ned_to_enu
from .tables import check_finite, existing_file, read_text_table

__all__ = ["IMU_AXES", "SECONDS_PER_WEEK", "import_kf_gins", "export_kf_gins", "read_gnss",
           "read_nav"]

#: the KF-GINS IMU frame: x forward, y right, z down
IMU_AXES = FRD
SECONDS_PER_WEEK = 604800.0


def _unwrap_week(t):
    """Seconds of week made continuous across a week rollover."""
    jumps = np.diff(t) < -SECONDS_PER_WEEK / 2
    return t + SECONDS_PER_WEEK * np.concatenate([[0], np.cumsum(jumps)])


def _read_imu_bin(path):
    """The binary IMU file: records of 7 little-endian float64."""
    raw = np.fromfile(path, dtype="<f8")
    if raw.size == 0 or raw.size % 7:
        raise BadInput(f"binary IMU file holds {raw.size} doubles, not a multiple of 7", path)
    data = raw.reshape(-1, 7)
    check_finite(data, path, "KF-GINS IMU file", t=data[:, 0])
    return data


def _read_imu(path):
    if Path(path).suffix.lower() == ".bin":
        data = _read_imu_bin(path)
    else:
        data = read_text_table(path, (7, 8), "KF-GINS IMU file")
    t = check_times(_unwrap_week(data[:, 0]), path, "IMU time")
    C = C_b_src(IMU_AXES)
    imu = ImuData(t, data[:, 1:4] @ C.T, data[:, 4:7] @ C.T)
    odo = SpeedData(t, v=data[:, 7]) if data.shape[1] == 8 else None
    return imu, odo


def _read_odometer(path):
    data = read_text_table(path, 2, "KF-GINS odometer file")
    t = check_times(_unwrap_week(data[:, 0]), path, "odometer time")
    return SpeedData(t, v=data[:, 1])


def read_gnss(path) -> pd.DataFrame:
    """The GNSS position file: columns ``t`` [s], ``lat_deg``, ``lon_deg``, ``h_m``,
    ``std_north_m``, ``std_east_m``, ``std_down_m`` (and ``vN_m_s, vE_m_s, vD_m_s`` for the
    13-column variant)."""
    data = read_text_table(path, (7, 13), "KF-GINS GNSS file")
    t = check_times(_unwrap_week(data[:, 0]), path, "GNSS time")
    cols = {"t": t, "lat_deg": data[:, 1], "lon_deg": data[:, 2], "h_m": data[:, 3]}
    std = data[:, 4:7] if data.shape[1] == 7 else data[:, 7:10]
    if data.shape[1] == 13:
        cols.update(vN_m_s=data[:, 4], vE_m_s=data[:, 5], vD_m_s=data[:, 6])
    cols.update(std_north_m=std[:, 0], std_east_m=std[:, 1], std_down_m=std[:, 2])
    return pd.DataFrame(cols)


def read_nav(path) -> Truth:
    """A ``.nav`` file (reference or navigation result) as a :class:`Truth` in SI and the
    DESIGN conventions (ENU velocity, RFU body, ``[pitch, roll, yaw]``)."""
    data = read_text_table(path, 11, "KF-GINS .nav file")
    t = check_times(_unwrap_week(data[:, 1]), path, ".nav time")
    roll, pitch, yaw = np.deg2rad(data[:, 8:11]).T
    return Truth(t, np.deg2rad(data[:, 2]), np.deg2rad(data[:, 3]), data[:, 4],
                 ned_to_enu(data[:, 5:8]), design_euler_from_ned_rpy(roll, pitch, yaw))


def import_kf_gins(source, *, odo=None, gnss=None, nav=None, name=None) -> Bundle:
    """Read a KF-GINS / OB_GINS data set into a :class:`Bundle` (SI, DESIGN frames).

    Parameters
    ----------
    source : path of the IMU file: text (7 or 8 columns) or ``.bin`` (module docstring)
    odo : optional path of a 2-column odometer file (overrides an 8th IMU column)
    gnss : optional path of the GNSS position file (initial position, ``meta['gnss']``)
    nav : optional path of the ``.nav`` reference (becomes the truth)
    name : bundle name (default: the IMU file's stem)

    Raises
    ------
    BadInput
        Missing file, wrong number of columns, non-numeric value, time not increasing.
    """
    src = existing_file(source, "KF-GINS IMU file")
    imu, odometer = _read_imu(src)
    if odo is not None:
        odometer = _read_odometer(odo)
    truth = read_nav(nav) if nav is not None else None
    meta = {"name": name or src.stem, "source": {"format": "kf-gins", "imu": str(src)},
            "imu_axes": {"source": list(IMU_AXES), "to": "b = [right, forward, up]"},
            "time": "GNSS seconds of week"}
    gaps = find_gaps(imu.t)
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    if odometer is not None:
        meta["source"]["odometer"] = str(odo) if odo is not None else "IMU file column 8"
    if truth is not None:
        meta["source"]["truth"] = str(nav)
        meta["initial_position"] = {"lat_deg": float(np.rad2deg(truth.lat[0])),
                                    "lon_deg": float(np.rad2deg(truth.lon[0])),
                                    "h_m": float(truth.h[0])}
    if gnss is not None:
        g = read_gnss(gnss)
        meta["gnss"] = {"file": str(gnss), "rows": len(g), "t_first_s": float(g.t.iloc[0]),
                        "note": "not used by inmotion (no GNSS aiding)"}
        if truth is None:
            meta["initial_position"] = {"lat_deg": float(g.lat_deg.iloc[0]),
                                        "lon_deg": float(g.lon_deg.iloc[0]),
                                        "h_m": float(g.h_m.iloc[0])}
    return Bundle(imu=imu, meta=meta, odometer=odometer, truth=truth)


def _read_solution_csv(result_dir) -> Solution:
    """``solution.csv`` of a result folder (DESIGN: degrees for lat, lon and angles)."""
    path = existing_file(Path(result_dir) / "solution.csv", "result solution.csv")
    df = pd.read_csv(path)
    need = ["t", "lat", "lon", "h", "vE", "vN", "vU", "pitch", "roll", "yaw"]
    missing = [c for c in need if c not in df.columns]
    if missing:
        raise BadInput(f"missing column {missing[0]!r}", path)
    a = df[need].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if len(bad):
        raise BadInput("value that is not a finite number", path, row=int(bad[0]) + 1)
    from ..result import check_solution
    from ..safe_write import refuse_partial
    refuse_partial(Path(result_dir), "result")
    sol = Solution(a[:, 0], np.deg2rad(a[:, 1]), np.deg2rad(a[:, 2]), a[:, 3], a[:, 4:7],
                   np.deg2rad(a[:, 7:10]))
    check_solution(sol, file=path, hint="")       # latitude 3000 deg, unsorted rows ...
    return sol


def export_kf_gins(result, out_path, *, gps_week=0) -> Path:
    """Write a solution as a KF-GINS ``.nav`` file (11 columns, see the module docstring).

    Parameters
    ----------
    result : a :class:`Solution` or a result folder holding ``solution.csv``
    out_path : the ``.nav`` file to write
    gps_week : the GNSS week written in column 1 (KF-GINS writes 0 when unknown); times are
        written as they are, taken to be seconds of week.
    """
    sol = result if isinstance(result, Solution) else _read_solution_csv(result)
    rpy = np.rad2deg(ned_rpy_from_design_euler(sol.euler))
    vel_ned = ned_to_enu(sol.vel_n)                  # the swap is its own inverse
    table = np.column_stack([np.full(len(sol), float(gps_week)), sol.t,
                             np.rad2deg(sol.lat), np.rad2deg(sol.lon), sol.h, vel_ned, rpy])
    from ..safe_write import atomic_write, check_output_path, output_error
    out = check_output_path(out_path, folder=False)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise output_error(out, e) from None
    atomic_write(out, lambda tmp: np.savetxt(
        tmp, table, fmt=["%.0f", "%.6f", "%.11f", "%.11f", "%.4f", "%.5f", "%.5f", "%.5f",
                         "%.8f", "%.8f", "%.8f"]))
    return out

