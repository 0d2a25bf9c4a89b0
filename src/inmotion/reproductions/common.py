"""What the per-paper reproductions (``paper000`` .. ``paper004``, ``real``) share.

One idea: run a list of independent Monte Carlo tasks on the project's one campaign engine
(:mod:`inmotion.evaluate.montecarlo`'s Dask client: a local cluster of single-threaded worker
processes, or an existing scheduler given by address), or in this process, in task order, with
an optional progress bar. Each reproduction keeps its own tasks (the seeding scheme of its
paper), its own run function and its own statistics; a task's result never depends on the
worker, the order of completion or the number of workers.

``inmotion reproduce ... --scheduler ADDRESS`` (:func:`engine`) opens the client once for every
paper of the command; without it ``--workers N > 1`` starts a local cluster per call.
"""
from __future__ import annotations

import contextlib
import functools
import json
from pathlib import Path
from typing import Optional

import numpy as np

__all__ = ["run_tasks", "run_tasks_checkpointed", "engine", "drift_free_dr_gyro",
           "conditions_markdown", "turned_heading"]

#: the client opened by :func:`engine` (None: each :func:`run_tasks` call decides)
_CLIENT = None


@contextlib.contextmanager
def engine(workers: Optional[int] = None, scheduler: Optional[str] = None):
    """Run every :func:`run_tasks` inside the block on one Dask client: connected to
    ``scheduler`` (an address such as ``tcp://host:8786``), or a local cluster of ``workers``
    processes when ``workers > 1``; with neither, tasks run in this process."""
    global _CLIENT
    if not scheduler and not (workers and workers > 1):
        yield None
        return
    from ..evaluate.montecarlo import open_client
    with open_client(workers, scheduler) as client:
        old, _CLIENT = _CLIENT, client
        try:
            yield client
        finally:
            _CLIENT = old


def _apply_chunk(fn, chunk):
    return [fn(t) for t in chunk]


def run_tasks(fn, tasks, workers, *, desc: str, progress: bool = True, chunksize: int = 1) -> list:
    """``[fn(task) for task in tasks]`` on the campaign engine's workers.

    Parameters
    ----------
    fn : callable
        The run function (module-level, so that a worker can import it).
    tasks : list
        One argument of ``fn`` per run; the results come back in this order.
    workers : int or None
        Worker processes when no :func:`engine` is open: ``> 1`` starts a local Dask cluster
        for this call; ``None``, 0 or 1 run in this process.
    desc : str
        The progress bar's label (``tqdm``, one step a task).
    progress : bool
        Show the bar.
    chunksize : int
        Tasks sent to a worker as one Dask task (short runs: less scheduler cost).
    """
    tasks = list(tasks)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), desc=desc, unit="run")
    try:
        if _CLIENT is not None:
            return _on_client(_CLIENT, fn, tasks, chunksize, bar)
        if workers and workers > 1:
            with engine(workers) as client:
                return _on_client(client, fn, tasks, chunksize, bar)
        results = []
        for task in tasks:
            results.append(fn(task))
            if bar is not None:
                bar.update(1)
        return results
    finally:
        if bar is not None:
            bar.close()


def _on_client(client, fn, tasks, chunksize, bar) -> list:
    from distributed import as_completed
    size = max(1, int(chunksize))
    chunks = [tasks[i:i + size] for i in range(0, len(tasks), size)]
    futures = [client.submit(_apply_chunk, fn, c, pure=False) for c in chunks]
    for f in as_completed(futures):
        f.result()                      # a run's exception stops the reproduction here
        if bar is not None:
            bar.update(len(chunks[futures.index(f)]))
    return [r for f in futures for r in f.result()]


def run_tasks_checkpointed(fn, tasks, workers, path, *, desc: str, progress: bool = True,
                           run_missing: bool = True) -> list:
    """:func:`run_tasks` that keeps every finished task's record in the JSON-lines file
    ``path`` and, when called again with the same file, runs only the tasks not in it.

    A long reproduction on a loaded machine can then be stopped and resumed, or cut to the
    tasks that finished (the caller orders its tasks so that a prefix is a complete smaller
    experiment). A task is identified by ``json.dumps(task, default=str)`` (a SeedSequence
    by its repr); records come back from the file as JSON (lists for arrays). A torn last
    line (a write interrupted) is ignored and its task run again. ``run_missing=False``:
    run nothing, return the records of the tasks in the file (in task order; the others
    are left out).
    """
    path = Path(path)
    done = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                r = json.loads(line)
                done[r["key"]] = r["record"]
            except (json.JSONDecodeError, KeyError, TypeError):
                continue
    keys = [_task_key(t) for t in tasks]
    todo = [t for t, k in zip(tasks, keys) if k not in done]
    if not run_missing:
        return [done[k] for k in keys if k in done]
    new = run_tasks(functools.partial(_run_and_append, fn, str(path)), todo, workers,
                    desc=desc, progress=progress)
    fresh = dict(zip((_task_key(t) for t in todo), new))
    return [done[k] if k in done else fresh[k] for k in keys]


def _task_key(task) -> str:
    return json.dumps(task, default=str)


def _jsonable(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return str(x)


def _run_and_append(fn, path, task):
    rec = fn(task)
    line = json.dumps({"key": _task_key(task), "record": rec}, default=_jsonable)
    with open(path, "a") as f:         # one write of one line: workers may append at once
        f.write(line + "\n")
    return rec


def turned_heading(C_nb, d_yaw_rad):
    """``C_b^n`` with its heading (ENU Euler yaw) changed by ``d_yaw_rad``, pitch and roll kept:
    a start or a first-level answer made a chosen amount worse (paper 003's 53' coarse start,
    paper 004's first level)."""
    import numpy as np

    from ..core import rotations
    e = rotations.euler_from_dcm(np.asarray(C_nb, dtype=float))
    e[2] += d_yaw_rad
    return rotations.dcm_from_euler(e)


def drift_free_dr_gyro(imu, eps_b):
    """The gyro rows of a dead reckoner that does not see the IMU's drift ``eps_b`` (3,)
    [rad/s], a simulation study's oracle (it needs the truth): ``dtheta - eps_b * dt`` per IMU
    row, the first row's interval taken equal to the second's. Passed as ``dtheta_dr`` to
    ``run_dr_kf`` / ``run_sins_dr`` with ``dr_sees_gyro_drift=False``, it is the world paper
    000's printed F describes."""
    import numpy as np
    t = np.asarray(imu.t, dtype=float)
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]) if len(t) > 1 else t[0])
    return imu.dtheta - np.asarray(eps_b, dtype=float)[None, :] * dt[:, None]


def conditions_markdown(rows) -> list:
    """A report's conditions table (issue 17: it opens every report) as markdown lines:
    ``rows`` of ``(parameter, paper's value, ours, why ours differs)``; a ``|`` or a line
    break inside a cell becomes ``/`` or a space."""
    def cell(x):
        return str(x).replace("|", "/").replace("\n", " ")
    L = ["## Conditions", "", "| parameter | paper | ours | why ours differs |",
         "| --- | --- | --- | --- |"]
    L += ["| " + " | ".join(cell(x) for x in row) + " |" for row in rows]
    return L + [""]
