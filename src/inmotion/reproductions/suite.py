"""One registry of the paper reproductions, their summary rows, and ``reproduce all``.

Each paper has its own module (:mod:`inmotion.reproductions.paper000` ... ``_004`` and
:mod:`inmotion.reproductions.real`) that runs its Monte Carlo and writes markdown tables
(paper beside measured), PNG figures and a results JSON into a folder. This module

* names them (``000``, ``001``, ``002``, ``003``, ``004``, ``real``) and calls each with the
  arguments its function actually takes (:func:`run_reproduction`); the numerics are theirs;
* reads each one's results JSON back into **summary rows** (:func:`summary_rows`), one per
  paper figure: ``quantity``, ``unit``, ``paper``, ``measured``, ``better`` (which direction is
  better: ``lower``, ``higher`` or ``closer`` to ``target``), ``verdict`` (better / worse /
  same / -, from :func:`inmotion.evaluate.stats.verdict`) and a ``note`` saying how the figure
  is taken. The rows are written to ``paper_rows.json`` beside the results;
* runs them all, each into its own sub-folder, and writes one self-contained HTML page
  (:func:`reproduce_all`; the page is built by :mod:`inmotion.reproductions.page` with the
  report's page machinery). A reproduction that raises is recorded with its error and the
  others still run; ``reuse=True`` skips a paper whose results file already exists and only
  re-reads it.

Which measured figure stands beside which paper figure is a choice, written in each row's note:
a paper reports one vehicle run, the reproductions report statistics over Monte Carlo runs
(median of each run's maximum where the paper gives an envelope, mean and STD where it gives
mean and STD). ``better`` for a mean error is ``closer`` to 0 (a smaller bias), for a spread,
an envelope, an RMS or a count of degradations ``lower``.
"""
from __future__ import annotations

import contextlib
import importlib
import inspect
import json
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

from ..errors import BadInput
from .common import engine

__all__ = ["Reproduction", "REPRODUCTIONS", "names", "get", "run_reproduction",
           "summary_rows", "reproduce_all", "ROWS_FILE", "ALL_SUMMARY_FILE"]

#: the rows of one reproduction, beside its results
ROWS_FILE = "paper_rows.json"
#: what ``reproduce all`` writes at the top of its folder
ALL_SUMMARY_FILE = "reproduce_summary.json"


@dataclass(frozen=True)
class Reproduction:
    """A paper reproduction: where its function is and what it writes.

    Attributes
    ----------
    name : the CLI name (``"000"`` ... ``"004"``, ``"real"``)
    title : the paper, short
    module, function : the per-paper entry point (imported lazily)
    results_file : the JSON it writes, read back by ``rows``
    rows : ``rows(results: dict) -> list[dict]``, the summary rows before their verdicts
    issue_runs : Monte Carlo runs the issue asks for (None: the function takes no runs)
    """

    name: str
    title: str
    module: str
    function: str
    results_file: str
    rows: Callable[[dict], list]
    issue_runs: Optional[int]

    def load(self) -> Callable:
        """The per-paper function (imports its module now)."""
        return getattr(importlib.import_module(self.module), self.function)

    def constants(self):
        """The per-paper module (its paper tables are read from it)."""
        return importlib.import_module(self.module)


def _mc_tolerance(std, n) -> float:
    """Two Monte Carlo standard errors of a mean of ``n`` draws with spread ``std``: a mean
    within this of the paper's is ``same`` (the runs cannot tell them apart)."""
    try:
        return 2.0 * float(std) / float(n) ** 0.5 if n and n > 1 else 0.0
    except (TypeError, ValueError):
        return 0.0


def _row(quantity, unit, paper, measured, better="lower", note="", **extra) -> dict:
    out = {"quantity": quantity, "unit": unit, "paper": paper, "measured": measured,
           "better": better, "note": note}
    out.update(extra)
    return out


