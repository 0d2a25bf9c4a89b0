"""The MATLAB file of the EMS-SymINSGNSS data set (M. Atia, doi:10.5281/zenodo.1183569), as
in ``shared/data/real/ems_toronto_511s/ems_data_for_lc.mat``.

One struct ``ems_data`` (MATLAB v5) with ``time`` [s], ``accel`` (N, 3) specific force
[m/s^2], ``gyro`` (N, 3) [rad/s], reference ``roll``, ``pitch``, ``heading`` [rad], ``lat``,
``lon`` [rad], ``vel_N`` = [vE, vN, vU] [m/s] and ``h``.

Body axes: the data set says only "z down". :data:`IMU_AXES` declares x forward, y right
(Forward-Right-Down, the only right-handed choice with x along the car and z down that makes
the reference angles aerospace ZYX angles): it is checked on the data
(``tests/test_importers.py``): the body rates from the gyro increments follow, axis by axis, the
body rates of the converted reference attitude (correlation above 0.9, slope 1 +- 0.15), and the
mean specific force over the first minute agrees with ``C_n^b (dv_n/dt + [0, 0, g])`` from the
reference to the accelerometer biases (0.3 m/s^2).

The reference attitude is taken as aerospace ZYX ``roll, pitch, heading`` of that FRD frame in
North-East-Down and converted to the DESIGN ``[pitch, roll, yaw]`` through the DCM.
The reference height ``h`` is a constant placeholder, not a measurement (``meta['truth']``
says so); the vertical velocity is identically 0. Rates become increments over each interval
by :func:`inmotion.io.resample.rates_to_increments`. There is no odometer.
"""
from __future__ import annotations

import numpy as np
import scipy.io

from ...core.bundle import Bundle, ImuData, Truth
from ...errors import BadInput
from ..resample import check_times, find_gaps, rates_to_increments
from .axes import C_b_src, FRD, design_euler_from_ned_rpy
from .tables import as_float, check_finite, check_order, existing_file
from .vehicle import road_vehicle

__all__ = ["IMU_AXES", "import_ems"]

#: declared body axes of the EMS IMU (z down from the data set; x forward, y right checked)
IMU_AXES = FRD

_FIELDS_N3 = ("accel", "gyro", "vel_N")
_FIELDS_N = ("time", "roll", "pitch", "heading", "lat", "lon", "h")


def _load_struct(path, var):
    try:
        mat = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except (ValueError, OSError, NotImplementedError, TypeError,
            scipy.io.matlab.MatReadError) as exc:
        raise BadInput(f"not a readable MATLAB file ({exc})", path) from None
    if var not in mat:
        raise BadInput(f"no variable {var!r} in the MATLAB file "
                       f"(found {', '.join(k for k in mat if not k.startswith('__'))})", path)
    s = mat[var]
    missing = [f for f in _FIELDS_N3 + _FIELDS_N if not hasattr(s, f)]
    if missing:
        raise BadInput(f"{var} has no field {missing[0]!r}", path)
    return s


def _fields(s, path):
    n = as_float(s.time, path, "field 'time'").size
    out = {}
    for f in _FIELDS_N:
        a = as_float(getattr(s, f), path, f"field {f!r}").reshape(-1)
        if f == "h" and a.size == 1:
            a = np.full(n, float(a[0]))
        if a.size != n:
            raise BadInput(f"field {f!r} has {a.size} values for {n} times", path)
        out[f] = a
    for f in _FIELDS_N3:
        a = as_float(getattr(s, f), path, f"field {f!r}")
        if a.shape != (n, 3):
            raise BadInput(f"field {f!r} has shape {a.shape}, expected ({n}, 3)", path)
        out[f] = a
    t = check_times(out["time"], path, "time")
    for f, a in out.items():
        check_finite(a, path, f"field {f!r}", t=t)
    return out


def import_ems(source, *, var="ems_data", order=2, name=None) -> Bundle:
    """Read the EMS MATLAB file into a :class:`Bundle` (SI, DESIGN frames, no odometer).

    Parameters
    ----------
    source : the ``.mat`` file
    var : the struct's name in the file
    order : 2 (trapezoid) or 4 (cubic) integration of rates to increments
    name : bundle name (default: the file's stem)
    """
    order = check_order(order)
    path = existing_file(source, "EMS MATLAB file")
    d = _fields(_load_struct(path, var), path)
    t_src = d["time"]
    C = C_b_src(IMU_AXES)
    gaps = find_gaps(t_src)
    t, dtheta = rates_to_increments(t_src, d["gyro"] @ C.T, order=order, gaps=gaps)
    _, dvel = rates_to_increments(t_src, d["accel"] @ C.T, order=order, gaps=gaps)
    euler = design_euler_from_ned_rpy(d["roll"], d["pitch"], d["heading"])
    truth = Truth(t_src, d["lat"], d["lon"], d["h"], d["vel_N"], euler)
    meta = {
        "name": name or path.stem,
        "source": {"format": "ems", "file": str(path), "variable": var,
                   "rates_to_increments": "trapezoid" if order == 2 else "cubic"},
        "imu_axes": {"source": list(IMU_AXES), "to": "b = [right, forward, up]",
                     "note": "data set states z down; x forward, y right assumed and checked "
                             "against the reference attitude rates"},
        "initial_position": {"lat_deg": float(np.rad2deg(truth.lat[0])),
                             "lon_deg": float(np.rad2deg(truth.lon[0])), "h_m": float(truth.h[0])},
        "truth": {"h": "placeholder constant, not a measured height",
                  "vU": "identically 0 in the source"},
        "license": "LGPL-3.0 (EMS-SymINSGNSS)",
        "vehicle": road_vehicle(),
    }
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    return Bundle(imu=ImuData(t, dtheta, dvel), meta=meta, truth=truth)
