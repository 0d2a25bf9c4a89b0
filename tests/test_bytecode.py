"""The warm-up writes the byte-code a command reads (issue 13, a CLI run's fixed cost): where
Python may not write ``.pyc`` files itself (``PYTHONDONTWRITEBYTECODE=1``, a read-only
install), every command would otherwise compile the source of each module it imports
(measured 0.10 s of CPU for ``navigate --method sins-dr``). Checked by what the interpreter
reports (``python -v``: ``code object from '...pyc'`` for byte-code read, from the ``.py`` for
source compiled), not by the warm-up's own bookkeeping.
"""
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

from inmotion.warmup import compile_bytecode

ROOT = Path(importlib.util.find_spec("inmotion").origin).resolve().parent


def _loaded_from(code, path_prefix):
    """``{module file: 'pyc' | 'source'}`` for the files under ``path_prefix`` that a fresh
    interpreter, not allowed to write byte-code, loads while running ``code``."""
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    err = subprocess.run([sys.executable, "-v", "-c", code], capture_output=True, text=True,
                         env=env, check=True).stderr
    out = {}
    for m in re.finditer(r"^# code object from '?([^'\n]+?)'?$", err, re.M):
        p = m.group(1)
        if p.startswith(str(path_prefix)):
            src = p if p.endswith(".py") else importlib.util.source_from_cache(p)
            out[src] = "source" if p.endswith(".py") else "pyc"
    return out


def test_after_the_warm_up_the_run_path_reads_byte_code():
    compile_bytecode()
    got = _loaded_from("import inmotion.cli.main, inmotion.navigate.sins_dr, "
                       "inmotion.io.bundle_stream, inmotion.io.result", ROOT)
    assert len(got) > 20                         # the run path's modules were seen
    compiled = sorted(p for p, how in got.items() if how == "source")
    assert not compiled, f"compiled from source: {compiled}"


def test_a_generated_kernel_module_gets_its_byte_code(tmp_path):
    """A module the engine generates and loads by file (as the predict kernels are) is
    byte-compiled too."""
    src = tmp_path / "predict_test.py"
    src.write_text("X = 41 + 1\n")
    name = "inmotion_predict_test_bytecode"
    spec = importlib.util.spec_from_file_location(name, src)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    try:
        spec.loader.exec_module(mod)
        assert compile_bytecode() >= 1
        assert compile_bytecode() == 0            # up to date now: nothing compiled again
    finally:
        del sys.modules[name]
    code = (f"import importlib.util as u; s = u.spec_from_file_location('m', {str(src)!r}); "
            "m = u.module_from_spec(s); s.loader.exec_module(m); assert m.X == 42")
    assert _loaded_from(code, tmp_path) == {str(src): "pyc"}
