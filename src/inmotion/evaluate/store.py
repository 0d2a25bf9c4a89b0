"""A campaign's results on disk: one Parquet dataset, written run by run, safe to kill.

Layout of ``DIR/results/``::

    journal-<id>.jsonl             runs finished since the last compaction, one JSON line each
    point-PPPP/part-<id>.parquet   compacted rows of point PPPP (the dataset, partitioned by point)

Each finished run is appended to the journal as one line and flushed to the operating system at
once (tens of microseconds), so a campaign killed at any moment keeps every run that finished;
a line cut short by the kill is ignored when read. Every ``compact_every`` runs or
``compact_after_s`` seconds (and when the campaign ends) the journal's rows are written as one Parquet part per point (to a temporary name,
then renamed) and the journal is deleted; a kill between the two leaves rows in both, which
reading removes (a run's rows are identical). ``pyarrow.dataset`` / ``pandas.read_parquet`` read
the parts directly; :meth:`ResultStore.table` adds the journal.

Arrays a run returns go to ``DIR/arrays/point-PPPP/run-RRRRRR.npz`` (written whole, renamed).
Only one campaign process writes a directory at a time.
"""
from __future__ import annotations

import json
import os
import time
import uuid
from pathlib import Path
from typing import Iterable, Optional

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

__all__ = ["ResultStore", "KEY"]

#: the columns that name a run
KEY = ("point_id", "run_index")


def _part_dir(point_id: int) -> str:
    return f"point-{int(point_id):04d}"


def _table(records) -> pa.Table:
    """Rows to an Arrow table with the union of their columns (``pa.Table.from_pylist`` keeps
    only the first row's columns: an error row first would drop every result column)."""
    columns = dict.fromkeys(k for r in records for k in r)
    return pa.Table.from_pydict({k: [r.get(k) for r in records] for k in columns})


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not a scalar: {o!r}")


