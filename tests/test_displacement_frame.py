"""Issue 15: the displacement rows in the frame of the sensor's displacement
(``aided_kf._rows_to_displacement_frame``), checked against plane geometry. Over an interval
of a turn the sensor's displacement (the chord at the middle heading) lies ``a = r T / 2`` off
the body's forward axis at the interval's end, and the vehicle's lateral slip ``S``
(perpendicular to it) then has a part ``S sin a`` along that axis: in the body's axes the
precise forward row carries it as if it were the sensor's noise; in the displacement's frame
the along row is the length residual alone and the slip is all in the lateral row."""
import numpy as np
import pytest

from inmotion.align import aided_kf as ak
from inmotion.estimation import measurements as ms
from inmotion.estimation.aiding_rows import SUB_LAYOUT
from test_length_row import _rows

PHI = SUB_LAYOUT.offsets()[0]


def _turn_interval(r_deg_s, slip_m, dL_m, d=7.0, T=0.5):
    a = np.radians(r_deg_s) * T / 2.0
    e = np.array([np.sin(a), np.cos(a), 0.0])          # chord direction in the end's body axes
    perp = np.array([np.cos(a), -np.sin(a), 0.0])      # the body's right axis turned with it
    return d * e, (d + dL_m) * e + slip_m * perp, a


@pytest.mark.parametrize("r_deg_s, slip_m", [(4.0, 5e-3), (-4.0, 5e-3), (3.0, -8e-3)])
def test_slip_stays_out_of_the_along_row(r_deg_s, slip_m):
    """4 deg/s, 0.5 s, 5 mm of slip, 7 m: the body-axis forward row carries 8.7e-5 m of slip
    (4 times a 20,000 pulses/m odometer's 2e-5 m); the displacement frame's along row is
    ``|Delta P| - d`` to round-off and the lateral row holds the slip."""
    dL = 1e-5
    dD, dP, a = _turn_interval(r_deg_s, slip_m, dL)
    length = ak._length_fill(ms.DisplacementIncrement.fill)
    assert ak.ROWS_IN_DISPLACEMENT_FRAME
    n, z, H, _ = _rows(length, dD, dP)
    assert n == 3
    exact = np.linalg.norm(dP) - np.linalg.norm(dD)
    np.testing.assert_allclose(z[1], exact, atol=1e-12)
    np.testing.assert_allclose(z[0], slip_m, rtol=1e-6)
    np.testing.assert_allclose(z[2], 0.0, atol=1e-12)
    # the body's axes (rotation off): the forward row is off by the slip's part along it
    ak.ROWS_IN_DISPLACEMENT_FRAME = False
    try:
        _, zb, Hb, _ = _rows(ak._length_fill.__wrapped__(ms.DisplacementIncrement.fill), dD, dP)
    finally:
        ak.ROWS_IN_DISPLACEMENT_FRAME = True
    assert abs(zb[1] - exact) > 0.9 * abs(slip_m * np.sin(a))
    assert abs(slip_m * np.sin(a)) > 4 * 2.04e-5
    # a length has no attitude column; the body's forward row has the yaw one, d sin a
    np.testing.assert_allclose(H[1, PHI:PHI + 3], 0.0, atol=1e-12)
    assert abs(Hb[1, PHI + 2]) > 0.9 * 7.0 * abs(np.sin(a))


def test_straight_interval_is_unchanged():
    """Sensor displacement along the body's forward axis: the rotation is the identity."""
    dD = np.array([0.0, 7.0, 0.0])
    dP = np.array([4e-3, 7.00001, -2e-3])
    length = ak._length_fill(ms.DisplacementIncrement.fill)
    _, z, H, r = _rows(length, dD, dP)
    ak.ROWS_IN_DISPLACEMENT_FRAME = False
    try:
        _, zb, Hb, rb = _rows(ak._length_fill.__wrapped__(ms.DisplacementIncrement.fill), dD, dP)
    finally:
        ak.ROWS_IN_DISPLACEMENT_FRAME = True
    np.testing.assert_allclose(z, zb, atol=1e-15)
    np.testing.assert_allclose(H, Hb, atol=1e-15)
    np.testing.assert_array_equal(r, rb)
