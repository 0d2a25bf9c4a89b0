"""Statistics of a campaign's results table, per point, and paper-versus-measured verdicts.

A reproduction hands the report its paper's figures as rows (see :func:`compare_rows`)::

    {"quantity": "yaw error, 60 m/s, RMS", "unit": "arcmin", "paper": 3.2,
     "measured": 2.9}                                   # a number it computed itself, or
    {"quantity": ..., "unit": ..., "paper": 3.2,
     "column": "errors.final.yaw_arcmin", "stat": "rms",
     "where": {"param.method": "imada-dual", "param.scenario.speed_m_s": 60}}

with optional ``"better": "lower"`` (default: a smaller measured figure is better, as for
errors), ``"higher"``, or ``"closer"`` (nearer to ``"target"``, default 0), and ``"tolerance"``
(absolute, in the row's unit) within which the two figures count as the ``same``.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..errors import BadInput

__all__ = ["STATISTICS", "statistic", "point_statistics", "compare_rows", "verdict",
           "final_error_columns"]


def _p95_abs(x):
    return float(np.percentile(np.abs(x), 95))


#: name -> function of a 1-D float array without NaN (the ok runs)
STATISTICS = {
    "mean": lambda x: float(np.mean(x)),
    "std": lambda x: float(np.std(x, ddof=1)) if len(x) > 1 else float("nan"),
    "rms": lambda x: float(np.sqrt(np.mean(np.square(x)))),
    "mean_abs": lambda x: float(np.mean(np.abs(x))),
    "median": lambda x: float(np.median(x)),
    "p95_abs": _p95_abs,
    "max_abs": lambda x: float(np.max(np.abs(x))),
    "min": lambda x: float(np.min(x)),
    "max": lambda x: float(np.max(x)),
}


def statistic(values, name: str) -> float:
    """``STATISTICS[name]`` of the finite values (NaN if none)."""
    if name not in STATISTICS:
        raise BadInput(f"unknown statistic {name!r}; choose from {', '.join(STATISTICS)}")
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return STATISTICS[name](x) if len(x) else float("nan")


def final_error_columns(df: pd.DataFrame) -> list:
    """The ``errors.final.*`` columns of a default-run table, else every numeric result column."""
    cols = [c for c in df.columns if c.startswith("errors.final.")]
    if cols:
        return cols
    skip = {"point_id", "run_index", "seed", "elapsed_s"}
    return [c for c in df.columns if c not in skip and not c.startswith("param.")
            and pd.api.types.is_numeric_dtype(df[c])]


def point_statistics(df: pd.DataFrame, columns, stats=("mean", "std", "rms", "p95_abs")):
    """One row per point: ``label``, ``runs``, ``failed`` and ``<column>:<stat>`` over its ok runs."""
    rows = []
    for pid, g in df.groupby("point_id", sort=True):
        ok = g[g["status"] == "ok"]
        row = {"point_id": pid, "label": g["label"].iloc[0] if "label" in g else str(pid),
               "runs": len(g), "failed": int((g["status"] != "ok").sum())}
        for c in columns:
            for s in stats:
                row[f"{c}:{s}"] = statistic(ok[c], s) if c in ok else float("nan")
        rows.append(row)
    return pd.DataFrame(rows)


def _select(df: pd.DataFrame, where: dict) -> pd.DataFrame:
    sel = df[df["status"] == "ok"] if "status" in df else df
    for col, value in (where or {}).items():
        if col not in sel:
            raise BadInput(f"paper row selects on {col!r}, which the results do not have")
        sel = sel[sel[col] == value]
    return sel


def verdict(paper, measured, better="lower", target=0.0, tolerance=0.0) -> str:
    """``"better"``, ``"worse"``, ``"same"`` (within ``tolerance``) or ``"-"`` (a figure missing)."""
    try:
        p, m = float(paper), float(measured)
    except (TypeError, ValueError):
        return "-"
    if not (math.isfinite(p) and math.isfinite(m)):
        return "-"
    if abs(m - p) <= tolerance:
        return "same"
    if better == "lower":
        return "better" if m < p else "worse"
    if better == "higher":
        return "better" if m > p else "worse"
    if better == "closer":
        return "better" if abs(m - target) < abs(p - target) else "worse"
    raise BadInput(f"paper row: 'better' must be lower, higher or closer, got {better!r}")


def compare_rows(rows, df: pd.DataFrame | None = None) -> list:
    """The paper rows with ``measured`` filled in (from ``df`` where they name a column) and a
    ``verdict``; see the module notes for the row format."""
    out = []
    for i, row in enumerate(rows or []):
        if not isinstance(row, dict) or "quantity" not in row:
            raise BadInput(f"paper row {i + 1}: expected a mapping with a 'quantity', got {row!r}")
        r = dict(row)
        if r.get("measured") is None and "column" in r:
            if df is None:
                raise BadInput(f"paper row {r['quantity']!r} names a column but there is no table")
            sel = _select(df, r.get("where"))
            if r["column"] not in sel:
                raise BadInput(f"paper row {r['quantity']!r}: no column {r['column']!r} in the results")
            r["measured"] = statistic(sel[r["column"]], r.get("stat", "rms"))
            r["n_runs"] = int(sel[r["column"]].notna().sum())
        r["verdict"] = verdict(r.get("paper"), r.get("measured"), r.get("better", "lower"),
                               float(r.get("target", 0.0)), float(r.get("tolerance", 0.0)))
        out.append(r)
    return out
