"""Reading the numeric tables of foreign formats, with one clear message when they are wrong.

Every failure is :class:`inmotion.errors.BadInput` naming the file, the 1-based data row and,
where the time column could be read, the time.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ...errors import BadInput

__all__ = ["existing_file", "existing_dir", "read_text_table", "check_finite"]


def existing_file(path, what="file") -> Path:
    """``path`` as a :class:`Path`, or BadInput if it is not an existing file."""
    p = Path(path)
    if not p.is_file():
        raise BadInput(f"{what} not found" if not p.exists() else f"{what} is not a file", p)
    return p


def existing_dir(path, what="folder") -> Path:
    """``path`` as a :class:`Path`, or BadInput if it is not an existing folder."""
    p = Path(path)
    if not p.is_dir():
        raise BadInput(f"{what} not found" if not p.exists() else f"{what} is not a folder", p)
    return p


def read_text_table(path, ncols, what="table") -> np.ndarray:
    """A headerless numeric text table, columns separated by spaces, tabs or commas.

    Parameters
    ----------
    path : the file
    ncols : int or tuple of ints, the allowed numbers of columns (all rows alike)
    what : the table's name in messages

    Returns
    -------
    (N, ncols) float64; text after ``#`` is a comment.

    The table is parsed by pandas' C reader straight into float64 (memory: the output array);
    only when that fails is the file walked line by line to name the first bad row.
    """
    p = existing_file(path, what)
    allowed = (ncols,) if isinstance(ncols, int) else tuple(ncols)
    data = _fast_parse(p)
    if data is None or data.shape[1] not in allowed or not np.isfinite(data).all():
        _diagnose(p, allowed, what)           # raises with the file, row and time
        raise BadInput(f"{what} could not be read as a numeric table", p)
    return data


def _first_data_line(p):
    with open(p, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.strip() and not line.lstrip().startswith("#"):
                return line
    return ""


def _fast_parse(p):
    """float64 array, or None if the C reader cannot parse the file cleanly."""
    first = _first_data_line(p)
    if not first:
        return None
    sep = "," if "," in first else r"\s+"
    try:
        df = pd.read_csv(p, sep=sep, header=None, comment="#", dtype=float,
                         skipinitialspace=True, engine="c")
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    return df.to_numpy(dtype=float)


def _diagnose(p, allowed, what):
    """Walk the file and raise BadInput at the first malformed row."""
    width, row = None, 0
    with open(p, encoding="utf-8", errors="replace") as f:
        for line in f:
            fields = line.split("#", 1)[0].replace(",", " ").split()
            if not fields:
                continue
            row += 1
            if width is None:
                width = len(fields)
                if width not in allowed:
                    raise BadInput(f"{what} must have {' or '.join(map(str, allowed))} "
                                   f"columns, got {width}", p, row=row)
            if len(fields) != width:
                raise BadInput(f"{what} row has {len(fields)} columns, expected {width}", p,
                               row=row)
            values = pd.to_numeric(pd.Series(fields), errors="coerce").to_numpy(dtype=float)
            if not np.isfinite(values).all():
                time = float(values[0]) if np.isfinite(values[0]) else None
                raise BadInput(f"{what}: value that is not a finite number", p, row=row,
                               time=time)
    if row == 0:
        raise BadInput(f"{what} has no data rows", p)


def as_float(a, file, what) -> np.ndarray:
    """``a`` as a float64 array, or BadInput if it holds text or objects that are no numbers."""
    try:
        return np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise BadInput(f"{what}: not numbers ({str(exc).splitlines()[0][:80]})", file) from None


def check_order(order) -> int:
    """The rate-integration order option: 2 (trapezoid) or 4 (cubic)."""
    if order not in (2, 4) or isinstance(order, bool):
        raise BadInput(f"option order={order!r}: must be 2 (trapezoid) or 4 (cubic)")
    return int(order)


def check_finite(data, file, what, t=None, first_row=1):
    """BadInput at the first row of ``data`` (N, ...) holding a NaN, inf or non-number."""
    data = as_float(data, file, what)
    bad = ~np.isfinite(data.reshape(len(data), -1)).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        time = None if t is None or not np.isfinite(t[i]) else float(t[i])
        raise BadInput(f"{what}: value that is not a finite number", file,
                       row=i + first_row, time=time)