class ResultStore:
    """The results of the campaign in ``root`` (see the module notes).

    Parameters
    ----------
    root : path
        The campaign directory.
    compact_every : int
        Runs between two compactions of the journal into Parquet parts.
    compact_after_s : float
        Or seconds since the journal's first pending run, whichever comes first, so a reader of
        the Parquet dataset alone is never far behind.
    """

    def __init__(self, root, compact_every: int = 500, compact_after_s: float = 60.0):
        self.root = Path(root)
        self.results = self.root / "results"
        self.arrays = self.root / "arrays"
        self.compact_every = int(compact_every)
        self.compact_after_s = float(compact_after_s)
        self._journal = None
        self._pending = []
        self._since = 0.0

    # ------------------------------------------------------------------ writing
    def write(self, record: dict, arrays: Optional[dict] = None) -> None:
        """Record one finished run (and its arrays); durable against a kill on return."""
        if arrays:
            self._write_arrays(record, arrays)
        if self._journal is None:
            self.results.mkdir(parents=True, exist_ok=True)
            path = self.results / f"journal-{uuid.uuid4().hex[:12]}.jsonl"
            self._journal = (path, open(path, "a", encoding="utf-8"))
        line = json.dumps(record, default=_json_default, allow_nan=True)
        self._journal[1].write(line + "\n")
        self._journal[1].flush()
        if not self._pending:
            self._since = time.monotonic()
        self._pending.append(record)
        if (len(self._pending) >= self.compact_every
                or time.monotonic() - self._since >= self.compact_after_s):
            self.compact()

    def compact(self) -> None:
        """Write the pending rows as Parquet parts (one per point) and drop the journal."""
        if self._journal is not None:
            path, f = self._journal
            f.close()
            self._journal = None
            self._write_parts(self._pending)
            self._pending = []
            path.unlink(missing_ok=True)

    def close(self) -> None:
        self.compact()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _write_parts(self, records) -> None:
        by_point = {}
        for r in records:
            by_point.setdefault(int(r["point_id"]), []).append(r)
        token = uuid.uuid4().hex[:12]
        for pid, rows in by_point.items():
            table = _table(rows)
            target = self.results / _part_dir(pid) / f"part-{token}.parquet"
            self._atomic(target, lambda tmp: pq.write_table(table, tmp, compression="zstd"))

    def _write_arrays(self, record, arrays) -> None:
        target = (self.arrays / _part_dir(record["point_id"])
                  / f"run-{int(record['run_index']):06d}.npz")

        def save(tmp):
            with open(tmp, "wb") as f:
                np.savez(f, **{k: np.asarray(v) for k, v in arrays.items()})
        self._atomic(target, save)

    @staticmethod
    def _atomic(path: Path, write) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        write(tmp)
        os.replace(tmp, path)

    # ------------------------------------------------------------------ reading
    def part_files(self) -> list:
        if not self.results.is_dir():
            return []
        return sorted(self.results.glob("point-*/part-*.parquet"))

    def journal_files(self) -> list:
        if not self.results.is_dir():
            return []
        return sorted(self.results.glob("journal-*.jsonl"))

    def _journal_records(self) -> list:
        out = []
        for path in self.journal_files():
            with open(path, encoding="utf-8") as f:
                for line in f:
                    try:
                        out.append(json.loads(line))
                    except json.JSONDecodeError:
                        pass            # the line a kill cut short: that run is not finished
        return out

    @staticmethod
    def _read_part(path, columns=None):
        """A Parquet part, or BadInput naming it (a part is written whole and renamed, so a
        broken one was damaged after the campaign wrote it)."""
        try:
            return pq.read_table(path, columns=columns)
        except (OSError, ValueError, pa.ArrowException) as exc:
            from ..errors import BadInput
            raise BadInput(f"unreadable results part ({' '.join(str(exc).split())[:120]}); "
                           "delete it and run the campaign again with --resume to redo its "
                           "runs", file=path) from None

    def done(self) -> set:
        """``{(point_id, run_index)}`` of every recorded run."""
        keys = set()
        for p in self.part_files():
            t = self._read_part(p, columns=list(KEY))
            keys.update(zip(t.column(0).to_pylist(), t.column(1).to_pylist()))
        keys.update((r["point_id"], r["run_index"]) for r in self._journal_records())
        return keys

    def table(self):
        """Every recorded run, one row each, sorted by ``(point_id, run_index)`` (pandas)."""
        import pandas as pd
        tables = [self._read_part(p) for p in self.part_files()]
        journal = self._journal_records()
        if journal:
            tables.append(_table(journal))
        if not tables:
            return pd.DataFrame(columns=["point_id", "run_index", "seed", "status", "error"])
        df = pa.concat_tables(tables, promote_options="permissive").to_pandas()
        df = df.drop_duplicates(subset=list(KEY), keep="first")
        return df.sort_values(list(KEY), kind="stable").reset_index(drop=True)

    def read_arrays(self, point_id: int, run_index: int) -> Optional[dict]:
        path = self.arrays / _part_dir(point_id) / f"run-{int(run_index):06d}.npz"
        if not path.exists():
            return None
        with np.load(path) as z:
            return {k: z[k] for k in z.files}

    # ------------------------------------------------------------------ maintenance
    def remove_partial(self) -> int:
        """Delete temporary files a killed campaign left behind; returns how many."""
        n = 0
        for sub in (self.results, self.arrays):
            if sub.is_dir():
                for p in sub.glob("**/.*.tmp"):
                    p.unlink(missing_ok=True)
                    n += 1
        return n

    def remove(self, keys: Iterable[tuple]) -> None:
        """Forget the runs ``keys`` (to run them again): rewrites the parts and journals that
        hold them, deletes their arrays."""
        keys = {(int(a), int(b)) for a, b in keys}
        if not keys:
            return
        self.compact()
        journal = [r for r in self._journal_records()
                   if (r["point_id"], r["run_index"]) not in keys]
        for p in self.journal_files():
            p.unlink()
        if journal:
            self._write_parts(journal)
        for p in self.part_files():
            t = self._read_part(p)
            mask = [(a, b) not in keys for a, b in zip(t.column("point_id").to_pylist(),
                                                       t.column("run_index").to_pylist())]
            if not all(mask):
                kept = t.filter(pa.array(mask))
                if kept.num_rows:
                    self._atomic(p, lambda tmp: pq.write_table(kept, tmp, compression="zstd"))
                else:
                    p.unlink()
        for pid, idx in keys:
            (self.arrays / _part_dir(pid) / f"run-{idx:06d}.npz").unlink(missing_ok=True)
