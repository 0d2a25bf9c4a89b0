"""Issue 15, session 19: where the coarse stage cannot resolve the heading, the horizontal
position and velocity sigma cover what the unknown heading leaves of them
(``multiplex.floor_unresolved_horizontal_sigma``)."""
import numpy as np

from inmotion.align.multiplex import floor_unresolved_horizontal_sigma
from inmotion.core import earth
from inmotion.core.solution import Solution


def _track(n=200):
    """A curved 2 km track near 37 deg N (a quarter circle then a straight)."""
    s = np.linspace(0.0, 2000.0, n)
    th = np.minimum(s / 1000.0, 1.0) * np.pi / 2          # heading turns 90 deg in the first km
    dn = np.cumsum(np.cos(th)) * (s[1] - s[0])
    de = np.cumsum(np.sin(th)) * (s[1] - s[0])
    return dn - dn[0], de - de[0], th


def test_floor_is_the_rms_of_a_uniform_heading_error_per_axis():
    """Monte Carlo: the track turned about its start by a heading error uniform on +-180 deg
    has per-axis RMS position error ``sqrt(1.5 d_N^2 + 0.5 d_E^2)`` north and ``sqrt(0.5 d_N^2
    + 1.5 d_E^2)`` east (``d`` the displacement from the start), the floor the function
    sets; the velocity's likewise."""
    dn, de, th = _track()
    lat0, h0 = np.radians(37.0), 20.0
    r_m, r_n = earth.radii(lat0)
    n = len(dn)
    v = 15.0 * np.stack([np.sin(th), np.cos(th), np.zeros(n)], -1)
    sol = Solution(np.arange(n, dtype=float), lat0 + dn / (r_m + h0),
                   np.radians(-122.0) + de / ((r_n + h0) * np.cos(lat0)), np.full(n, h0), v,
                   np.zeros((n, 3)), sigma={"north": np.full(n, 5.0), "east": np.full(n, 5.0),
                                            "vE": np.full(n, 0.1), "vN": np.full(n, 0.1)})
    floor_unresolved_horizontal_sigma(sol)
    psi = np.random.default_rng(1).uniform(-np.pi, np.pi, 20000)
    c, s_ = np.cos(psi)[:, None], np.sin(psi)[:, None]
    en = (c - 1) * dn - s_ * de                    # north error of the rotated track
    ee = s_ * dn + (c - 1) * de                    # east error
    rms_n, rms_e = np.sqrt((en ** 2).mean(0)), np.sqrt((ee ** 2).mean(0))
    d = np.hypot(dn, de)
    far = d > 100.0
    assert np.allclose(rms_n[far] / sol.sigma["north"][far], 1.0, atol=0.03)
    assert np.allclose(rms_e[far] / sol.sigma["east"][far], 1.0, atol=0.03)
    assert sol.sigma["north"][0] == 5.0                   # at the start the filter's own
    vn, ve = v[:, 1], v[:, 0]
    rv_n = np.sqrt((((c - 1) * vn - s_ * ve) ** 2).mean(0))
    rv_e = np.sqrt(((s_ * vn + (c - 1) * ve) ** 2).mean(0))
    assert np.allclose(rv_n / sol.sigma["vN"], 1.0, atol=0.03)
    assert np.allclose(rv_e / sol.sigma["vE"], 1.0, atol=0.03)
