"""Uneven sampling: rates to increments, a sensor on its own clock, gaps.

Real logs come with sample times that jitter and drift (a phone IMU at "100 Hz" is 104.36 Hz
with microsecond jitter), sensors that output rates instead of increments, velocity sensors on
their own clock, and dropouts. This module turns them into what a bundle holds, with one
documented policy for each case.

Rates to increments
    A rate sample ``w[k]`` is taken as the instantaneous rate at ``t[k]`` (not a mean over the
    previous period). Row ``k`` of the result holds the integral over the actual interval
    ``(t[k-1], t[k]]`` (the time convention of ``docs/ARCHITECTURE.md``):

    * ``order=2`` (default): trapezoid, ``(w[k-1] + w[k]) / 2 * (t[k] - t[k-1])``; exact for a
      rate linear in time, error ``-h^3 w'' / 12`` per interval otherwise.
    * ``order=4``: the integral over ``(t[k-1], t[k]]`` of the cubic through four neighbouring
      samples (``t[k-2] .. t[k+1]``, shifted inwards at both ends), with the weights solved on
      the real, uneven times; exact for a cubic rate. Intervals whose stencil touches a gap fall
      back to the trapezoid.

    The first sample has no interval before it: the result has ``N - 1`` rows, at ``t[1:]``.

Gaps
    An interval is a gap when it is longer than ``GAP_FACTOR`` (3) times the median sample
    period (or than ``max_gap_s`` when given). Policy:

    * IMU: the increment over a gap is still the trapezoid over it (the only information there
      is), and the gap is reported (``gaps`` lists ``(t_start, t_end)`` pairs, which the
      importers put in ``meta['gaps']``) so that a method can reset or inflate its covariance.
    * A velocity sensor interpolated to other epochs: epochs inside a gap, or before the first
      or after the last sample, get NaN and ``valid = False``; nothing is ever extrapolated.

Times must be finite and strictly increasing: anything else is bad input, reported with the
row and the time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import BadInput

__all__ = ["GAP_FACTOR", "Gaps", "check_times", "find_gaps", "gap_threshold",
           "rates_to_increments", "interpolate_at"]

#: an interval longer than this many median sample periods is a gap
GAP_FACTOR = 3.0


@dataclass
class Gaps:
    """Intervals ``(t[k-1], t[k]]`` longer than ``threshold_s``; ``index`` holds ``k``."""

    index: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    threshold_s: float

    def __len__(self):
        return len(self.index)

    def as_list(self) -> list:
        """``[[t_start_s, t_end_s], ...]`` (plain floats, for ``meta.yaml``)."""
        return [[float(a), float(b)] for a, b in zip(self.t_start, self.t_end)]


def check_times(t, file=None, what="t") -> np.ndarray:
    """``t`` as float64 (N,), after checking it is finite and strictly increasing.

    Raises
    ------
    BadInput
        Naming ``file``, the 1-based data row and the time of the first offending sample.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    if len(t) < 2:
        raise BadInput(f"{what}: need at least 2 samples, got {len(t)}", file)
    bad = np.flatnonzero(~np.isfinite(t))
    if len(bad):
        raise BadInput(f"{what} is not finite", file, row=int(bad[0]) + 1)
    back = np.flatnonzero(np.diff(t) <= 0.0)
    if len(back):
        k = int(back[0]) + 1
        raise BadInput(f"{what} not strictly increasing (previous {t[k - 1]:.9g} s)",
                       file, row=k + 1, time=float(t[k]))
    return t


def gap_threshold(t, factor=GAP_FACTOR, max_gap_s=None) -> float:
    """The longest interval [s] that is not a gap: ``max_gap_s``, else ``factor`` x median."""
    if max_gap_s is not None:
        return float(max_gap_s)
    return float(factor * np.median(np.diff(t)))


def find_gaps(t, factor=GAP_FACTOR, max_gap_s=None) -> Gaps:
    """The gaps of a time series (see the module's policy)."""
    t = np.asarray(t, dtype=float)
    thr = gap_threshold(t, factor, max_gap_s)
    k = np.flatnonzero(np.diff(t) > thr) + 1
    return Gaps(k, t[k - 1], t[k], thr)


def _trapezoid(t, rate):
    dt = np.diff(t)[:, None]
    return 0.5 * (rate[1:] + rate[:-1]) * dt


