"""Errors of a solution against truth, and the ``errors`` block of ``summary.json``.

Errors are estimate minus truth (``docs/result.md``):

- attitude: Euler differences ``[pitch, roll, yaw]`` wrapped to [-180, 180) deg (so yaw 359 deg
  against truth 1 deg is -2 deg), and the misalignment ``phi`` = ``[phi_E, phi_N, phi_U]`` of
  the DESIGN convention ``C_b^n(computed) = (I - [phi x]) C_b^n(true)``, computed exactly by
  :func:`inmotion.core.rotations.misalignment`;
- velocity: ENU differences [m/s];
- position: north and east offsets [m] on the local radii of curvature at the truth point
  (:func:`inmotion.core.earth.local_ne_offsets`), horizontal = their norm (>= 0), vertical =
  height difference (signed);
- distance travelled: the truth's 3-D path length [m] from the first compared epoch.

Truth is interpolated linearly to the solution's times (positions, velocities and unwrapped
Euler angles). Truth is normally at the IMU rate (100 Hz) and solutions at IMU epochs, so the
interpolation is exact there; between truth samples 10 ms apart its error is far below what
any method here resolves. Solution epochs outside the truth's time span are dropped.

Summary statistics over the "last 100 s" use the epochs with ``t >= t_end - 100 s`` (all of
them for shorter runs).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from typing import TYPE_CHECKING, Mapping

from . import rotations
from .bundle import Truth
from .earth import radii
from .solution import Solution
from ..errors import BadInput

if TYPE_CHECKING:                 # pandas only where a caller asks for a DataFrame
    import pandas as pd

__all__ = ["ERROR_KEYS", "error_series", "error_columns", "errors_block", "interpolate_truth"]

ARCMIN_PER_RAD = 180.0 * 60.0 / np.pi

#: the keys of each statistic in the ``errors`` block, in DESIGN order
ERROR_KEYS = ("pitch_arcmin", "roll_arcmin", "yaw_arcmin",
              "phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin",
              "vE_m_s", "vN_m_s", "vU_m_s", "horizontal_m", "vertical_m")

LAST_WINDOW_S = 100.0


def interpolate_truth(truth: Truth, t: ArrayLike) -> Truth:
    """Truth linearly interpolated to times ``t`` [s] (inside the truth's span).

    Euler angles are unwrapped before interpolation and yaw re-wrapped to [0, 2 pi), so
    interpolation across north (359 -> 1 deg) stays near north.
    """
    t = np.asarray(t, dtype=float)

    def lin(y):
        return np.interp(t, truth.t, y)

    eul = np.unwrap(truth.euler, axis=0)
    euler = np.column_stack([lin(eul[:, i]) for i in range(3)])
    euler[:, 2] = rotations.wrap_2pi(euler[:, 2])
    vel = np.column_stack([lin(truth.vel_n[:, i]) for i in range(3)])
    return Truth(t, lin(truth.lat), lin(np.unwrap(truth.lon)), lin(truth.h), vel, euler)


def error_series(solution: Solution, truth: Truth) -> "pd.DataFrame":
    """:func:`error_columns` as a ``pandas.DataFrame`` (its columns, in its order)."""
    import pandas as pd
    return pd.DataFrame(error_columns(solution, truth))


def error_columns(solution: Solution, truth: Truth) -> dict[str, np.ndarray]:
    """Error time series of ``solution`` against ``truth``, estimate minus truth, as ordered
    columns (what ``errors.csv`` holds; no pandas, so a command-line run does not import it).

    Parameters
    ----------
    solution : Solution
    truth : Truth

    Returns
    -------
    dict of str to (N,) float arrays
        Columns ``t`` [s], ``pitch_arcmin, roll_arcmin, yaw_arcmin`` (Euler differences wrapped
        to +-180 deg), ``phi_E_arcmin, phi_N_arcmin, phi_U_arcmin`` (misalignment),
        ``vE_m_s, vN_m_s, vU_m_s``, ``north_m, east_m, horizontal_m, vertical_m`` and
        ``distance_m`` (truth distance travelled since the first row); one row per solution
        epoch inside the truth's time span.
    """
    inside = (solution.t >= truth.t[0]) & (solution.t <= truth.t[-1])
    if not inside.any():
        raise BadInput(f"solution ({solution.t[0]:.6g} .. {solution.t[-1]:.6g} s) and truth "
                       f"({truth.t[0]:.6g} .. {truth.t[-1]:.6g} s) do not overlap in time")
    t = solution.t[inside]
    tr = interpolate_truth(truth, t)
    d_euler = rotations.wrap_pi(solution.euler[inside] - tr.euler) * ARCMIN_PER_RAD
    phi = rotations.misalignment(rotations.dcm_from_euler(solution.euler[inside]),
                                 rotations.dcm_from_euler(tr.euler)) * ARCMIN_PER_RAD
    d_vel = solution.vel_n[inside] - tr.vel_n
    d_north, d_east = _ne_offsets(solution.lat[inside], solution.lon[inside], tr)
    cols = {"t": t}
    cols.update(zip(ERROR_KEYS[0:3], d_euler.T))
    cols.update(zip(ERROR_KEYS[3:6], phi.T))
    cols.update(zip(ERROR_KEYS[6:9], d_vel.T))
    cols["north_m"], cols["east_m"] = d_north, d_east
    cols["horizontal_m"] = np.hypot(d_north, d_east)
    cols["vertical_m"] = solution.h[inside] - tr.h
    cols["distance_m"] = _path_length(truth, t)
    return cols


def _ne_offsets(lat, lon, tr: Truth):
    """North and east offsets [m] of (lat, lon) [rad] from the truth points, local radii."""
    r_m, r_n = radii(tr.lat)
    d_lon = rotations.wrap_pi(lon - tr.lon)
    return (lat - tr.lat) * (r_m + tr.h), d_lon * (r_n + tr.h) * np.cos(tr.lat)


def _path_length(truth: Truth, t) -> np.ndarray:
    """Truth's cumulative 3-D path length [m] at times ``t`` (from ``t[0]``); a truth whose
    rows are a subset of the full-rate table carries the length along the full table
    (``Truth.path_length_m``)."""
    if truth.path_length_m is not None:
        s = np.interp(t, truth.t, truth.path_length_m)
        return s - s[0]
    r_m, r_n = radii(truth.lat[:-1])
    step = np.sqrt((np.diff(truth.lat) * (r_m + truth.h[:-1])) ** 2
                   + (rotations.wrap_pi(np.diff(truth.lon)) * (r_n + truth.h[:-1])
                      * np.cos(truth.lat[:-1])) ** 2
                   + np.diff(truth.h) ** 2)
    cum = np.concatenate([[0.0], np.cumsum(step)])
    s = np.interp(t, truth.t, cum)
    return s - s[0]


def _column(table, name: str) -> np.ndarray:
    """Column ``name`` of a DataFrame or of a mapping of arrays, as a numpy array."""
    return np.asarray(table[name])


def errors_block(errors: "pd.DataFrame | Mapping[str, np.ndarray]",
                 window_s: float = LAST_WINDOW_S) -> dict:
    """The ``errors`` block of ``summary.json`` from an :func:`error_series` table (or the
    columns of :func:`error_columns`).

    Returns
    -------
    dict
        ``final``, ``rms_last_100s``, ``max_abs_last_100s`` (each a dict over exactly
        :data:`ERROR_KEYS`), ``distance_m`` (truth distance over the run) and ``duration_s``.
        ``horizontal_m`` is a magnitude (>= 0); every other key is signed in ``final``.
    """
    t = _column(errors, "t")
    last = t >= t[-1] - window_s
    block = {"final": {}, "rms_last_100s": {}, "max_abs_last_100s": {}}
    for k in ERROR_KEYS:
        x = _column(errors, k)
        block["final"][k] = float(x[-1])
        block["rms_last_100s"][k] = float(np.sqrt(np.mean(x[last] ** 2)))
        block["max_abs_last_100s"][k] = float(np.max(np.abs(x[last])))
    block["distance_m"] = float(_column(errors, "distance_m")[-1])
    block["duration_s"] = float(t[-1] - t[0])
    return block


#: consistency groups: name -> (error-series columns, their scale to SI, solution sigma keys)
NEES_GROUPS = {
    "attitude": (("phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin"), 1.0 / ARCMIN_PER_RAD,
                 ("phi_E", "phi_N", "phi_U")),
    "velocity": (("vE_m_s", "vN_m_s", "vU_m_s"), 1.0, ("vE", "vN", "vU")),
    "position": (("north_m", "east_m", "vertical_m"), 1.0, ("north", "east", "h")),
}


def consistency_block(solution: Solution,
                      errors: "pd.DataFrame | Mapping[str, np.ndarray]") -> dict:
    """The ``consistency`` block of ``summary.json``: does the filter's sigma cover its error?

    For each group of :data:`NEES_GROUPS` whose sigmas the solution reports, the normalized
    estimation error squared per row, ``NEES = sum_i (e_i / sigma_i)^2`` over the group's
    three axes (the solution's per-axis sigmas; cross-covariances are not in the result
    files, so this is the diagonal NEES), skipping the first row (the prior) and rows with
    a zero sigma. Reported: ``mean`` (3 for a consistent filter), ``band_95`` (the 95 %
    band of a mean of ``rows`` independent chi-square(3) values, a loose check since errors
    are correlated in time), ``in_band`` and ``fraction_rows_above_99`` (rows above the
    chi-square(3) 99 % point, 11.34: 1 % expected). Groups without sigmas are left out.
    """
    from ..estimation.chi2 import isf      # chi-square upper quantiles (scipy's chdtri)

    te = _column(errors, "t")
    inside = (solution.t >= te[0]) & (solution.t <= te[-1])
    block = {}
    for name, (cols, scale, keys) in NEES_GROUPS.items():
        if not all(k in solution.sigma for k in keys):
            continue
        e = np.column_stack([_column(errors, c) * scale for c in cols])
        s = np.column_stack([np.asarray(solution.sigma[k])[inside] for k in keys])
        ok = np.all(s > 0, axis=1) & np.all(np.isfinite(s), axis=1) & np.all(np.isfinite(e),
                                                                             axis=1)
        ok[0] = False
        if not ok.any():
            continue
        nees = np.sum((e[ok] / s[ok]) ** 2, axis=1)
        n = len(nees)
        lo, hi = isf(0.975, 3 * n) / n, isf(0.025, 3 * n) / n
        m = float(nees.mean())
        block[name] = {"mean": m, "dof": 3, "rows": n, "band_95": [float(lo), float(hi)],
                       "in_band": bool(lo <= m <= hi),
                       "fraction_rows_above_99": float(np.mean(nees > isf(0.01, 3)))}
    return block
