"""Sigma points of paper 001 eq. 24-26: weights, moments, exactness of the transform."""
import numpy as np
import pytest

from inmotion.estimation.sigma_points import ScaledSigmaPoints, unscented_transform


def _spd(rng, n):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("n,sigma,kappa,zeta", [(3, 1.0, 0.0, 2.0), (4, 0.5, 1.0, 2.0),
                                                (7, 1e-3, 0.0, 2.0), (2, 1.0, 6.0, 0.0)])
def test_points_reproduce_mean_and_covariance(n, sigma, kappa, zeta):
    rng = np.random.default_rng(n)
    x, P = rng.normal(size=n), _spd(rng, n)
    sp = ScaledSigmaPoints(n, sigma, kappa, zeta)
    chi = sp.points(x, P)
    assert chi.shape == (2 * n + 1, n)
    assert np.isclose(sp.Wm.sum(), 1.0)
    assert np.allclose(sp.Wm @ chi, x)
    dev = chi - x
    # the zeroth point sits on the mean, so W^c_0 does not enter: sum W^c_i dev dev^T = P
    assert np.allclose((dev * sp.Wc[:, None]).T @ dev, P)
    assert np.isclose(sp.lam, sigma ** 2 * (n + kappa) - n)


def test_linear_map_is_exact():
    rng = np.random.default_rng(1)
    n = 4
    x, P = rng.normal(size=n), _spd(rng, n)
    A, b = rng.normal(size=(3, n)), rng.normal(size=3)
    sp = ScaledSigmaPoints(n, 0.7, 0.0, 2.0)
    y = sp.points(x, P) @ A.T + b
    R = 0.1 * np.eye(3)
    mean, cov, _ = unscented_transform(y, sp.Wm, sp.Wm, noise_cov=R)
    assert np.allclose(mean, A @ x + b)
    assert np.allclose(cov, A @ P @ A.T + R)


def test_quadratic_mean_is_exact():
    # y = x^2 for x ~ N(mu, s^2): E[y] = mu^2 + s^2, which the scaled points capture exactly
    mu, s2 = 1.5, 0.3
    sp = ScaledSigmaPoints(1, 1.0, 2.0, 2.0)
    y = sp.points(np.array([mu]), np.array([[s2]])) ** 2
    assert np.isclose(sp.Wm @ y[:, 0], mu ** 2 + s2)


def test_injected_manifold_add():
    sp = ScaledSigmaPoints(2)
    calls = []

    def add(x, dx):
        calls.append(dx.shape)
        return x + 2.0 * dx

    chi = sp.points(np.zeros(2), np.eye(2), add=add)
    assert calls == [(5, 2)]
    assert np.allclose(chi[1:3], 2.0 * np.sqrt(sp.n + sp.lam) * np.eye(2))


def test_bad_parameters_raise():
    with pytest.raises(ValueError, match="n \\+ lambda"):
        ScaledSigmaPoints(3, sigma=1.0, kappa=-3.0)
    with pytest.raises(ValueError, match="dimension"):
        ScaledSigmaPoints(0)
