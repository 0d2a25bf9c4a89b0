"""What the per-paper reproductions (``paper000`` .. ``paper003``) share.

One idea: run a list of independent Monte Carlo tasks, in this process or in a pool of
processes, in task order, with an optional progress bar. Each reproduction keeps its own
tasks (the seeding scheme of its paper), its own run function and its own statistics.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

__all__ = ["run_tasks", "turned_heading"]


def run_tasks(fn, tasks, workers, *, desc: str, progress: bool = True, chunksize: int = 1) -> list:
    """``[fn(task) for task in tasks]``, in ``workers`` processes when ``workers > 1``.

    Parameters
    ----------
    fn : callable
        The run function (module-level, so that a process pool can pickle it).
    tasks : list
        One argument of ``fn`` per run; the results come back in this order.
    workers : int or None
        Processes (``ProcessPoolExecutor``); ``None``, 0 or 1 run in this process.
    desc : str
        The progress bar's label (``tqdm``, one step a task).
    progress : bool
        Show the bar.
    chunksize : int
        Tasks handed to a worker at a time (``Executor.map``).
    """
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), desc=desc, unit="run")
    results = []
    if workers and workers > 1:
        with ProcessPoolExecutor(max_workers=int(workers)) as ex:
            for r in ex.map(fn, tasks, chunksize=chunksize):
                results.append(r)
                if bar is not None:
                    bar.update(1)
    else:
        for task in tasks:
            results.append(fn(task))
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    return results


def turned_heading(C_nb, d_yaw_rad):
    """``C_b^n`` with its heading (ENU Euler yaw) changed by ``d_yaw_rad``, pitch and roll kept:
    a start or a first-level answer made a chosen amount worse (paper 003's 53' coarse start,
    paper 004's first level)."""
    import numpy as np

    from ..core import rotations
    e = rotations.euler_from_dcm(np.asarray(C_nb, dtype=float))
    e[2] += d_yaw_rad
    return rotations.dcm_from_euler(e)
