"""Statistics of a campaign's results table, per point, and paper-versus-measured verdicts.

A reproduction hands the report its paper's figures as rows (see :func:`compare_rows`)::

    {"quantity": "yaw error, 60 m/s, RMS", "unit": "arcmin", "paper": 3.2,
     "measured": 2.9, "measured_se": 0.2, "n_runs": 50}   # a number it computed itself, or
    {"quantity": ..., "unit": ..., "paper": 3.2,
     "column": "errors.final.yaw_arcmin", "stat": "rms",
     "where": {"param.method": "imada-dual", "param.scenario.speed_m_s": 60}}

with optional ``"better": "lower"`` (default: a smaller measured figure is better, as for
errors), ``"higher"``, or ``"closer"`` (nearer to ``"target"``, default 0).

Verdict rules (issue 17): a row is ``better`` or ``worse`` only when the two figures differ by
more than the Monte Carlo uncertainty of both, and they are the same statistic over comparable
sample sizes. The row says how uncertain its figures are, by one of

- ``measured_interval`` ``[lo, hi]``: where the paper's statistic would fall, 95 %, if the
  paper's experiment were run under our model with the paper's sample size (e.g. the spread of
  single-run values when the paper reports one run): the paper inside it is ``same``;
- ``measured_se`` (and ``paper_se`` where the paper's figure has a known spread, e.g. its STD
  over its runs / sqrt(runs)): standard errors; ``same`` when
  ``|measured - paper| <= 2 sqrt(measured_se^2 + paper_se^2)``;
- ``tolerance`` (absolute, the row's unit, > 0): the former rule, kept for rows that state it.

A row with none of them (or a zero tolerance, which claims no uncertainty at all) has verdict
``undecided``: no uncertainty, no verdict. A row with
``comparable: False`` (and a ``why``) is ``not comparable``: a different statistic, sample
sizes too far apart for a size-dependent statistic (``statistic`` in ``SIZE_DEPENDENT`` with
``n_runs`` and ``paper_n`` more than a factor 2 apart), compute times on different machines.
``kind`` is ``paper`` (default: a figure of the paper), ``ablation`` (a variant of our own,
listed apart and not counted) or ``timing``.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..errors import BadInput

__all__ = ["STATISTICS", "statistic", "point_statistics", "compare_rows", "verdict",
           "final_error_columns", "VERDICTS", "SIZE_DEPENDENT", "count_verdicts",
           "standard_error"]


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


#: verdicts a row can have; the first three count as decided
VERDICTS = ("better", "same", "worse", "not comparable", "undecided", "-")
#: statistics whose value depends on the number of runs or windows they are taken over
SIZE_DEPENDENT = ("std", "max", "max_abs", "p95_abs", "min", "range")


def verdict(paper, measured, better="lower", target=0.0, tolerance=None, *, measured_se=None,
            paper_se=None, measured_interval=None, comparable=True) -> str:
    """The verdict of one paper row under the rules of the module notes.

    ``"better"`` / ``"worse"`` (beyond the uncertainty, in the sense of ``better``), ``"same"``
    (within it), ``"not comparable"``, ``"undecided"`` (no uncertainty given) or ``"-"`` (a
    figure missing)."""
    try:
        p, m = float(paper), float(measured)
    except (TypeError, ValueError):
        return "-"
    if not (math.isfinite(p) and math.isfinite(m)):
        return "-"
    if not comparable:
        return "not comparable"
    if better not in ("lower", "higher", "closer"):
        raise BadInput(f"paper row: 'better' must be lower, higher or closer, got {better!r}")
    if measured_interval is not None:
        lo, hi = (float(v) for v in measured_interval)
        if lo > hi:
            raise BadInput(f"paper row: measured_interval must be [lo, hi], got {measured_interval!r}")
        if lo <= p <= hi:
            return "same"
    elif _finite(measured_se) or _finite(paper_se):
        band = 2.0 * math.hypot(float(measured_se) if _finite(measured_se) else 0.0,
                                float(paper_se) if _finite(paper_se) else 0.0)
        if abs(m - p) <= band:
            return "same"
    elif tolerance is not None and float(tolerance) > 0.0:
        if abs(m - p) <= float(tolerance):
            return "same"
    else:
        return "undecided"
    if better == "lower":
        return "better" if m < p else "worse"
    if better == "higher":
        return "better" if m > p else "worse"
    return "better" if abs(m - target) < abs(p - target) else "worse"


def _finite(v) -> bool:
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _comparable(r: dict) -> bool:
    """False where the row says so, or where a size-dependent statistic is taken over sample
    sizes more than a factor 2 apart (the row's ``why`` is filled in)."""
    if r.get("comparable") is False:
        return False
    stat, n, pn = r.get("statistic"), r.get("n_runs"), r.get("paper_n")
    if r.get("paper_statistic") and stat and r["paper_statistic"] != stat:
        r.setdefault("why", f"different statistics: paper {r['paper_statistic']}, ours {stat}")
        return False
    if stat in SIZE_DEPENDENT and n and pn and not 0.5 <= float(n) / float(pn) <= 2.0:
        r.setdefault("why", f"{stat} over {n} against the paper's over {pn}")
        return False
    return True


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
            stat = r.get("stat", "rms")
            r["measured"] = statistic(sel[r["column"]], stat)
            r["n_runs"] = int(sel[r["column"]].notna().sum())
            r.setdefault("statistic", stat)
            if not any(k in r for k in ("measured_se", "measured_interval", "tolerance")):
                r["measured_se"] = standard_error(sel[r["column"]], stat)
        kind = r.setdefault("kind", "paper")
        if kind not in ("paper", "ablation", "timing"):
            raise BadInput(f"paper row {r['quantity']!r}: kind must be paper, ablation or timing, "
                           f"got {kind!r}")
        r["verdict"] = verdict(r.get("paper"), r.get("measured"), r.get("better", "lower"),
                               float(r.get("target", 0.0)), r.get("tolerance"),
                               measured_se=r.get("measured_se"), paper_se=r.get("paper_se"),
                               measured_interval=r.get("measured_interval"),
                               comparable=_comparable(r))
        out.append(r)
    return out


def standard_error(values, name: str, resamples: int = 400, seed: int = 0) -> float:
    """Monte Carlo standard error of ``STATISTICS[name]`` over the finite values: for the mean
    the textbook ``s / sqrt(n)``, for every other statistic the bootstrap (``resamples`` draws
    with replacement, a fixed ``seed`` so a report is reproducible). NaN below 2 values."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return float("nan")
    if name == "mean":
        return float(np.std(x, ddof=1) / np.sqrt(len(x)))
    f = STATISTICS[name]
    rng = np.random.default_rng(seed)
    boots = [f(x[rng.integers(0, len(x), len(x))]) for _ in range(resamples)]
    return float(np.std(boots, ddof=1))


def count_verdicts(rows) -> dict:
    """Counts per verdict of the paper rows (``kind`` paper or timing); ablations are counted
    apart under ``"ablation"``."""
    out = {v: 0 for v in VERDICTS}
    out["ablation"] = 0
    for r in rows:
        if r.get("kind", "paper") == "ablation":
            out["ablation"] += 1
        else:
            out[r.get("verdict", "-")] = out.get(r.get("verdict", "-"), 0) + 1
    return out
