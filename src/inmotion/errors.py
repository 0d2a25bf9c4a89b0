"""Exceptions that the command line turns into exit statuses.

:class:`BadInput` is the user's input being wrong (a file, a row, a value, a configuration):
the CLI prints its one-line message and exits with status 2. Anything else is an internal
failure (exit 1).
"""
from __future__ import annotations

import math
import re

__all__ = ["BadInput"]


class BadInput(ValueError):
    """Input that cannot be used, with where it is: ``file``, ``row`` (1-based data row),
    ``time`` [s] and what is wrong. ``str()`` is the one message the user sees."""

    def __init__(self, what: str, file=None, row=None, time=None):
        # the user wrote YAML or typed options: a missing value is "null" to them, never
        # Python's None (``'runs' must be an integer >= 1, got null``)
        what = re.sub(r"\bNone\b", "null", str(what))
        if time is not None and not math.isfinite(time):
            time = None
        self.what, self.file, self.row, self.time = what, file, row, time
        where = []
        if file is not None:
            where.append(str(file))
        if row is not None:
            where.append(f"row {row}")
        if time is not None:
            where.append(f"t={time:.6g} s")
        super().__init__((", ".join(where) + ": " if where else "") + what)
