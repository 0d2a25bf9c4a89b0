"""Sigma-point schemes as strategy objects, with injected manifold operations.

A scheme knows how many points it draws, their weights, and where they sit relative to a mean
for a given covariance. Filters on curved state spaces (attitude) inject three operations so
the same scheme serves both flat and manifold states (the filterpy convention):

``add(x, dx)``
    state plus a perturbation (flat: ``x + dx``), vectorized over rows of ``dx``;
``residual(chi, x)``
    the perturbation taking ``x`` to each row of ``chi`` (flat: ``chi - x``);
``mean(chi, w)``
    the weighted mean of the rows of ``chi`` (flat: ``w @ chi``; quaternions:
    :func:`inmotion.estimation.quat_average.quat_average`).

:class:`ScaledSigmaPoints` is the scheme of paper 001 eq. 24-26 (the scaled unscented
transform of Julier 2002 / van der Merwe 2004, with the paper's symbols):

    lambda = sigma^2 (n + kappa) - n
    chi_0 = x,  chi_i = x + [sqrt((n + lambda) P)]_i,  chi_{n+i} = x - [sqrt((n + lambda) P)]_i
    W^m_0 = lambda / (n + lambda),                   W^m_i = 1 / (2 (n + lambda))
    W^c_0 = lambda / (n + lambda) + 1 - sigma^2 + zeta,  W^c_i = 1 / (2 (n + lambda))

``[sqrt(A)]_i`` is the i-th column of the lower Cholesky factor ``L`` of ``A = L L^T``. The
printed eq. 26 is garbled in the text extraction (its zeroth line repeated); the form above is
the scaled unscented transform the paper cites, and the tests check that it reproduces the mean
and covariance of the distribution it samples.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ScaledSigmaPoints", "flat_add", "flat_residual", "flat_mean",
           "unscented_transform"]


def flat_add(x, dx):
    """``x + dx`` (flat state space)."""
    return x + dx


def flat_residual(chi, x):
    """``chi - x`` (flat state space)."""
    return chi - x


def flat_mean(chi, w):
    """``sum_i w_i chi_i`` (flat state space)."""
    return w @ chi


class ScaledSigmaPoints:
    """The scaled sigma-point scheme of paper 001 eq. 24-26.

    Parameters
    ----------
    n : int
        State dimension.
    sigma : float
        Spread scale factor ``sigma`` (the paper's ``10^-4 <= sigma <= 1``; usually called alpha).
    kappa : float
        Secondary scaling ``kappa`` (the paper suggests 0 or ``3 n``; 0 by default).
    zeta : float
        Prior-knowledge term ``varsigma`` of ``W^c_0`` (2 is optimal for Gaussian priors).

    Attributes
    ----------
    lam : float
        ``lambda = sigma^2 (n + kappa) - n``.
    Wm, Wc : (2n+1,) arrays
        Mean and covariance weights.
    """

    def __init__(self, n: int, sigma: float = 1.0, kappa: float = 0.0, zeta: float = 2.0):
        if n < 1:
            raise ValueError(f"state dimension must be >= 1, got {n}")
        self.n, self.sigma, self.kappa, self.zeta = int(n), float(sigma), float(kappa), float(zeta)
        self.lam = self.sigma ** 2 * (self.n + self.kappa) - self.n
        if self.n + self.lam <= 0.0:
            raise ValueError(f"n + lambda must be > 0 (got {self.n + self.lam}); "
                             "raise sigma or kappa")
        w = 1.0 / (2.0 * (self.n + self.lam))
        self.Wm = np.full(self.num_points, w)
        self.Wc = np.full(self.num_points, w)
        self.Wm[0] = self.lam / (self.n + self.lam)
        self.Wc[0] = self.lam / (self.n + self.lam) + 1.0 - self.sigma ** 2 + self.zeta

    @property
    def num_points(self) -> int:
        return 2 * self.n + 1

    def offsets(self, P):
        """The perturbations ``0, +[sqrt((n+lambda) P)]_i, -[sqrt((n+lambda) P)]_i`` (eq. 24).

        Parameters
        ----------
        P : (n, n) array, symmetric positive definite.

        Returns
        -------
        (2n+1, n) array, row ``i`` is the offset of sigma point ``i``.
        """
        L = np.linalg.cholesky((self.n + self.lam) * P)
        return np.vstack([np.zeros((1, self.n)), L.T, -L.T])

    def points(self, x, P, add=flat_add):
        """Sigma points around ``x`` with covariance ``P``: ``add(x, offsets(P))`` (eq. 24)."""
        return add(x, self.offsets(P))

    def __repr__(self):
        return (f"ScaledSigmaPoints(n={self.n}, sigma={self.sigma}, kappa={self.kappa}, "
                f"zeta={self.zeta})")


def unscented_transform(chi, Wm, Wc, noise_cov=None, mean=flat_mean, residual=flat_residual):
    """Mean and covariance of transformed sigma points (paper 001 eq. 32-33 and 35-36).

    Parameters
    ----------
    chi : (m, d) array
        Transformed sigma points.
    Wm, Wc : (m,) arrays
        Mean and covariance weights of the scheme.
    noise_cov : (d', d') array or None
        Added noise covariance (``Q`` or ``R``); ``d'`` is the residual dimension.
    mean, residual : callables
        Manifold operations (see the module docstring).

    Returns
    -------
    x_mean : (d,) array
    P : (d', d') array
    dev : (m, d') array, the residuals ``residual(chi, x_mean)`` (for cross covariances).
    """
    x_mean = mean(chi, Wm)
    dev = residual(chi, x_mean)
    P = (dev * Wc[:, None]).T @ dev
    if noise_cov is not None:
        P = P + noise_cov
    return x_mean, P, dev