def _cubic_weights(t):
    """Weights (N-1, 4) and stencil starts (N-1,) integrating the cubic through 4 samples
    over each interval ``(t[k-1], t[k]]``, in the real (uneven) times."""
    n = len(t)
    k = np.arange(1, n)
    j0 = np.clip(k - 2, 0, n - 4)
    idx = j0[:, None] + np.arange(4)
    h = t[k] - t[k - 1]
    s = (t[idx] - t[k - 1][:, None]) / h[:, None]          # local abscissae, interval = [0, 1]
    V_T = s[:, None, :] ** np.arange(4)[None, :, None]      # V_T[m, p, i] = s_i^p
    moments = 1.0 / (np.arange(4) + 1.0)                     # int_0^1 s^p ds
    w = np.linalg.solve(V_T, np.broadcast_to(moments, (n - 1, 4))[..., None])[..., 0]
    return w * h[:, None], j0


def rates_to_increments(t, rate, order=2, gaps: Gaps | None = None):
    """Increments of a sampled rate over each actual interval (see the module docstring).

    Parameters
    ----------
    t : (N,) s, strictly increasing (check with :func:`check_times`)
    rate : (N,) or (N, M) rate samples at ``t`` (rad/s, m/s^2, ...)
    order : 2 (trapezoid) or 4 (cubic through four neighbours; needs N >= 4)
    gaps : intervals where ``order=4`` falls back to the trapezoid (default: :func:`find_gaps`)

    Returns
    -------
    t_out : (N-1,) s, ``t[1:]``, the end of each interval
    incr : (N-1,) or (N-1, M), the integral of the rate over ``(t[k-1], t[k]]``
    """
    t = np.asarray(t, dtype=float)
    rate = np.asarray(rate, dtype=float)
    flat = rate.ndim == 1
    r2 = rate[:, None] if flat else rate
    if len(r2) != len(t):
        raise ValueError(f"rate has {len(r2)} rows for {len(t)} times")
    incr = _trapezoid(t, r2)
    if order == 4 and len(t) >= 4:
        w, j0 = _cubic_weights(t)
        idx = j0[:, None] + np.arange(4)
        cubic = np.einsum("mi,mij->mj", w, r2[idx])
        gaps = find_gaps(t) if gaps is None else gaps
        is_gap = np.zeros(len(t) - 1, dtype=int)
        is_gap[np.asarray(gaps.index, dtype=int) - 1] = 1    # interval m spans t[m], t[m+1]
        cum = np.concatenate([[0], np.cumsum(is_gap)])
        near_gap = cum[j0 + 3] - cum[j0] > 0                  # stencil covers intervals j0..j0+2
        incr = np.where(near_gap[:, None], incr, cubic)
    elif order not in (2, 4):
        raise ValueError(f"order must be 2 or 4, got {order}")
    return t[1:], (incr[:, 0] if flat else incr)


def interpolate_at(t_src, v_src, t_out, max_gap_s=None, factor=GAP_FACTOR):
    """A sensor on its own clock, linearly interpolated to other epochs, never extrapolated.

    Parameters
    ----------
    t_src : (N,) s, strictly increasing;  v_src : (N,) or (N, M) samples at ``t_src``
    t_out : (K,) s, the epochs wanted (any order)
    max_gap_s, factor : the gap threshold of :func:`gap_threshold` on ``t_src``

    Returns
    -------
    v_out : (K,) or (K, M), NaN where not valid
    valid : (K,) bool, False before the first sample, after the last, and strictly inside a
        gap (an epoch that falls exactly on a sample is valid).
    """
    t_src = np.asarray(t_src, dtype=float)
    v_src = np.asarray(v_src, dtype=float)
    t_out = np.asarray(t_out, dtype=float)
    flat = v_src.ndim == 1
    v2 = v_src[:, None] if flat else v_src
    j = np.searchsorted(t_src, t_out, side="left")           # t_src[j-1] < t_out <= t_src[j]
    inside = (t_out >= t_src[0]) & (t_out <= t_src[-1])
    jc = np.clip(j, 1, len(t_src) - 1)
    t0, t1 = t_src[jc - 1], t_src[jc]
    on_sample = (t_out == t0) | (t_out == t1)
    thr = gap_threshold(t_src, factor, max_gap_s)
    valid = inside & ((t1 - t0 <= thr) | on_sample)
    a = ((t_out - t0) / (t1 - t0))[:, None]
    v_out = (1.0 - a) * v2[jc - 1] + a * v2[jc]
    v_out[~valid] = np.nan
    return (v_out[:, 0] if flat else v_out), valid
