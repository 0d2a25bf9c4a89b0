"""Kalman building blocks and the state layout, against closed forms and each other."""
import numpy as np
import pytest

from inmotion.estimation import kalman
from inmotion.estimation.layout import Layout, position_units


def _spd(rng, n, scale=1.0):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T + n * np.eye(n))


# -- layout ------------------------------------------------------------------------------

def test_layout_slices_names_and_units():
    lay = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk"])
    assert lay.n == 25
    assert lay["phi_D"] == slice(15, 18)
    assert lay.index("dk") == 24 and lay.names[24] == "dk"
    assert lay.index("mount_y") == 22
    units = lay.unit_map()
    assert units["mount_x"].unit == "arcmin"
    assert units["mount_x"].scale * np.deg2rad(1 / 60) == pytest.approx(1.0)
    assert units["dk"].unit == "ppm" and units["dk"].scale == 1e6
    assert units["eps_z"].scale * np.deg2rad(1) / 3600 == pytest.approx(1.0)
    # composition appends
    lay15 = Layout(["phi", "dv", "dp", "eps", "nabla"])
    assert (lay15 + ["mount", "dk"]).names == lay15.names + ("mount_x", "mount_y", "mount_z", "dk")


def test_layout_errors_and_helpers():
    with pytest.raises(ValueError, match="twice"):
        Layout(["phi", "phi"])
    with pytest.raises(KeyError, match="unknown state block"):
        Layout(["phi", "nope"])
    lay = Layout(["phi", "dk"])
    with pytest.raises(KeyError, match="not in this layout"):
        lay["dv"]
    P = lay.diag({"phi": [1.0, 2.0, 3.0], "dk": 4.0})
    assert np.allclose(np.diag(P), [1, 2, 3, 4])
    d = lay.as_dict(np.arange(8.0).reshape(2, 4))
    assert np.allclose(d["phi_N"], [1.0, 5.0])
    # a 1 m north offset at 45 deg in rad, times the display scale, is 1 m
    u = position_units(np.deg2rad(45.0))
    from inmotion.core import earth
    r_m, r_n = earth.radii(np.deg2rad(45.0))
    assert u["dp_lat"].scale / r_m == pytest.approx(1.0)
    assert u["dp_D_lon"].scale / (r_n * np.cos(np.deg2rad(45))) == pytest.approx(1.0)


# -- discretization ----------------------------------------------------------------------

def test_trapezoid_discretization_matches_van_loan():
    rng = np.random.default_rng(1)
    n = 8
    F = 0.05 * rng.standard_normal((n, n))
    G = rng.standard_normal((n, 3))
    Qc = G @ G.T
    dt = 0.1
    Phi, Qd = kalman.discretize(F, Qc, dt)
    Phi_x, Qd_x = kalman.discretize_van_loan(F, Qc, dt)
    assert np.allclose(Phi, Phi_x, rtol=0, atol=1e-6)
    # trapezoid error is O(dt^3 |F|^2 |Qc|)
    assert np.max(np.abs(Qd - Qd_x)) < 1e-4 * np.max(np.abs(Qd_x))


def test_van_loan_scalar_closed_form():
    # x_dot = -x/tau + w, q: Qd = q tau / 2 (1 - exp(-2 dt / tau))
    tau, q, dt = 3.0, 0.7, 0.5
    Phi, Qd = kalman.discretize_van_loan(np.array([[-1 / tau]]), np.array([[q]]), dt)
    assert Phi[0, 0] == pytest.approx(np.exp(-dt / tau), rel=1e-12)
    assert Qd[0, 0] == pytest.approx(q * tau / 2 * (1 - np.exp(-2 * dt / tau)), rel=1e-10)


# -- updates -----------------------------------------------------------------------------

def test_joseph_equals_standard_when_well_conditioned():
    rng = np.random.default_rng(2)
    n, m = 6, 3
    P = _spd(rng, n)
    H = rng.standard_normal((m, n))
    R = _spd(rng, m, 0.5)
    x = rng.standard_normal(n)
    z = rng.standard_normal(m)
    xj, Pj, nuj, Sj = kalman.joseph_update(x, P, z, H, R)
    xs, Ps, nus, Ss = kalman.standard_update(x, P, z, H, R)
    assert np.allclose(xj, xs, atol=1e-12)
    assert np.allclose(Pj, Ps, atol=1e-10)
    assert np.allclose(Sj, H @ P @ H.T + R)
    # information form: P+^-1 = P^-1 + H^T R^-1 H
    assert np.allclose(np.linalg.inv(Pj), np.linalg.inv(P) + H.T @ np.linalg.solve(R, H))


