"""The campaign engine when Dask loses work: a result lost with its worker whose re-computation
then fails, a worker killed from outside, a task no worker ever runs. Every run is recorded
exactly once and the campaign ends (no hang); each test is guarded by a hard time limit."""
from __future__ import annotations

import contextlib
import faulthandler
import logging
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from inmotion.errors import BadInput
from inmotion.evaluate.campaign import run_generator
from inmotion.evaluate.montecarlo import open_client, run_campaign
from inmotion.evaluate.store import ResultStore
from inmotion.evaluate.sweep import load_sweep

SYNTH = "inmotion.evaluate.runs:synthetic_run"
#: this module as the worker processes import it (pytest puts tests/ on sys.path, and Dask's
#: spawned workers inherit it)
HERE = Path(__file__).stem


@contextlib.contextmanager
def hang_guard(seconds: float):
    """Fail hard instead of hanging: past ``seconds`` every thread's stack is dumped and the
    test process exits (pytest-timeout is not installed)."""
    faulthandler.dump_traceback_later(seconds, exit=True, file=sys.stderr)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


class _DiesWhenPickled:
    """A result that takes its worker down when the worker serializes it for the client: the
    result is lost with the worker after the task finished, before the client has it."""

    def __reduce__(self):
        os._exit(71)


def poison_run(spec: dict, rng: np.random.Generator) -> dict:
    """Run ``poison_run`` of the campaign: its first execution returns a result that kills the
    worker when fetched; every later execution (Dask's re-computation of the lost result, the
    engine's re-submissions) kills its worker at once. Other runs return their first draw."""
    k = int(rng.bit_generator.seed_seq.spawn_key[-1])
    x = float(rng.normal())
    if k == spec["poison_run"]:
        marker = Path(spec["marker_dir"]) / f"ran-{k}"
        if marker.exists():
            os._exit(70)
        marker.write_text("1")
        return {"first": x, "arrays": {"poison": _DiesWhenPickled()}}
    return {"first": x}


def once_each(df, n_runs):
    keys = list(zip(df["point_id"], df["run_index"]))
    return len(keys) == n_runs and len(set(keys)) == n_runs


def test_a_result_lost_with_its_worker_whose_recomputation_dies_is_recorded(tmp_path):
    """The race that hung the campaign (seen once at load 10): a task finished, its worker died
    before the client fetched the result, and the re-computation Dask started then ended in
    ``KilledWorker``; ``as_completed(with_results=True)`` lost that future for good. Here the
    poisoned run provokes it on every execution order."""
    doc = {"name": "poison", "run": f"{HERE}:poison_run", "runs": 6, "seed": 5,
           "poison_run": 2, "marker_dir": str(tmp_path)}
    with hang_guard(120), open_client(workers=2) as client:
        df = run_campaign(load_sweep(doc), tmp_path / "c", client=client, quiet=True,
                          stall_s=10.0)
    assert once_each(df, 6)
    bad = df[df["status"] != "ok"]
    assert bad["run_index"].tolist() == [2]
    assert bad["error"].iloc[0].startswith("KilledWorker")
    ok = df[df["status"] == "ok"].sort_values("run_index")
    expected = [run_generator(5, k).normal() for k in ok["run_index"]]
    assert ok["first"].tolist() == expected


class _NeverRuns:
    """A client whose chosen submissions ask for a resource no worker has: Dask keeps those
    tasks waiting forever while the workers idle (a task lost to the campaign)."""

    def __init__(self, client, lose):
        self._client, self._lose, self.lost = client, lose, []

    def submit(self, fn, chunk, **kw):
        if self._lose(chunk, self.lost):
            self.lost.append([t.run_index for t in chunk])
            kw["resources"] = {"never-available": 1}
        return self._client.submit(fn, chunk, **kw)

    def __getattr__(self, name):
        return getattr(self._client, name)


def test_a_task_no_worker_runs_is_submitted_again_by_the_watchdog(tmp_path, caplog):
    sweep = load_sweep({"name": "stuck", "run": SYNTH, "runs": 8, "seed": 3,
                        "grid": {"scale": [1.0, 2.0]}})
    def lose(chunk, lost):
        """Run 6's every task and run 5's first task never run."""
        runs = {t.run_index for t in chunk}
        return 6 in runs or (5 in runs and not any(5 in r for r in lost))

    with hang_guard(120), open_client(workers=2) as c:
        proxy = _NeverRuns(c, lose)
        t0 = time.monotonic()
        with caplog.at_level(logging.WARNING, logger="inmotion.evaluate.montecarlo"):
            df = run_campaign(sweep, tmp_path / "c", client=proxy, quiet=True, stall_s=1.0,
                              max_chunk=1)
        wall = time.monotonic() - t0
    assert once_each(df, 16)
    bad = df[df["status"] != "ok"]
    # run 6 of both points lost twice (LOSS_RETRIES = 1): recorded as TaskLost; run 5 ran
    assert sorted(bad["run_index"].tolist()) == [6, 6]
    assert bad["error"].str.startswith("TaskLost: Dask lost the task").all()
    ok = df[df["status"] == "ok"]
    assert len(ok) == 14 and (ok["run_index"] == 5).sum() == 2
    for _, r in ok.iterrows():
        x = run_generator(3, int(r["run_index"])).normal(0.0, r["param.scale"], 64)
        assert r["mean"] == x.mean()
    assert "taken as lost and submitted again" in caplog.text
    assert wall < 60, wall


