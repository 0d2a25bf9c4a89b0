"""``inmotion report DIR``: one self-contained HTML page for a campaign, a run, or a collection.

What ``DIR`` is decides what the page shows:

- a **result folder** (``summary.json``, ``solution``, ``errors`` tables (CSV or Parquet) of
  :mod:`inmotion.io.result`): a summary line (final horizontal error in m and in % of distance
  travelled, heading and level error), the ``errors`` block with its rows and headers in words
  and units, ``|error|`` on a log scale with the method's 3 sigma (the start-up transient does
  not swamp the converged error), the errors over the converged end of the run (the last 100 s
  or quarter) with +-3 sigma, a plan view of the horizontal position error, the estimated
  states each with its unit and meaning, the configuration;
- a **campaign directory** (``campaign.json`` and ``results/`` of
  :mod:`inmotion.evaluate.montecarlo`): per-point statistics of the final errors and their
  distributions, failed runs with their seeds, Monte Carlo error envelopes and the plan view where
  runs saved arrays (``save_arrays: true``), the sweep and the versions it ran with;
- a **collection** (a folder of the above, e.g. ``inmotion reproduce all``): one summary table of
  every paper comparison, then a section per member.

A reproduction passes its paper's figures as ``paper={"title": ..., "rows": [...]}`` (rows as in
:mod:`inmotion.evaluate.stats`), or puts them under ``paper:`` in its sweep or in a
``paper.yaml`` / ``paper.json`` beside the results; the page shows them side by side with the
measured figures and says better / worse / same.

The page has no external reference: figures are PNG (matplotlib, Agg) embedded as base64 data
URIs, styles are inline, there is no script. The PNGs are also written to
``<report stem>_figures/`` next to the page, for papers and slides.
"""
from __future__ import annotations

import base64
import html
import json
import math
import time
from pathlib import Path
from typing import Optional, Union

import numpy as np
import pandas as pd
import yaml

from ..io.safe_write import atomic_write
from .._typing import PathLike
from ..errors import BadInput
from . import plots
from .stats import compare_rows, final_error_columns, point_statistics

__all__ = ["build_report", "detect_kind", "load_paper", "save_paper"]

MAX_ENSEMBLE_RUNS = 200   #: runs drawn in a Monte Carlo envelope figure
MAX_ENSEMBLE_POINTS = 8   #: points with an envelope figure
MAX_TRACKS = 8            #: lines in the plan view
MAX_STATE_PANELS = 16     #: estimated states shown for a run
KEY_FINAL = ("pitch_arcmin", "roll_arcmin", "yaw_arcmin", "phi_U_arcmin", "horizontal_m",
             "vertical_m")

CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;max-width:1250px;
color:#1b1f24;padding:0 1em;line-height:1.4}
h1{font-size:1.6em;border-bottom:2px solid #445;padding-bottom:.2em}h2{margin-top:1.8em;
border-bottom:1px solid #ccd}h3{margin-top:1.3em}table{border-collapse:collapse;margin:.6em 0;
font-size:.88em}th,td{border:1px solid #ccd;padding:.25em .55em;text-align:right}
th{background:#eef0f4}td.l,th.l{text-align:left}tr:nth-child(even) td{background:#fafbfc}
.better{color:#116329;font-weight:600}.worse{color:#b3261e;font-weight:600}.same{color:#555}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #dde}figcaption{font-size:.85em;
color:#555}pre{background:#f5f6f8;padding:.7em;overflow-x:auto;font-size:.82em}.note{color:#666;
font-size:.9em}details{margin:.5em 0}
"""


# ----------------------------------------------------------------------------- the page
class _Page:
    """An HTML page being built: sections and embedded figures (also saved as PNG files)."""

    def __init__(self, title: str, fig_dir: Path):
        self.title, self.fig_dir, self.parts, self.names = title, fig_dir, [], set()

    def add(self, fragment: str) -> None:
        self.parts.append(fragment)

    def figure(self, name: str, fig, caption: str) -> None:
        base = name = _slug(name)
        k = 2
        while name in self.names:
            name, k = f"{base}-{k}", k + 1
        self.names.add(name)
        data = plots.png_bytes(fig)
        self.fig_dir.mkdir(parents=True, exist_ok=True)
        (self.fig_dir / f"{name}.png").write_bytes(data)
        b64 = base64.b64encode(data).decode("ascii")
        self.add(f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{b64}">'
                 f"<figcaption>{_e(caption)}</figcaption></figure>")

    def html(self) -> str:
        stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
        return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<title>{_e(self.title)}</title><style>{CSS}</style></head><body>"
                f"<h1>{_e(self.title)}</h1><p class=\"note\">inmotion report, {stamp}</p>"
                + "\n".join(self.parts) + "</body></html>\n")


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _slug(s: str) -> str:
    out = "".join(c if c.isalnum() else "-" for c in s.lower())
    return "-".join(filter(None, out.split("-")))[:80] or "figure"


def _fmt(x) -> str:
    if x is None:
        return "–"
    if isinstance(x, (float, np.floating)):
        return "–" if not math.isfinite(x) else f"{x:.4g}"
    return str(x)


def _table(header, rows, left=1) -> str:
    """An HTML table; the first ``left`` columns are left-aligned text."""
    th = "".join(f'<th class="{"l" if i < left else ""}">{_e(h)}</th>' for i, h in enumerate(header))
    body = []
    for row in rows:
        cells = []
        for i, v in enumerate(row):
            cls = "l" if i < left else ""
            if isinstance(v, tuple):            # (text, css class)
                v, extra = v
                cls = f"{cls} {extra}"
            cells.append(f'<td class="{cls.strip()}">{_e(_fmt(v))}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _pre_yaml(obj) -> str:
    text = yaml.safe_dump(json.loads(json.dumps(obj, default=str)), sort_keys=False,
                          default_flow_style=None, width=100)
    return f"<pre>{_e(text)}</pre>"


# ----------------------------------------------------------------------------- inputs
def detect_kind(path: Path) -> str:
    """``"campaign"``, ``"result"``, ``"collection"``; :class:`BadInput` otherwise."""
    path = Path(path)
    if not path.is_dir():
        raise BadInput("not a directory", file=path)
    if (path / "campaign.json").is_file():
        return "campaign"
    if (path / "summary.json").is_file():
        return "result"
    if any(_is_member(p) for p in path.iterdir()):
        return "collection"
    raise BadInput("neither a campaign (campaign.json), a result folder (summary.json) nor a "
                   "folder of them", file=path)


def _is_member(p: Path) -> bool:
    """A campaign or result folder (not a hidden one: a writer's unfinished sibling)."""
    return (p.is_dir() and not p.name.startswith(".")
            and ((p / "campaign.json").is_file() or (p / "summary.json").is_file()))


def load_paper(source) -> Optional[dict]:
    """Paper figures from a dict, a YAML/JSON file, or ``None``: ``{"title", "rows"}``."""
    if source is None:
        return None
    if isinstance(source, (str, Path)):
        p = Path(source)
        from ..io.safe_yaml import load_yaml_file
        if not p.is_file():
            raise BadInput("paper figures file not found", file=p)
        source = load_yaml_file(p, "paper figures", invalid="not valid YAML")
    if isinstance(source, list):
        source = {"rows": source}
    if not isinstance(source, dict) or not isinstance(source.get("rows", []), list):
        raise BadInput(f"paper figures must be a mapping with a 'rows' list, got {source!r}")
    return source


def save_paper(directory, paper: dict) -> Path:
    """Write a reproduction's paper figures beside its results (``paper.json``), where
    :func:`build_report` finds them; returns the file."""
    paper = load_paper(paper)
    path = Path(directory) / "paper.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(paper, indent=1, default=str))
    return path


def _paper_for(root: Path, given, manifest_paper=None):
    if given is not None:
        return load_paper(given)
    for name in ("paper.yaml", "paper.json"):
        if (root / name).is_file():
            return load_paper(root / name)
    return load_paper(manifest_paper)


# ----------------------------------------------------------------------------- sections
def _paper_section(page: _Page, paper: Optional[dict], df=None) -> list:
    if not paper or not paper.get("rows"):
        return []
    rows = compare_rows(paper["rows"], df)
    page.add(f"<h3>Against the paper: {_e(paper.get('title', ''))}</h3>")
    page.add(_table(["quantity", "unit", "paper", "measured", "verdict"],
                    [(r["quantity"], r.get("unit", ""), r.get("paper"), r.get("measured"),
                      (r["verdict"], r["verdict"])) for r in rows], left=2))
    if paper.get("notes"):
        page.add(f"<p class=\"note\">{_e(paper['notes'])}</p>")
    return rows


def _versions_section(page: _Page, used: Optional[dict]) -> None:
    from .montecarlo import versions
    now = versions()
    keys = list(dict.fromkeys(list(used or {}) + list(now)))
    page.add("<h3>Versions</h3>")
    if used:
        page.add(_table(["package", "run with", "report made with"],
                        [(k, used.get(k, "–"), now.get(k, "–")) for k in keys]))
    else:
        page.add(_table(["package", "report made with"], [(k, now[k]) for k in keys]))


def _result_section(page: _Page, root: Path, paper=None, level=2) -> list:
    from ..io.result import find_table, read_result, read_summary, read_table
    summary = read_summary(root)
    page.add(f"<h{level}>Run: {_e(summary.get('method') or root.name)} "
             f"<small>({_e(root)})</small></h{level}>")
    rows = _paper_section(page, _paper_for(root, paper), None)
    block = summary.get("errors")
    if block:
        page.add(_result_summary(summary, block))
        keys = list(block.get("final", {}))
        stats = [k for k in ("final", "rms_last_100s", "max_abs_last_100s") if k in block]
        page.add(_table(["error (estimate − truth)", "key", "unit"]
                        + [STAT_WORDS.get(k, k) for k in stats],
                        [[plots.ERROR_WORDS.get(k, (k, ""))[0], k,
                          plots.ERROR_WORDS.get(k, ("", ""))[1]]
                         + [block[s].get(k) for s in stats] for k in keys], left=3))
    cons = (block or {}).get("consistency") or {}
    if cons or summary.get("nis"):
        page.add(_consistency_section(cons, summary.get("nis") or {}))
    if summary.get("stages"):            # inmotion process: which stage ran when and why
        page.add("<h3>Stages</h3>" + _table(
            ["stage", "method", "start [s]", "end [s]", "heading at end [deg]",
             "heading 1σ at end [arcmin]", "why"],
            [[s.get("stage"), s.get("method"), s.get("start_s"), s.get("end_s"),
              (s.get("attitude_end_deg") or s.get("attitude_start_deg") or {}).get("yaw"),
              (s.get("sigma_end_arcmin") or {}).get("phi_U"), (s.get("why"), "l")]
             for s in summary["stages"]], left=2))
        head = summary.get("heading") or {}
        if head:
            page.add(f"<p>Heading: {_e(head.get('source', ''))}: {_e(head.get('why', ''))}</p>")
    solution = read_result(root)
    errors_path = find_table(root, "errors")
    if errors_path is not None:
        err = read_table(errors_path)
        t = err["t"].to_numpy()
        sigma = _sigma_on(solution, t)
        columns = {c: err[c].to_numpy() for c in err.columns}
        page.figure(f"{root.name}-abs-errors", plots.abs_error_curves(t, columns, sigma),
                    "|error| against truth on a log scale, with the method's 3σ (dashed, where "
                    "it gives one): the start-up transient and the converged error on one axis")
        tail = t >= max(t[0], t[-1] - max(100.0, 0.25 * (t[-1] - t[0])))
        if tail.sum() >= 2:
            page.figure(f"{root.name}-errors-end", plots.error_curves(
                t[tail], {c: v[tail] for c, v in columns.items()},
                {c: v[tail] for c, v in sigma.items()}),
                f"the converged part: errors over the last {t[-1] - t[tail][0]:.0f} s with the "
                "method's ±3σ (shaded where it gives one)")
        if {"north_m", "east_m"} <= set(err.columns):
            page.figure(f"{root.name}-position-error", plots.position_error_plan(
                t, err["east_m"].to_numpy(), err["north_m"].to_numpy()),
                "plan view of the horizontal position error, coloured by time; the dotted "
                "circle is the final error")
    else:
        page.figure(f"{root.name}-plan", plots.plan_view(_result_tracks(solution, root)),
                    "plan view of the drive")
    _states_figure(page, root)
    page.add("<h3>Configuration</h3>" + _pre_yaml({k: summary.get(k) for k in
                                                   ("method", "config", "timing", "bundle", "init")
                                                   if summary.get(k) is not None}))
    return rows


def _consistency_section(cons: dict, nis: dict) -> str:
    """Does the filter's sigma cover its error (NEES against truth, ``errors.consistency``)
    and do its innovations fit their covariance (NIS per measurement kind, ``nis``)?"""
    rows = []
    for name, c in cons.items():
        band = c.get("band_95") or [None, None]
        rows.append([f"NEES {name}", c.get("mean"), 3.0, c.get("dof"), band[0], band[1],
                     c.get("rows"), "yes" if c.get("in_band") else "no"])
    for kind, c in nis.items():
        band = c.get("band_95") or [None, None]
        rows.append([f"NIS {kind} (per dof)", c.get("mean_per_dof"),
                     c.get("expected_mean_per_dof", 1.0), c.get("dof"), band[0],
                     band[1], c.get("samples"),
                     "-" if c.get("in_band") is None else "yes" if c["in_band"] else "no"])
    return ("<h3>Consistency</h3><p>NEES: the mean of (error / sigma)² summed over a group's "
            "three axes (3 for a filter whose sigma is honest); NIS: the mean innovation "
            "chi-square per degree of freedom of each measurement kind (1 when the "
            "innovations fit their covariance, or the residual test's model's mean where "
            "its rows' noise is weighted, e.g. fkf's channels with the vehicle's constraint "
            "violation). The 95 % bands assume independent rows, a loose check.</p>"
            + _table(["statistic", "mean", "expected", "dof", "95 % band low",
                      "95 % band high", "rows / samples", "in band"], rows, left=1))


#: the errors block's statistics in words
STAT_WORDS = {"final": "final", "rms_last_100s": "RMS, last 100 s",
              "max_abs_last_100s": "max |error|, last 100 s"}


def _result_summary(summary: dict, block: dict) -> str:
    """One paragraph: drive, and the final errors a navigation engineer quotes first."""
    f = block.get("final", {})
    d, dur = block.get("distance_m"), block.get("duration_s")
    parts = []
    if isinstance(d, (int, float)) and isinstance(dur, (int, float)):
        parts.append(f"{_e(summary.get('method') or 'the method')} over {dur:.1f} s and "
                     f"{d / 1000:.3f} km")
    hor = f.get("horizontal_m")
    if isinstance(hor, (int, float)):
        pct = (f" = <b>{100 * hor / d:.3g} % of distance travelled</b>"
               if isinstance(d, (int, float)) and d > 0 else "")
        parts.append(f"final horizontal error <b>{hor:.3g} m</b>{pct}")
    if isinstance(f.get("phi_U_arcmin"), (int, float)):
        parts.append(f"heading (phi_U) {f['phi_U_arcmin']:.3g} arcmin")
    if all(isinstance(f.get(k), (int, float)) for k in ("phi_E_arcmin", "phi_N_arcmin")):
        parts.append(f"level {math.hypot(f['phi_E_arcmin'], f['phi_N_arcmin']):.3g} arcmin")
    if isinstance(f.get("vertical_m"), (int, float)):
        parts.append(f"vertical {f['vertical_m']:.3g} m")
    return ("<p>" + "; ".join(parts) + ". Errors are estimate minus truth; the statistics "
            "cover the last 100 s of the run.</p>")


def _states_figure(page: _Page, root: Path) -> None:
    """The estimated states of ``states.csv`` with their ±3σ (``sigma_<column>``): those with a
    sigma first (the calibrated quantities), at most :data:`MAX_STATE_PANELS`."""
    from ..io.result import find_table, read_table
    path = find_table(root, "states")
    if path is None:
        return
    df = read_table(path)
    names = [c for c in df.columns if c != "t" and not c.startswith("sigma_")]
    names = ([c for c in names if f"sigma_{c}" in df] + [c for c in names if f"sigma_{c}" not in df])
    names = names[:MAX_STATE_PANELS]
    if not names or "t" not in df:
        return
    page.figure(f"{root.name}-states", plots.state_curves(
        df["t"].to_numpy(), {c: df[c].to_numpy() for c in names},
        {c: df[f"sigma_{c}"].to_numpy() for c in names if f"sigma_{c}" in df}),
        f"estimated states with the filter's ±3σ where it gives one: {', '.join(names)}")


def _sigma_on(solution, t) -> dict:
    """The solution's 1-sigma interpolated to times ``t``, in the error columns' units."""
    from .runs import SIGMA_TO_ERROR
    out = {}
    for name, s in solution.sigma.items():
        if name in SIGMA_TO_ERROR and np.isfinite(s).any():
            col, scale = SIGMA_TO_ERROR[name]
            out[col] = np.interp(t, solution.t, np.asarray(s, dtype=float)) * scale
    return out


def _result_tracks(solution, root: Path) -> list:
    from ..core.earth import local_ne_offsets
    lat0, lon0, h0 = solution.lat[0], solution.lon[0], solution.h[0]
    north, east = local_ne_offsets(solution.lat, solution.lon, lat0, lon0, h0)
    tracks = [("estimate", east, north)]
    from ..io.result import find_table, read_table
    path = find_table(root, "errors")
    if path is not None:
        err = read_table(path)
        if {"north_m", "east_m"} <= set(err.columns):
            t = err["t"].to_numpy()
            tracks.append(("truth", np.interp(t, solution.t, east) - err["east_m"].to_numpy(),
                           np.interp(t, solution.t, north) - err["north_m"].to_numpy()))
    return tracks


def _campaign_section(page: _Page, root: Path, paper=None, level=2) -> list:
    from .store import ResultStore
    from .montecarlo import _read_manifest
    manifest = _read_manifest(root)
    store = ResultStore(root)
    df = store.table()
    page.add(f"<h{level}>Campaign: {_e(manifest.get('name', root.name))} "
             f"<small>({_e(root)})</small></h{level}>")
    n_total = manifest["runs"] * len(manifest["points"])
    n_err = int((df["status"] != "ok").sum()) if len(df) else 0
    page.add(f"<p>{len(df)} of {n_total} runs done ({n_err} failed), {len(manifest['points'])} "
             f"point(s) × {manifest['runs']} run(s), campaign seed {manifest['seed']}, run "
             f"function <code>{_e(manifest['run'])}</code>.</p>")
    rows = _paper_section(page, _paper_for(root, paper, manifest.get("paper")), df)
    if len(df) == 0:
        return rows
    cols = final_error_columns(df)
    key = [c for c in cols if c.rsplit(".", 1)[-1] in KEY_FINAL] or cols[:6]
    _campaign_tables(page, df, key, cols)
    if key:
        page.figure(f"{root.name}-final-errors", plots.final_distributions(
            _values_by_label(df, key), key), "distribution of final errors per point (box: "
            "quartiles, whiskers: 1.5 IQR; dots: runs)")
    _failed_table(page, df)
    _ensemble_figures(page, root, df, store)
    page.add("<h3>Sweep</h3>" + _pre_yaml({"grid": manifest.get("grid"),
                                           "points": [{"point_id": p["point_id"],
                                                       "label": p["label"]}
                                                      for p in manifest["points"]],
                                           "base (point 0)": manifest["points"][0]["spec"]}))
    _versions_section(page, manifest.get("versions"))
    return rows


def _campaign_tables(page, df, key, cols):
    stats = point_statistics(df, key, ("mean", "std", "rms"))
    header = ["point", "runs", "failed"] + [f"{c.rsplit('.', 1)[-1]} mean ± std (RMS)" for c in key]
    rows = []
    for _, r in stats.iterrows():
        rows.append([r["label"], r["runs"], r["failed"]] + [
            f"{_fmt(r[f'{c}:mean'])} ± {_fmt(r[f'{c}:std'])} ({_fmt(r[f'{c}:rms'])})" for c in key])
    page.add("<h3>Final errors per point</h3>" + _table(header, rows))
    full = point_statistics(df, cols, ("mean", "std", "rms", "p95_abs"))
    body = [[r["label"], c, *(r[f"{c}:{s}"] for s in ("mean", "std", "rms", "p95_abs"))]
            for _, r in full.iterrows() for c in cols]
    page.add("<details><summary>all result columns</summary>"
             + _table(["point", "column", "mean", "std", "RMS", "95% |x|"], body, left=2)
             + "</details>")


def _values_by_label(df, columns) -> dict:
    ok = df[df["status"] == "ok"]
    out = {}
    for pid, g in ok.groupby("point_id", sort=True):
        out[str(g["label"].iloc[0]) if "label" in g else str(pid)] = {
            c: g[c].to_numpy(dtype=float) for c in columns if c in g}
    return out


def _failed_table(page, df, limit=30):
    bad = df[df["status"] != "ok"]
    if bad.empty:
        return
    page.add(f"<h3>Failed runs ({len(bad)})</h3><p class=\"note\">re-run one alone with "
             "<code>inmotion.evaluate.montecarlo.rerun(DIR, point_id, run_index)</code>.</p>")
    page.add(_table(["point", "run", "seed", "error"],
                    [(r.get("label", r["point_id"]), r["run_index"], r["seed"], r["error"])
                     for _, r in bad.head(limit).iterrows()], left=4))


def _ensemble_figures(page, root, df, store):
    """Monte Carlo envelopes and the plan view, from the runs' saved arrays."""
    ok = df[df["status"] == "ok"]
    tracks = []
    for n_points, (pid, g) in enumerate(ok.groupby("point_id", sort=True)):
        if n_points >= MAX_ENSEMBLE_POINTS:
            break
        arrays = [a for a in (store.read_arrays(int(pid), int(k))
                              for k in g["run_index"].head(MAX_ENSEMBLE_RUNS)) if a]
        if not arrays:
            continue
        label = str(g["label"].iloc[0])
        t, runs, sigma = _stack(arrays)
        if runs:
            page.figure(f"{root.name}-envelope-{label}", plots.ensemble_curves(
                t, runs, sigma), f"{label}: errors of {len(arrays)} runs, ensemble ±3 std and "
                "the filter's ±3σ")
        first = arrays[0]
        if "track.east_m" in first and len(tracks) < MAX_TRACKS and not any(
                len(e) == len(first["track.east_m"]) and np.array_equal(e, first["track.east_m"])
                for name, e, _ in tracks if name.startswith("truth")):
            tracks.append((f"truth: {label}" if tracks else "truth", first["track.east_m"],
                           first["track.north_m"]))
        if "track.east_m" in first and "err.east_m" in first and len(tracks) < MAX_TRACKS:
            tt = first["track.t"]
            tracks.append((f"estimate: {label}",
                           first["track.east_m"] + np.interp(tt, first["t"], first["err.east_m"]),
                           first["track.north_m"] + np.interp(tt, first["t"], first["err.north_m"])))
    if tracks:
        page.figure(f"{root.name}-plan", plots.plan_view(tracks), "plan view (first run)")


def _stack(arrays):
    """Common time base (the first run's) and (R, N) stacks of ``err.*`` / ``sigma.*`` arrays."""
    t = np.asarray(arrays[0].get("t", []), dtype=float)
    runs, sigma = {}, {}
    for prefix, out in (("err.", runs), ("sigma.", sigma)):
        names = [k for k in arrays[0] if k.startswith(prefix)]
        for k in names:
            rows = [np.interp(t, a["t"], a[k]) for a in arrays if k in a and len(a["t"])]
            if rows and len(t):
                out[k[len(prefix):]] = np.vstack(rows)
    return t, runs, sigma


def _collection(page: _Page, root: Path, paper) -> None:
    members = sorted(p for p in root.iterdir() if _is_member(p))
    summary_at = len(page.parts)
    all_rows = []
    for m in members:
        section = _campaign_section if (m / "campaign.json").is_file() else _result_section
        rows = section(page, m, None)
        all_rows += [(m.name, r) for r in rows]
    extra = _paper_section(_Page("", page.fig_dir), load_paper(paper), None) if paper else []
    all_rows += [("", r) for r in extra]
    if all_rows:
        table = _table(["part", "quantity", "unit", "paper", "measured", "verdict"],
                       [(name, r["quantity"], r.get("unit", ""), r.get("paper"), r.get("measured"),
                         (r["verdict"], r["verdict"])) for name, r in all_rows], left=3)
        counts = pd.Series([r["verdict"] for _, r in all_rows]).value_counts().to_dict()
        page.parts.insert(summary_at, "<h2>Summary: paper against measured</h2>" + table
                          + f"<p>{_e(', '.join(f'{v} {k}' for k, v in counts.items()))}</p>")


# ----------------------------------------------------------------------------- entry point
def build_report(path: PathLike, output: Optional[PathLike] = None, *,
                 paper: Union[None, dict, PathLike] = None,
                 title: Optional[str] = None) -> Path:
    """Write the HTML report of ``path`` (a campaign, a result folder or a folder of them).

    Parameters
    ----------
    path : directory
    output : file, optional
        The page (default ``path/report.html``); figures go to ``<stem>_figures/`` beside it.
    paper : dict or path, optional
        The paper's figures (see :mod:`inmotion.evaluate.stats`); overrides any in ``path``.
    title : str, optional

    Returns
    -------
    Path of the page.
    """
    root = Path(path)
    kind = detect_kind(root)
    out = Path(output) if output else root / "report.html"
    page = _Page(title or f"inmotion report: {root.resolve().name}", out.parent / f"{out.stem}_figures")
    if kind == "campaign":
        _campaign_section(page, root, paper)
    elif kind == "result":
        _result_section(page, root, paper)
        _versions_section(page, None)
    else:
        _collection(page, root, paper)
        _versions_section(page, None)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = page.html()
    atomic_write(out, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return out
