"""One Monte Carlo run as a picklable task, its seed, and the per-run result files.

Seeding
-------
Run ``k`` of a campaign with seed ``s`` draws every random number from::

    numpy.random.default_rng(numpy.random.SeedSequence(s, spawn_key=(k,)))

which is the ``k``-th child of ``SeedSequence(s).spawn(...)``: statistically independent streams
for different runs, and a value that depends on ``(s, k)`` only, never on the worker, the order
of completion or the number of workers. All points of a sweep share the run's stream (common
random numbers): run ``k`` of every method sees the same simulated drive, so differences between
methods are not masked by drive-to-drive scatter. :func:`execute_task` run alone reproduces any
run exactly.

Records
-------
A run's record (one row of the results table, :mod:`inmotion.evaluate.store`) holds
``point_id``, ``run_index``, ``seed``, ``status`` (``ok`` / ``error``), ``error``, ``traceback``,
``label``, the point's grid values as ``param.<dotted path>``, the run function's scalars
(nested dicts flattened with ``.``), ``elapsed_s`` (wall time of the run) and ``worker``; these
two are the only columns that may differ between two executions of the same run. Arrays a run
returns under the key ``"arrays"`` travel beside the record.

Several tasks may travel as one Dask task (:func:`execute_tasks`) when runs are short, to spread
the scheduler's cost; each run keeps its own seed, so this changes no number.
"""
from __future__ import annotations

import importlib
import json
import os
import socket
import time
import traceback
from dataclasses import dataclass

import numpy as np

__all__ = ["Task", "run_seed_sequence", "run_generator", "execute_task", "execute_tasks",
           "error_record", "flatten"]

TIMING_COLUMNS = ("elapsed_s", "worker")


def run_seed_sequence(campaign_seed: int, run_index: int) -> np.random.SeedSequence:
    """The seed sequence of run ``run_index``: ``SeedSequence(campaign_seed, spawn_key=(run_index,))``."""
    return np.random.SeedSequence(int(campaign_seed), spawn_key=(int(run_index),))


def run_generator(campaign_seed: int, run_index: int) -> np.random.Generator:
    """The ``numpy.random.Generator`` (PCG64) of one run; see the module notes."""
    return np.random.default_rng(run_seed_sequence(campaign_seed, run_index))


@dataclass(frozen=True)
class Task:
    """Everything a worker needs for one run: picklable, no file access.

    ``run`` is ``"module:function"`` of ``f(spec: dict, rng: Generator) -> dict``. ``affinity``
    (from the run function's optional ``affinity(spec)``) groups tasks worth running on one worker
    one after the other: same run index and same affinity, e.g. the methods of a sweep on one
    simulated drive, which the worker then simulates once. It never changes a result.
    """

    campaign_seed: int
    run_index: int
    point_id: int
    params: dict
    spec: dict
    run: str
    label: str = ""
    affinity: str = ""


def _resolve(path: str):
    mod, _, attr = path.partition(":")
    return getattr(importlib.import_module(mod), attr)


def _scalar(v):
    """A Parquet-friendly scalar: numpy scalars to Python, other objects to JSON text."""
    if isinstance(v, np.generic):
        return v.item()
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, np.ndarray) and v.ndim == 0:
        return v.item()
    return json.dumps(v, default=lambda o: np.asarray(o).tolist())


def flatten(d: dict, prefix: str = "") -> dict:
    """``{"final": {"yaw_arcmin": 1.0}} -> {"final.yaw_arcmin": 1.0}``; leaves become scalars."""
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        else:
            out[key] = _scalar(v)
    return out


def _base_record(task: Task) -> dict:
    record = {"point_id": task.point_id, "run_index": task.run_index, "seed": task.campaign_seed,
              "status": "ok", "error": "", "traceback": "", "label": task.label}
    record.update({f"param.{k}": _scalar(v) for k, v in task.params.items()})
    return record


def error_record(task: Task, exc: BaseException, tb: str = "") -> dict:
    """The row of a run that failed with ``exc`` (its seed and point are kept)."""
    record = _base_record(task)
    record.update(status="error", error=f"{type(exc).__name__}: {exc}", traceback=tb,
                  elapsed_s=float("nan"), worker="")
    return record


def execute_task(task: Task) -> tuple:
    """Run one task; never raises for the run's own failure.

    Returns
    -------
    record : dict
        The row for the results table (see the module notes).
    arrays : dict or None
        Arrays the run function returned under ``"arrays"``.
    """
    t0 = time.perf_counter()
    arrays = None
    try:
        out = dict(_resolve(task.run)(task.spec, run_generator(task.campaign_seed, task.run_index)))
        arrays = out.pop("arrays", None)
        record = _base_record(task)
        scalars = flatten(out)
        clash = sorted(set(scalars) & set(record))
        if clash:
            raise ValueError(f"run function returned reserved column names {clash}")
        record.update(scalars)
    except Exception as exc:  # the campaign goes on; the error is a result
        record = error_record(task, exc, traceback.format_exc(limit=20))
    record["elapsed_s"] = time.perf_counter() - t0
    record["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return record, arrays


def execute_tasks(tasks) -> list:
    """:func:`execute_task` over a list of tasks, in order (one Dask task for several short runs)."""
    return [execute_task(t) for t in tasks]
