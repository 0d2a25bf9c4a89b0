"""The segment layout of comma2k19 (Schafer et al., arXiv:1812.05752), as in
``shared/data/real/comma2k19_rav4_60s``.

Layout: every signal is a folder holding two NumPy ``.npy`` files without extension, ``t``
(float64 s on the device boot clock) and ``value``.

``processed_log/IMU/accelerometer``, ``.../gyro``
    Phone IMU, specific force [m/s^2] and angular rate [rad/s] (``gyro`` is bias-corrected by
    the phone; ``gyro_uncalibrated`` is also there), axes :data:`IMU_AXES` = [forward, right,
    down], about 104 Hz with jitter. When the two have different time stamps, the gyro rate is
    interpolated to the accelerometer's (:func:`_gyro_on_accel_clock`). Turned into increments
    over each real interval by :func:`inmotion.io.resample.rates_to_increments` (trapezoid by
    default); the first sample only opens the first interval.
``processed_log/CAN/speed``
    Vehicle speed [m/s], about 89 Hz, on its own clock: the odometer ``v``. It reads about 0.6 %
    low against the reference (a real scale error, left in: estimating it is a method's job).
``global_pose/frame_times, frame_positions, frame_velocities, frame_orientations``
    The reference at 20 Hz: ECEF position [m] and velocity [m/s] of the camera and the Hamilton
    quaternion ``[w, x, y, z]`` rotating camera axes :data:`CAMERA_AXES` = [forward, right, down]
    into ECEF. It becomes the truth at the frame times: ``lat, lon, h`` from
    :func:`inmotion.core.earth.ecef_to_lla`, ``vel_n = C_n^e v_e``, and
    ``C_b^n = C_n^e C_e^cam C_cam^b`` with b = Right-Forward-Up.

The IMU axes agree with the camera axes (data README), so the truth attitude is the IMU's; the
camera/IMU is mounted about 0.8 deg (yaw) and 3.8 deg (pitch) off the direction of travel, so
the truth yaw differs from the course over ground by about that much.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...core import earth, rotations
from ...core.bundle import Bundle, ImuData, SpeedData, Truth
from ...errors import BadInput
from ..resample import check_times, find_gaps, interpolate_at, rates_to_increments
from .axes import C_b_src, FRD
from .tables import as_float, check_finite, check_order, existing_dir
from .vehicle import road_vehicle

__all__ = ["IMU_AXES", "CAMERA_AXES", "import_comma2k19", "read_signal"]

#: phone IMU axes of the comma2k19 processed logs
IMU_AXES = FRD
#: camera axes of ``global_pose/frame_orientations``
CAMERA_AXES = FRD


def _load_npy(path, what):
    if not path.is_file():
        raise BadInput(f"{what}: file not found (comma2k19 segment layout expected)", path)
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise BadInput(f"{what}: not a NumPy .npy file ({exc})", path) from None


def read_signal(folder, ncols=None):
    """``(t, value)`` of one signal folder; ``value`` reshaped to (N, ncols) when given."""
    folder = Path(folder)
    t = as_float(_load_npy(folder / "t", folder.name + " t"), folder / "t",
                 folder.name + " t").reshape(-1)
    value = as_float(_load_npy(folder / "value", folder.name + " value"), folder / "value",
                     folder.name + " value")
    if value.shape[0] != len(t) or (ncols is not None and value.size != len(t) * ncols):
        raise BadInput(f"value has shape {value.shape} for {len(t)} times"
                       + (f" (expected ({len(t)}, {ncols}))" if ncols else ""), folder)
    t = check_times(t, folder / "t", "time")
    if ncols is not None:
        value = value.reshape(len(t), ncols)
    check_finite(value, folder / "value", folder.name, t=t)
    return t, value


def _gyro_on_accel_clock(t_f, f_src, t_w, w_src, folder):
    """Accelerometer and gyro on one clock: the accelerometer's, cut to the span the gyro
    covers, with the gyro rate linearly interpolated to it (never extrapolated). Across a gyro
    gap (:func:`inmotion.io.resample.find_gaps`) the rate is still interpolated, the only
    information there is, and the gap is returned for ``meta['gaps']['gyro']``."""
    if len(t_f) == len(t_w) and np.all(t_f == t_w):
        return t_f, f_src, w_src, None
    keep = (t_f >= t_w[0]) & (t_f <= t_w[-1])
    if keep.sum() < 2:
        raise BadInput("accelerometer and gyro time spans do not overlap", folder)
    t = t_f[keep]
    w, valid = interpolate_at(t_w, w_src, t)
    if not valid.all():
        w = np.column_stack([np.interp(t, t_w, w_src[:, j]) for j in range(3)])
    return t, f_src[keep], w, find_gaps(t_w)


def _imu(root, gyro, order):
    folder = root / "processed_log/IMU"
    t_f, f_src = read_signal(folder / "accelerometer", 3)
    t_w, w_src = read_signal(folder / gyro, 3)
    t_src, f_src, w_src, gyro_gaps = _gyro_on_accel_clock(t_f, f_src, t_w, w_src, folder)
    C = C_b_src(IMU_AXES)
    gaps = find_gaps(t_src)
    t, dtheta = rates_to_increments(t_src, w_src @ C.T, order=order, gaps=gaps)
    _, dvel = rates_to_increments(t_src, f_src @ C.T, order=order, gaps=gaps)
    return ImuData(t, dtheta, dvel), gaps, gyro_gaps


def _truth(root):
    pose = root / "global_pose"
    t = check_times(_load_npy(pose / "frame_times", "frame_times").astype(float).reshape(-1),
                    pose / "frame_times", "frame time")
    arrays = {}
    for key, width in (("frame_positions", 3), ("frame_velocities", 3),
                       ("frame_orientations", 4)):
        a = _load_npy(pose / key, key).astype(float)
        if a.shape != (len(t), width):
            raise BadInput(f"shape {a.shape}, expected ({len(t)}, {width})", pose / key)
        check_finite(a, pose / key, key, t=t)
        arrays[key] = a
    lat, lon, h = earth.ecef_to_lla(arrays["frame_positions"])
    C_ne = earth.enu_from_ecef_matrix(lat, lon)
    vel_n = np.einsum("kij,kj->ki", C_ne, arrays["frame_velocities"])
    C_e_cam = rotations.dcm_from_quat(arrays["frame_orientations"])
    C_cam_b = C_b_src(CAMERA_AXES).T
    euler = rotations.euler_from_dcm(C_ne @ C_e_cam @ C_cam_b)
    gps = _load_npy(pose / "frame_gps_times", "frame_gps_times") \
        if (pose / "frame_gps_times").is_file() else None
    return Truth(t, lat, lon, h, vel_n, euler), gps


#: ``meta['imu']`` of the phone IMU (issue 15). The dataset documents no IMU specification:
#: these are *assumed* figures for a consumer phone MEMS, marked ``source: assumed``, so that a
#: filter run on the imported log with its default settings does not assume a navigation-grade
#: IMU. The phone's ``gyro`` is bias-corrected by the phone, so its residual is modelled as a
#: first-order Gauss-Markov bias (``drift_markov_*``, :mod:`inmotion.estimation.
#: error_model`): 1-sigma 150 deg/h, the scale of the 35-190 deg/h residual against the
#: reference that the data README reports (about 100 deg/h), correlation time 30 s, the scale
#: over which that residual changes by about 100 deg/h (10 s window means in
#: ``reproduce real``); accelerometer bias 10 mg (0.08 m/s^2 measured against the reference).
#: The bias is a constant plus that Gauss-Markov part (issue 15; ``od-kf`` then carries two
#: error states per axis, ``eps`` and ``eps_gm``): the constant ``drift_deg_h`` 150 deg/h,
#: assumed (a consumer MEMS gyro's turn-on residual, which the phone's own bias correction
#: need not remove; the figure the constant-bias model used before), not fitted. What the
#: segment shows (``reproduce real``), not put into the spec because the only segment is the
#: one the results are judged on: a constant (x, y, z: -96, -125, 107 deg/h against the
#: reference) plus a wander of about +-50 deg/h;
#: the sample-to-sample noise (sensor plus engine vibration, no reference needed) is an angle
#: random walk of about 2.5, 1.0, 0.5 deg/sqrt(h) on x, y, z (the spec's 0.5 is the z value).
PHONE_IMU_SPEC = {
    "gyro": {"drift_deg_h": 150.0, "drift_markov_deg_h": 150.0, "drift_markov_tau_s": 30.0,
             "arw_deg_sqrt_h": 0.5},
    "accel": {"bias_ug": 10000.0, "vrw_ug_sqrt_hz": 300.0},
    "source": "assumed",
    "assumed_by": "inmotion's comma2k19 importer: consumer phone MEMS class, not documented by "
                  "the dataset (io.importers.comma2k19.PHONE_IMU_SPEC)",
    "grade": "consumer (phone MEMS)",
}


def _imu_spec(imu, gyro):
    """``meta['imu']``: :data:`PHONE_IMU_SPEC`; with ``gyro_uncalibrated`` (the phone's bias
    not removed) a 1000 deg/h constant drift is assumed on top."""
    spec = {k: (dict(v) if isinstance(v, dict) else v) for k, v in PHONE_IMU_SPEC.items()}
    if gyro == "gyro_uncalibrated":
        spec["gyro"]["drift_deg_h"] = 1000.0
    return {"rate_hz": float(1.0 / np.median(np.diff(imu.t))), **spec}


def import_comma2k19(source, *, gyro="gyro", order=2, name=None) -> Bundle:
    """Read a comma2k19 segment folder into a :class:`Bundle` (SI, DESIGN frames).

    Parameters
    ----------
    source : the segment folder (holding ``processed_log`` and ``global_pose``)
    gyro : ``"gyro"`` (bias-corrected by the phone) or ``"gyro_uncalibrated"``
    order : 2 (trapezoid) or 4 (cubic) integration of rates to increments
    name : bundle name (default: the folder name)

    Raises
    ------
    BadInput
        Missing folder or file, arrays of the wrong shape, non-finite values, times not
        increasing.
    """
    order = check_order(order)
    root = existing_dir(source, "comma2k19 segment folder")
    if gyro not in ("gyro", "gyro_uncalibrated"):
        raise BadInput(f"gyro must be 'gyro' or 'gyro_uncalibrated', got {gyro!r}")
    imu, gaps, gyro_gaps = _imu(root, gyro, order)
    t_can, v_can = read_signal(root / "processed_log/CAN/speed", 1)
    truth, gps = _truth(root)
    meta = {
        "name": name or root.name,
        "source": {"format": "comma2k19", "folder": str(root), "gyro": gyro,
                   "rates_to_increments": "trapezoid" if order == 2 else "cubic"},
        "imu_axes": {"source": list(IMU_AXES), "to": "b = [right, forward, up]"},
        "time": "device boot clock [s]",
        "initial_position": {"lat_deg": float(np.rad2deg(truth.lat[0])),
                             "lon_deg": float(np.rad2deg(truth.lon[0])), "h_m": float(truth.h[0])},
        "imu": _imu_spec(imu, gyro),
        "vehicle": road_vehicle(),
        "odometer": {"signal": "CAN speed", "note": "reads about 0.6 % low against the "
                     "reference; not corrected"},
        "truth": {"source": "global_pose (offline INS/GNSS/vision fusion by the dataset "
                  "authors, no accuracy stated)", "frame": "camera = IMU axes; mounted about "
                  "0.8 deg yaw and 3.8 deg pitch off the direction of travel"},
        "license": "MIT (comma.ai, comma2k19)",
    }
    if gps is not None:
        meta["truth"]["gps_week"] = int(gps[0, 0])
        meta["truth"]["gps_tow_first_s"] = float(gps[0, 1])
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    if gyro_gaps is not None:
        meta["source"]["gyro_clock"] = "own clock, interpolated to the accelerometer's"
        if len(gyro_gaps):
            meta.setdefault("gaps", {})["gyro"] = gyro_gaps.as_list()
    return Bundle(imu=imu, meta=meta, odometer=SpeedData(t_can, v=v_can[:, 0]), truth=truth)
