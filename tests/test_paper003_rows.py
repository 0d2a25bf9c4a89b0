"""Paper 003 measurement rows against numerical derivatives of the nonlinear measurements.

Each test builds the exact (nonlinear) measurement from a true state and the filter's
computed quantities with the named errors applied, and checks every column of ``H`` by a
central difference. Rows already covered by ``tests/test_error_model.py`` are not repeated.
"""
import numpy as np
import pytest

from inmotion.core import rotations as R
from inmotion.core import earth
from inmotion.estimation import error_model as em
from inmotion.estimation.aiding_rows import (NHC_LAYOUT, SUB_LAYOUT, displacement_rows,
                                             nhc_vehicle_rows, velocity_rows)
from inmotion.align.parked_kf import PARKED_LAYOUT, parked_F

LAY = SUB_LAYOUT
COLS = ["phi", "dv", "dk", "mount", "lever"]


def _unpack(x):
    return {b: x[LAY[b]] for b in COLS}


def _rng():
    return np.random.default_rng(7)


def _truth(rng):
    C = R.dcm_from_euler(np.radians([3.0, -2.0, 47.0]))
    C_vb0 = R.mounting_dcm(np.radians(np.array([10.0, 0.0, 15.0]) / 60))
    return C, C_vb0, rng.normal(0, 1, 3) * 0.05, np.array([-0.8, -1.5, -0.9])


def _velocity_z(x, C, C_vb0, omega, lever, s):
    """The vehicle constraint holds at the IMU (the simulator's world): the IMU moves along
    the true forward axis ``C_v^b [0, 1, 0]`` at ``v`` and the sensor at ``lever`` reads ``s
    = v + f^T (omega x l)``; the filter maps ``s`` back with the nominal forward axis and its
    lever arm."""
    e = _unpack(x)
    C_vb = R.mounting_dcm(np.r_[e["mount"][0], 0.0, e["mount"][1]]) @ C_vb0
    f_true, f0 = C_vb[:, 1], C_vb0[:, 1]
    v = s - f_true @ np.cross(omega, lever)
    v_true = C @ (f_true * v)                                    # IMU velocity in n
    v_hat = v_true + e["dv"]
    C_hat = R.apply_misalignment(C, e["phi"])
    s_m = (1 + e["dk"][0]) * s
    return v_hat - C_hat @ (f0 * s_m - f0 * (f0 @ np.cross(omega, lever + e["lever"])))


def _fd(fun, n, eps=1e-7):
    return np.column_stack([(fun(eps * np.eye(n)[j]) - fun(-eps * np.eye(n)[j])) / (2 * eps)
                            for j in range(n)])


def test_velocity_rows_match_numerical_derivative():
    rng = _rng()
    C, C_vb0, omega, lever = _truth(rng)
    s = 12.0
    assert np.allclose(_velocity_z(LAY.zeros(), C, C_vb0, omega, lever, s), 0, atol=1e-12)
    H, v_s = velocity_rows(LAY, C, s, C_vb0, lever, omega)
    J = _fd(lambda x: _velocity_z(x, C, C_vb0, omega, lever, s), LAY.n)
    for b in ("phi", "dv", "dk", "lever"):
        np.testing.assert_allclose(H[:, LAY[b]], J[:, LAY[b]], atol=1e-6, err_msg=b)
    # mount: the rows take the sensor's speed s for the IMU's v; they differ by the lever
    # term f^T (omega x l) and the true forward axis's turn of it: terms of (mount error) x
    # (lever velocity), bounded by twice |omega x l| per mount column (1-2 % of the column)
    lever_speed = np.linalg.norm(np.cross(omega, lever))
    np.testing.assert_allclose(H[:, LAY["mount"]], J[:, LAY["mount"]],
                               atol=2.0 * lever_speed, err_msg="mount")
    assert 2.0 * lever_speed < 0.02 * s
    assert np.allclose(H[:, LAY["dp"]], 0) and np.allclose(H[:, LAY["eps"]], 0)


