"""Ahead-of-time compiled kernels: the run path of ``navigate --method sins / sins-dr``
without numba (issue 13: a command-line run's fixed cost).

A run that calls a numba kernel pays for numba's import (~0.24 s) and for the first call's
build of its CPU target (~0.15 s) before any kernel runs, more than issue 13's 0.4 s target
for a whole run. :mod:`inmotion._aot_build` (a step of ``python -m inmotion.warmup``, which
``make install`` runs) compiles, with ``numba.pycc``, the kernels those runs call into one
C extension module; this module finds that extension and calls it, and never imports numba.

What the extension holds (:mod:`inmotion._aot_build`):

* per filter *case* (the ``sins`` and ``sins-dr`` methods' filters as the command line builds
  them): the engine's loop :func:`inmotion.estimation.engine._advance` with that case's fill
  and accumulator functions bound as constants (the JIT path passes them as first-class
  function arguments; the compiled loop is the same function, called through the same
  function-pointer code), :func:`~inmotion.estimation.engine._mode` and
  :func:`~inmotion.estimation.engine._write_output`, each for the argument types of that case;
* per predict kernel (one per F pattern, :mod:`inmotion.estimation.predict`): the generated
  kernel, whose address the filter's workspace holds;
* the numba functions those runs call from Python through :func:`call`
  (:func:`inmotion.estimation.error_model._fill_F` for ``F_pattern``, the pure SINS's
  ``sins_run`` and ``time_steps``) and the two input checks of :mod:`inmotion.core._kernels`
  the bundle readers call.

The results are bit-identical to the JIT path's (the same numba front end and LLVM; the
predict kernel is lowered into the extension from its source, not linked from numba's
optimized JIT module: linked, it was optimized twice, and LLVM fused the first two products
of some sums the other way, a last-bit difference; ``tests/test_aot.py`` compares whole runs).

Staleness: the extension's file name carries :func:`source_key`, a hash of every source file
whose code the kernels compile (``inmotion/core``, ``inmotion/estimation``,
``inmotion/_jit.py``), of numba's version file and of the CPU (``/proc/cpuinfo``'s flags: the
code is built for the host's CPU): an edited kernel changes the key, the old extension is no
longer found, and the run takes the JIT path (``python -m inmotion.warmup`` builds the new
one). A case is used only when its fill functions (by name) and the type of every argument
(:func:`type_spec`: dtype, dimensions, contiguity, writability) are those it was built for;
anything else (another method, another configuration that changes the layout or the
measurements) takes the JIT path, as before. ``INMOTION_AOT=0`` switches the extension off.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import tempfile
from pathlib import Path

__all__ = ["source_key", "type_spec", "enabled", "module", "kernel_address", "case",
           "first_nonfinite_row", "first_not_increasing", "call", "aot_dirs",
           "EXT_PREFIX"]

#: bump when the extension's layout (its exports, the manifest) changes meaning
FORMAT = "inmotion-aot 1"
EXT_PREFIX = "inmotion_aot_"
_ROOT = Path(__file__).resolve().parent
#: the sources whose code the compiled kernels contain (numba compiles what they reach)
_SOURCE_DIRS = ("core", "estimation")
_SOURCE_FILES = ("_jit.py",)

_state: dict = {}


def enabled() -> bool:
    """The extension may be used (``INMOTION_AOT`` is not ``0``)."""
    return os.environ.get("INMOTION_AOT", "1") != "0"


def _cpu_flags() -> bytes:
    try:
        with open("/proc/cpuinfo", "rb") as f:
            for line in f:
                if line.startswith((b"flags", b"Features")):
                    return line
    except OSError:
        pass
    import platform
    return platform.processor().encode() + platform.machine().encode()


def source_key() -> str:
    """Hash of the kernels' sources, numba's version file, the CPU and this module's format
    (the extension's name carries it; ~1 ms: read and hash ~30 files)."""
    key = _state.get("key")
    if key is None:
        h = hashlib.sha256(FORMAT.encode())
        files = [p for d in _SOURCE_DIRS for p in sorted((_ROOT / d).glob("*.py"))]
        files += [_ROOT / f for f in _SOURCE_FILES if (_ROOT / f).is_file()]
        for p in files:
            h.update(p.name.encode())
            h.update(p.read_bytes())
        spec = importlib.util.find_spec("numba")       # finds, does not import
        if spec is not None and spec.origin:
            try:
                h.update((Path(spec.origin).parent / "_version.py").read_bytes())
            except OSError:
                h.update(spec.origin.encode())
        h.update(_cpu_flags())
        h.update(sys.version.encode())
        key = _state["key"] = h.hexdigest()[:20]
    return key


def aot_dirs():
    """Where the extension is looked for and built: ``$INMOTION_AOT_DIR``, else
    ``__pycache__/aot`` beside this file, else the user's cache directory."""
    env = os.environ.get("INMOTION_AOT_DIR")
    if env:
        yield Path(env)
    yield _ROOT / "__pycache__" / "aot"
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    yield Path(cache) / "inmotion" / "aot"
    yield Path(tempfile.gettempdir()) / f"inmotion-aot-{os.getuid()}"


def module():
    """``(extension module, manifest)`` for the current sources, or ``None`` (none built,
    stale, switched off, or it failed to load)."""
    if "module" in _state:
        return _state["module"]
    found = None
    if enabled():
        name = EXT_PREFIX + source_key()
        for d in aot_dirs():
            manifest = d / f"{name}.json"
            if not manifest.is_file():
                continue
            for suffix in importlib.machinery.EXTENSION_SUFFIXES:
                path = d / f"{name}{suffix}"
                if path.is_file():
                    try:
                        man = json.loads(manifest.read_text())
                        spec = importlib.util.spec_from_file_location(name, path)
                        mod = importlib.util.module_from_spec(spec)
                        spec.loader.exec_module(mod)
                        sys.modules[name] = mod
                    except (OSError, ImportError, ValueError):
                        continue
                    found = (mod, man)
                    break
            if found:
                break
    _state["module"] = found
    return found


def type_spec(obj) -> str:
    """A string naming the numba type ``obj`` would have as an argument (arrays: dtype,
    dimensions, layout, writability; tuples: their class and members; scalars: kind), without
    numba: two objects with the same spec have the same numba type."""
    import numpy as np
    if isinstance(obj, np.ndarray):
        f = obj.flags
        lay = "C" if f.c_contiguous else "F" if f.f_contiguous else "A"
        return f"{obj.dtype.str}{obj.ndim}{lay}{'' if f.writeable else 'r'}"
    if isinstance(obj, tuple):
        return f"{type(obj).__name__}(" + ",".join(type_spec(a) for a in obj) + ")"
    if isinstance(obj, (bool, np.bool_)):
        return "b"
    if isinstance(obj, (int, np.integer)):
        return "i8" if isinstance(obj, int) else f"i{obj.dtype.str}"
    if isinstance(obj, (float, np.floating)):
        return "f8" if isinstance(obj, float) else f"f{obj.dtype.str}"
    return f"?{type(obj).__name__}"


def kernel_address(kernel_key: str):
    """Address of the compiled predict kernel of source hash ``kernel_key`` in the
    extension, or ``None``."""
    found = module()
    if found is None:
        return None
    mod, man = found
    export = man["kernels"].get(kernel_key)
    return None if export is None else int(getattr(mod, export)())


class Case:
    """One filter case's compiled functions (``advance``, ``mode``, ``write_output``) and the
    argument types ``advance`` was built for (``args_spec``: the spec of each argument after
    ``S``, ``C``)."""

    def __init__(self, mod, entry):
        i = entry["index"]
        self.advance = getattr(mod, f"advance_{i}")
        self.mode = getattr(mod, f"mode_{i}")
        self.write_output = getattr(mod, f"write_output_{i}")
        self.args_spec = tuple(entry["args"])
        self.out_spec = entry["out"]


def case_key(fills, accs, S, C) -> str:
    """The key of a filter case: its fill and accumulator functions' names and the types of
    its state ``S`` and constants ``C``."""
    return hashlib.sha256(json.dumps([list(fills), list(accs), type_spec(S), type_spec(C)])
                          .encode()).hexdigest()[:24]


def case(fills, accs, S, C):
    """The compiled :class:`Case` of a filter (names of its fill and accumulator functions,
    its ``S`` and ``C``), or ``None``."""
    found = module()
    if found is None:
        return None
    mod, man = found
    entry = man["cases"].get(case_key(fills, accs, S, C))
    return None if entry is None else Case(mod, entry)


def _common(name, *args):
    """The extension's ``name`` on ``args`` when their types are the ones it was built for,
    else ``None``."""
    found = module()
    if found is not None:
        mod, man = found
        want = man["common"].get(name)
        if want is not None and want == [type_spec(a) for a in args]:
            return getattr(mod, name)
    return None


def _checker(name, a, ndim):
    """The extension's ``name`` (built for float64 arrays of ``ndim`` dimensions, any
    layout) if ``a`` is one, else the JIT kernel of :mod:`inmotion.core._kernels`."""
    found = module()
    if (found is not None and name in found[1]["common"] and getattr(a, "ndim", -1) == ndim
            and a.dtype.str == "<f8"):
        return getattr(found[0], name)
    from .core import _kernels as K
    return getattr(K, name)


def first_nonfinite_row(a) -> int:
    """:func:`inmotion.core._kernels.first_nonfinite_row` (ahead of time when available)."""
    return _checker("first_nonfinite_row", a, 2)(a)


def first_not_increasing(t) -> int:
    """:func:`inmotion.core._kernels.first_not_increasing` (ahead of time when available)."""
    return _checker("first_not_increasing", t, 1)(t)


def call(name: str, jit, *args):
    """``jit(*args)`` (a numba function called from Python), through the extension's
    ``name`` when it has one built for the arguments' types."""
    fn = _common(name, *args)
    return (jit if fn is None else fn)(*args)
