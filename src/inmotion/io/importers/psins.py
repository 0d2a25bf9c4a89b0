"""The PSINS toolbox's logs (G. Yan, NWPU; github.com/WangShanpeng/PSINS), as in
``shared/data/real/psins_*``: the text IMU log ``*.imu`` and the transfer-alignment MATLAB file.

Two layouts, told apart by the file's extension:

``.imu`` (text, "PSINS-format SIMU log file"; ``lasergyro.imu``)
    Lines starting with ``%`` are comments. Then three header rows and one row per sample,
    6 numbers each:

    1. ``[pitch0, roll0, yaw0]`` deg, ``[VE0, VN0, VU0]`` m/s, "maybe inaccurate";
    2. latitude deg, longitude deg, height m, ``t0`` s, sampling interval ms, ``g`` m/s^2;
    3. gyro scale factors arcsec per count x3, accelerometer scale factors ug*s per count x3;
    4. and on: gyro counts x, y, z, accelerometer counts x, y, z, axes "X-Right, Y-Forward,
       Z-Up" (:data:`IMU_AXES`, already the DESIGN body frame); each row is the increment over
       one sampling interval.

    Row ``k`` (0-based) becomes the IMU row at ``t0 + (k + 1) ts``, the increment over
    ``(t0 + k ts, t0 + (k + 1) ts]``. ``dtheta = counts * gf`` [arcsec -> rad] and
    ``dvel = counts * af * 1e-6 * g`` [m/s] with ``g`` the header's (PSINS's ``glv.ug`` is
    ``1e-6 g0``, ``g0 = 9.7803267714``; the header says 9.780327).
    PSINS's yaw is counter-clockwise from North; ours is clockwise: the attitude is converted
    through the direction cosine matrix (:func:`design_euler_from_psins`), which for PSINS's
    ``C_b^n = R_z(yaw) R_x(pitch) R_y(roll)`` gives ``yaw_ours = -yaw_psins`` (mod 360) and
    the same pitch and roll.

    There is no reference. The log the data README describes is a parked vehicle
    (``parked=True`` by default): ``meta.yaml`` gets the header position as
    ``initial_position``, zero ``initial_velocity`` (exact for a parked vehicle), the header
    attitude as ``initial_attitude`` (the file calls it "maybe inaccurate"; ``meta`` says so)
    and the IMU's specification under ``imu`` with ``source: documented``: the figures the
    toolbox author gives for this class of unit (the data README), and the quantization the
    header's scale factors define.

``.mat`` (``transfer_align_fog_mems.mat``)
    ``mimu`` (N, 7): MEMS ``[dtheta_x, dtheta_y, dtheta_z]`` rad, ``[dv_x, dv_y, dv_z]`` m/s,
    ``t`` s, Right-Forward-Up, row k the increment ending at ``t`` (taken as it is);
    ``fogavp`` (M, 10): the FOG INS solution ``[pitch, roll, yaw]`` rad (PSINS yaw),
    ``[vE, vN, vU]`` m/s, ``[lat, lon]`` rad, ``h`` m, ``t`` s, at 10 Hz; ``mu0`` (3,) rad, the
    MEMS-to-FOG mounting the toolbox author estimated; ``eb0``, ``db0``, the author's MEMS gyro
    and accelerometer bias estimates (copied to ``meta['imu']`` as documented values).

    The FOG solution becomes the bundle's ``truth`` at its own 10 Hz times (the truth table
    may have its own rate: :func:`inmotion.core.metrics.interpolate_truth` interpolates it
    to the solution's epochs). Truth attitude is the IMU's: with ``mounting="mu0"`` (default)
    ``C_mems^n = C_fog^n C_mems^fog``, ``C_mems^fog = exp([mu0 x])``, the sign checked on the
    data (the MEMS rates rotated this way match the FOG attitude's rates best, see
    ``tests/test_importers.py``); ``mounting="none"`` keeps the FOG attitude.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import scipy.io

from ...core import rotations
from ...core.bundle import Bundle, ImuData, Truth
from ...errors import BadInput
from ..resample import check_times, find_gaps
from .tables import check_finite, existing_file

__all__ = ["IMU_AXES", "import_psins", "read_psins_imu", "design_euler_from_psins",
           "psins_from_design_euler", "RLG_SPEC", "ARCSEC"]

#: PSINS IMUs are mounted "X-Right, Y-Forward, Z-Up": the DESIGN body frame itself
IMU_AXES = ("right", "forward", "up")
ARCSEC = np.pi / 180.0 / 3600.0
DATASET = ("PSINS toolbox, G. Yan, NWPU (github.com/WangShanpeng/PSINS, snapshot c1706f1)")
LICENSE = "BSD-2-Clause (PSINS toolbox)"

#: the toolbox author's nominal figures for the navigation-grade RLG unit of
#: ``lasergyro.imu`` (data README): gyro drift 0.01-0.03 deg/h, accelerometer bias ~100 ug,
#: angle random walk ~0.001 deg/sqrt(h). The drift is given as the top of the range.
RLG_SPEC = {"gyro": {"drift_deg_h": 0.03, "drift_range_deg_h": [0.01, 0.03],
                     "arw_deg_sqrt_h": 0.001},
            "accel": {"bias_ug": 100.0}}


def _psins_C_nb(euler_psins):
    """PSINS ``a2mat``: ``C_b^n = R_z(yaw) R_x(pitch) R_y(roll)``, yaw counter-clockwise."""
    e = np.atleast_2d(np.asarray(euler_psins, dtype=float))
    return rotations.rot_z(e[:, 2]) @ rotations.rot_x(e[:, 0]) @ rotations.rot_y(e[:, 1])


def design_euler_from_psins(euler_psins) -> np.ndarray:
    """DESIGN ``[pitch, roll, yaw]`` [rad] (N, 3) from PSINS ``[pitch, roll, yaw]`` [rad]
    (ENU, Right-Forward-Up, yaw counter-clockwise from North), through the DCM."""
    return rotations.euler_from_dcm(_psins_C_nb(euler_psins))


def psins_from_design_euler(euler) -> np.ndarray:
    """Inverse of :func:`design_euler_from_psins` (PSINS yaw in (-pi, pi])."""
    C = rotations.dcm_from_euler(np.atleast_2d(np.asarray(euler, dtype=float)))
    pitch = np.arcsin(np.clip(C[:, 2, 1], -1.0, 1.0))
    roll = np.arctan2(-C[:, 2, 0], C[:, 2, 2])
    yaw = np.arctan2(-C[:, 0, 1], C[:, 1, 1])
    return np.stack([pitch, roll, yaw], axis=-1)


# ----------------------------------------------------------------------------- .imu text

def read_psins_imu(path) -> tuple[np.ndarray, np.ndarray]:
    """``(header (3, 6), counts (N, 6))`` of a PSINS ``.imu`` text log (BadInput if malformed)."""
    p = existing_file(path, "PSINS .imu file")
    try:
        df = pd.read_csv(p, sep=r"\s+", header=None, comment="%", dtype=float, engine="c")
        data = df.to_numpy(dtype=float)
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise BadInput(f"not a PSINS .imu table of 6 numbers per row ({exc})", p) from None
    if data.ndim != 2 or data.shape[1] != 6:
        raise BadInput(f"a PSINS .imu file has 6 columns per row, got {data.shape[-1]}", p)
    if len(data) < 5:
        raise BadInput(f"a PSINS .imu file has 3 header rows and data rows; got {len(data)} "
                       f"rows", p)
    check_finite(data, p, "PSINS .imu row")
    return data[:3], data[3:]


def _import_imu_text(path: Path, parked: bool, name) -> Bundle:
    header, counts = read_psins_imu(path)
    att_deg, vel0 = header[0, :3], header[0, 3:]
    lat_deg, lon_deg, h_m, t0, ts_ms, g = header[1]
    gf, af = header[2, :3], header[2, 3:]
    if not (0 < ts_ms < 1e4) or not (9.0 < g < 10.5) or (gf <= 0).any() or (af <= 0).any() \
            or abs(lat_deg) > 90:
        raise BadInput(f"header rows do not read as PSINS's (interval {ts_ms} ms, g {g}, "
                       f"scale factors {gf}, {af}, latitude {lat_deg})", path, row=2)
    ts = ts_ms * 1e-3
    n = len(counts)
    t = t0 + ts * np.arange(1, n + 1)
    dtheta = counts[:, :3] * (gf * ARCSEC)
    dvel = counts[:, 3:] * (af * 1e-6 * g)
    euler = design_euler_from_psins(np.deg2rad(att_deg))[0]
    ed = np.rad2deg(euler)
    meta = {
        "name": name or path.stem,
        "source": {"format": "psins", "layout": "imu text (counts)", "file": str(path),
                   "rows": int(n), "t0_s": float(t0), "sampling_interval_ms": float(ts_ms),
                   "g_m_s2": float(g), "gyro_scale_arcsec_per_count": gf.tolist(),
                   "accel_scale_ug_s_per_count": af.tolist(),
                   "increments": "counts x scale factor; row k over (t0 + k ts, t0 + (k+1) ts]"},
        "imu_axes": {"source": list(IMU_AXES), "to": "b = [right, forward, up]",
                     "note": "PSINS: X-Right, Y-Forward, Z-Up (the file's comment block)"},
        "initial_position": {"lat_deg": float(lat_deg), "lon_deg": float(lon_deg),
                             "h_m": float(h_m)},
        "initial_attitude": {"pitch_deg": float(ed[0]), "roll_deg": float(ed[1]),
                             "yaw_deg": float(ed[2])},
        "initial_attitude_note": (f"header row 1, 'maybe inaccurate' (the file); PSINS yaw "
                                  f"{att_deg[2]:g} deg counter-clockwise -> {ed[2]:.6g} deg "
                                  f"clockwise"),
        "imu": {"rate_hz": float(1.0 / ts),
                "gyro": {**RLG_SPEC["gyro"],
                         "quantization_arcsec": gf.tolist()},
                "accel": {**RLG_SPEC["accel"],
                          "quantization_m_s": (af * 1e-6 * g).tolist()},
                "source": "documented",
                "documented_by": "PSINS toolbox author's nominal figures for this class of "
                                 "ring-laser-gyro unit (shared/data/real/README.md); "
                                 "quantization from the file's scale factors",
                "grade": "navigation (ring-laser gyro)"},
        "license": LICENSE,
        "dataset": DATASET,
    }
    if parked:
        meta["initial_velocity"] = {"vE_m_s": 0.0, "vN_m_s": 0.0, "vU_m_s": 0.0}
        meta["motion"] = {"parked": True,
                          "note": "parked vehicle, engine running, people moving about it "
                                  "(pitch sways ~0.1 deg): position and zero velocity exact, "
                                  "no attitude reference"}
    elif np.any(vel0 != 0):
        meta["initial_velocity"] = {"vE_m_s": float(vel0[0]), "vN_m_s": float(vel0[1]),
                                    "vU_m_s": float(vel0[2])}
    gaps = find_gaps(t)
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    return Bundle(imu=ImuData(t, dtheta, dvel), meta=meta)


# ----------------------------------------------------------------------------- .mat

def _mat_array(mat, key, ncols, path):
    if key not in mat:
        raise BadInput(f"no variable {key!r} in the MATLAB file (found "
                       f"{', '.join(k for k in mat if not k.startswith('__'))})", path)
    a = np.asarray(mat[key], dtype=float)
    if ncols is None:
        a = a.reshape(-1)
        if a.size != 3:
            raise BadInput(f"{key} has {a.size} values, expected 3", path)
        return a
    if a.ndim != 2 or a.shape[1] != ncols or len(a) < 3:
        raise BadInput(f"{key} has shape {a.shape}, expected (N, {ncols})", path)
    return a


#: the transfer-alignment file's MEMS platform is not fixed in its vehicle (data README: it
#: rolls by about +-32 deg between 33 and 73 s, about its own forward axis, which sits about
#: 5 deg off the direction of travel): the direction of travel then moves in the IMU's axes by
#: up to 5 deg * sin(32 deg) = 2.6 deg, and it does so within a quarter swing, which the
#: file's own gyro shows taking about 6 s (the forward gyro's integral goes from 0 to -33 deg
#: between 30 and 36 s): a random walk that reaches 2.6 deg in 6 s,
#: 2.6 deg / sqrt(6 s) = 64 arcmin/sqrt(s), written as ``meta.vehicle.
#: mounting_rw_arcmin_sqrt_s`` (:func:`inmotion.align.meta_spec.mounting_rw_from_meta`; the
#: toolbox's own demo models the MEMS-to-FOG angles as a Markov process too). Issue 15,
#: session 22: with it every Kalman method's final error on the log is within 2.8 times its
#: sigma; with 25 (the same excursion spread over the 40 s) sins-dr's track was 3.06 times
MEMS_PLATFORM_RW_ARCMIN_SQRT_S = 64.0
#: the MEMS's white noise as the toolbox's demo for the transfer-alignment file sets it
#: (``imuerrset(500, 1000, 0.1, 10)``: bias 500 deg/h, 1000 ug; angle random walk
#: 0.1 deg/sqrt(h), velocity random walk 10 ug/sqrt(Hz)); the biases come from the file's own
#: ``eb0``, ``db0``
MEMS_DEMO_ARW_DEG_SQRT_H = 0.1
MEMS_DEMO_VRW_UG_SQRT_HZ = 10.0
MEMS_DEMO_NOISE = "imuerrset(500, 1000, 0.1, 10)"


def _import_mat(path: Path, mounting: str, name) -> Bundle:
    try:
        mat = scipy.io.loadmat(path)
    except (ValueError, OSError, NotImplementedError, TypeError,
            scipy.io.matlab.MatReadError) as exc:
        raise BadInput(f"not a readable MATLAB file ({exc})", path) from None
    if mounting not in ("mu0", "none"):
        raise BadInput(f"mounting must be 'mu0' or 'none', not {mounting!r}")
    mimu = _mat_array(mat, "mimu", 7, path)
    fog = _mat_array(mat, "fogavp", 10, path)
    check_finite(mimu, path, "mimu")
    check_finite(fog, path, "fogavp")
    t = check_times(mimu[:, 6], path, "mimu t")
    tf = check_times(fog[:, 9], path, "fogavp t")
    extra = {k: _mat_array(mat, k, None, path) for k in ("mu0", "eb0", "db0") if k in mat}
    C_nf = _psins_C_nb(fog[:, :3])
    mu = extra.get("mu0") if mounting == "mu0" else None
    if mounting == "mu0" and mu is None:
        raise BadInput("mounting='mu0' but the file has no mu0", path)
    C_nb = C_nf if mu is None else C_nf @ rotations.dcm_from_rotvec(mu)
    euler = rotations.euler_from_dcm(C_nb)
    truth = Truth(tf, fog[:, 6], fog[:, 7], fog[:, 8], fog[:, 3:6], euler)
    imu_spec = {"rate_hz": float(1.0 / np.median(np.diff(t))), "grade": "low-cost MEMS",
                "source": "documented",
                "documented_by": "PSINS toolbox author's estimates in the file (eb0, db0); "
                                 "the noise densities of the toolbox's demo for this file "
                                 f"(test_align_transfer_fog_mems.m: {MEMS_DEMO_NOISE})",
                "gyro": {"arw_deg_sqrt_h": MEMS_DEMO_ARW_DEG_SQRT_H},
                "accel": {"vrw_ug_sqrt_hz": MEMS_DEMO_VRW_UG_SQRT_HZ}}
    if "eb0" in extra:
        imu_spec["gyro"]["drift_deg_h"] = (np.rad2deg(extra["eb0"]) * 3600.0).tolist()
    if "db0" in extra:
        imu_spec["accel"]["bias_ug"] = (extra["db0"] / 9.7803267714 * 1e6).tolist()
    meta = {
        "name": name or path.stem,
        "source": {"format": "psins", "layout": "transfer-alignment MATLAB file",
                   "file": str(path), "variables": ["mimu", "fogavp"] + sorted(extra),
                   "increments": "mimu as they are (row k over the interval ending at t)"},
        "imu_axes": {"source": list(IMU_AXES), "to": "b = [right, forward, up]"},
        "initial_position": {"lat_deg": float(np.rad2deg(fog[0, 6])),
                             "lon_deg": float(np.rad2deg(fog[0, 7])), "h_m": float(fog[0, 8])},
        "imu": imu_spec,
        "truth": {"what": "FOG INS solution of the same vehicle (PSINS fogavp), 10 Hz; "
                          "accuracy not stated (arc-minute class)",
                  "yaw": "PSINS yaw (counter-clockwise) converted through the DCM",
                  "attitude": ("FOG attitude rotated into the MEMS axes by mu0, "
                               "C_mems^n = C_fog^n exp([mu0 x]) (author's estimate)")
                  if mu is not None else "FOG attitude as it is (MEMS mounting not applied)"},
        "vehicle": {"mounting_rw_arcmin_sqrt_s": MEMS_PLATFORM_RW_ARCMIN_SQRT_S,
                    "source": "derived from the dataset README (the MEMS platform rolls by "
                              "about +-32 deg in the vehicle, about 5 deg off the direction "
                              "of travel) and the file's gyro (a quarter swing in about 6 s): "
                              "2.6 deg / sqrt(6 s)"},
        "license": LICENSE,
        "dataset": DATASET,
    }
    if mu is not None:
        meta["truth"]["mu0_deg"] = np.rad2deg(mu).tolist()
    gaps = find_gaps(t)
    if len(gaps):
        meta["gaps"] = {"imu": gaps.as_list(), "threshold_s": gaps.threshold_s}
    return Bundle(imu=ImuData(t, mimu[:, :3], mimu[:, 3:6]), meta=meta, truth=truth)


def import_psins(source, *, parked=1, mounting="mu0", name=None) -> Bundle:
    """Read a PSINS log into a :class:`Bundle` (module docstring).

    Parameters
    ----------
    source : a ``.imu`` text log (counts) or the transfer-alignment ``.mat`` file
    parked : ``.imu`` only: 1 (default) the vehicle is parked, velocity zero (``meta``);
        0 no such claim
    mounting : ``.mat`` only: ``mu0`` (default) truth attitude rotated into the MEMS axes by
        the file's ``mu0``; ``none``: the FOG attitude as it is
    name : bundle name (default: the file's stem)
    """
    path = existing_file(source, "PSINS file")
    if path.suffix.lower() == ".mat":
        return _import_mat(path, str(mounting), name)
    flag = str(parked).strip().lower()
    if flag not in ("1", "0", "true", "false", "yes", "no"):
        raise BadInput(f"parked must be 1 or 0, not {parked!r}")
    return _import_imu_text(path, flag in ("1", "true", "yes"), name)
