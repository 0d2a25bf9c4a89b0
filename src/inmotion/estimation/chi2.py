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

Quantiles (:func:`ppf`, :func:`isf`, :func:`threshold`) are computed here, without scipy
(``scipy.special`` costs about 0.1 s of imports, a quarter of a short command-line run): the
regularized incomplete gamma function ``P(a, x)`` by its power series below ``x = a + 1`` and
``Q(a, x)`` by its continued fraction above (Press et al., Numerical Recipes, 3rd ed.,
sec. 6.2), the prefactor ``x^a e^-x / Gamma(a)`` in Stirling's form for ``a >= 10`` (no
cancellation of terms of size ``a ln a``), and the quantile by Newton's method on the log of
the smaller tail as a function of ``ln x`` from the Wilson-Hilferty approximation, kept in a
bracket. Contract: the values of ``scipy.stats.chi2.ppf`` / ``isf`` to a relative 1e-11 for
``0.5 <= dof <= 1e6`` and tail probabilities down to 1e-300 (``tests/test_chi2_quantiles``
compares them on a grid); not bit for bit, as they were when they called scipy. Beyond
``dof = 1e7`` they call ``scipy.special`` (the series would need too many terms; between 1e6
and 1e7 scipy's own values drift by up to 1e-8 relative from these).
"""
from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["ppf", "isf", "threshold", "statistic", "exceeds", "nis_summary", "nis_warnings",
           "NIS_WARN_FACTOR"]


_LN_SQRT_2PI = 0.9189385332046727418       # ln sqrt(2 pi)
#: beyond this many degrees of freedom the quantiles come from scipy (the series here would
#: need tens of thousands of terms)
_SCIPY_DOF = 1e7
_EPS = 2.220446049250313e-16


def _stirlerr(a):
    """``ln Gamma(a) - ((a - 1/2) ln a - a + ln sqrt(2 pi))`` for ``a >= 10``: the Stirling
    series to ``a^-9`` (the next term is below 1e-17 of the sum there)."""
    r = 1.0 / (a * a)
    return (1.0 / 12 - r * (1.0 / 360 - r * (1.0 / 1260 - r * (1.0 / 1680 - r / 1188)))) / a


def _log_prefactor(a, x):
    """``ln(x^a e^-x / Gamma(a))``; for ``a >= 10`` as ``-a (t - ln(1 + t)) + ln sqrt(a / 2
    pi) - stirlerr(a)`` with ``t = (x - a) / a`` (no cancellation of terms of size ``a ln a``
    against each other)."""
    if a < 10.0:
        return a * math.log(x) - x - math.lgamma(a)
    t = (x - a) / a
    core = -a * (t - math.log1p(t)) if abs(t) < 0.5 else a * math.log(x / a) - (x - a)
    return core + 0.5 * math.log(a) - _LN_SQRT_2PI - _stirlerr(a)


def _log_tail(a, x, upper):
    """``(ln T, ln pdf)`` of the gamma(a) distribution at ``x > 0``: ``T`` the lower
    regularized incomplete gamma ``P(a, x)`` or, with ``upper``, ``Q(a, x) = 1 - P``; by the
    power series of ``P`` for ``x < a + 1`` and the continued fraction of ``Q`` (modified
    Lentz) otherwise (Press et al., Numerical Recipes, sec. 6.2), the other tail as one minus
    it (then above about 0.3, so without loss)."""
    lp = _log_prefactor(a, x)
    if x < a + 1.0:                                   # P = e^lp / a * sum x^n / (a+1)..(a+n)
        term = s = 1.0 / a
        ap = a
        for _ in range(1_000_000):
            ap += 1.0
            term *= x / ap
            s += term
            if term < s * _EPS:
                break
        log_p = lp + math.log(s)
        log_t = math.log(-math.expm1(log_p)) if upper else log_p
    else:                                             # Q = e^lp * 1 / (x + 1 - a - ...)
        tiny = 1e-300
        b = x + 1.0 - a
        c = 1.0 / tiny
        d = 1.0 / b
        h = d
        for i in range(1, 1_000_000):
            an = -i * (i - a)
            b += 2.0
            d = an * d + b
            d = tiny if abs(d) < tiny else d
            c = b + an / c
            c = tiny if abs(c) < tiny else c
            d = 1.0 / d
            delta = d * c
            h *= delta
            if abs(delta - 1.0) < _EPS:
                break
        log_q = lp + math.log(h)
        log_t = log_q if upper else math.log(-math.expm1(log_q))
    return log_t, lp - math.log(x)


def _normal_quantile(p):
    """Acklam's rational approximation of the standard normal quantile (relative error about
    1e-9): only a starting point here."""
    a = (-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
         1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00)
    b = (-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
         6.680131188771972e+01, -1.328068155288572e+01)
    c = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
         -2.549671348283239e+00, 4.374664141464968e+00, 2.938163982698783e+00)
    d = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
         3.754408661907416e+00)
    if p < 0.02425:
        q = math.sqrt(-2.0 * math.log(p))
        return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) / \
            ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    if p > 1.0 - 0.02425:
        return -_normal_quantile(1.0 - p)
    q = p - 0.5
    r = q * q
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q / \
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)


def _gamma_quantile(a, tail, upper):
    """``x`` with ``Q(a, x) = tail`` (``upper``) or ``P(a, x) = tail``, ``0 < tail <= 1/2``:
    Newton's method on ``ln T(x) = ln tail`` from the Wilson-Hilferty approximation,
    safeguarded by a bracket (bisection in ``ln x`` where a step leaves it), to a relative
    step of a few ulps."""
    log_target = math.log(tail)
    z = _normal_quantile(tail)
    z = -z if upper else z
    w = 1.0 / (9.0 * a)
    x = a * (1.0 - w + z * math.sqrt(w)) ** 3          # Wilson-Hilferty (chi2 / 2)
    if not upper:                 # P(a, x) <= x^a / Gamma(a + 1): its root is below x
        small = math.exp((log_target + math.lgamma(a + 1.0)) / a)
        x = max(x, small) if x > 0.0 else small
        if x < 1e-290:
            return x              # no double is worth iterating for down there
    if not x > 0.0:
        x = a
    step = min(1.0, 4.0 / math.sqrt(a))      # in ln x: about 4 sigma where a is large
    u = math.log(x)                 # Newton on ln T as a function of ln x: ln P is near a
    lo, hi = -math.inf, math.inf    # line in ln x in the lower tail, where x spans decades
    for _ in range(200):
        log_t, log_pdf = _log_tail(a, x, upper)
        f = log_t - log_target                           # increasing in u unless upper
        if f == 0.0:
            return x
        if (f > 0.0) != upper:
            hi = u
        else:
            lo = u
        slope = math.exp(log_pdf + u - log_t) * (-1.0 if upper else 1.0)
        u_new = u - f / slope if slope != 0.0 else math.nan
        if not (lo < u_new < hi):      # outside the bracket: bisect, or step out to find one
            u_new = (0.5 * (lo + hi) if math.isfinite(lo) and math.isfinite(hi) else
                     u - step if math.isfinite(hi) else u + step)
        x_new = math.exp(u_new)
        if abs(u_new - u) <= 4.0 * _EPS or x_new == x:
            return x_new
        u, x = u_new, x_new
    return x


@functools.lru_cache(maxsize=1024)
def _quantile(tail, dof, upper):
    """The chi-square(dof) quantile with upper (``upper``) or lower tail probability
    ``tail`` in (0, 1): twice the gamma(dof / 2) quantile, from the smaller tail. Kept for
    the arguments asked before (a result's summary asks the same 95 % band of each group with
    the same rows, and of each measurement kind with the same samples: 1-6 ms each at tens
    of thousands of degrees of freedom)."""
    if dof > _SCIPY_DOF:
        from scipy import special
        return float(special.chdtri(dof, tail) if upper else
                     2.0 * special.gammaincinv(dof / 2.0, tail))
    a = 0.5 * dof
    if tail > 0.5:               # the other tail: 1 - tail is exact for tail in [1/2, 1]
        tail, upper = 1.0 - tail, not upper
    return 2.0 * _gamma_quantile(a, tail, upper)


def _scalar_or_array(x):
    x = np.asarray(x, dtype=float)
    return float(x) if x.ndim == 0 else x


def _quantiles(tail, dof, upper):
    """:func:`_quantile` over the broadcast of ``tail`` and ``dof``, with scipy's values at
    the ends (tail 0 and 1) and NaN where scipy gives NaN (tail outside [0, 1] or NaN, ``dof``
    not > 0 or not finite)."""
    tail, dof = np.broadcast_arrays(np.asarray(tail, dtype=float), np.asarray(dof, dtype=float))
    out = np.empty(tail.shape)
    for i in np.ndindex(tail.shape):
        t, d = float(tail[i]), float(dof[i])
        if not (0.0 <= t <= 1.0 and d > 0.0 and math.isfinite(d)):
            out[i] = math.nan
        elif t == 0.0 or t == 1.0:
            out[i] = math.inf if (t == 0.0) == upper else 0.0
        else:
            out[i] = _quantile(t, d, upper)
    return _scalar_or_array(out)


def ppf(p, dof):
    """The ``p`` quantile of ``chi2(dof)``: ``x`` with ``P(X <= x) = p``.

    Parameters
    ----------
    p : float or array, probability in [0, 1] (0 gives 0, 1 gives inf, outside: NaN)
    dof : int or array, degrees of freedom (> 0)

    Returns
    -------
    float, or an array of the broadcast shape: the value of ``scipy.stats.chi2.ppf(p, dof)``
    (module docstring: to a relative 1e-11).
    """
    return _quantiles(p, dof, upper=False)


def isf(q, dof):
    """The upper ``q`` quantile of ``chi2(dof)``: ``x`` with ``P(X > x) = q``; the value of
    ``scipy.stats.chi2.isf(q, dof)`` to a relative 1e-11 (``q`` in [0, 1]: 0 gives inf, 1 gives
    0)."""
    return _quantiles(q, dof, upper=True)


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
    (a loose check where innovations are correlated in time); ``expected_mean_per_dof`` 1 and
    ``model`` ``"chi2"`` (a caller whose statistic follows another model replaces the three,
    e.g. :func:`inmotion.align.aided_kf.residual_test_nis`); ``None`` values before any
    sample."""
    if dof <= 0:
        return {"samples": int(samples), "dof": 0, "mean_per_dof": None,
                "expected_mean_per_dof": 1.0, "model": "chi2", "band_95": None,
                "in_band": None}
    m = float(nis_sum) / dof
    lo, hi = isf(0.975, dof) / dof, isf(0.025, dof) / dof
    return {"samples": int(samples), "dof": int(dof), "mean_per_dof": m,
            "expected_mean_per_dof": 1.0, "model": "chi2",
            "band_95": [float(lo), float(hi)], "in_band": bool(lo <= m <= hi)}


