"""Federated fusion (paper 003 eq. 33-36) and the chi-square tests (eq. 40-45)."""
import numpy as np
import pytest
from scipy.stats import chi2 as sp_chi2

from inmotion.estimation import chi2, federated
from inmotion.estimation.kalman import joseph_update


def _spd(rng, n, scale=1.0):
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T + n * np.eye(n))


def test_federated_fusion_equals_centralized_estimate():
    """Two local filters sharing the prior with beta = 1/2 each (P0 / beta), each updated with
    its own independent measurements, fused by eq. 36, give the centralized estimate."""
    rng = np.random.default_rng(1)
    n = 5
    P0 = _spd(rng, n)
    x0 = rng.normal(size=n)
    H1, H2 = rng.normal(size=(3, n)), rng.normal(size=(2, n))
    R1, R2 = _spd(rng, 3, 0.1), _spd(rng, 2, 0.2)
    z1, z2 = rng.normal(size=3), rng.normal(size=2)
    xc, Pc, _, _ = joseph_update(x0, P0, z1, H1, R1)
    xc, Pc, _, _ = joseph_update(xc, Pc, z2, H2, R2)
    locals_ = []
    for H, Rm, z, beta in ((H1, R1, z1, 0.5), (H2, R2, z2, 0.5)):
        x, P, _, _ = joseph_update(x0, federated.share(P0, beta), z, H, Rm)
        locals_.append((x, P))
    xg, Pg = federated.fuse([l[0] for l in locals_], [l[1] for l in locals_])
    np.testing.assert_allclose(Pg, Pc, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(xg, xc, rtol=1e-9, atol=1e-12)
    # the numba kernel on the leading block gives the same
    X = np.zeros((2, n + 2))
    P = np.zeros((2, n + 2, n + 2))
    for i, (x, Pl) in enumerate(locals_):
        X[i, :n] = x
        P[i, :n, :n] = Pl
        P[i, n:, n:] = np.eye(2)
    xk, Pk = np.zeros(n), np.zeros((n, n))
    assert federated.fuse_kernel(X, P, np.array([True, True]), n, xk, Pk, np.ones(2))
    np.testing.assert_allclose(xk, xc, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Pk, Pc, rtol=1e-9, atol=1e-12)
    # one filter alone: the fusion returns it unchanged
    assert federated.fuse_kernel(X, P, np.array([False, True]), n, xk, Pk, np.ones(2))
    np.testing.assert_allclose(xk, locals_[1][0])
    assert not federated.fuse_kernel(X, P, np.array([False, False]), n, xk, Pk, np.ones(2))


def test_share_rejects_bad_beta():
    with pytest.raises(ValueError):
        federated.share(np.eye(2), 0.0)


@pytest.mark.parametrize("dof,rate", [(3, 0.05), (3, 1e-3), (2, 0.01)])
def test_threshold_is_the_upper_quantile(dof, rate):
    T = chi2.threshold(rate, dof)
    assert sp_chi2.sf(T, dof) == pytest.approx(rate, rel=1e-9)
    if dof == 2:                                  # closed form: P(lambda > T) = exp(-T / 2)
        assert T == pytest.approx(-2 * np.log(rate), rel=1e-12)


@pytest.mark.parametrize("rate", [0.05, 0.01])
def test_false_alarm_rate_on_white_residuals(rate):
    """Residuals N(0, C) with a correlated C: the fraction of tests above T_lambda is the set
    rate within 4 Monte Carlo standard deviations."""
    rng = np.random.default_rng(3)
    N = 200_000
    C = _spd(rng, 3, 0.01)
    r = rng.normal(size=(N, 3)) @ np.linalg.cholesky(C).T
    frac = chi2.exceeds(r, C, rate).mean()
    assert abs(frac - rate) < 4 * np.sqrt(rate * (1 - rate) / N)


def test_false_alarm_rate_of_a_consistent_kalman_filter():
    """The innovations of a consistent linear Kalman filter (constant velocity, position
    measured) are white with covariance H P H^T + R, so their test keeps the set rate."""
    rng = np.random.default_rng(4)
    dt, q, r = 0.1, 0.5, 0.2
    F = np.array([[1, dt], [0, 1]])
    Q = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    H = np.array([[1.0, 0.0]])
    Rm = np.array([[r ** 2]])
    x_true = np.zeros(2)
    x, P = np.zeros(2), np.eye(2)
    L = np.linalg.cholesky(Q)
    lam = []
    for k in range(6000):
        x_true = F @ x_true + L @ rng.normal(size=2)
        z = H @ x_true + r * rng.normal(size=1)
        x, P = F @ x, F @ P @ F.T + Q
        x, P, nu, S = joseph_update(x, P, z, H, Rm)
        if k > 100:
            lam.append(chi2.statistic(nu, S))
    lam = np.array(lam)
    rate = 0.01
    frac = np.mean(lam > chi2.threshold(rate, 1))
    assert abs(frac - rate) < 4 * np.sqrt(rate * (1 - rate) / len(lam))


def test_chi2_bad_arguments():
    with pytest.raises(ValueError):
        chi2.threshold(0.0, 3)
    with pytest.raises(ValueError):
        chi2.threshold(0.1, 0)
