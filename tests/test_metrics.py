"""Error metrics against hand-made truth / solution pairs with known offsets."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.core.bundle import Truth
from inmotion.core.earth import radii
from inmotion.core.solution import Solution
from inmotion.core.metrics import ERROR_KEYS, error_series, errors_block

DESIGN_KEYS = {"pitch_arcmin", "roll_arcmin", "yaw_arcmin", "phi_E_arcmin", "phi_N_arcmin",
               "phi_U_arcmin", "vE_m_s", "vN_m_s", "vU_m_s", "horizontal_m", "vertical_m"}


def straight_truth(n=3001, dt=0.1, v=20.0, yaw_deg=30.0):
    """Level drive at constant speed on a heading: positions from the radii (exact path)."""
    t = dt * np.arange(n)
    lat0, lon0, h = np.radians(40.0), np.radians(116.0), 50.0
    r_m, r_n = radii(lat0)
    yaw = np.radians(yaw_deg)
    vE, vN = v * np.sin(yaw), v * np.cos(yaw)
    # small region: constant radii; lat/lon linear in t
    lat = lat0 + vN * t / (r_m + h)
    lon = lon0 + vE * t / ((r_n + h) * np.cos(lat0))
    vel = np.tile([vE, vN, 0.0], (n, 1))
    euler = np.tile([0.0, 0.0, yaw], (n, 1))
    return Truth(t, lat, lon, np.full(n, h), vel, euler)


def as_solution(tr: Truth, **changes) -> Solution:
    d = dict(t=tr.t, lat=tr.lat, lon=tr.lon, h=tr.h, vel_n=tr.vel_n, euler=tr.euler)
    d.update(changes)
    return Solution(**{k: np.array(v, dtype=float) for k, v in d.items()})


def test_perfect_solution_has_zero_error():
    tr = straight_truth()
    err = error_series(as_solution(tr), tr)
    for k in ERROR_KEYS:
        assert np.abs(err[k]).max() < 1e-9, k


def test_ten_metres_north():
    tr = straight_truth()
    r_m, _ = radii(tr.lat)
    sol = as_solution(tr, lat=tr.lat + 10.0 / (r_m + tr.h))
    err = error_series(sol, tr)
    np.testing.assert_allclose(err["horizontal_m"], 10.0, rtol=1e-9)
    np.testing.assert_allclose(err["north_m"], 10.0, rtol=1e-9)
    np.testing.assert_allclose(err["east_m"], 0.0, atol=1e-9)
    np.testing.assert_allclose(err["vertical_m"], 0.0, atol=1e-12)


def test_east_and_vertical_offsets():
    tr = straight_truth()
    _, r_n = radii(tr.lat)
    sol = as_solution(tr, lon=tr.lon - 3.0 / ((r_n + tr.h) * np.cos(tr.lat)), h=tr.h - 4.0)
    err = error_series(sol, tr)
    np.testing.assert_allclose(err["east_m"], -3.0, rtol=1e-9)
    np.testing.assert_allclose(err["horizontal_m"], 3.0, rtol=1e-9)
    np.testing.assert_allclose(err["vertical_m"], -4.0, rtol=1e-12)


def test_yaw_wraps_across_north():
    tr = straight_truth(yaw_deg=1.0)
    euler = tr.euler.copy()
    euler[:, 2] = np.radians(359.0)
    err = error_series(as_solution(tr, euler=euler), tr)
    np.testing.assert_allclose(err["yaw_arcmin"], -120.0, rtol=1e-9)
    # level attitude: C_computed = R_z(-(psi + dpsi)) = R_z(-dpsi) C_true = (I - dpsi [e_U x])
    # C_true to first order, so phi_U = dpsi (the yaw error itself, same sign)
    np.testing.assert_allclose(err["phi_U_arcmin"], -120.0, rtol=1e-6)
    np.testing.assert_allclose(err["phi_E_arcmin"], 0.0, atol=1e-9)


def test_misalignment_matches_small_tilt():
    tr = straight_truth(yaw_deg=0.0)
    phi = np.radians([2.0, -1.0, 0.5]) / 60.0          # arcmin-level misalignment
    C = rotations.apply_misalignment(tr.C_nb, phi)
    err = error_series(as_solution(tr, euler=rotations.euler_from_dcm(C)), tr)
    np.testing.assert_allclose(err[["phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin"]]
                               .to_numpy(), np.tile([2.0, -1.0, 0.5], (len(tr.t), 1)),
                               rtol=1e-9)


def test_velocity_error_and_distance():
    tr = straight_truth(n=3001, dt=0.1, v=20.0, yaw_deg=0.0)   # due north: exact path
    sol = as_solution(tr, vel_n=tr.vel_n + [0.1, -0.2, 0.05])
    err = error_series(sol, tr)
    np.testing.assert_allclose(err[["vE_m_s", "vN_m_s", "vU_m_s"]].to_numpy()[-1],
                               [0.1, -0.2, 0.05], rtol=1e-9)
    assert err["distance_m"].iloc[-1] == pytest.approx(20.0 * 300.0, rel=1e-5)


def test_truth_interpolated_to_solution_times():
    tr = straight_truth(n=301, dt=1.0)
    t = np.arange(10.25, 200.0, 0.5)
    lat = np.interp(t, tr.t, tr.lat)
    lon = np.interp(t, tr.t, tr.lon)
    sol = Solution(t, lat, lon, np.full(len(t), 50.0), np.tile(tr.vel_n[0], (len(t), 1)),
                   np.tile(tr.euler[0], (len(t), 1)))
    err = error_series(sol, tr)
    assert np.abs(err["horizontal_m"]).max() < 1e-6
    assert err["t"].iloc[0] == 10.25


def test_errors_block_keys_and_statistics():
    tr = straight_truth(n=3001, dt=0.1, yaw_deg=0.0)
    r_m, _ = radii(tr.lat)
    # north error growing linearly 0 .. 30 m over 300 s
    north = 0.1 * tr.t
    sol = as_solution(tr, lat=tr.lat + north / (r_m + tr.h))
    block = errors_block(error_series(sol, tr))
    assert set(block) == {"final", "rms_last_100s", "max_abs_last_100s", "distance_m",
                          "duration_s"}
    for k in ("final", "rms_last_100s", "max_abs_last_100s"):
        assert set(block[k]) == DESIGN_KEYS
    assert block["final"]["horizontal_m"] == pytest.approx(30.0, rel=1e-9)
    assert block["max_abs_last_100s"]["horizontal_m"] == pytest.approx(30.0, rel=1e-9)
    # rms of a linear ramp from 20 to 30 m: sqrt((a^2 + a b + b^2) / 3)
    assert block["rms_last_100s"]["horizontal_m"] == pytest.approx(
        np.sqrt((400 + 600 + 900) / 3), rel=1e-3)
    assert block["duration_s"] == pytest.approx(300.0)
    assert block["distance_m"] == pytest.approx(6000.0, rel=1e-5)


def test_no_overlap_is_bad_input():
    from inmotion.errors import BadInput
    tr = straight_truth(n=11)
    sol = as_solution(tr, t=tr.t + 1000.0)
    with pytest.raises(BadInput, match="do not overlap"):
        error_series(sol, tr)


def test_truth_yaw_interpolated_across_north():
    """Truth yaw 359 deg then 1 deg; a solution between them at 0 deg has no error."""
    t = np.array([0.0, 1.0, 2.0])
    euler = np.radians([[0, 0, 357.0], [0, 0, 359.0], [0, 0, 1.0]])
    tr = Truth(t, np.full(3, 0.7), np.full(3, 2.0), np.zeros(3), np.zeros((3, 3)), euler)
    sol = Solution(np.array([1.5]), np.array([0.7]), np.array([2.0]), np.zeros(1),
                   np.zeros((1, 3)), np.radians([[0, 0, 0.0]]))
    err = error_series(sol, tr)
    assert abs(err["yaw_arcmin"].iloc[0]) < 1e-9
    assert abs(err["phi_U_arcmin"].iloc[0]) < 1e-9


def test_consistency_block_is_chi_square_for_errors_drawn_with_the_sigma():
    """Errors drawn from N(0, sigma^2) per axis give a mean NEES near 3 inside its band; a
    sigma ten times too small (an overconfident filter) puts it far above."""
    import pandas as pd

    from inmotion.core.solution import Solution
    from inmotion.core.metrics import ARCMIN_PER_RAD, consistency_block

    rng = np.random.default_rng(4)
    n = 2001
    t = np.arange(n) * 0.1
    sig = {"phi_E": np.full(n, 1e-4), "phi_N": np.full(n, 2e-4), "phi_U": np.full(n, 1e-3),
           "vE": np.full(n, 0.01), "vN": np.full(n, 0.02), "vU": np.full(n, 0.05)}
    sol = Solution(t, np.zeros(n), np.zeros(n), np.zeros(n), np.zeros((n, 3)),
                   np.zeros((n, 3)), sigma=sig)
    e = {"t": t}
    for c, k, scale in (("phi_E_arcmin", "phi_E", ARCMIN_PER_RAD),
                        ("phi_N_arcmin", "phi_N", ARCMIN_PER_RAD),
                        ("phi_U_arcmin", "phi_U", ARCMIN_PER_RAD),
                        ("vE_m_s", "vE", 1.0), ("vN_m_s", "vN", 1.0), ("vU_m_s", "vU", 1.0)):
        e[c] = rng.standard_normal(n) * sig[k] * scale
    block = consistency_block(sol, pd.DataFrame(e))
    assert set(block) == {"attitude", "velocity"}          # no position sigma given
    for g in block.values():
        assert g["rows"] == n - 1 and g["in_band"] and abs(g["mean"] - 3.0) < 0.3
        assert 0.0 <= g["fraction_rows_above_99"] < 0.02
    sol.sigma = {k: v / 10 for k, v in sig.items()}
    bad = consistency_block(sol, pd.DataFrame(e))
    assert not bad["attitude"]["in_band"] and bad["attitude"]["mean"] > 200