# ----------------------------------------------------------------------------- adapters
def _rows_000(res: dict) -> list:
    """Paper 000 sec. 5: misalignment accuracy ("better than", E / N / U) and steady-state STD.

    Measured: median over runs of each run's max |error| over the last 100 s, and median of the
    STD over the last 100 s (``summary.json`` of :mod:`paper000`)."""
    from . import paper000 as m
    rows = []
    for (exp, setting), (acc, std) in m.PAPER.items():
        s = res["summary"].get(f"{exp}/{setting}")
        if s is None:
            continue
        for i, axis in enumerate("ENU"):
            note = "median over runs of max |error| in the last 100 s; paper: 'better than', one run"
            if axis == "U" and "gyrocompass_limit_median_abs_arcmin" in s:
                note += (f"; the heading settles at the gyrocompassing limit -eps_E / (Omega cos L) "
                         f"of each run's drawn drift, median |limit| "
                         f"{s['gyrocompass_limit_median_abs_arcmin']:.2f} arcmin")
            rows.append(_row(f"000 {exp} {setting}: phi_{axis} accuracy", "arcmin", acc[i],
                             s["max_abs_last100_median_arcmin"][i], note=note))
            if std[i] is not None:
                rows.append(_row(f"000 {exp} {setting}: phi_{axis} STD", "arcmin", std[i],
                                 s["std_last100_median_arcmin"][i],
                                 note="median over runs of the STD over the last 100 s"))
    return rows


def _rows_001(res: dict) -> list:
    """Paper 001 Tables 1-3: heading error mean and STD in the last window, compute time.

    Measured (``results.json`` of :mod:`paper001`): mean over runs of each run's window
    mean (``better: closer`` to 0) and of its time-STD; each scheme's compute time over
    oba's, one run on this machine (the paper's seconds are MATLAB on its own machine: only
    ratios compare)."""
    from . import paper001 as m
    rows = []
    for test, paper in ((1, m.PAPER_TABLE1), (2, m.PAPER_TABLE2)):
        tab = res["tables"].get(str(test)) or res["tables"].get(test) or {}
        w = len(m.WINDOWS[test]) - 1
        a, b = m.WINDOWS[test][w]
        for key, t in tab.items():
            name, variant = key.split("/")
            label = name if variant == "-" else f"{name} ({variant} states)"
            p_mean, p_std = paper[name][w]
            rows.append(_row(f"001 test {test} {label}: heading mean {a}-{b} s", "deg", p_mean,
                             t["mean"][w], better="closer",
                             tolerance=_mc_tolerance(t["sd_of_means"][w], res.get("runs")),
                             note="mean over runs of the window mean (same: within 2 Monte "
                                  "Carlo standard errors); paper: one car run"))
            rows.append(_row(f"001 test {test} {label}: heading STD {a}-{b} s", "deg", p_std,
                             t["std"][w], note="mean over runs of the window's time-STD"))
    for test in (1, 2):
        # Table 3 as cost ratios to OBA: absolute seconds on another machine and language
        # (MATLAB) do not compare; the ratio of a scheme's cost to the integral method's does
        times = res.get("time_s", {}).get(str(test)) or res.get("time_s", {}).get(test) or {}
        oba = times.get("oba/-")
        for key, sec in times.items():
            name, variant = key.split("/")
            if variant not in ("-", "paper") or name == "oba" or not oba:
                continue
            rows.append(_row(f"001 test {test} {name}: compute time / oba's", "1",
                             m.PAPER_TABLE3[name][test - 1] / m.PAPER_TABLE3["oba"][test - 1],
                             sec / oba,
                             note="one 300 s run each on one core here (the paper's: MATLAB, "
                                  "its machine); lower: the scheme costs less against oba"))
    return rows


def _rows_002(res: dict) -> list:
    """Paper 002: horizontal position, heading and level error envelopes after settling.

    Measured (``summary.json`` of :mod:`paper002`): median over runs of each run's
    maximum after the filter settles."""
    from . import paper002 as m
    keys = (("horizontal_m", "horizontal_max_m", "m", "horizontal position error"),
            ("heading_arcmin", "heading_max_arcmin", "arcmin", "heading error"),
            ("level_arcmin", "level_max_arcmin", "arcmin", "level error"))
    rows = []
    for mode, paper in m.PAPER.items():
        agg = res["aggregate"].get(mode)
        if agg is None:
            continue
        for pkey, skey, unit, what in keys:
            rows.append(_row(f"002 sins-dr {mode}: max {what}", unit, paper[pkey],
                             agg[skey]["median"],
                             note=f"median over runs of each run's max after {res.get('settle_s', m.SETTLE_S):g} s; "
                                  "paper: +- envelope of one run"))
    return rows


