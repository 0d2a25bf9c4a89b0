"""Issue 15: the paper 003 displacement rows' along-sensor row compared as a length
(``aided_kf._length_fill``), checked against plane geometry: a SINS displacement of length
``L`` at an angle ``c`` off the sensor's distance ``d`` leaves ``L - d`` on that row, where the
first-order rows leave ``L cos c - d``; the lateral and vertical rows and ``H`` are the plain
fill's; a slow or stopped interval (angle beyond ``LENGTH_MAX_ANGLE``) keeps the plain rows."""
import numpy as np
import pytest

from inmotion.align import aided_kf as ak
from inmotion.estimation import measurements as ms
from inmotion.estimation.aiding_rows import SUB_LAYOUT


def _rows(fill, dD_n, dP_n, T=0.5, exact=False):
    xs = np.zeros(10)
    xs[6] = 1.0                       # identity attitude: n and b axes coincide
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    acc[ms.ACC_D:ms.ACC_D + 3] = dD_n
    acc[ms.ACC_W:ms.ACC_W + 3] = dD_n
    acc[ms.ACC_DP:ms.ACC_DP + 3] = dP_n
    m = ms.DisplacementIncrement(np.array([0.01, 0.0014, 0.02]), exact_attitude_columns=exact)
    p = np.asarray(m.params(), dtype=float)
    z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(3)
    n = fill(xs, xs, np.zeros(ms.AUX_SIZE), acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
    return n, z, H, r


@pytest.mark.parametrize("c_deg, L", [(0.5, 7.0), (2.0, 7.003), (-1.0, 6.99)])
def test_along_sensor_row_is_the_length_residual(c_deg, L):
    d = 7.0
    c = np.radians(c_deg)
    dD = np.array([0.0, d, 0.0])
    dP = L * np.array([np.sin(c) * 0.6, np.cos(c), np.sin(c) * 0.8])   # off in both axes
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP)
    assert plain[0] == length[0] == 3
    np.testing.assert_allclose(plain[1][1], L * np.cos(c) - d, atol=1e-12)
    np.testing.assert_allclose(length[1][1], L - d, atol=1e-12)
    np.testing.assert_allclose(length[1][[0, 2]], plain[1][[0, 2]], atol=0)
    np.testing.assert_array_equal(length[2], plain[2])
    np.testing.assert_array_equal(length[3], plain[3])


@pytest.mark.parametrize("c_deg, L", [(0.5, 7.0), (2.0, 7.003), (-1.0, 6.99)])
def test_length_row_with_exact_attitude_columns(c_deg, L):
    """``exact_attitude_columns`` (issue 15): the attitude columns from the SINS's
    displacement, ``-[Delta P_b x]``; the along row, the length ``|Delta P_b| - |Delta D_b|``,
    differentiates the SINS side along the SINS's displacement ``u_P`` and the sensor side
    along the sensor's."""
    d = 7.0
    c = np.radians(c_deg)
    dD = np.array([0.0, d, 0.0])
    dP = L * np.array([np.sin(c) * 0.6, np.cos(c), np.sin(c) * 0.8])
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP, exact=True)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP, exact=True)
    np.testing.assert_allclose(length[1][1], L - d, atol=1e-12)
    np.testing.assert_array_equal(length[2][[0, 2]], plain[2][[0, 2]])
    # identity attitude: the plain rows' attitude columns are -[Delta P_b x]
    np.testing.assert_allclose(plain[2][:, SUB_LAYOUT["phi"]],
                               -np.array([[0.0, -dP[2], dP[1]], [dP[2], 0.0, -dP[0]],
                                          [-dP[1], dP[0], 0.0]]), atol=1e-15)
    u = dP / np.linalg.norm(dP)
    sensor = np.zeros(SUB_LAYOUT.n, bool)
    for b in ("dk", "mount", "lever"):
        sensor[SUB_LAYOUT[b]] = True
    np.testing.assert_allclose(length[2][1, ~sensor], (u @ plain[2])[~sensor], atol=1e-15)
    np.testing.assert_array_equal(length[2][1, sensor], plain[2][1, sensor])
    # a length has no attitude column (none here: no specific force given)
    np.testing.assert_allclose(length[2][1, SUB_LAYOUT["phi"]], 0.0, atol=1e-12)