def test_a_worker_killed_from_outside_costs_no_run(tmp_path):
    """SIGKILL of a worker process mid-run (the OOM killer, an operator): the run it was
    running is re-run (not marked), every run is recorded once."""
    sweep = load_sweep({"name": "outside", "run": SYNTH, "runs": 12, "seed": 8, "sleep_s": 0.1,
                        "grid": {"scale": [1.0, 2.0]}})
    out = tmp_path / "c"
    with hang_guard(120), open_client(workers=2) as c:
        pids = list(c.run(os.getpid).values())
        store = ResultStore(out)
        killed = []

        def killer():
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                if len(store.done()) >= 4:
                    os.kill(pids[0], signal.SIGKILL)
                    killed.append(pids[0])
                    return
                time.sleep(0.02)

        thread = threading.Thread(target=killer, daemon=True)
        thread.start()
        df = run_campaign(sweep, out, client=c, quiet=True, stall_s=10.0, max_chunk=1)
        thread.join()
    assert killed
    assert once_each(df, 24)
    assert (df["status"] == "ok").all(), df["error"].tolist()


@pytest.mark.parametrize("value", [0, -1.0, float("nan"), float("inf"), True, "10"])
def test_a_bad_stall_time_is_refused(tmp_path, value):
    with pytest.raises(BadInput, match="stall_s must be a positive number"):
        run_campaign(load_sweep({"run": SYNTH}), tmp_path / "c", workers=1, stall_s=value)


def test_a_killed_worker_counts_the_schedulers_own_attempts():
    """A ``KilledWorker`` after Dask's default 3 allowed failures stands for 4 dead workers
    (the engine then records a run alone at once); after allowed-failures 0, for 1."""
    from distributed.scheduler import KilledWorker
    from inmotion.evaluate.montecarlo import LOSS_RETRIES, TaskLost, _worker_deaths
    assert _worker_deaths(KilledWorker("k", None, 3)) == 4 > LOSS_RETRIES
    assert _worker_deaths(KilledWorker("k", None, 0)) == 1 <= LOSS_RETRIES
    assert _worker_deaths(TaskLost(1, 60.0)) == 1
    assert _worker_deaths(RuntimeError("worker lost")) == 1


def test_the_dead_worker_of_a_killed_task_is_read_from_its_exception():
    from types import SimpleNamespace
    from distributed.scheduler import KilledWorker
    from inmotion.evaluate.montecarlo import _dead_worker
    ws = SimpleNamespace(address="tcp://127.0.0.1:4000")   # as WorkerState.clean() has it
    assert _dead_worker(KilledWorker("k", ws, 0)) == "tcp://127.0.0.1:4000"
    assert _dead_worker(KilledWorker("k", None, 0)) is None
    assert _dead_worker(RuntimeError("boom")) is None and _dead_worker(None) is None


def _kill_the_worker(client) -> set:
    """SIGKILL the (one) worker process; the worker addresses before."""
    before = set(client.scheduler_info(n_workers=-1)["workers"])
    os.kill(next(iter(client.run(os.getpid).values())), signal.SIGKILL)
    return before


def _new_workers(client, before, wait_s) -> int:
    """Workers registered that were not in ``before``, once one is there or after ``wait_s``."""
    deadline = time.monotonic() + wait_s
    while True:
        new = set(client.scheduler_info(n_workers=-1)["workers"]) - before
        if new or time.monotonic() > deadline:
            return len(new)
        time.sleep(0.1)


def test_the_engines_cluster_keeps_a_worker_slot_through_a_slow_restart():
    """Dask's ``lost-worker-timeout`` closes a worker's nanny for good when no worker of that
    name is registered that long after a death: with runs crashing one worker after another
    the local cluster lost all its workers and the campaign waited forever (a plain
    LocalCluster at load 10: no nanny left after 160 runs with 22 crashing ones). Here the
    timeout the user's configuration sets is 0.2 s (a worker restarts in about a second), and
    the engine's cluster (:data:`CLUSTER_CONFIG`) keeps its worker."""
    import dask
    with hang_guard(120), dask.config.set({"distributed.deploy.lost-worker-timeout": 0.2}):
        with open_client(workers=1) as c:
            for _ in range(2):
                before = _kill_the_worker(c)
                assert _new_workers(c, before, 30.0) == 1
            time.sleep(1.0)                          # well past the 0.2 s check: still there
            assert len(c.scheduler_info(n_workers=-1)["workers"]) == 1
