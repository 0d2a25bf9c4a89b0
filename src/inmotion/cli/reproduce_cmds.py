"""``inmotion reproduce PAPER``: re-create a paper's experiment and set it beside the paper.

::

    inmotion reproduce PAPER -o DIR [--runs N] [--workers N | --scheduler ADDRESS] [--seed N]
                       [--reuse] [--quiet] [--json]   # PAPER: 000 001 002 003 004 real, or all

One paper writes its markdown tables, PNG figures and results JSON into DIR, its summary rows
to ``DIR/paper_rows.json`` and an HTML page ``DIR/report.html``; ``all`` runs every paper into
``DIR/<paper>`` and writes one page covering them (``DIR/report.html``) with the summary table
(paper figure, measured figure, better or worse). ``--runs`` defaults to each paper's issue
count (000: 50, 001: 30, 002: 20, 003: 20, 004: 50). ``--reuse`` skips a paper whose results
file is already in its folder and only re-reads it (e.g. to assemble ``all`` from runs made
one by one). A paper's Monte Carlo is a campaign specification shipped in
``inmotion/reproductions/campaigns/`` (papers 000 to 004), run by the campaign engine into
``DIR/campaign/<name>/``, so the same command again resumes an interrupted reproduction; the
runs go to the engine's Dask workers: ``--workers N`` local processes, or an existing
scheduler with ``--scheduler ADDRESS`` (as for ``inmotion montecarlo``). Progress goes to stderr; ``--quiet`` silences it; ``--json`` prints the summary
rows. An unknown PAPER is bad input (exit status 2), with the valid names.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import click

__all__ = ["reproduce"]


def _root_flag(ctx, name: str) -> bool:
    return bool(getattr(ctx.find_root().obj, name, False))


def _fmt(x) -> str:
    if isinstance(x, float):
        return f"{x:.4g}"
    return "-" if x is None else str(x)


def _rows_text(summary: dict) -> list:
    lines = [f"paper {summary['paper']}: {summary['status']}"
             + (f" ({summary.get('error')})" if summary["status"] != "ok" else "")]
    for r in summary["rows"]:
        lines.append(f"  {r['quantity']:60s} {r.get('unit', ''):7s} paper {_fmt(r.get('paper')):>9s}"
                     f"  measured {_fmt(r.get('measured')):>9s}  {r.get('verdict', '-')}")
    return lines


@click.command("reproduce")
@click.argument("paper")
@click.option("-o", "--output", required=True, type=click.Path(file_okay=False),
              help="Folder to write (for 'all': one sub-folder per paper).")
@click.option("--runs", type=click.IntRange(min=1),
              help="Monte Carlo runs (default: the paper's issue count).")
@click.option("--workers", type=click.IntRange(min=1), default=2, show_default=True,
              help="Local worker processes.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run the Monte Carlo tasks on an existing Dask scheduler (tcp://host:8786).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Base seed.")
@click.option("--reuse", is_flag=True,
              help="Skip papers whose results already exist in the folder; re-read them.")
@click.option("--data", "data_dir", type=click.Path(file_okay=False), default=None,
              envvar="INMOTION_REAL_DATA", show_envvar=True,
              help="Folder of the real drives for 'real' (default: $INMOTION_REAL_DATA, else "
                   "../shared/data/real from the working directory).")
@click.option("--quiet", "-q", is_flag=True, help="No progress.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary rows as JSON.")
@click.pass_context
def reproduce(ctx, paper, output, runs, workers, scheduler, seed, reuse, data_dir, quiet,
              as_json):
    """Reproduce PAPER (000 001 002 003 004 real, or all) in simulation, beside the paper.

    ``real`` runs the real drives found in ``--data DIR`` (or ``$INMOTION_REAL_DATA``).
    """
    from ..reproductions import suite as rp
    if data_dir is not None:            # reproduce_real reads it (also in worker processes)
        os.environ["INMOTION_REAL_DATA"] = str(Path(data_dir).resolve())
    quiet = quiet or _root_flag(ctx, "quiet")
    as_json = as_json or _root_flag(ctx, "json")
    from ..io.safe_write import check_output_path
    out = check_output_path(output)
    if scheduler:
        from ..evaluate.montecarlo import _check_address
        _check_address(scheduler)                       # BadInput (exit 2) before any work
    if paper == "all":
        def note(text):
            if not quiet:
                click.echo(f"inmotion: {text}", err=True)
        summary = rp.reproduce_all(out, runs=runs, workers=workers, seed=seed,
                                   progress=not quiet, reuse=reuse, notify=note,
                                   scheduler=scheduler)
        papers = summary["papers"]
    else:
        rp.get(paper)                                   # BadInput (exit 2) before any work
        from ..reproductions.page import write_page
        one = rp.run_reproduction(paper, out, runs=runs, workers=workers, seed=seed,
                                  progress=not quiet, reuse=reuse, scheduler=scheduler)
        page = write_page(out / "report.html", [one], title=f"inmotion: paper {paper} reproduced")
        summary, papers = {"papers": [one], "report": str(page)}, [one]
    if as_json:
        click.echo(json.dumps(summary, indent=1, default=rp._json_default))
    else:
        lines = [ln for s in papers for ln in _rows_text(s)]
        click.echo("\n".join(lines + [f"report: {summary['report']}"]))
    failed = [s["paper"] for s in papers if s["status"] != "ok"]
    if failed and not quiet:
        click.echo(f"inmotion: failed: {', '.join(failed)} (see the report)", err=True)
    ctx.exit(1 if failed else 0)
