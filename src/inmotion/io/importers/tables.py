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
    (N, ncols) float64; lines starting with ``#`` or ``%`` are comments.
    """
    p = existing_file(path, what)
    allowed = (ncols,) if isinstance(ncols, int) else tuple(ncols)
    lines = [ln.replace(",", " ").split() for ln in p.read_text().splitlines()]
    rows = [ln for ln in lines if ln and not ln[0].startswith(("#", "%"))]
    if not rows:
        raise BadInput(f"{what} has no data rows", p)
    width = len(rows[0])
    if width not in allowed:
        raise BadInput(f"{what} must have {' or '.join(map(str, allowed))} columns, "
                       f"got {width}", p, row=1)
    for i, r in enumerate(rows):
        if len(r) != width:
            raise BadInput(f"{what} row has {len(r)} columns, expected {width}", p, row=i + 1)
    frame = pd.DataFrame(np.array(rows, dtype=str))
    data = frame.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    check_finite(data, p, what, t=data[:, 0])
    return data


def check_finite(data, file, what, t=None, first_row=1):
    """BadInput at the first row of ``data`` (N, ...) holding a NaN, inf or non-number."""
    data = np.asarray(data, dtype=float)
    bad = ~np.isfinite(data.reshape(len(data), -1)).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        time = None if t is None or not np.isfinite(t[i]) else float(t[i])
        raise BadInput(f"{what}: value that is not a finite number", file,
                       row=i + first_row, time=time)