def test_slow_interval_keeps_the_first_order_rows():
    """Stopped (2 mm of distance, 1 cm across: 0.46 rad): the plain rows."""
    dD = np.array([0.0, 0.002, 0.0])
    dP = np.array([0.01, 0.002, 0.0])
    assert np.arctan2(0.01, 0.002) > ak.LENGTH_MAX_ANGLE
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP)
    np.testing.assert_array_equal(length[1], plain[1])


def _symmetry_rows(a_fwd, gamma, k, exact, T=0.5, n=50, v0=10.0):
    """One straight interval at forward acceleration ``a_fwd``: the SINS displacement exact,
    the sensor's turned by a mounting ``gamma`` [rad] and scaled by ``1 + k``; identity
    attitude (n = b)."""
    dt = T / n
    t = np.arange(1, n + 1) * dt
    xs = np.zeros(10)
    xs[6] = 1.0

    def v(tt):
        return np.array([0.0, v0 + a_fwd * tt, 0.0])
    dP = sum(0.5 * (v(tt - dt) + v(tt)) * dt for tt in t)
    Rg = np.array([[np.cos(gamma), -np.sin(gamma), 0.0], [np.sin(gamma), np.cos(gamma), 0.0],
                   [0.0, 0.0, 1.0]])
    dD = (1.0 + k) * (Rg @ dP)
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    acc[ms.ACC_DP:ms.ACC_DP + 3] = dP
    acc[ms.ACC_D:ms.ACC_D + 3] = dD
    acc[ms.ACC_W:ms.ACC_W + 3] = dD
    acc[ms.ACC_FN:ms.ACC_FN + 3] = [0.0, a_fwd * T, 9.8 * T]
    m = ms.DisplacementIncrement(np.array([0.001, 4e-5, 0.001]), exact_attitude_columns=exact)
    p = np.asarray(m.params(), dtype=float)
    z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(3)
    ak._length_fill(ms.DisplacementIncrement.fill)(
        xs, xs, np.zeros(ms.AUX_SIZE), acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
    return z, H, v(T)


@pytest.mark.parametrize("a_fwd, gamma_arcmin, k", [(0.0, 15.0, 2e-3), (0.5, 15.0, 2e-3),
                                                    (0.5, -30.0, -2e-3), (0.0, 0.0, 0.0)])
def test_rows_are_blind_to_a_rotation_about_the_vertical(a_fwd, gamma_arcmin, k):
    """Issue 15: a SINS whose attitude and velocity are both turned by ``psi`` about the
    vertical (``phi = [0, 0, psi]``, ``dv = v x phi``) has exactly the true body-frame
    displacement, so the rows ``z = C_n^b Delta P_n - Delta D_b`` do not change: ``H`` must
    give 0 in that direction, whatever the sensor's own errors in ``z``. With the attitude
    columns from the sensor's displacement (before) ``H x = -[z x] psi``: a 15' mounting
    (2.2 cm over 7 m) at psi = 1e-3 gives 2.2e-5 m on the along row, a 20,000 pulses/m
    odometer's whole noise, so the filter reads the heading from the mounting's residual
    (``benchmarks/heading_symmetry.py``); ``exact_attitude_columns`` gives 0."""
    psi = 1e-3
    phi = np.array([0.0, 0.0, psi])
    hx = {}
    for exact in (True, False):
        z, H, v_end = _symmetry_rows(a_fwd, np.radians(gamma_arcmin / 60.0), k, exact)
        x = np.zeros(SUB_LAYOUT.n)
        x[SUB_LAYOUT["phi"]] = phi
        x[SUB_LAYOUT["dv"]] = np.cross(v_end, phi)
        hx[exact] = H @ x
    np.testing.assert_allclose(hx[True], 0.0, atol=1e-12)
    # paper 003's form (the sensor's displacement) sees psi against the residual z (the
    # sensor's mounting and scale): psi |z| on the along row, a fine odometer's noise
    if gamma_arcmin:
        assert abs(z[0]) > 1e-2
        assert np.abs(hx[False]).max() > 0.9 * psi * abs(z[0])
