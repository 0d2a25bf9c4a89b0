"""What the streaming tests share (issue 13): a window read in chunks must give the in-memory
run's solution bit for bit, and must never be loaded whole."""
import numpy as np

from inmotion.io.bundle_stream import BundleStream

#: info entries that hold wall times (they differ between any two runs)
TIMING_KEYS = ("wall_time_s", "timing_s", "timing")


def assert_same_solution(a, b, skip=()):
    """Two solutions equal bit for bit: the nav arrays, every sigma and state series, and the
    info (but its timings and the ``skip`` keys)."""
    for k in ("t", "lat", "lon", "h", "vel_n", "euler"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert a.sigma.keys() == b.sigma.keys() and a.states.keys() == b.states.keys()
    for d1, d2 in ((a.sigma, b.sigma), (a.states, b.states)):
        for k in d1:
            np.testing.assert_array_equal(d1[k], d2[k], err_msg=k)
    keys = [k for k in a.info if k not in (*TIMING_KEYS, *skip)]
    assert {k: a.info[k] for k in keys} == {k: b.info.get(k) for k in keys}


def refuse_window_loads(monkeypatch):
    """A bundle read in chunks that fails the test if anything loads a window into memory."""
    def refuse(self, *a, **k):
        raise AssertionError("the window was loaded into memory")
    monkeypatch.setattr(BundleStream, "load_window", refuse)