def _rows_003(res: dict) -> list:
    """Paper 003 Tables 2-3: heading (and fkf pitch / roll) error mean and STD.

    Measured (``results.json`` of :mod:`paper003`): mean (``closer`` to 0) and STD over
    all runs x windows at each window's end; the paper's are over its 10 windows of one car."""
    from . import paper003 as m
    rows = []
    for k, (p_mean, p_std) in m.PAPER_TABLE2.items():
        s = res["table2"].get(k)
        if s is None:
            continue
        rows.append(_row(f"003 Table 2 {k}: heading mean", "arcmin", p_mean, s["mean"],
                         better="closer", tolerance=_mc_tolerance(s["std"], res.get("runs")),
                         note="over runs x windows (same: within 2 standard errors, counting "
                              "runs only, as a run's windows share its drift); paper: 10 "
                              "windows, one car"))
        rows.append(_row(f"003 Table 2 {k}: heading STD", "arcmin", p_std, s["std"],
                         note="over runs x windows"))
    for ax, (p_mean, p_std) in m.PAPER_TABLE3.items():
        s = res["table3"].get(ax)
        if s is None:
            continue
        rows.append(_row(f"003 Table 3 fkf: {ax} mean", "arcmin", p_mean, s["mean"],
                         better="closer", tolerance=_mc_tolerance(s["std"], res.get("runs")),
                         note="over runs x windows (same: within 2 standard errors)"))
        rows.append(_row(f"003 Table 3 fkf: {ax} STD", "arcmin", p_std, s["std"],
                         note="over runs x windows (drawn gyro drift per run spreads the "
                              "heading; the paper's 10 windows share one car's drift)"))
    return rows


def _rows_004(res: dict) -> list:
    """Paper 004 Tables 2, 6 (heading at 120 s per speed) and 4-5 (degradations).

    Measured (``results.json`` of :mod:`paper004`): the paper's statistics over the runs
    of each speed, paper form of the methods (raw ``V^b(0)``, plain q-method); degradations
    over the 30 segments of the simulated one-hour drive when it was run."""
    from . import paper004 as m
    pick = (("MAE", "lower"), ("mean", "closer"), ("STD", "lower"), ("max_abs", "lower"))
    rows = []
    for table, label, paper in (("Table 2", "imada-vb", m.PAPER_TABLE2),
                                ("Table 6", "mimada-dual", m.PAPER_TABLE6)):
        for v in m.SPEEDS_M_S:
            s = (res["stats"].get(str(v)) or res["stats"].get(v) or {}).get(label)
            if s is None:
                continue
            for stat, better in pick:
                tol = _mc_tolerance(s["STD"], res.get("runs")) if stat == "mean" else 0.0
                rows.append(_row(f"004 {table} {label} {v} m/s: heading {stat}", "deg",
                                 paper[v][m.STAT_NAMES.index(stat)], s[stat], better=better,
                                 tolerance=tol,
                                 note=f"{res.get('runs')} runs, paper form; paper: 50 runs"
                                      + ("; same: within 2 standard errors" if tol else "")))
    seg = res.get("segments")
    if seg:
        for table, label, paper in (("Table 4", "mimada", m.PAPER_TABLE4),
                                    ("Table 5", "mimada-dual", m.PAPER_TABLE5)):
            d = seg["degradation"].get(label, {}).get("heading")
            if d is not None:
                rows.append(_row(f"004 {table} {label}: heading degradations", "of 30",
                                 paper["heading"][4], d["degradations"],
                                 note="segments of a simulated 1 h drive; paper: 30 car segments"))
    return rows


def _rows_real(res) -> list:
    """Real drives (issue 9): no paper figures. ``results.json`` of :mod:`real` is a
    list of rows ``quantity, reference, measured, unit, note``; the reference (derived from the
    data's reference trajectory or README, where there is one) goes into the note and the
    ``reference`` field, the verdict is ``-``."""
    rows = []
    for r in res if isinstance(res, list) else []:
        ref = r.get("reference")
        note = r.get("note", "")
        if ref is not None:
            note = f"reference {ref:.4g}; {note}"
        rows.append(_row(f"real {r['quantity']}", r.get("unit", ""), None, r.get("measured"),
                         note=note, reference=ref))
    return rows


