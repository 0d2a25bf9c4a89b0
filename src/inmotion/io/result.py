"""Result folders: what a run writes, and reading it back (``docs/result.md``).

Tables are CSV (default) or Parquet (``fmt="parquet"``, ``--format parquet``): the same
columns, ``solution.parquet`` instead of ``solution.csv`` and so on; readers take either.
``summary.json`` says which (``"format"``). :func:`thin` keeps one row per output period
(``--output-rate``).

::

    solution.csv   t [s], lat, lon [deg], h [m], vE, vN, vU [m/s], pitch, roll, yaw [deg],
                   yaw in [0, 360), and sigma_* columns (1-sigma, same units as the
                   value they belong to: sigma_north, sigma_east, sigma_h [m];
                   sigma_vE, sigma_vN, sigma_vU [m/s]; sigma_phi_E, sigma_phi_N,
                   sigma_phi_U [deg] (misalignment); empty where a method has none)
    states.csv     t [s] and each estimated state by name with its unit in the column name,
                   e.g. mount_x_arcmin, dk_ppm (unit and scale from Solution.state_units;
                   states without one are written in SI as name_si)
    summary.json   method, config, timing, final values (human units), info, the state
                   columns map, and with truth the ``errors`` block
    errors.csv     with truth: the error series of inmotion.core.metrics.error_series

A result folder is written whole or not at all (:func:`inmotion.io.safe_write.staged_folder`):
the files are written into a hidden sibling, which then takes the folder's place in one rename,
so a run killed or failing while writing leaves the earlier result as it was; ``states.csv`` /
``errors.csv`` of an earlier run that this one does not produce are dropped, other files kept.
A solution holding NaN or impossible values (:func:`check_solution`) is refused, never written.
:func:`read_result` refuses a half-written folder, unsorted rows and impossible values.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from .._typing import PathLike
from ..core import rotations
from ..core.bundle import Truth
from ..core.solution import Solution, StateUnit
from ..errors import BadInput
from ..core.metrics import consistency_block, error_columns, errors_block
from .bundle import _plain, arrow_table, write_csv
from .safe_write import atomic_write, refuse_partial, staged_folder

if TYPE_CHECKING:      # writing a result needs no pandas (a run's start-up); reading does
    import pandas as pd

__all__ = ["write_result", "read_result", "write_errors", "SOLUTION_COLUMNS", "SIGMA_UNITS",
           "read_summary", "write_summary", "thin", "find_table", "read_table", "FORMATS",
           "check_solution"]

#: table formats of a result folder (file suffixes)
FORMATS = ("csv", "parquet")
_TABLES = ("solution", "states", "errors")

SOLUTION_COLUMNS = ("t", "lat", "lon", "h", "vE", "vN", "vU", "pitch", "roll", "yaw")

#: sigma names of Solution.sigma and the factor from SI to the file unit
SIGMA_UNITS = {"north": 1.0, "east": 1.0, "h": 1.0, "vE": 1.0, "vN": 1.0, "vU": 1.0,
               "phi_E": 180.0 / np.pi, "phi_N": 180.0 / np.pi, "phi_U": 180.0 / np.pi}


def _solution_columns(sol: Solution) -> dict[str, np.ndarray]:
    """The columns of ``solution.csv``, in order, in file units."""
    e = np.degrees(sol.euler)
    cols = {"t": sol.t, "lat": np.degrees(sol.lat), "lon": np.degrees(sol.lon), "h": sol.h,
            "vE": sol.vel_n[:, 0], "vN": sol.vel_n[:, 1], "vU": sol.vel_n[:, 2],
            "pitch": e[:, 0], "roll": e[:, 1], "yaw": np.mod(e[:, 2], 360.0)}
    for name, x in sol.sigma.items():
        cols[f"sigma_{name}"] = np.asarray(x, dtype=float) * SIGMA_UNITS.get(name, 1.0)
    return cols


def _state_columns(sol: Solution) -> dict:
    """``{state: {"column", "unit", "scale"}}`` for states.csv."""
    out = {}
    for name in sol.states:
        su = sol.state_units.get(name, StateUnit("si", 1.0))
        out[name] = {"column": f"{name}_{su.unit}", "unit": su.unit, "scale": float(su.scale)}
    return out


def _final_values(sol: Solution) -> dict:
    e = np.degrees(sol.euler[-1])
    v = sol.vel_n[-1]
    return {"t_s": float(sol.t[-1]), "lat_deg": float(np.degrees(sol.lat[-1])),
            "lon_deg": float(np.degrees(sol.lon[-1])), "h_m": float(sol.h[-1]),
            "vE_m_s": float(v[0]), "vN_m_s": float(v[1]), "vU_m_s": float(v[2]),
            "pitch_deg": float(e[0]), "roll_deg": float(e[1]),
            "yaw_deg": float(np.mod(e[2], 360.0))}


def thin(solution: Solution, rate_hz: float) -> Solution:
    """``solution`` with one row per output period ``1 / rate_hz`` [s]: the first row at or
    after each multiple of the period from the first epoch, and always the last row (so a
    result still ends where the run ended, for ``--init RESULT``)."""
    if rate_hz is None or rate_hz <= 0 or len(solution) < 3:
        return solution
    t = solution.t
    k = np.floor((t - t[0]) * rate_hz + 1e-6)
    keep = np.r_[True, k[1:] != k[:-1]]
    keep[-1] = True
    if keep.all():
        return solution
    return Solution(t[keep], solution.lat[keep], solution.lon[keep], solution.h[keep],
                    solution.vel_n[keep], solution.euler[keep],
                    sigma={k_: np.asarray(v)[keep] for k_, v in solution.sigma.items()},
                    states={k_: np.asarray(v)[keep] for k_, v in solution.states.items()},
                    state_units=dict(solution.state_units), info=dict(solution.info))


def thin_select(rate_hz: float):
    """:func:`thin`'s choice of rows made chunk by chunk as a method makes its output rows: a
    ``select(t, sigma) -> (mask, stop)`` for a streaming run
    (:meth:`inmotion.estimation.velocity_aided.VelocityAidedRun.run_stream`), so that rows
    :func:`thin` would drop are not kept (memory, and the work on them) by a method without
    an output rate of its own. It keeps the rows :func:`thin` keeps (the first, each first
    row of a period, with the same arithmetic, the period counted from the first row it is
    given) and the last row of every chunk (the run may end there); :func:`thin` applied
    afterwards drops those extra rows: on increasing times the rows it keeps from these are
    exactly those it keeps from all the rows (a row starts a period among the rows kept iff
    it starts one among all of them, since every row that starts one is kept)."""
    state = {"t0": None, "k": None}

    def select(t, sigma=None):
        t = np.asarray(t, dtype=float)
        if len(t) == 0:
            return np.zeros(0, dtype=bool), False
        if state["t0"] is None:
            state["t0"] = t[0]
        k = np.floor((t - state["t0"]) * rate_hz + 1e-6)
        keep = np.r_[state["k"] is None or k[0] != state["k"], k[1:] != k[:-1]]
        keep[-1] = True
        state["k"] = k[-1]
        return keep, False
    return select


def find_table(folder: PathLike, stem: str) -> Path | None:
    """``folder/stem.csv`` or ``folder/stem.parquet``, whichever exists (None: neither)."""
    for fmt in FORMATS:
        p = Path(folder) / f"{stem}.{fmt}"
        if p.is_file():
            return p
    return None


def read_table(path: PathLike) -> "pd.DataFrame":
    """A result table (CSV or Parquet by its suffix); :class:`BadInput` if unreadable/empty."""
    import pandas as pd
    p = Path(path)
    if p.suffix == ".parquet":
        try:
            df = pd.read_parquet(p)
        except Exception as e:     # pyarrow raises several types for a damaged file
            raise BadInput(f"cannot read Parquet: {str(e).strip().splitlines()[0]}",
                           file=p) from None
        if len(df) == 0:
            raise BadInput("no data rows", file=p)
        return df
    return _read_csv(p)


def _write_table(df: "pd.DataFrame | dict[str, np.ndarray]", folder: Path, stem: str,
                 fmt: str) -> None:
    """Write one table (a DataFrame or ordered columns) as ``stem.csv`` or ``stem.parquet``
    with pyarrow (NaN as null / an empty CSV field either way)."""
    if fmt not in FORMATS:
        raise BadInput(f"unknown result format {fmt!r}; choose from {', '.join(FORMATS)}")
    if fmt == "parquet":
        import pyarrow.parquet as pq
        atomic_write(folder / f"{stem}.parquet",
                     lambda p: pq.write_table(arrow_table(df), p))
    else:
        _write_csv(df, folder / f"{stem}.csv")
    for other in FORMATS:          # one format per table: remove an earlier run's other one
        if other != fmt:
            (folder / f"{stem}.{other}").unlink(missing_ok=True)


def _unlink_table(folder: Path, stem: str) -> None:
    for fmt in FORMATS:
        (folder / f"{stem}.{fmt}").unlink(missing_ok=True)


def write_result(solution: Solution, path: PathLike, truth: Truth | None = None,
                 summary_extra: dict | None = None, fmt: str = "csv") -> dict:
    """Write a result folder; return the summary written to ``summary.json``.

    Parameters
    ----------
    solution : Solution
        SI inside; written in degrees / m / m/s.
    path : str or Path
        The folder (created if missing).
    truth : Truth, optional
        If given, ``errors.csv`` and the ``errors`` block are written too.
    summary_extra : dict, optional
        Merged into the summary (e.g. ``{"bundle": ..., "timing": {...}, "init": ...}``).
    fmt : {"csv", "parquet"}
        Format of the tables (``summary.json`` is JSON either way).
    """
    if len(solution) == 0:
        raise BadInput("the solution has no epochs; nothing to write")
    if fmt not in FORMATS:
        raise BadInput(f"unknown result format {fmt!r}; choose from {', '.join(FORMATS)}")
    check_solution(solution)
    with staged_folder(path, what="result") as folder:
        summary = _write_result_files(solution, folder, truth, summary_extra, fmt)
    return summary


_DIVERGED = (" (the method diverged, or its input or configuration is wrong); nothing "
             "written")


def _write_result_files(solution, folder: Path, truth, summary_extra, fmt) -> dict:
    tables = [("solution", _solution_columns(solution))]
    states = _state_columns(solution)
    if states:
        tables.append(("states", {"t": solution.t,
                                  **{s["column"]: np.asarray(solution.states[n]) * s["scale"]
                                     for n, s in states.items()}}))
    else:
        _unlink_table(folder, "states")
    if truth is None:
        _unlink_table(folder, "errors")
        for stem, cols in tables:
            _write_table(cols, folder, stem, fmt)
        writer = None
    else:
        # the solution and states tables written in a thread (pyarrow's writer releases the
        # GIL) while this one computes the errors against truth and writes their table
        writer = _Writer([(cols, folder, stem, fmt) for stem, cols in tables])
    try:
        summary = _summary(solution, states, summary_extra, fmt)
        if truth is not None:
            summary["errors"] = write_errors(solution, truth, folder, fmt=fmt)
    finally:
        if writer is not None:
            writer.join()              # its exception (if any) raised here, as it was raised
    write_summary(summary, folder)
    return summary


class _Writer:
    """:func:`_write_table` of each of ``jobs`` in a thread; :meth:`join` waits for it and
    raises its exception, if any."""

    def __init__(self, jobs):
        import threading

        from . import bundle_stream
        bundle_stream.one_malloc_arena()    # before the first thread (bundle_stream notes)
        self._error = None
        self._thread = threading.Thread(target=self._run, args=(jobs,), daemon=True,
                                        name="inmotion-writer")
        self._thread.start()

    def _run(self, jobs):
        try:
            for job in jobs:
                _write_table(*job)
        except BaseException as e:       # noqa: BLE001 (raised by join)
            self._error = e

    def join(self):
        self._thread.join()
        if self._error is not None:
            e, self._error = self._error, None
            raise e


def _summary(solution, states, summary_extra, fmt) -> dict:
    info = dict(solution.info)
    summary = {"method": info.pop("method", None), "config": info.pop("config", None),
               "timing": info.pop("timing", {}), "epochs": len(solution),
               "final": _final_values(solution), "states": states, "info": info,
               "format": fmt}
    if info.get("nis") is not None:      # NIS per measurement kind (chi2.nis_summary)
        summary["nis"] = info.pop("nis")
    summary.update(summary_extra or {})
    return summary


def check_solution(sol: Solution, file=None, hint: str = _DIVERGED) -> None:
    """Refuse a solution that no vehicle can have: NaN or infinite values, latitude or pitch
    beyond +-90 deg, time not increasing, a speed above 1000 m/s, a height beyond 1000 km (a
    diverged method, or input in the wrong units). Raises :class:`BadInput` naming the first bad epoch."""
    t = np.asarray(sol.t, dtype=float)
    cols = {"t": t, "lat": sol.lat, "lon": sol.lon, "h": sol.h, "vE": sol.vel_n[:, 0],
            "vN": sol.vel_n[:, 1], "vU": sol.vel_n[:, 2], "pitch": sol.euler[:, 0],
            "roll": sol.euler[:, 1], "yaw": sol.euler[:, 2]}
    src = file if file is not None else "solution"
    for name, x in cols.items():
        bad = ~np.isfinite(np.asarray(x, dtype=float))
        if bad.any():
            i = int(np.argmax(bad))
            tt = float(t[i]) if np.isfinite(t[i]) else None
            raise BadInput(f"{name} is not a finite number{hint}", file=src, row=i + 1,
                           time=tt)
    checks = [(np.abs(sol.lat) > np.pi / 2 + 1e-9, "latitude beyond +-90 deg"),
              (np.abs(sol.euler[:, 0]) > np.pi / 2 + 1e-9, "pitch beyond +-90 deg"),
              (np.linalg.norm(sol.vel_n, axis=1) > 1000.0, "speed above 1000 m/s"),
              (np.abs(sol.h) > 1e6, "height beyond +-1000 km")]
    if len(t) > 1:
        checks.append((np.concatenate([[False], np.diff(t) <= 0]), "time not increasing"))
    for bad, what in checks:
        if bad.any():
            i = int(np.argmax(bad))
            raise BadInput(f"{what}{hint}", file=src, row=i + 1, time=float(t[i]))


def write_errors(solution: Solution, truth: Truth, folder: PathLike,
                 fmt: str | None = None) -> dict:
    """Write ``errors.csv`` (or ``.parquet``) into ``folder`` and return the ``errors`` block.

    ``fmt`` None: the format of the folder's solution table (CSV if there is none).
    """
    folder = Path(folder)
    if fmt is None:
        sol = find_table(folder, "solution")
        fmt = sol.suffix[1:] if sol is not None else "csv"
    err = error_columns(solution, truth)
    _write_table(err, folder, "errors", fmt)
    block = errors_block(err)
    cons = consistency_block(solution, err)
    if cons:
        block["consistency"] = cons
    return block


def write_summary(summary: dict, folder: PathLike) -> None:
    """``summary.json`` (NaN and inf written as null), atomically."""
    text = json.dumps(_json_safe(summary), indent=2, allow_nan=False)
    atomic_write(Path(folder) / "summary.json", lambda p: Path(p).write_text(text + "\n"))


def _json_safe(x):
    x = _plain(x)
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, (str, int, float, bool)) or x is None:
        return x
    return str(x)


def _write_csv(df: "pd.DataFrame | dict[str, np.ndarray]", target: Path) -> None:
    atomic_write(target, lambda p: write_csv(df, p))


def _read_csv(p: Path) -> "pd.DataFrame":
    import pandas as pd
    try:
        df = pd.read_csv(p)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as e:
        raise BadInput(f"cannot read CSV: {str(e).strip().splitlines()[0]}", file=p) from None
    if len(df) == 0:
        raise BadInput("no data rows", file=p)
    return df


def read_summary(path: PathLike) -> dict:
    """The parsed ``summary.json`` of a result folder."""
    p = Path(path) / "summary.json"
    if not p.is_file():
        raise BadInput("missing summary.json (not a result folder, or the run did not finish)",
                       file=p)
    try:
        summary = json.loads(p.read_text())
    except json.JSONDecodeError as e:
        raise BadInput(f"malformed JSON at line {e.lineno}: {e.msg}", file=p) from None
    except (UnicodeDecodeError, RecursionError) as e:
        raise BadInput(f"not a JSON summary ({type(e).__name__})", file=p) from None
    if not isinstance(summary, dict):
        raise BadInput(f"must be a JSON object, got {type(summary).__name__}", file=p)
    for key, types in (("states", dict), ("info", dict)):
        if summary.get(key) is not None and not isinstance(summary[key], types):
            raise BadInput(f"{key!r} must be a JSON object, got {type(summary[key]).__name__}",
                           file=p)
    return summary


def read_result(path: PathLike) -> Solution:
    """Read a result folder back into a :class:`Solution` (SI inside).

    ``info`` gets the summary's ``info`` plus ``method``, ``config``, ``timing`` and, if
    present, ``errors``; ``state_units`` come from the summary's ``states`` map.

    Parameters
    ----------
    path : str or Path
        The result folder (``solution.csv``, ``summary.json``, optional ``states.csv``).

    Returns
    -------
    Solution
        ``t`` [s], ``lat``, ``lon`` [rad], ``h`` [m], ``vel_n`` [m/s] ENU, ``euler`` [rad],
        ``sigma`` and ``states`` in SI.

    Raises
    ------
    BadInput
        A missing folder or file, a malformed table (file, row, what is wrong).
    """
    folder = Path(path)
    if not folder.is_dir():
        raise BadInput("result folder does not exist", file=folder)
    refuse_partial(folder, "result")
    summary = read_summary(folder)
    p = find_table(folder, "solution")
    if p is None:
        raise BadInput("missing solution.csv (or solution.parquet)", file=folder / "solution.csv")
    import pandas as pd
    df = read_table(p)
    missing = [c for c in SOLUTION_COLUMNS if c not in df.columns]
    if missing:
        raise BadInput(f"missing columns {', '.join(missing)}", file=p)
    vals = df[list(SOLUTION_COLUMNS)].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    bad = ~np.isfinite(vals).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        col = SOLUTION_COLUMNS[int(np.argmax(~np.isfinite(vals[i])))]
        raise BadInput(f"column {col!r}: value {df[col].iloc[i]!r} is not a finite number",
                       file=p, row=i + 1, time=vals[i, 0] if np.isfinite(vals[i, 0]) else None)
    sigma = {c[len("sigma_"):]: pd.to_numeric(df[c], errors="coerce").to_numpy(float)
             / SIGMA_UNITS.get(c[6:], 1.0) for c in df.columns if c.startswith("sigma_")}
    states, units = _read_states(folder, summary.get("states") or {}, len(df))
    info = dict(summary.get("info") or {})
    for k in ("method", "config", "timing", "errors"):
        if k in summary:
            info[k] = summary[k]
    euler = np.radians(vals[:, 7:10])
    euler[:, 2] = rotations.wrap_2pi(euler[:, 2])
    sol = Solution(vals[:, 0], np.radians(vals[:, 1]), np.radians(vals[:, 2]), vals[:, 3],
                   vals[:, 4:7], euler, sigma=sigma, states=states, state_units=units,
                   info=info)
    check_solution(sol, file=p, hint="")
    return sol


def _read_states(folder: Path, smap: dict, n: int):
    if not smap:
        return {}, {}
    p = find_table(folder, "states")
    if p is None:
        raise BadInput("missing states.csv that summary.json lists", file=folder / "states.csv")
    import pandas as pd
    df = read_table(p)
    if len(df) != n:
        raise BadInput(f"{len(df)} rows but solution.csv has {n}", file=p)
    states, units = {}, {}
    for name, s in smap.items():
        if not (isinstance(s, dict) and isinstance(s.get("column"), str)
                and isinstance(s.get("unit"), str) and isinstance(s.get("scale"), (int, float))
                and s["scale"] != 0):
            raise BadInput(f"summary.json: states.{name} must be {{column, unit, scale}}, got "
                           f"{s!r}"[:160], file=p)
        if s["column"] not in df.columns:
            raise BadInput(f"missing column {s['column']}", file=p)
        states[name] = pd.to_numeric(df[s["column"]], errors="coerce").to_numpy(float) / s["scale"]
        units[name] = StateUnit(s["unit"], s["scale"])
    return states, units