def test_joseph_stays_psd_with_a_suboptimal_gain_case():
    # a nearly perfect measurement of a large-variance state: the standard form loses
    # symmetry / positiveness in rounding, the Joseph form keeps P >= 0
    P = np.diag([1e6, 1e-6, 1.0])
    P[0, 2] = P[2, 0] = 999.0
    H = np.array([[1.0, 0.0, 0.0]])
    R = np.array([[1e-12]])
    _, Pj, _, _ = kalman.joseph_update(np.zeros(3), P, np.zeros(1), H, R)
    assert np.allclose(Pj, Pj.T)
    assert np.min(np.linalg.eigvalsh(Pj)) > -1e-9


def test_sequential_equals_batch_for_diagonal_R():
    rng = np.random.default_rng(3)
    n, m = 7, 4
    P = _spd(rng, n)
    H = rng.standard_normal((m, n))
    r = rng.uniform(0.1, 2.0, m)
    x = rng.standard_normal(n)
    z = rng.standard_normal(m)
    xb, Pb, _, _ = kalman.joseph_update(x, P, z, H, np.diag(r))
    xq, Pq, nu, s = kalman.sequential_update(x, P, z, H, r)
    assert np.allclose(xb, xq, atol=1e-10)
    assert np.allclose(Pb, Pq, atol=1e-10)
    assert nu[0] == pytest.approx(z[0] - H[0] @ x)
    assert s[0] == pytest.approx(H[0] @ P @ H[0] + r[0])


def test_random_constant_closed_form_and_nis():
    # estimate a constant from N noisy looks: P_N = 1 / (1/P0 + N/r); NIS ~ chi2(1)
    rng = np.random.default_rng(4)
    P0, r, N, runs = 4.0, 0.25, 30, 400
    nis = []
    for _ in range(runs):
        truth = rng.normal(0.0, np.sqrt(P0))
        kf = kalman.KalmanFilter(np.zeros(1), np.array([[P0]]))
        kf.set_model(np.zeros((1, 1)), np.zeros((1, 1)))
        for _ in range(N):
            kf.predict(0.1)
            kf.update(np.array([truth + rng.normal(0, np.sqrt(r))]), np.ones((1, 1)),
                      np.array([[r]]))
        nis.append(kf.nis_sum / kf.nis_dof)
    x, P = kf.state()
    assert P[0, 0] == pytest.approx(1.0 / (1.0 / P0 + N / r), rel=1e-9)
    # mean NIS per dof over 12000 scalar updates: 1 +- 3 * sqrt(2 / 12000)
    assert abs(np.mean(nis) - 1.0) < 3 * np.sqrt(2.0 / (runs * N))


def test_markov_process_variance_reaches_steady_state():
    # first-order Markov with q = 2 s^2 / tau: steady variance s^2 (trapezoid Qd, 0.1 s steps)
    tau, s = 20.0, 0.3
    kf = kalman.KalmanFilter(np.zeros(1), np.zeros((1, 1)))
    kf.set_model(np.array([[-1 / tau]]), np.array([[2 * s ** 2 / tau]]))
    for _ in range(4000):
        kf.predict(0.1)
    assert kf.sigma()[0] == pytest.approx(s, rel=1e-3)


def test_filter_rejects_wrong_covariance_shape():
    with pytest.raises(ValueError, match="P0 must be"):
        kalman.KalmanFilter(np.zeros(3), np.eye(2))


def test_numba_kernels_match_the_numpy_forms():
    rng = np.random.default_rng(5)
    n, m = 9, 3
    F = 0.05 * rng.standard_normal((n, n))
    G = rng.standard_normal((n, 2))
    Qc = G @ G.T
    P0 = _spd(rng, n)
    x0 = rng.standard_normal(n)
    kf = kalman.KalmanFilter(x0, P0)
    kf.set_model(F, Qc)
    kf.predict(0.1)
    xp, Pp = kalman.predict(x0, P0, *kalman.discretize(F, Qc, 0.1))
    assert np.allclose(kf.x, xp) and np.allclose(kf.P, Pp)
    H = rng.standard_normal((m, n))
    r = rng.uniform(0.5, 1.0, m)
    z = rng.standard_normal(m)
    xb, Pb, nu, S = kalman.joseph_update(kf.x.copy(), kf.P.copy(), z, H, np.diag(r))
    ok, nis = kf.update_sequential(z, H, r)
    assert ok and nis == pytest.approx(nu @ np.linalg.solve(S, nu))
    assert np.allclose(kf.x, xb, atol=1e-10) and np.allclose(kf.P, Pb, atol=1e-10)


def test_gate_rejects_an_outlier_and_leaves_the_state():
    kf = kalman.KalmanFilter(np.zeros(2), np.eye(2))
    H = np.array([[1.0, 0.0]])
    ok, nis = kf.update_sequential(np.array([10.0]), H, np.array([1.0]), threshold=9.0)
    assert not ok and nis == pytest.approx(50.0)          # 10^2 / (1 + 1)
    assert np.all(kf.x == 0) and np.allclose(kf.P, np.eye(2))
    ok, _ = kf.update_sequential(np.array([1.0]), H, np.array([1.0]), threshold=9.0)
    assert ok and kf.x[0] == pytest.approx(0.5)
