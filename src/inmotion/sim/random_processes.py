"""Random processes the error models share.

First-order Gauss-Markov process (paper 000 eq. 3, ``dx/dt = -x / tau + w``) sampled exactly at
period ``T``: ``x_{j+1} = phi x_j + sigma sqrt(1 - phi^2) w_j`` with ``phi = exp(-T / tau)``
and ``w_j`` standard normal; ``x_0 = sigma w_0`` (started stationary), so every sample has
standard deviation ``sigma`` and the autocorrelation is ``sigma^2 exp(-|dt| / tau)``.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

__all__ = ["markov"]


def markov(n, period_s, sigma, tau_s, rng, size=None):
    """``n`` samples of a stationary first-order Gauss-Markov process.

    Parameters
    ----------
    n : int;  period_s : float [s];  sigma : float, stationary 1-sigma (any unit)
    tau_s : float, correlation time [s];  rng : numpy.random.Generator
    size : int or None, number of independent processes (columns); None gives shape (n,)
    """
    shape = (n,) if size is None else (n, size)
    phi = np.exp(-period_s / tau_s)
    w = rng.standard_normal(shape)
    w[0] /= np.sqrt(1.0 - phi * phi)          # x_0 = sigma w_0: started stationary
    return lfilter([1.0], [1.0, -phi], sigma * np.sqrt(1.0 - phi * phi) * w, axis=0)
