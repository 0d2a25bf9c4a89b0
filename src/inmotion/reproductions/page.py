"""The HTML page of the paper reproductions: summary table first, then a section per paper.

Built with the report's page machinery (:class:`inmotion.evaluate.report._Page`, its table and
styles), so it looks like every other ``inmotion`` report and is self-contained in the same
way: PNG figures embedded as base64 data URIs, inline styles, no script, no external reference.

Per paper the section holds its summary rows (paper figure, measured figure, verdict, note),
the per-paper markdown report converted to HTML (tables, headings, lists, paragraphs; images it
names are embedded from the paper's folder), and every other PNG of the folder. A failed
reproduction shows its error and traceback instead.
"""
from __future__ import annotations

import base64
import html
import re
from pathlib import Path

from ..io.safe_write import atomic_write
from ..evaluate.report import _Page, _table, _versions_section

__all__ = ["write_page", "markdown_to_html"]

_IMG = re.compile(r"!\[([^\]]*)\]\(([^)\s]+)\)")


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _img(path: Path, caption: str) -> str:
    b64 = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{b64}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _inline(text: str) -> str:
    """Escape, then ``code`` and **bold** (the only inline markdown the reports use)."""
    t = _e(text)
    t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", t)


def _md_table(lines) -> str:
    cells = [[c.strip() for c in ln.strip().strip("|").split("|")] for ln in lines]
    cells = [r for r in cells if not all(re.fullmatch(r":?-{2,}:?", c) for c in r if c)]
    head, body = cells[0], cells[1:]
    th = "".join(f"<th>{_inline(c)}</th>" for c in head)
    rows = "".join("<tr>" + "".join(f'<td class="l">{_inline(c)}</td>' for c in r) + "</tr>"
                   for r in body)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{rows}</tbody></table>"


def markdown_to_html(text: str, folder: Path, used: set) -> str:
    """The subset of markdown the per-paper reports write, as HTML.

    Headings (``#``), pipe tables, ``- `` lists, images ``![alt](file.png)`` (embedded from
    ``folder`` if the file is there; their names are added to ``used``) and paragraphs."""
    out, block, kind = [], [], None

    def flush():
        nonlocal block, kind
        if kind == "table":
            out.append(_md_table(block))
        elif kind == "list":
            out.append("<ul>" + "".join(f"<li>{_inline(x[2:])}</li>" for x in block) + "</ul>")
        elif kind == "para":
            out.append(f"<p>{_inline(' '.join(block))}</p>")
        block, kind = [], None

    for line in text.splitlines():
        s = line.strip()
        k = ("table" if s.startswith("|") else "list" if s.startswith("- ") else
             "blank" if not s else "head" if s.startswith("#") else
             "img" if _IMG.fullmatch(s) else "para")
        if k != kind or k in ("head", "img", "blank"):
            flush()
        if k == "head":
            level = min(6, len(s) - len(s.lstrip("#")) + 2)
            out.append(f"<h{level}>{_inline(s.lstrip('#').strip())}</h{level}>")
        elif k == "img":
            alt, name = _IMG.fullmatch(s).groups()
            p = folder / name
            if p.is_file():
                used.add(p.name)
                out.append(_img(p, alt))
        elif k != "blank":
            block.append(s)
            kind = k
    flush()
    return "\n".join(out)


def _counts(rows) -> dict:
    from ..evaluate.stats import count_verdicts
    return count_verdicts(rows)


def _summary_table(results) -> str:
    body = []
    for r in results:
        c = _counts(r["rows"])
        wall = r.get("wall_s")
        state = r["status"] + (" (reused)" if r.get("reused") else "")
        body.append([r["paper"], r["title"], (state, "worse" if r["status"] != "ok" else ""),
                     len(r["rows"]), (c["better"], "better"), c["same"], (c["worse"], "worse"),
                     c["not comparable"], c["undecided"], c["-"], c["ablation"],
                     "" if wall is None else f"{wall:.0f}"])
    return _table(["paper", "title", "status", "figures", "better", "same", "worse",
                   "not comparable", "undecided", "no paper figure", "ablations (apart)",
                   "wall s"], body, left=3)


def _rows_table(rows, with_paper=False) -> str:
    head = (["paper"] if with_paper else []) + ["quantity", "unit", "paper figure",
                                                 "measured", "verdict", "note"]
    body = [([r["_paper"]] if with_paper else [])
            + [r["quantity"], r.get("unit", ""), r.get("paper"), r.get("measured"),
               (r.get("verdict", "-"), r.get("verdict", "-")), (r.get("note", ""), "l")]
            for r in rows]
    return _table(head, body, left=3 if with_paper else 2)


def _paper_section(page: _Page, r: dict) -> None:
    folder = Path(r["out_dir"])
    page.add(f'<h2 id="paper-{_e(r["paper"])}">Paper {_e(r["paper"])}: {_e(r["title"])}</h2>')
    page.add(f"<p class=\"note\">files: <code>{_e(folder)}</code></p>")
    if r["status"] != "ok":
        page.add(f'<p class="worse">failed: {_e(r.get("error", ""))}</p>'
                 f"<pre>{_e(r.get('traceback', ''))}</pre>")
        return
    if r["rows"]:
        page.add("<h3>Paper against measured</h3>" + _rows_table(r["rows"]))
    used = set()
    for md in sorted(folder.glob("*.md")):
        page.add(f"<details open><summary>{_e(md.name)}</summary>"
                 + markdown_to_html(md.read_text(), folder, used) + "</details>")
    for png in sorted(folder.glob("*.png")):
        if png.name not in used:
            page.add(_img(png, png.name))


def write_page(path, results, title: str) -> Path:
    """Write the reproductions' page to ``path``; ``results`` are the per-paper summaries of
    :func:`inmotion.reproductions.suite.run_reproduction` (or failure records). Returns the path."""
    out = Path(path)
    page = _Page(title, out.parent / f"{out.stem}_figures")
    page.add("<h2>Summary</h2>" + _summary_table(results))
    all_rows = [dict(row, _paper=r["paper"]) for r in results for row in r["rows"]]
    if all_rows and len(results) > 1:
        page.add("<h2>Every paper figure against the measured one</h2>"
                 "<p class=\"note\">verdict: better / worse than the paper in the row's sense "
                 "(lower, or closer to 0 for a mean error) only beyond the Monte Carlo "
                 "uncertainty of both figures and for the same statistic over comparable sample "
                 "sizes; same within it; not comparable (the reason is given) or undecided (no "
                 "uncertainty); - where one figure is missing. Ablations of our own are rows of "
                 "kind 'ablation', not counted. Notes say how each measured figure is taken.</p>"
                 + _rows_table(all_rows, with_paper=True))
    for r in results:
        _paper_section(page, r)
    _versions_section(page, None)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = page.html()
    atomic_write(out, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return out
