"""``docs/extending.md`` runs as written: its ``python`` code blocks, in order, make one module
(written to a temporary file, so that numba can cache the fill function like any module's) that
is imported, so the page cannot drift from the code. They define a measurement
outside the package (a wheel-speed sensor with its own scale state ``dk``), check its ``H``
by central differences against the nonlinear model, run it through the engine on simulated
truth, then wrap it as a method, register it and run it by name against the demo drive's
truth (its odometer's 2000 ppm scale factor estimated)."""
import importlib
import re
import sys
from pathlib import Path

import numba

from inmotion import registry

DOC = Path(__file__).resolve().parents[1] / "docs" / "extending.md"


def _blocks():
    return re.findall(r"^```python\n(.*?)^```", DOC.read_text(), re.S | re.M)


def test_the_extending_page_runs_as_written(capsys, tmp_path, monkeypatch):
    blocks = _blocks()
    assert len(blocks) >= 5
    name = "extending_doc_example"
    (tmp_path / f"{name}.py").write_text(
        "".join(f"# ---- {DOC.name}, block {i + 1}\n{code}\n" for i, code in enumerate(blocks)))
    monkeypatch.syspath_prepend(str(tmp_path))
    n_specs = len(registry._SPECS)
    try:
        ns = importlib.import_module(name).__dict__
        assert isinstance(ns["fill_wheel_speed"], numba.core.registry.CPUDispatcher)
        assert ns["f"].counts()["wheel_speed"]["used"] > 1000
        assert ns["sol"].info["method"] == "sins-wheel"
        out = capsys.readouterr().out
        assert "dk = " in out and "sins-wheel: " in out
    finally:
        del registry._SPECS[n_specs:]
        sys.modules.pop(name, None)


def test_register_refuses_a_taken_name_or_a_bad_kind():
    import pytest
    spec = registry.get("sins")
    with pytest.raises(ValueError, match="already registered"):
        registry.register(spec)
    with pytest.raises(ValueError, match="kind"):
        registry.register(registry.MethodSpec("x-y", "smooth", "a:b", "a:c", True, ""))
    with pytest.raises(ValueError, match="lower-case"):
        registry.register(registry.MethodSpec("Bad Name", "align", "a:b", "a:c", True, ""))
