"""The real-drive pieces: the reference calibration and the still-period gyro bias against
closed forms on synthetic bundles; the whole run on the real drives (skipped without data)."""
import json

import numpy as np
import pytest

from inmotion.core import earth, rotations
from inmotion.core.bundle import Bundle, ImuData, SpeedData, Truth
from inmotion.errors import BadInput
from inmotion.evaluate import reproduce_real as rr
from inmotion.navigate.pure import mounting_matrix

D = np.pi / 180.0
LAT = 43.6 * D


def synthetic_bundle(mount_rad, scale, n=50, yaw=30 * D, pitch=2 * D, roll=-1 * D):
    """Constant attitude; the vehicle moves along the sensor's forward axis
    ``C_b^n C_m^b [0, v, 0]`` and the odometer reads ``scale * v``."""
    t = np.arange(n) * 0.05
    euler = np.tile([pitch, roll, yaw], (n, 1))
    C_nb = rotations.dcm_from_euler(euler[0])
    v = 5.0 + 0.1 * t
    vel_n = (C_nb @ mounting_matrix(mount_rad) @ [0.0, 1.0, 0.0])[None, :] * v[:, None]
    truth = Truth(t, np.full(n, LAT), np.full(n, -1.38), np.full(n, 100.0), vel_n, euler)
    imu = ImuData(t, np.zeros((n, 3)), np.zeros((n, 3)))
    return Bundle(imu=imu, truth=truth, odometer=SpeedData(t, v=scale * v))


@pytest.mark.parametrize("mount_deg", [(3.8, 0.0, 0.0), (0.0, 0.0, -0.8), (-2.0, 0.0, 1.5)])
def test_reference_calibration_recovers_mounting_and_scale(mount_deg):
    mount = np.asarray(mount_deg) * D
    cal = rr.reference_calibration(synthetic_bundle(mount, 0.994))
    assert cal["scale"] == pytest.approx(0.994, abs=1e-12)
    single_axis = np.count_nonzero(mount) == 1
    tol = 1e-10 if single_axis else 2e-3          # two angles: exp([A x]) couples them (2nd order)
    assert cal["pitch_mount_deg"] == pytest.approx(mount_deg[0], abs=tol)
    assert cal["yaw_mount_deg"] == pytest.approx(mount_deg[2], abs=tol)


def test_still_gyro_bias_is_mean_rate_minus_earth_rate():
    b = synthetic_bundle(np.zeros(3), 1.0)
    bias = np.array([371.0, -486.0, -1165.0]) * D / 3600
    C_nb = b.truth.C_nb[0]
    w_b = C_nb.T @ earth.omega_ie_n(LAT) + bias
    dt = 0.05
    rng = np.random.default_rng(0)
    noise = rng.normal(0, 1e-4, (len(b.imu.t), 3))
    noise -= noise.mean(axis=0)                    # zero-mean noise: the mean is exact
    b.imu = ImuData(b.imu.t, (w_b + noise) * dt, b.imu.dvel)
    b.truth.vel_n[:] = 0.0
    b.truth.vel_n[30:] = [1.0, 0.0, 0.0]
    t_end = rr.still_period_end(b)
    assert t_end == pytest.approx(b.truth.t[30])
    np.testing.assert_allclose(rr.still_gyro_bias(b, b.imu.t[-1]), bias, atol=1e-15)


def test_no_still_period_is_bad_input():
    b = synthetic_bundle(np.zeros(3), 1.0)
    with pytest.raises(BadInput, match="no still period"):
        rr.still_period_end(b)
    with pytest.raises(BadInput, match="real data folder not found"):
        rr.reproduce_real("/tmp/unused", data_root="/nonexistent/real")


@pytest.mark.skipif(not rr.default_data_root().is_dir(), reason="real data not found")
def test_real_drives_end_to_end(tmp_path):
    res = rr.reproduce_real(tmp_path)
    assert {p.name for p in tmp_path.iterdir()} == {"real_results.json", "real_table.md",
                                                    "real_position_error.png"}
    assert json.loads((tmp_path / "real_results.json").read_text())["not_done"]
    comma = {r["run"]: r for r in res["drives"]["comma2k19_rav4_60s"]["runs"]}
    # aiding beats pure inertial, and removing the (oracle) scale and mounting errors helps
    assert comma["dr raw"]["final_horizontal_m"] < comma["sins"]["final_horizontal_m"]
    assert (comma["dr scale + mounting (from reference)"]["final_horizontal_m"]
            < comma["dr raw"]["final_horizontal_m"])
    cal = res["drives"]["comma2k19_rav4_60s"]["reference_calibration"]
    assert cal["pitch_mount_deg"] == pytest.approx(3.8, abs=0.5)    # README: about 3.8 deg
    # README: "roughly 0.8 deg in yaw"; the sign is that of mounting_matrix (travel to the
    # right of the camera's forward axis is a negative rotation about up)
    assert cal["yaw_mount_deg"] == pytest.approx(-0.8, abs=0.5)
    ems = {r["run"]: r for r in res["drives"]["ems_toronto_511s"]["runs"]}
    assert (ems["dr pseudo-odometer + still gyro bias"]["final_horizontal_m"]
            < ems["dr pseudo-odometer"]["final_horizontal_m"])