REPRODUCTIONS = {r.name: r for r in (
    Reproduction("000", "Yang et al. 2019: SINS / Doppler radar in-motion alignment (dr-kf)",
                 "inmotion.reproductions.paper000", "reproduce", "summary.json", _rows_000, 50),
    Reproduction("001", "Xiang et al. 2022: LDV-aided alignment, adaptive unscented "
                 "quaternion H-infinity filter", "inmotion.reproductions.paper001", "reproduce",
                 "results.json", _rows_001, 30),
    Reproduction("002", "Yang et al. 2018: SINS / Doppler radar integrated position and "
                 "orientation (sins-dr)", "inmotion.reproductions.paper002", "reproduce",
                 "summary.json", _rows_002, 20),
    Reproduction("003", "Chang et al. 2025: multi-source fusion alignment (fkf, FDI, "
                 "multiplexing)", "inmotion.reproductions.paper003", "reproduce",
                 "results.json", _rows_003, 20),
    Reproduction("004", "Qiao et al. 2019: multistage in-motion attitude determination "
                 "(imada, mimada)", "inmotion.reproductions.paper004", "reproduce",
                 "results.json", _rows_004, 50),
    Reproduction("real", "Real drives (comma2k19, EMS, PSINS RLG parked and MEMS/FOG): dead "
                 "reckoning, SINS and alignment against the "
                 "reference", "inmotion.reproductions.real", "reproduce",
                 "results.json", _rows_real, None),
)}


def names() -> list:
    """The reproduction names, in order."""
    return list(REPRODUCTIONS)


def get(name: str) -> Reproduction:
    """The reproduction called ``name``; :class:`BadInput` listing the valid names otherwise."""
    try:
        return REPRODUCTIONS[str(name)]
    except KeyError:
        raise BadInput(f"unknown paper {name!r}; valid: {', '.join(names())} or all") from None


# ----------------------------------------------------------------------------- one paper
def _call(rep: Reproduction, out: Path, runs, workers, seed, progress):
    """Call the per-paper function with the keyword arguments its signature has."""
    fn = rep.load()
    params = inspect.signature(fn).parameters
    given = {"runs": runs, "workers": workers, "seed": seed, "progress": progress}
    kwargs = {k: v for k, v in given.items() if k in params and v is not None}
    if runs is not None and "runs" not in params:
        raise BadInput(f"paper {rep.name!r} takes no --runs (it is not a Monte Carlo)")
    return fn(out, **kwargs)


def summary_rows(name: str, out_dir) -> list:
    """The summary rows of reproduction ``name`` from its results file in ``out_dir``, each
    with its ``verdict`` (:func:`inmotion.evaluate.stats.compare_rows`)."""
    from ..evaluate.stats import compare_rows
    rep = get(name)
    path = Path(out_dir) / rep.results_file
    if not path.is_file():
        raise BadInput(f"no results of paper {name} here (expected {rep.results_file})",
                       file=Path(out_dir))
    try:
        res = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise BadInput(f"results file is not valid JSON ({e})", file=path) from None
    return compare_rows(rep.rows(res))


def _finished(rep: Reproduction, out: Path) -> bool:
    return (out / rep.results_file).is_file()


