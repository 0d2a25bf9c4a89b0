"""Issue 15: the residual test's covariance ``Pa`` (the engine's "Test covariance").

``Pa`` is the covariance of the error a Kalman filter's own gains leave when the rows' true
noise is not the one its gains assume (the covariance analysis of a suboptimal filter):
checked here against the Joseph form written out, against ``P``'s own update where the two
noises agree, and against the Monte Carlo spread of a linear system's error, which is the
theory's claim. The fkf option itself must leave the filter's estimate untouched (only its
test changes)."""
import numpy as np
import pytest

from inmotion.estimation.kalman import sequential_joseph, sequential_joseph_pair
from update_problems import random_rows_problem


def _spd(rng, n):
    A = rng.standard_normal((n, n))
    return A @ A.T + n * np.eye(n)


def test_pair_update_with_equal_noise_is_the_filters_own():
    rng = np.random.default_rng(3)
    n, m = 7, 3
    P = _spd(rng, n)
    x = rng.standard_normal(n)
    H = rng.standard_normal((m, n))
    H[:, 4] = 0.0                       # a column the rows do not see
    z = rng.standard_normal(m)
    r = rng.uniform(0.5, 2.0, m)
    x1, P1 = x.copy(), P.copy()
    sequential_joseph(x1, P1, z, H, r, 0, m, 0.0, np.empty(n), np.empty((n, n)))
    x2, P2, Pa = x.copy(), P.copy(), P.copy()
    sequential_joseph_pair(x2, P2, Pa, z, H, r, r, 0, m, np.empty((n, n)))
    assert np.array_equal(x1, x2) and np.array_equal(P1, P2)      # bit for bit
    np.testing.assert_allclose(Pa, P1, rtol=1e-10, atol=1e-12)
    assert np.array_equal(Pa, Pa.T)


def test_pair_update_is_the_joseph_form_of_the_filters_gain():
    rng = np.random.default_rng(4)
    n, m = 6, 3
    P, Pa = _spd(rng, n), _spd(rng, n)
    H = rng.standard_normal((m, n))
    rl = rng.uniform(1.0, 3.0, m)
    ra = rng.uniform(0.1, 0.5, m)
    # written out: row by row, the gain from P and rl, the Joseph form on Pa with ra
    Pe, Pae = P.copy(), Pa.copy()
    for i in range(m):
        h = H[i]
        k = Pe @ h / (h @ Pe @ h + rl[i])
        A = np.eye(n) - np.outer(k, h)
        Pe = A @ Pe @ A.T + rl[i] * np.outer(k, k)
        Pae = A @ Pae @ A.T + ra[i] * np.outer(k, k)
    x = np.zeros(n)
    sequential_joseph_pair(x, P, Pa, np.zeros(m), H, rl, ra, 0, m, np.empty((n, n)))
    np.testing.assert_allclose(P, Pe, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Pa, Pae, rtol=1e-9, atol=1e-12)


def test_pa_is_the_error_covariance_of_a_filter_told_its_rows_are_worse():
    """A linear drive: position, velocity and a constant sensor scale (the along-track part
    of the length row), a displacement row per interval; the filter takes the rows' variance
    as 9 times the true one (the inflation its gains carry), its ``P`` then over-bounds the
    error while ``Pa`` (the same gains, the true variance) is the error's covariance over
    4000 drives."""
    rng = np.random.default_rng(5)
    runs, steps, T, v = 4000, 40, 0.5, 10.0
    Phi = np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    q = 1e-4
    Qd = q * np.array([[T ** 3 / 3, T ** 2 / 2, 0.0], [T ** 2 / 2, T, 0.0], [0.0, 0.0, 0.0]])
    Qd[2, 2] = 1e-10
    P0 = np.diag([0.0, 0.2 ** 2, 1e-3 ** 2])
    ra = np.array([(5e-3) ** 2])
    rl = 9.0 * ra
    H = np.array([[0.0, T, -v * T]])        # the interval's velocity and scale, in metres
    L = np.linalg.cholesky(Qd + 1e-30 * np.eye(3))
    e_end = np.empty((runs, 3))
    P = Pa = None
    for k in range(runs):
        e = rng.multivariate_normal(np.zeros(3), P0)   # true error of the zero estimate
        x = np.zeros(3)
        P, Pa = P0.copy(), P0.copy()
        for _ in range(steps):
            e = Phi @ e + L @ rng.standard_normal(3)
            x = Phi @ x
            P = Phi @ P @ Phi.T + Qd
            Pa = Phi @ Pa @ Phi.T + Qd
            z = H @ e + np.sqrt(ra) * rng.standard_normal(1)
            sequential_joseph_pair(x, P, Pa, z, H, rl, ra, 0, 1, np.empty((3, 3)))
        e_end[k] = e - x
    emp = np.cov(e_end.T)
    # the variances the row sees (velocity, the velocity-scale combination): sampling error
    # of a variance over 4000 draws is 2.2 % (1 sigma)
    for h in (np.array([0.0, 1.0, 0.0]), H[0]):
        got = h @ emp @ h
        assert got == pytest.approx(h @ Pa @ h, rel=0.08)
        assert h @ P @ h > 1.3 * got          # the filter's own P over-bounds it


