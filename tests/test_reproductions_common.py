"""``inmotion.reproductions.common.run_tasks``: the Monte Carlo loop the reproductions share
gives ``[fn(task) for task in tasks]`` in task order, in this process and in a pool."""
import pytest

from inmotion.reproductions.common import run_tasks


def _square(x):
    return x * x


@pytest.mark.parametrize("workers", [None, 1, 2])
def test_results_in_task_order(workers):
    tasks = list(range(7))
    assert run_tasks(_square, tasks, workers, desc="t", progress=False, chunksize=2) == \
        [x * x for x in tasks]


def test_progress_bar_counts_every_task(capsys):
    assert run_tasks(_square, [1, 2, 3], 1, desc="bar-test", progress=True) == [1, 4, 9]
    assert "3/3" in capsys.readouterr().err
