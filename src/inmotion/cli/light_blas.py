"""The command line's start-up shortcut for numba's CPU target (issue 13: a run's fixed cost).

Kept apart from :mod:`inmotion.cli.main` so that ``benchmarks/bench_startup.py`` can measure
numba's floor with it in a bare interpreter (this module imports nothing heavy).
"""
from __future__ import annotations

import sys

__all__ = ["light_numba_blas"]


def light_numba_blas() -> bool:
    """Load the one SciPy module numba's CPU target needs before it needs it, without the
    package ``scipy.linalg`` around it. Returns whether it did.

    The first call of any numba kernel builds numba's CPU target, which checks for a BLAS by
    ``import scipy.linalg.cython_blas`` (``numba.np.linalg.ensure_blas``, whatever the
    kernel does); Python imports the parent package first, and ``scipy.linalg``'s
    ``__init__`` costs about 0.12 s (``scipy._lib._util``, the array-API layer): a seventh of
    a short command. Here, before a method runs, the extension module
    ``scipy/linalg/cython_blas`` is imported under an empty stand-in for ``scipy.linalg``
    (and for ``scipy``, where ``import numba`` has not imported it yet) removed right
    after, so ``sys.modules`` then holds the real ``cython_blas`` (all numba uses: its
    function pointers) and no ``scipy.linalg``; numba's own import finds it; a later
    ``import scipy.linalg`` runs the real ``__init__``, which finds ``cython_blas``
    loaded. Skipped where ``scipy.linalg`` is already imported, with
    ``INMOTION_LIGHT_BLAS=0``, and on any failure (the stand-ins are removed and numba
    imports SciPy its own way). ``scipy`` itself has a lazy ``__getattr__``: nothing here
    reads ``scipy.linalg`` as an attribute, which would import the package. (The one trace
    left: the real ``scipy.linalg``, once imported, lacks the attribute ``cython_blas``;
    ``from scipy.linalg import cython_blas`` and ``import scipy.linalg.cython_blas`` find
    it.)
    """
    import importlib.machinery
    import importlib.util
    import os
    import types
    if (os.environ.get("INMOTION_LIGHT_BLAS") == "0" or "scipy.linalg" in sys.modules
            or "scipy.linalg.cython_blas" in sys.modules):
        return False
    try:
        spec = importlib.util.find_spec("scipy")
        root = spec.submodule_search_locations[0]
    except Exception:
        return False
    stubs = []
    try:
        for name, path in (("scipy", root), ("scipy.linalg", os.path.join(root, "linalg"))):
            if name in sys.modules:        # the real top-level package (numba imports it)
                continue
            m = types.ModuleType(name)
            m.__path__ = [path]
            m.__spec__ = importlib.machinery.ModuleSpec(name, None, is_package=True)
            m.__spec__.submodule_search_locations = [path]
            sys.modules[name] = m
            stubs.append(name)
        importlib.import_module("scipy.linalg.cython_blas")
        return True
    except Exception:
        sys.modules.pop("scipy.linalg.cython_blas", None)
        return False
    finally:
        for name in stubs:
            del sys.modules[name]
