"""numba's ``njit`` and ``intrinsic``, applied at first use: importing a module of kernels
does not import numba (issue 13).

A run whose kernels are compiled ahead of time (:mod:`inmotion._aot`) never calls a numba
function, and numba's import alone costs ~0.24 s of a command's ~0.7 s. So the modules on
that run path decorate their kernels with these instead of numba's: ``njit(**options)(f)``
and ``intrinsic(f)`` return a stand-in that records ``f`` and its options. The first use of
any stand-in (a call from Python, or any attribute, e.g. ``.overloads``) imports numba,
applies the real decorators to every recorded function, and puts the numba objects in
place of the stand-ins in the module namespaces of the package (so that numba, compiling a
kernel, finds numba functions as the globals it calls); decorations after that are applied
at once. Nothing changes for the JIT path but when numba is imported: the same decorators
with the same options on the same functions.

A stand-in kept elsewhere than in the package's namespaces (a test module that imported a
kernel before numba was, a tuple, a class attribute) stays a stand-in: calling it forwards to
the numba object, and numba types it as that object (``_numba_type_``), so numba code can
call it too.
"""
from __future__ import annotations

import sys

__all__ = ["njit", "intrinsic", "numba_module", "loaded", "real"]

_pending: list = []          # stand-ins not yet given their numba object
_numba = None


def loaded() -> bool:
    """numba has been imported and the stand-ins replaced."""
    return _numba is not None


def numba_module():
    """The ``numba`` module, every stand-in replaced by its numba object (imports numba)."""
    global _numba
    if _numba is None:
        import numba
        _numba = numba
        for s in _pending:
            s._build()
        _pending.clear()
        for name, mod in list(sys.modules.items()):
            if name == "inmotion" or name.startswith("inmotion."):
                ns = getattr(mod, "__dict__", None) or {}
                for k, v in list(ns.items()):
                    if isinstance(v, _StandIn):
                        ns[k] = v._real
    return _numba


class _StandIn:
    """A function to be decorated by numba at the first use of any stand-in."""

    def __init__(self, func, make):
        self._func, self._make, self._real = func, make, None
        for a in ("__module__", "__name__", "__qualname__", "__doc__"):
            setattr(self, a, getattr(func, a, None))
        self.py_func = func

    def _build(self):
        if self._real is None:
            self._real = self._make(self._func)

    def __call__(self, *args, **kw):
        numba_module()
        return self._real(*args, **kw)

    def __getattr__(self, name):          # only for attributes the stand-in does not have
        if name.startswith("__"):
            raise AttributeError(name)
        numba_module()
        return getattr(self._real, name)

    @property
    def _numba_type_(self):
        """numba's type of the real object (how numba types a stand-in that code outside
        the package's namespaces, e.g. a test module, imported before numba was)."""
        numba_module()
        from numba.core.registry import cpu_target
        return cpu_target.typing_context.resolve_value_type(self._real)

    def __repr__(self):
        return f"<numba function {self.__qualname__} (not yet compiled)>"

    def __reduce__(self):                 # by reference, as a module-level function
        return _by_name, (self.__module__, self.__qualname__)


def _by_name(module, qualname):
    import importlib
    return getattr(importlib.import_module(module), qualname)


def real(f):
    """``f`` itself, or the numba object of a stand-in (imports numba)."""
    if isinstance(f, _StandIn):
        numba_module()
        return f._real
    return f


def _decorate(make):
    def apply(func):
        if _numba is not None:
            return make(func)
        s = _StandIn(func, make)
        _pending.append(s)
        return s
    return apply


def njit(*args, **options):
    """``numba.njit(**options)``, applied at first use (module docstring). Only the keyword
    form (``@njit(cache=True)``, ``njit(cache=True)(f)``) and an explicit signature as the one
    positional argument."""
    if len(args) > 1 or (args and callable(args[0]) and not options):
        raise TypeError("njit: use @njit(...) with keyword options")
    return _decorate(lambda f: _numba.njit(*args, **options)(f))


def intrinsic(func):
    """``numba.extending.intrinsic(func)``, applied at first use."""
    def make(f):
        from numba.extending import intrinsic as real
        return real(f)
    return _decorate(make)(func)