def _displacement_z(x, C_list, C_vb0, dth_list, lever, ds_list, dt):
    e = _unpack(x)
    C_vb = R.mounting_dcm(np.r_[e["mount"][0], 0.0, e["mount"][1]]) @ C_vb0
    dP = np.zeros(3)
    dD = np.zeros(3)
    f_true, f0 = C_vb[:, 1], C_vb0[:, 1]
    for C, dth, ds in zip(C_list, dth_list, ds_list):
        # the IMU moves along the true forward axis; the sensor reads ds plus the forward
        # part of the lever term (the vehicle constraint holds at the IMU)
        dP += C @ (f_true * (ds - f_true @ np.cross(dth, lever))) + e["dv"] * dt
        C_hat = R.apply_misalignment(C, e["phi"])
        dD += C_hat @ (f0 * (1 + e["dk"][0]) * ds
                       - f0 * (f0 @ np.cross(dth, lever + e["lever"])))
    C_end = R.apply_misalignment(C_list[-1], e["phi"])
    return C_end.T @ (dP - dD)


def _interval(rate_rad_s, n=50, dt=0.01):
    C0 = R.dcm_from_euler(np.radians([2.0, 1.0, 120.0]))
    w = np.array([0.1, 0.2, 1.0]) * rate_rad_s
    C_list = [C0 @ R.dcm_from_rotvec(w * dt * (j + 1)) for j in range(n)]
    dth_list = [w * dt] * n
    ds_list = list(10.0 * dt * (1 + 0.01 * np.arange(n)))
    return C_list, dth_list, ds_list, dt


@pytest.mark.parametrize("rate", [0.0, 0.05])
def test_displacement_rows_match_numerical_derivative(rate):
    """Exact for a non-rotating body; with 0.05 rad/s (a 1.4 deg turn over the 0.5 s
    interval) the ``mount``/``lever`` columns keep the documented small-rotation error."""
    C_list, dth_list, ds_list, dt = _interval(rate)
    _, C_vb0, _, lever = _truth(_rng())
    f = lambda x: _displacement_z(x, C_list, C_vb0, dth_list, lever, ds_list, dt)
    assert np.allclose(f(LAY.zeros()), 0, atol=1e-12)
    f0 = C_vb0[:, 1]
    dD_n = sum(C @ (f0 * ds - f0 * (f0 @ np.cross(dth, lever)))
               for C, dth, ds in zip(C_list, dth_list, ds_list))
    dW_n = sum(C @ (f0 * ds) for C, ds in zip(C_list, ds_list))
    T = dt * len(C_list)
    H = displacement_rows(LAY, C_list[-1], T, dD_n, dW_n, np.sum(dth_list, axis=0), C_vb0)
    J = _fd(f, LAY.n)
    for b in ("phi", "dv", "dk"):
        np.testing.assert_allclose(H[:, LAY[b]], J[:, LAY[b]], atol=1e-6, err_msg=b)
    for b in ("mount", "lever"):
        tol = 1e-6 if rate == 0 else 0.02 * np.abs(J[:, LAY[b]]).max()
        np.testing.assert_allclose(H[:, LAY[b]], J[:, LAY[b]], atol=tol, err_msg=b)


def test_nhc_vehicle_rows_match_numerical_derivative():
    rng = _rng()
    C, C_vb0, _, _ = _truth(rng)
    v_n = C @ C_vb0 @ [0, 14.0, 0]         # the vehicle moves along its forward axis
    lay = NHC_LAYOUT

    def z(x):
        C_hat = R.apply_misalignment(C, x[lay["phi"]])
        return (C_vb0.T @ C_hat.T @ (v_n + x[lay["dv"]]))[[0, 2]]

    assert np.allclose(z(lay.zeros()), 0, atol=1e-12)
    H = nhc_vehicle_rows(lay, C, v_n, C_vb0)
    np.testing.assert_allclose(H, _fd(z, lay.n), atol=1e-6)


def test_parked_F_is_the_shared_model_at_rest():
    """Eq. 12 is the shared SINS model with v = 0 restricted to phi, dv, eps, nabla (no
    position states, no gravity gradient)."""
    lat = np.radians(39.9)
    C = R.dcm_from_euler(np.radians([1.0, -2.0, 60.0]))
    f_n = np.array([0.01, -0.02, earth.G0])
    full = em.ErrorModel(NHC_LAYOUT, em.ProcessNoise()).F(
        em.LinPoint(lat=lat, h=0.0, vel_n=np.zeros(3), C_nb=C, f_n=f_n))
    idx = np.r_[NHC_LAYOUT["phi"], NHC_LAYOUT["dv"], NHC_LAYOUT["eps"], NHC_LAYOUT["nabla"]]
    np.testing.assert_allclose(parked_F(lat, C, f_n), full[np.ix_(idx, idx)], atol=1e-15)
    assert PARKED_LAYOUT.n == 12 and SUB_LAYOUT.n == 21 and NHC_LAYOUT.n == 15
