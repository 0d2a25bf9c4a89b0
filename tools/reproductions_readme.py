"""Write ``docs/reproductions/README.md`` from the ``paper_rows.json`` of each folder there.

Usage: ``python tools/reproductions_readme.py [DIR]`` (default ``docs/reproductions``). The
folders are snapshots of ``inmotion reproduce P -o DIR`` (``report.md``, PNGs and
``paper_rows.json``); this script only tabulates their rows, it measures nothing.
"""
from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

ORDER = ("000", "001", "002", "003", "004", "real")
VERDICTS = ("better", "same", "worse")


def _fmt(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def build(root: Path) -> str:
    rows = {p: json.loads((root / p / "paper_rows.json").read_text())["rows"]
            for p in ORDER if (root / p / "paper_rows.json").exists()}
    L = [f"# Paper reproductions: snapshot (tabulated at commit {_commit()})", "",
         "Each folder holds the output of `inmotion reproduce P --workers 2 -o DIR` on the "
         "project's 2-core machine: the paper's `report.md` (tables beside the paper's "
         "figures, notes on every shortfall), its PNG figures and `paper_rows.json`. This "
         "page is written from those files by `tools/reproductions_readme.py`. Regenerate "
         "everything with `inmotion reproduce all -o DIR` (one self-contained HTML page).", "",
         "| paper | better | same | worse | no paper figure |",
         "| --- | ---: | ---: | ---: | ---: |"]
    for p, rs in rows.items():
        c = Counter(r["verdict"] if r["verdict"] in VERDICTS else "-" for r in rs)
        L.append(f"| [{p}]({p}/report.md) | {c['better']} | {c['same']} | {c['worse']} | "
                 f"{c['-']} |")
    L += ["", "| paper | quantity | unit | paper | measured | verdict |",
          "| --- | --- | --- | ---: | ---: | --- |"]
    for p, rs in rows.items():
        for r in rs:
            L.append(f"| {p} | {r['quantity']} | {r['unit']} | {_fmt(r['paper'])} | "
                     f"{_fmt(r['measured'])} | {r['verdict']} |")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/reproductions")
    (root / "README.md").write_text(build(root))
    print(f"wrote {root / 'README.md'}")
