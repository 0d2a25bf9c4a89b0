"""``inmotion montecarlo`` and ``inmotion report``: the campaign engine and the HTML reports.

::

    inmotion montecarlo SCENARIO.yaml|SWEEP.yaml|NAME --method NAME --runs N -o DIR
                        [--seed N] [--workers N | --scheduler ADDRESS] [--resume]
                        [--retry-failed] [--init-error 'pitch=1deg,yaw=5deg'] [--set key=value]
                        [--save-arrays] [--no-report] [--quiet] [--json]
    inmotion report DIR [-o FILE.html] [--paper PAPER.yaml] [--title TEXT]

The commands are added to the ``inmotion`` group in :mod:`inmotion.cli.main`. They raise
:class:`BadInput` for the user's mistakes (exit status 2) and honour the group's ``--quiet`` and
``--json`` as well as their own.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import click

from ..errors import BadInput

__all__ = ["montecarlo", "report"]


def _root_flag(ctx, name: str) -> bool:
    return bool(getattr(ctx.find_root().obj, name, False))


def _parse_sets(items) -> dict:
    """``("gain=2", "mode=[1,2]") -> {"gain": 2, "mode": [1, 2]}`` (values read as YAML)."""
    import yaml
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise BadInput(f"--set {item!r}: expected key=value")
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError:
            raise BadInput(f"--set {item!r}: the value is not valid YAML") from None
    return out


def _summary(df, sweep) -> dict:
    """Per point: runs, failures and mean / RMS of the final errors (JSON-able)."""
    from ..evaluate.stats import final_error_columns, point_statistics
    cols = final_error_columns(df) if len(df) else []
    stats = point_statistics(df, cols, ("mean", "rms")) if len(df) else None
    points = []
    for p in sweep.points:
        row = {"point_id": p.point_id, "label": p.label, "params": p.params}
        if stats is not None and p.point_id in set(stats["point_id"]):
            s = stats[stats["point_id"] == p.point_id].iloc[0]
            row.update(runs=int(s["runs"]), failed=int(s["failed"]),
                       final={c: {"mean": _num(s[f"{c}:mean"]), "rms": _num(s[f"{c}:rms"])}
                              for c in cols})
        points.append(row)
    return {"name": sweep.name, "runs_per_point": sweep.runs, "seed": sweep.seed,
            "runs_done": int(len(df)), "runs_failed": int((df["status"] != "ok").sum())
            if len(df) else 0, "points": points}


def _num(x):
    return None if x is None or (isinstance(x, float) and not math.isfinite(x)) else float(x)


def _summary_text(summary: dict, out: Path) -> str:
    lines = [f"{summary['name']}: {summary['runs_done']} runs ({summary['runs_failed']} failed) "
             f"in {out}"]
    for p in summary["points"]:
        final = p.get("final", {})
        show = [c for c in final if c.rsplit(".", 1)[-1] in
                ("yaw_arcmin", "pitch_arcmin", "roll_arcmin", "horizontal_m")] or list(final)[:4]
        figures = ", ".join(f"{c.rsplit('.', 1)[-1]} RMS {final[c]['rms']:.4g}"
                            for c in show if final[c]["rms"] is not None)
        lines.append(f"  [{p['point_id']}] {p['label']}: {p.get('runs', 0)} runs, "
                     f"{p.get('failed', 0)} failed" + (f"; {figures}" if figures else ""))
    return "\n".join(lines)


@click.command()
@click.argument("scenario")
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False),
              help="Campaign directory (results, table.parquet, report.html).")
@click.option("--method", help="Method name (see `inmotion methods`); overrides the sweep's.")
@click.option("--runs", type=click.IntRange(min=1), help="Runs per parameter point.")
@click.option("--seed", type=click.IntRange(min=0), help="Campaign seed (default: the sweep's, else 0).")
@click.option("--workers", type=click.IntRange(min=1),
              help="Local worker processes (default: all cores).")
@click.option("--scheduler", metavar="ADDRESS", help="Use an existing Dask scheduler instead.")
@click.option("--resume", is_flag=True, help="Complete the campaign in DIR: run only missing runs.")
@click.option("--retry-failed", is_flag=True, help="With --resume: re-run failed runs too.")
@click.option("--init-error", help="Initial attitude error, e.g. 'pitch=1deg,roll=1deg,yaw=5deg'.")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="A method option (repeatable; the value is read as YAML).")
@click.option("--save-arrays", is_flag=True, help="Keep each run's error series (for envelopes).")
@click.option("--report/--no-report", default=True, show_default=True,
              help="Write DIR/report.html at the end.")
@click.option("--quiet", "-q", is_flag=True, help="No progress bar.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.pass_context
def montecarlo(ctx, scenario, output, method, runs, seed, workers, scheduler, resume,
               retry_failed, init_error, sets, save_arrays, report, quiet, as_json):
    """Monte Carlo campaign of SCENARIO (a scenario or sweep YAML file, or a shipped name).

    Each run k draws from SeedSequence(seed, spawn_key=(k,)): the same numbers on any number of
    workers. Results land in DIR/results as runs finish; --resume completes an interrupted one.
    """
    from ..evaluate.montecarlo import run_campaign
    from ..evaluate.sweep import load_sweep
    if workers and scheduler:
        raise BadInput("give --workers or --scheduler, not both")
    quiet = quiet or _root_flag(ctx, "quiet")
    as_json = as_json or _root_flag(ctx, "json")
    overrides = {"method": method, "runs": runs, "seed": seed, "init_error": init_error}
    source = scenario if Path(scenario).is_file() else {"scenario": scenario, "name": scenario}
    sweep = load_sweep(source, overrides=overrides)
    extra = _parse_sets(sets)
    for p in sweep.points:
        if extra:
            p.spec.setdefault("method_options", {}).update(extra)
        if save_arrays:
            p.spec["save_arrays"] = True
    out = Path(output)
    try:
        df = run_campaign(sweep, out, workers=workers, scheduler=scheduler, resume=resume,
                          retry_failed=retry_failed, quiet=quiet)
    except KeyboardInterrupt:
        from ..evaluate.store import ResultStore
        n = len(ResultStore(out).done())
        click.echo(f"inmotion: interrupted; {n} finished runs are kept in {out}: "
                   "run the same command with --resume to complete the campaign", err=True)
        ctx.exit(130)
    summary = _summary(df, sweep)
    if report:
        from ..evaluate.report import build_report
        summary["report"] = str(build_report(out))
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        click.echo(_summary_text(summary, out))
        if report:
            click.echo(f"report: {summary['report']}")


@click.command()
@click.argument("directory", type=click.Path(file_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="The HTML page (default DIR/report.html).")
@click.option("--paper", type=click.Path(dir_okay=False),
              help="YAML/JSON of the paper's figures to compare with.")
@click.option("--title", help="Page title.")
@click.option("--json", "as_json", is_flag=True, help="Print where the page is as JSON.")
@click.pass_context
def report(ctx, directory, output, paper, title, as_json):
    """HTML report of DIRECTORY: a campaign, a result folder, or a folder of them.

    One self-contained page (figures embedded, works offline); PNG figures beside it.
    """
    from ..evaluate.report import build_report
    page = build_report(directory, output, paper=paper, title=title)
    figures = sorted(str(p) for p in page.parent.glob(f"{page.stem}_figures/*.png"))
    if as_json or _root_flag(ctx, "json"):
        click.echo(json.dumps({"report": str(page), "figures": figures}, indent=2))
    else:
        click.echo(f"report: {page} ({len(figures)} figures)")
