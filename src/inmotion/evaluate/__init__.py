"""inmotion.evaluate: errors against truth (:mod:`.metrics`), campaigns, reproductions, reports.

The package is also the function ``inmotion.evaluate(solution, truth, window_s=100.0)``
(:func:`inmotion.api.evaluate`: the ``errors`` block of ``summary.json``). A package and a
function cannot both own the name ``inmotion.evaluate`` (importing any ``inmotion.evaluate.*``
module rebinds it to the package), so the package is callable and calls the function.
"""
import sys as _sys
import types as _types


class _CallablePackage(_types.ModuleType):
    def __call__(self, solution, truth, window_s: float = 100.0) -> dict:
        """:func:`inmotion.api.evaluate`: the errors block of ``solution`` against truth."""
        from ..api import evaluate
        return evaluate(solution, truth, window_s)


_sys.modules[__name__].__class__ = _CallablePackage
