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
from typing import Optional

__all__ = ["run_tasks", "engine"]

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
