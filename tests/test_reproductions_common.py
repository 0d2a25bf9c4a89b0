"""``inmotion.reproductions.common.engine``: one Dask client for every campaign of a
``reproduce`` command, local workers or an existing scheduler (the campaigns themselves:
``tests/test_reproduction_campaigns.py``)."""


def _square(x):
    return x * x


def test_one_engine_serves_every_call_inside_it():
    from inmotion.reproductions import common
    with common.engine(workers=2) as client:
        assert client is not None and common._CLIENT is client
        assert client.submit(_square, 3).result() == 9
        assert len(client.scheduler_info(n_workers=-1)["workers"]) == 2
    assert common._CLIENT is None


def test_no_engine_without_workers_or_scheduler():
    from inmotion.reproductions import common
    with common.engine(workers=1) as client:
        assert client is None and common._CLIENT is None


def test_a_bad_scheduler_address_is_bad_input(tmp_path):
    from click.testing import CliRunner

    from inmotion.cli.main import cli
    res = CliRunner().invoke(cli, ["reproduce", "002", "-o", str(tmp_path / "o"),
                                   "--scheduler", "not an address"])
    assert res.exit_code == 2 and "expected an address like tcp://host:8786" in res.output


def test_a_scheduler_serves_the_campaigns():
    from distributed import LocalCluster

    from inmotion.reproductions import common
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with common.engine(scheduler=cluster.scheduler_address) as client:
            assert common._CLIENT is client
            assert client.scheduler.address == cluster.scheduler_address
            assert client.submit(_square, 4).result() == 16
