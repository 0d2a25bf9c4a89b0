"""``inmotion.core.bundle.row_at_or_after``: the row lookup shared by ``Truth.at``,
``Solution.state_at`` and the reproductions, against its definition on a uniform grid."""
import numpy as np

from inmotion.core.bundle import row_at_or_after


def test_first_row_at_or_after_and_clipped():
    t = np.arange(11) * 0.1                      # 0.0 .. 1.0 s
    assert int(row_at_or_after(t, -5.0)) == 0    # before the start: first row
    assert int(row_at_or_after(t, 0.0)) == 0     # exactly on a sample: that sample
    assert int(row_at_or_after(t, 0.25)) == 3    # between samples: the one after
    assert int(row_at_or_after(t, 9.0)) == 10    # past the end: last row


def test_tolerance_reaches_back_to_a_sample_just_before():
    t = np.array([0.0, 1.0, 2.0])
    assert int(row_at_or_after(t, 1.0 + 1e-9)) == 2
    assert int(row_at_or_after(t, 1.0 + 1e-9, 1e-6)) == 1


def test_array_times_give_array_of_rows():
    t = np.array([0.0, 1.0, 2.0])
    np.testing.assert_array_equal(row_at_or_after(t, np.array([-1.0, 0.5, 1.0, 3.0])),
                                  [0, 1, 1, 2])
