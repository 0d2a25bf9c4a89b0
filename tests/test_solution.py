"""NavState.from_truth: the start every method takes from a truth table."""
import numpy as np

from inmotion.core import rotations
from inmotion.core.bundle import Truth
from inmotion.core.solution import NavState


def _truth():
    t = np.arange(5.0)
    euler = np.column_stack([np.full(5, 0.01), np.full(5, -0.02), np.linspace(0.5, 0.9, 5)])
    return Truth(t, np.full(5, 0.6), np.full(5, 1.9), np.linspace(100, 104, 5),
                 np.tile([1.0, 2.0, 0.5], (5, 1)), euler)


def test_first_row_by_default_and_exact():
    tr = _truth()
    s = NavState.from_truth(tr)
    assert s.t == 0.0 and s.lat == 0.6 and s.h == 100.0
    np.testing.assert_array_equal(s.vel_n, [1.0, 2.0, 0.5])
    np.testing.assert_allclose(s.euler, tr.euler[0], atol=1e-14)


def test_row_at_or_after_t_and_euler_error_added():
    tr = _truth()
    err = np.radians([1.0, -2.0, 3.0])
    s = NavState.from_truth(tr, t=2.5, euler_error=err)
    assert s.t == 3.0 and s.h == 103.0
    np.testing.assert_allclose(s.euler, tr.euler[3] + err, atol=1e-12)
    # the error is an Euler-angle offset, not a misalignment: check it against the rotation
    C = rotations.dcm_from_euler(tr.euler[3] + err)
    np.testing.assert_allclose(s.C_nb, C, atol=1e-12)
