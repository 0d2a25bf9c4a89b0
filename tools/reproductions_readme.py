"""Write ``docs/reproductions/README.md`` from the ``paper_rows.json`` of each folder there.

Usage: ``python tools/reproductions_readme.py [DIR]`` (default ``docs/reproductions``). The
folders are snapshots of ``inmotion reproduce P -o DIR`` (``report.md``, PNGs and
``paper_rows.json``); this script only tabulates their rows, it measures nothing. Every
row's verdict is recomputed here under the rules of :mod:`inmotion.evaluate.stats` (beyond the
Monte Carlo uncertainty of both figures, the same statistic over comparable sample sizes;
ablations of our own listed apart), so the counts follow the rules even for an older snapshot.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from inmotion.evaluate.stats import compare_rows, count_verdicts

ORDER = ("000", "001", "002", "003", "004", "real")
_DROP = ("verdict",)


def _fmt(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def build(root: Path) -> str:
    rows = {p: compare_rows([{k: v for k, v in r.items() if k not in _DROP}
                             for r in json.loads((root / p / "paper_rows.json").read_text())["rows"]])
            for p in ORDER if (root / p / "paper_rows.json").exists()}
    L = [f"# Paper reproductions: snapshot (tabulated at commit {_commit()})", "",
         "Each folder holds the output of `inmotion reproduce P --workers 2 -o DIR` on the "
         "project's 2-core machine: the paper's `report.md` (tables beside the paper's "
         "figures, notes on every shortfall), its PNG figures and `paper_rows.json`. This "
         "page is written from those files by `tools/reproductions_readme.py`. Regenerate "
         "everything with `inmotion reproduce all -o DIR` (one self-contained HTML page).", "",
         "Verdicts: a row is *better* or *worse* only when the two figures differ by more than "
         "the Monte Carlo uncertainty of both (the row's standard errors, or the interval in "
         "which the paper's statistic would fall under our model at the paper's sample size), "
         "and only when they are the same statistic over comparable sample sizes; else *same*, "
         "*not comparable* (with the reason) or *undecided* (the row carries no uncertainty). "
         "Ablations of our own are listed apart and not counted; compute times on different "
         "machines are not comparable.", "",
         "| paper | better | same | worse | not comparable | undecided | no paper figure "
         "| ablations (apart) |",
         "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for p, rs in rows.items():
        c = count_verdicts(rs)
        L.append(f"| [{p}]({p}/report.md) | {c['better']} | {c['same']} | {c['worse']} | "
                 f"{c['not comparable']} | {c['undecided']} | {c['-']} | {c['ablation']} |")
    for title, keep in (("Paper figures", lambda r: r["kind"] != "ablation"),
                        ("Ablations of our own (not counted)", lambda r: r["kind"] == "ablation")):
        sel = [(p, r) for p, rs in rows.items() for r in rs if keep(r)]
        if not sel:
            continue
        L += ["", f"## {title}", "",
              "| paper | quantity | unit | paper | measured | uncertainty | verdict |",
              "| --- | --- | --- | ---: | ---: | --- | --- |"]
        for p, r in sel:
            L.append(f"| {p} | {r['quantity']} | {r['unit']} | {_fmt(r['paper'])} | "
                     f"{_fmt(r['measured'])} | {_uncertainty(r)} | {r['verdict']}"
                     f"{' (' + r['why'] + ')' if r.get('why') else ''} |")
    return "\n".join(L) + "\n"


def _uncertainty(r) -> str:
    if r.get("measured_interval") is not None:
        lo, hi = r["measured_interval"]
        return f"[{lo:.3g}, {hi:.3g}]"
    parts = [f"{k.split('_')[0]} se {r[k]:.2g}" for k in ("measured_se", "paper_se")
             if isinstance(r.get(k), (int, float))]
    if parts:
        return ", ".join(parts)
    return f"tol {r['tolerance']:.2g}" if isinstance(r.get("tolerance"), (int, float)) else "-"


if __name__ == "__main__":
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/reproductions")
    (root / "README.md").write_text(build(root))
    print(f"wrote {root / 'README.md'}")
