"""Results out to what other tools read: a NED / FRD CSV and a GeoJSON track.

``inmotion export ned-csv RESULT -o FILE.csv``
    One row per solution row: ``t_s, lat_deg, lon_deg, h_m`` (ellipsoidal), ``north_m,
    east_m, down_m`` (local offsets from the first row, flat-Earth at the first row's radii),
    ``vN_m_s, vE_m_s, vD_m_s`` (velocity in the local North-East-Down frame), ``roll_deg,
    pitch_deg, yaw_deg`` (aerospace ZYX Euler angles of a Forward-Right-Down body in NED:
    ``C_b^n = R_z(yaw) R_y(pitch) R_x(roll)``; yaw clockwise from North in [0, 360)), then the
    1-sigma columns of the solution when it has them (``sigma_north_m`` ...). Lines starting
    with ``#`` above the header state the convention, the method and the source.
``inmotion export geojson RESULT -o FILE.geojson``
    A GeoJSON ``FeatureCollection`` (RFC 7946: WGS-84 longitude, latitude, height in m) with
    one ``LineString`` of the track and ``Point`` features for its start and end; properties
    carry the method, the times and the distance. At most ``max_points`` vertices (the track is
    thinned evenly; the last point is kept).

The KF-GINS ``.nav`` export is :func:`inmotion.io.importers.kf_gins.export_kf_gins`.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Union

import numpy as np
import pandas as pd

from .._typing import PathLike
from ..core.earth import local_ne_offsets
from ..core.solution import Solution
from ..errors import BadInput

__all__ = ["load_solution", "ned_frame", "export_ned_csv", "export_geojson", "EXPORTERS"]

NED_CONVENTION = (
    "# frames: position and velocity in the local North-East-Down (NED) frame; body "
    "Forward-Right-Down (FRD)\n"
    "# attitude: aerospace ZYX Euler angles, C_b^n = R_z(yaw) R_y(pitch) R_x(roll); yaw "
    "clockwise from North in [0, 360) deg\n"
    "# north_m, east_m, down_m: offsets from the first row; h_m: ellipsoidal height\n")


def load_solution(result: Union[Solution, PathLike]) -> Solution:
    """A :class:`Solution` as it is, or read from a result folder (CSV or Parquet)."""
    if isinstance(result, Solution):
        return result
    from .result import read_result
    return read_result(result)


def ned_frame(sol: Solution) -> pd.DataFrame:
    """The solution as the NED / FRD table of :func:`export_ned_csv`."""
    from .importers.axes import ned_rpy_from_design_euler
    north, east = local_ne_offsets(sol.lat, sol.lon, sol.lat[0], sol.lon[0], sol.h[0])
    rpy = np.degrees(ned_rpy_from_design_euler(sol.euler))
    cols = {"t_s": sol.t, "lat_deg": np.degrees(sol.lat), "lon_deg": np.degrees(sol.lon),
            "h_m": sol.h, "north_m": north, "east_m": east, "down_m": -(sol.h - sol.h[0]),
            "vN_m_s": sol.vel_n[:, 1], "vE_m_s": sol.vel_n[:, 0], "vD_m_s": -sol.vel_n[:, 2],
            "roll_deg": rpy[:, 0], "pitch_deg": rpy[:, 1], "yaw_deg": np.mod(rpy[:, 2], 360.0)}
    for name, unit, scale in (("north", "m", 1.0), ("east", "m", 1.0), ("h", "m", 1.0),
                              ("vN", "m_s", 1.0), ("vE", "m_s", 1.0), ("vU", "m_s", 1.0),
                              ("phi_E", "deg", 180 / np.pi), ("phi_N", "deg", 180 / np.pi),
                              ("phi_U", "deg", 180 / np.pi)):
        if name in sol.sigma:
            cols[f"sigma_{name}_{unit}"] = np.asarray(sol.sigma[name], dtype=float) * scale
    return pd.DataFrame(cols)


def export_ned_csv(result: Union[Solution, PathLike], out_path: PathLike) -> Path:
    """Write the solution as a NED / FRD CSV with its convention in ``#`` header lines."""
    sol = load_solution(result)
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    method = sol.info.get("method") or "unknown method"
    with open(out, "w") as f:
        f.write(NED_CONVENTION)
        f.write(f"# method: {method}; written by inmotion\n")
        ned_frame(sol).to_csv(f, index=False, float_format="%.10g")
    return out


def export_geojson(result: Union[Solution, PathLike], out_path: PathLike,
                   max_points: int = 5000) -> Path:
    """Write the track as GeoJSON (a LineString plus start and end points)."""
    sol = load_solution(result)
    if len(sol) < 2:
        raise BadInput("the solution has fewer than 2 rows; no track to write")
    idx = np.unique(np.r_[np.linspace(0, len(sol) - 1, min(len(sol), max_points)).astype(int),
                          len(sol) - 1])
    lon, lat, h = np.degrees(sol.lon[idx]), np.degrees(sol.lat[idx]), sol.h[idx]
    coords = [[round(float(a), 9), round(float(b), 9), round(float(c), 3)]
              for a, b, c in zip(lon, lat, h)]
    north, east = local_ne_offsets(sol.lat, sol.lon, sol.lat[0], sol.lon[0], sol.h[0])
    dist = float(np.sum(np.hypot(np.diff(north), np.diff(east))))
    method = sol.info.get("method")
    props = {"method": method, "t_start_s": float(sol.t[0]), "t_end_s": float(sol.t[-1]),
             "rows": int(len(sol)), "vertices": len(coords), "distance_m": dist}
    features = [
        {"type": "Feature", "geometry": {"type": "LineString", "coordinates": coords},
         "properties": {**props, "name": f"{method or 'track'}"}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": coords[0]},
         "properties": {"name": "start", "t_s": float(sol.t[0])}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": coords[-1]},
         "properties": {"name": "end", "t_s": float(sol.t[-1])}},
    ]
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"type": "FeatureCollection", "features": features}) + "\n")
    return out


#: ``inmotion export FORMAT``: format -> function(result, out_path) -> Path
EXPORTERS = {"ned-csv": export_ned_csv, "geojson": export_geojson}