def test_the_gated_test_takes_pa_and_leaves_the_filter_as_without_it():
    """The engine's gated update with a test covariance: the statistic is the batch ``nu^T (H
    Pa H^T + diag(r_test))^-1 nu``, ``x`` and ``P`` are what the update without ``Pa`` makes,
    bit for bit, and ``Pa`` takes the Joseph form of ``P``'s gains with ``r_test``."""
    from inmotion.estimation import engine as eng
    rng = np.random.default_rng(6)
    n, m = 9, 3
    P, x, H, z, rl, rt = random_rows_problem(rng, n, m, 0.6)
    Pa = 0.3 * _spd(rng, n)
    nu = z[:m] - H[:m] @ x
    want = nu @ np.linalg.solve(H[:m] @ Pa @ H[:m].T + np.diag(rt), nu)
    xw, Pw = np.empty(n), np.empty((n, n))
    x1, P1 = x.copy(), P.copy()
    eng._gated(x1, P1, z, H, rl, rt, m, 0.0, xw, Pw, True, np.empty((0, 0)))
    x2, P2, Pa2 = x.copy(), P.copy(), Pa.copy()
    ok, nis = eng._gated(x2, P2, z, H, rl, rt, m, 0.0, xw, Pw, True, Pa2)
    assert ok and nis == pytest.approx(want, rel=1e-10)
    assert np.array_equal(x1, x2) and np.array_equal(P1, P2)
    x3, P3, Pa3 = x.copy(), P.copy(), Pa.copy()
    sequential_joseph_pair(x3, P3, Pa3, z, H, rl, rt, 0, m, np.empty((n, n)))
    # (compiled in another context, LLVM may fuse a product differently: the last bits)
    np.testing.assert_allclose(Pa2, Pa3, rtol=1e-12, atol=1e-13)
    # over the gate: nothing changes
    x4, P4, Pa4 = x.copy(), P.copy(), Pa.copy()
    ok, nis = eng._gated(x4, P4, z, H, rl, rt, m, 0.99 * want, xw, Pw, True, Pa4)
    assert not ok and np.array_equal(x4, x) and np.array_equal(P4, P) and np.array_equal(Pa4, Pa)


def test_fkf_with_the_detection_off_is_the_filter_without_the_test_covariance():
    """The option changes the test alone: with the detection off fkf's outputs are bit for bit
    those without it, and its test statistics differ."""
    from consistency_mc import drive_003
    from inmotion.align import aided_kf as ak
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    rng = np.random.default_rng(8)
    b = simulate(drive_003(), rng)
    init = NavState.from_truth(b.truth, euler_error=np.radians([0.1, 0.1, 0.5]))
    cfg = {"fdi": False, "keep_test_statistics": True}
    on = ak.run_fkf(b, dict(cfg, test_covariance=True), init)
    off = ak.run_fkf(b, dict(cfg, test_covariance=False), init)
    for k in off.states:
        assert np.array_equal(on.states[k], off.states[k]), k
    assert np.array_equal(on.vel_n, off.vel_n) and np.array_equal(on.lat, off.lat)
    lam_on, lam_off = on.info["test_statistics"]["lambda"], off.info["test_statistics"]["lambda"]
    assert lam_on.shape == lam_off.shape and not np.allclose(lam_on, lam_off, equal_nan=True)
