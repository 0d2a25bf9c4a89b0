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


def _rows(fill, dD_n, dP_n, T=0.5):
    xs = np.zeros(10)
    xs[6] = 1.0                       # identity attitude: n and b axes coincide
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    acc[ms.ACC_D:ms.ACC_D + 3] = dD_n
    acc[ms.ACC_W:ms.ACC_W + 3] = dD_n
    acc[ms.ACC_DP:ms.ACC_DP + 3] = dP_n
    m = ms.DisplacementIncrement(np.array([0.01, 0.0014, 0.02]))
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


def test_slow_interval_keeps_the_first_order_rows():
    """Stopped (2 mm of distance, 1 cm across: 0.46 rad): the plain rows."""
    dD = np.array([0.0, 0.002, 0.0])
    dP = np.array([0.01, 0.002, 0.0])
    assert np.arctan2(0.01, 0.002) > ak.LENGTH_MAX_ANGLE
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP)
    np.testing.assert_array_equal(length[1], plain[1])
