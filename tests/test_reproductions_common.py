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


def test_one_engine_serves_every_call_inside_it():
    from inmotion.reproductions import common
    with common.engine(workers=2) as client:
        assert client is not None and common._CLIENT is client
        assert run_tasks(_square, [1, 2, 3], 1, desc="t", progress=False) == [1, 4, 9]
        assert len(client.scheduler_info(n_workers=-1)["workers"]) == 2
    assert common._CLIENT is None


def test_a_bad_scheduler_address_is_bad_input(tmp_path):
    from click.testing import CliRunner

    from inmotion.cli.main import cli
    res = CliRunner().invoke(cli, ["reproduce", "002", "-o", str(tmp_path / "o"),
                                   "--scheduler", "not an address"])
    assert res.exit_code == 2 and "expected an address like tcp://host:8786" in res.output


def test_a_scheduler_runs_the_tasks():
    from distributed import LocalCluster

    from inmotion.reproductions import common
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with common.engine(scheduler=cluster.scheduler_address):
            assert run_tasks(_square, list(range(5)), None, desc="t", progress=False) == \
                [0, 1, 4, 9, 16]