#: a measurement kind whose mean NIS per degree of freedom exceeds this many times its model's
#: mean (``expected_mean_per_dof``) gets a warning (:func:`nis_warnings`)
NIS_WARN_FACTOR = 3.0
#: what a kind's large NIS most likely means, where it says more than the noise model
_NIS_HINTS = {"zero_velocity": " (a zero-velocity filter: was the vehicle still?)"}


def nis_warnings(nis) -> list:
    """One warning per measurement kind of a ``nis`` block (``{kind: nis_summary block}``,
    :func:`nis_summary`, as ``summary.json`` holds it) whose mean NIS per degree of freedom is
    above :data:`NIS_WARN_FACTOR` times its model's mean: the residuals are larger than the
    filter's own innovation covariance says, so its sigma understates its error (issue 15: a
    method outside its envelope says so). Kinds without samples are skipped; ``None`` or an
    empty block gives ``[]``."""
    out = []
    for kind, b in (nis or {}).items():
        if not isinstance(b, dict):
            continue
        m, e = b.get("mean_per_dof"), b.get("expected_mean_per_dof") or 1.0
        if m is None or not m > NIS_WARN_FACTOR * e:
            continue
        out.append(f"{kind}: mean NIS per degree of freedom {m:.3g} ({e:.2g} expected)"
                   f"{_NIS_HINTS.get(kind, '')}: the residuals are larger than the noise model, so the reported sigma "
                   "understates the error")
    return out
