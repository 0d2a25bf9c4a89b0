"""Imports point downward only (docs/ARCHITECTURE.md): read from the source with ``ast``.

- nothing in the library imports :mod:`inmotion.reproductions` (the experiments sit above it;
  only the command line's ``reproduce`` command reaches them);
- ``inmotion.io`` and ``inmotion.core`` never import ``inmotion.evaluate`` (the error metrics
  live in ``inmotion.core.metrics``).
"""
import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "inmotion"


def _imports(path: Path) -> set[str]:
    """Absolute module names a file imports (relative imports resolved against its package)."""
    rel = path.relative_to(SRC.parent).with_suffix("")
    package = list(rel.parts[:-1]) if rel.name != "__init__" else list(rel.parts[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
    return out


def _source_files():
    """The package's source files (not the predict kernels generated into ``__pycache__``)."""
    return [p for p in sorted(SRC.rglob("*.py")) if "__pycache__" not in p.parts]


def _library_files(exclude: tuple[str, ...]):
    for p in _source_files():
        top = p.relative_to(SRC).parts[0]
        if top not in exclude:
            yield p


def test_the_resolver_sees_a_relative_import(tmp_path):
    # the check below would pass vacuously if relative imports were not resolved
    got = _imports(SRC / "io" / "result.py")
    assert "inmotion.core.metrics" in got and "inmotion.core.rotations" in got


@pytest.mark.parametrize("path", list(_library_files(("reproductions", "cli"))),
                         ids=lambda p: str(p.relative_to(SRC)))
def test_the_library_does_not_import_the_reproductions(path):
    bad = {m for m in _imports(path) if m.startswith("inmotion.reproductions")}
    assert not bad, f"{path.relative_to(SRC)} imports {sorted(bad)}"


@pytest.mark.parametrize("path", [p for p in _source_files()
                                  if p.relative_to(SRC).parts[0] in ("io", "core")],
                         ids=lambda p: str(p.relative_to(SRC)))
def test_io_and_core_do_not_import_evaluate(path):
    bad = {m for m in _imports(path) if m.startswith("inmotion.evaluate")}
    assert not bad, f"{path.relative_to(SRC)} imports {sorted(bad)}"