def run_reproduction(name: str, out_dir, runs=None, workers=2, seed=0, progress=True,
                     reuse=False, scheduler=None) -> dict:
    """Run reproduction ``name`` into ``out_dir`` and write its summary rows.

    Parameters
    ----------
    name : ``"000"`` ... ``"004"`` or ``"real"``
    out_dir : folder (created); the per-paper module writes its files there
    runs : Monte Carlo runs (None: the module's default, which is the issue's count)
    workers, seed : passed on where the function takes them
    progress : the module's progress bar (stderr)
    reuse : if the results file is already there, do not run again; only re-read it
    scheduler : address of a Dask scheduler (``tcp://host:8786``) that runs the Monte Carlo
        tasks (:func:`inmotion.reproductions.common.engine`); default: ``workers`` local
        processes of the same campaign engine

    Returns
    -------
    dict ``{"paper", "title", "status": "ok", "reused", "wall_s", "out_dir", "rows"}``, also
    written to ``out_dir/paper_rows.json``. Exceptions of the reproduction propagate.
    """
    rep = get(name)
    out = Path(out_dir)
    reused = bool(reuse and _finished(rep, out))
    t0 = time.perf_counter()
    if not reused:
        out.mkdir(parents=True, exist_ok=True)
        with engine(workers, scheduler):
            _call(rep, out, runs, workers, seed, progress)
    summary = {"paper": rep.name, "title": rep.title, "status": "ok", "reused": reused,
               "wall_s": time.perf_counter() - t0,
               "runs": runs if runs is not None else rep.issue_runs, "seed": seed,
               "out_dir": str(out), "rows": summary_rows(rep.name, out)}
    if reused:      # the run that made the results: its wall time, runs and seed
        summary.update(_previous(out))
    (out / ROWS_FILE).write_text(json.dumps(summary, indent=1, default=_json_default))
    return summary


def _previous(out: Path) -> dict:
    """``wall_s``, ``runs``, ``seed`` of the run recorded in ``out/paper_rows.json`` (if any)."""
    try:
        old = json.loads((out / ROWS_FILE).read_text())
    except (OSError, json.JSONDecodeError):
        return {"wall_s": None}
    return {k: old.get(k) for k in ("wall_s", "runs", "seed")}


def _json_default(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return str(x)


# ----------------------------------------------------------------------------- all
def reproduce_all(out_dir, runs=None, workers=2, seed=0, progress=True, reuse=False,
                  papers=None, notify=None, scheduler=None) -> dict:
    """Run every reproduction into ``out_dir/<name>`` and write one HTML report.

    A reproduction that raises is recorded (``status: "failed"``, its error and the last lines
    of its traceback) and the others still run.

    Parameters
    ----------
    out_dir : folder (created)
    runs : runs per paper (None: each paper's issue count)
    workers, seed, progress, reuse, scheduler : as :func:`run_reproduction` (one Dask
        client serves every paper)
    papers : names to run (default all of :data:`REPRODUCTIONS`)
    notify : ``notify(text)`` called as each paper starts and ends (the CLI prints to stderr)

    Returns
    -------
    dict ``{"papers": [summary per paper], "report": path of the HTML page}``, also written to
    ``out_dir/reproduce_summary.json``.
    """
    from .page import write_page
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    notify = notify or (lambda text: None)
    todo = list(papers or names())
    needed = not all(reuse and _finished(get(n), out / n) for n in todo)
    with engine(workers, scheduler) if needed else contextlib.nullcontext():
        results = _run_each(todo, out, runs, workers, seed, progress, reuse, notify)
    page = write_page(out / "report.html", results,
                      title="inmotion: the five papers reproduced in simulation")
    summary = {"papers": results, "report": str(page)}
    (out / ALL_SUMMARY_FILE).write_text(json.dumps(summary, indent=1, default=_json_default))
    return summary


def _run_each(todo, out, runs, workers, seed, progress, reuse, notify) -> list:
    """:func:`run_reproduction` of each paper in ``todo``; a failure is recorded, not raised."""
    results = []
    for k, name in enumerate(todo):
        rep = get(name)
        t0 = time.perf_counter()
        notify(f"paper {name} ({k + 1} of {len(todo)}): {rep.title}")
        try:
            r_runs = runs if rep.issue_runs is not None else None
            results.append(run_reproduction(name, out / name, r_runs, workers, seed, progress,
                                            reuse))
        except Exception as e:     # recorded in the report; the others still run
            results.append({"paper": rep.name, "title": rep.title, "status": "failed",
                            "error": f"{type(e).__name__}: {e}",
                            "traceback": "".join(traceback.format_exc().splitlines(True)[-12:]),
                            "wall_s": time.perf_counter() - t0, "out_dir": str(out / name),
                            "rows": []})
        r = results[-1]
        notify(f"paper {name}: {r['status']}" + (" (reused)" if r.get("reused") else "")
               + (f", {r['error']}" if r["status"] != "ok" else f", {len(r['rows'])} figures")
               + f", {time.perf_counter() - t0:.0f} s")
    return results
