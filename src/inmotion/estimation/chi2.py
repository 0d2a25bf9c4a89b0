"""Chi-square tests on Kalman residuals and on sensor speeds (paper 003 eq. 40-42, 43-45).

Residual test (paper 003 sec. 3.2.2, eq. 40-42): with the innovation
``r_k = Z_k - H_k X_{k,k-1}`` and its covariance ``C_rk = H_k P_{k,k-1} H_k^T + R_k``, the
statistic ``lambda_k = r_k^T C_rk^-1 r_k`` is chi-square with ``m`` (the measurement
dimension) degrees of freedom while the channel is healthy; a fault gives ``r_k`` a non-zero
mean and ``lambda_k`` grows. The channel is declared faulty when ``lambda_k > T_lambda``, the
upper ``zeta`` quantile of ``chi2(m)``, ``zeta`` the false-alarm rate per test.

Parked / moving test (sec. 3.3.2, eq. 43-45): the forward speeds of the odometer and the LDV,
zero-mean white noise of variances ``C_vk`` when parked, give ``lambda_v = v^T C_v^-1 v``,
chi-square with 2 degrees of freedom; above ``T_lambda`` the vehicle moves.

The paper prints the decision rule of eq. 42 with the two outcomes swapped ("lambda <= T:
faulted"); its text (and eq. 45) say the opposite, which is what is implemented.

Quantiles (:func:`ppf`, :func:`isf`, :func:`threshold`) call the ``scipy.special`` functions
``scipy.stats.chi2`` itself calls (``2 gammaincinv(dof/2, p)``, ``chdtri(dof, q)``), imported
on first use: ``scipy.stats`` costs about
half a second of imports, ``scipy.special`` a fraction of it, and only a run that needs a
quantile pays even that. ``chi2.ppf(p, dof)`` here is a drop-in for
``scipy.stats.chi2.ppf(p, dof)`` (the same values, bit for bit).
"""
from __future__ import annotations

import numpy as np

__all__ = ["ppf", "isf", "threshold", "statistic", "exceeds", "nis_summary"]


def _chdtri(dof, upper):
    from scipy.special import chdtri
    return chdtri(dof, upper)


def _lower(dof, p):
    from scipy.special import gammaincinv
    return 2.0 * gammaincinv(dof / 2.0, p)


def _scalar_or_array(x):
    x = np.asarray(x, dtype=float)
    return float(x) if x.ndim == 0 else x


def ppf(p, dof):
    """The ``p`` quantile of ``chi2(dof)``: ``x`` with ``P(X <= x) = p``.

    Parameters
    ----------
    p : float or array, probability in [0, 1] (0 gives 0, 1 gives inf, outside: NaN)
    dof : int or array, degrees of freedom (> 0)

    Returns
    -------
    float, or an array of the broadcast shape: the value of ``scipy.stats.chi2.ppf(p, dof)``.
    """
    p = np.asarray(p, dtype=float)
    dof = np.asarray(dof, dtype=float)
    x = np.asarray(_lower(dof, p), dtype=float)
    x = np.where(p == 0.0, 0.0, np.where(p == 1.0, np.inf, x))
    x = np.where((p < 0.0) | (p > 1.0) | ~(dof > 0.0) | np.isnan(p), np.nan, x)
    return _scalar_or_array(x)


def isf(q, dof):
    """The upper ``q`` quantile of ``chi2(dof)``: ``x`` with ``P(X > x) = q``; the value of
    ``scipy.stats.chi2.isf(q, dof)`` (``q`` in [0, 1]: 0 gives inf, 1 gives 0)."""
    q = np.asarray(q, dtype=float)
    dof = np.asarray(dof, dtype=float)
    x = np.asarray(_chdtri(dof, q), dtype=float)
    x = np.where(q == 0.0, np.inf, np.where(q == 1.0, 0.0, x))
    x = np.where((q < 0.0) | (q > 1.0) | ~(dof > 0.0) | np.isnan(q), np.nan, x)
    return _scalar_or_array(x)


def threshold(false_alarm_rate: float, dof: int) -> float:
    """``T_lambda``: the upper ``false_alarm_rate`` quantile of ``chi2(dof)``.

    Parameters
    ----------
    false_alarm_rate : probability per test that a healthy channel is declared faulty, (0, 1)
    dof : degrees of freedom (the measurement dimension ``m``)
    """
    if not 0.0 < false_alarm_rate < 1.0:
        raise ValueError(f"false_alarm_rate must be in (0, 1), got {false_alarm_rate}")
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof}")
    return float(isf(false_alarm_rate, dof))


def statistic(r, C) -> np.ndarray:
    """``lambda = r^T C^-1 r`` for one residual (m,) or a stack (N, m) with (m, m) / (N, m, m).

    Parameters
    ----------
    r : residuals, any unit;  C : their covariance, the unit squared
    """
    r = np.asarray(r, dtype=float)
    C = np.asarray(C, dtype=float)
    sol = np.linalg.solve(C, r[..., None])[..., 0]
    return np.einsum("...i,...i->...", r, sol)


def exceeds(r, C, false_alarm_rate: float) -> np.ndarray:
    """True where ``lambda > T_lambda`` (eq. 42: faulted / eq. 45: moving)."""
    r = np.asarray(r, dtype=float)
    return statistic(r, C) > threshold(false_alarm_rate, r.shape[-1])


def nis_summary(nis_sum: float, dof: int, samples: int) -> dict:
    """The NIS block of one measurement kind (``summary.json`` ``nis``): over ``samples``
    applied samples with ``dof`` scalar rows in all and ``nis_sum`` the sum of their NIS
    (``nu^T S^-1 nu`` each), ``mean_per_dof`` (1 for a consistent filter: the sum is
    ``chi2(dof)`` when the innovations are white and ``S`` is their covariance) and
    ``band_95``, the 95 % band of that mean, ``[isf(0.975, dof), isf(0.025, dof)] / dof``
    (a loose check where innovations are correlated in time); ``None`` values before any
    sample."""
    if dof <= 0:
        return {"samples": int(samples), "dof": 0, "mean_per_dof": None, "band_95": None,
                "in_band": None}
    m = float(nis_sum) / dof
    lo, hi = isf(0.975, dof) / dof, isf(0.025, dof) / dof
    return {"samples": int(samples), "dof": int(dof), "mean_per_dof": m,
            "band_95": [float(lo), float(hi)], "in_band": bool(lo <= m <= hi)}
