"""The campaign engine: seeds, sweeps, identical results whatever the workers, kill and resume,
failures recorded as results."""
from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inmotion.errors import BadInput
from inmotion.evaluate.campaign import (Task, execute_task, flatten, run_generator,
                                        run_seed_sequence)
from inmotion.evaluate.store import ResultStore
from inmotion.evaluate.montecarlo import open_client, read_results, rerun, run_campaign
from inmotion.evaluate.runs import initial_state, parse_init_error
from inmotion.evaluate.sweep import expand_grid, load_sweep, set_path
from test_montecarlo_faults import hang_guard

SYNTH = "inmotion.evaluate.runs:synthetic_run"
TIMING = ["elapsed_s", "worker"]


def synth_sweep(runs=6, seed=11, **extra):
    doc = {"name": "synth", "run": SYNTH, "runs": runs, "seed": seed, "n": 16,
           "grid": {"scale": [1.0, 3.0], "n": [8, 16]}}
    doc.update(extra)
    return load_sweep(doc)


def comparable(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=TIMING).sort_values(["point_id", "run_index"]).reset_index(drop=True)


@pytest.fixture(autouse=True)
def _no_hang():
    """Every test of this file ends within 240 s or the test process exits with every
    thread's stack (a hung Dask wait must not eat CI's budget; no pytest-timeout here)."""
    with hang_guard(240):
        yield


@pytest.fixture(scope="module")
def cluster():
    """A Dask LocalCluster started by the test itself (2 single-threaded worker processes)."""
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address="127.0.0.1:0") as c:
        yield c


@pytest.fixture(scope="module")
def client(cluster):
    from distributed import Client
    with Client(cluster) as c:
        yield c


# ------------------------------------------------------------------------------- seeding
def test_run_seed_is_the_spawned_child_of_the_campaign_seed():
    children = np.random.SeedSequence(2026).spawn(5)
    for k in range(5):
        a = np.random.default_rng(children[k]).random(4)
        assert np.array_equal(run_generator(2026, k).random(4), a)
        assert run_seed_sequence(2026, k).spawn_key == (k,)
    assert not np.array_equal(run_generator(2026, 0).random(4), run_generator(2026, 1).random(4))
    assert not np.array_equal(run_generator(1, 0).random(4), run_generator(2, 0).random(4))


def test_execute_task_records_scalars_params_and_flattens():
    task = Task(5, 3, 1, {"scale": 2.0}, {"scale": 2.0, "n": 4}, SYNTH, "scale=2.0")
    record, arrays = execute_task(task)
    x = run_generator(5, 3).normal(0.0, 2.0, 4)
    assert record["status"] == "ok" and record["error"] == ""
    assert record["mean"] == x.mean() and record["stats.first"] == x[0]
    assert record["param.scale"] == 2.0 and record["seed"] == 5 and record["run_index"] == 3
    assert arrays is None
    assert flatten({"a": {"b": np.float64(1.5), "c": [1, 2]}}) == {"a.b": 1.5, "a.c": "[1, 2]"}


# ------------------------------------------------------------------------------- sweeps
def test_grid_is_a_cartesian_product_last_key_fastest():
    points = expand_grid({"scenario": {"imu": {"gyro": 0}}, "method": "a"},
                         {"scenario.imu.gyro": [1, 2], "method": ["x", "y", "z"]})
    assert [p.point_id for p in points] == list(range(6))
    assert [(p.spec["scenario"]["imu"]["gyro"], p.spec["method"]) for p in points] == \
        [(1, "x"), (1, "y"), (1, "z"), (2, "x"), (2, "y"), (2, "z")]
    assert points[4].params == {"scenario.imu.gyro": 2, "method": "y"}
    assert points[4].label == "gyro=2, method=y"


def test_sweep_file_with_scenario_path_and_plain_scenario(tmp_path):
    (tmp_path / "scn.yaml").write_text("duration_s: 10\nimu: {gyro_bias_deg_h: 0.1}\n")
    (tmp_path / "sweep.yaml").write_text(textwrap.dedent("""\
        name: demo
        runs: 3
        seed: 4
        scenario: scn.yaml
        method: sins
        grid:
          scenario.imu.gyro_bias_deg_h: [0.01, 0.1]
          method: [sins, dr]
        """))
    sw = load_sweep(tmp_path / "sweep.yaml")
    assert (sw.runs, sw.seed, len(sw.points)) == (3, 4, 4)
    assert sw.points[2].spec["scenario"] == {"duration_s": 10, "imu": {"gyro_bias_deg_h": 0.1}}
    plain = load_sweep(tmp_path / "scn.yaml", overrides={"method": "sins", "runs": 7})
    assert len(plain.points) == 1 and plain.runs == 7 and plain.name == "scn"
    assert plain.points[0].spec == {"scenario": {"duration_s": 10, "imu": {"gyro_bias_deg_h": 0.1}},
                                    "method": "sins"}


@pytest.mark.parametrize("doc, message", [
    ({"scenario": {}, "grid": {"a": 3}}, "non-empty list"),
    ({"scenario": {}, "grid": {"a": []}}, "non-empty list"),
    ({"scenario": {"a": 1}, "grid": {"scenario.a.b": [1]}}, "is not a mapping"),
    ({"scenario": {}, "runs": 0}, "'runs' must be an integer >= 1"),
    ({"scenario": {}, "seed": -1}, "'seed' must be an integer >= 0"),
    ({"scenario": {}, "run": "nocolon"}, "module:function"),
    ({"scenario": 3}, "name, a path or a mapping"),
])
def test_bad_sweeps_raise_bad_input(doc, message):
    with pytest.raises(BadInput, match=message):
        load_sweep(doc)


def test_bad_sweep_files_name_the_file(tmp_path):
    with pytest.raises(BadInput, match="file not found"):
        load_sweep(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("grid: [1, 2\n")
    with pytest.raises(BadInput, match=r"bad\.yaml: not valid YAML"):
        load_sweep(bad)
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(BadInput, match="mapping at the top level"):
        load_sweep(bad)
    bad.write_text("scenario: no_such_scenario_anywhere\n")
    with pytest.raises(BadInput, match="neither a file nor a shipped scenario"):
        load_sweep(bad)


def test_set_path_creates_missing_mappings():
    spec = {}
    set_path(spec, "method_options.gain.x", 3)
    assert spec == {"method_options": {"gain": {"x": 3}}}


# ------------------------------------------------------------------------------- the engine
def test_same_results_on_1_worker_2_workers_and_a_test_started_cluster(tmp_path, cluster):
    sweep = synth_sweep()
    one = run_campaign(sweep, tmp_path / "w1", workers=1, quiet=True)
    two = run_campaign(sweep, tmp_path / "w2", workers=2, quiet=True)
    ext = run_campaign(sweep, tmp_path / "ext", scheduler=cluster.scheduler_address, quiet=True)
    assert len(one) == sweep.runs * len(sweep.points) == 24
    assert (one["status"] == "ok").all()
    pd.testing.assert_frame_equal(comparable(one), comparable(two))
    pd.testing.assert_frame_equal(comparable(one), comparable(ext))
    assert two["worker"].nunique() == 2
    # any single run re-run alone, in this process, gives the same numbers
    again = rerun(tmp_path / "w2", 3, 4)
    row = one[(one.point_id == 3) & (one.run_index == 4)].iloc[0]
    for key in ("mean", "std", "max", "stats.first", "seed", "label"):
        assert again[key] == row[key]
    # and they are the run's own draws: scale 3, n 16 for point 3
    x = run_generator(sweep.seed, 4).normal(0.0, 3.0, 16)
    assert row["mean"] == x.mean() and row["max"] == x.max()
    # the consolidated table on disk is the returned one
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "w1" / "table.parquet"), one)


def test_a_raising_run_is_recorded_and_the_campaign_goes_on(tmp_path, client):
    sweep = synth_sweep(runs=10, fail_value=1.0)
    df = run_campaign(sweep, tmp_path / "c", client=client, quiet=True)
    assert len(df) == 40
    failed = df[df["status"] == "error"]
    ok = df[df["status"] == "ok"]
    assert 0 < len(failed) < len(df)
    # exactly the runs whose first draw exceeds 1.0 failed, with their error text and seed
    for _, row in df.iterrows():
        first = run_generator(sweep.seed, row.run_index).normal(0.0, row["param.scale"], 1)[0]
        assert (row.status == "error") == (first > 1.0)
    assert failed["error"].str.startswith("RuntimeError: synthetic failure").all()
    assert failed["traceback"].str.contains("synthetic_run").all()
    assert (failed["seed"] == sweep.seed).all() and failed["mean"].isna().all()
    assert ok["mean"].notna().all()
    # re-running the failures alone reproduces the failure
    r = rerun(tmp_path / "c", int(failed.iloc[0].point_id), int(failed.iloc[0].run_index))
    assert r["status"] == "error" and r["error"] == failed.iloc[0]["error"]


def test_a_run_that_kills_its_worker_is_the_only_error(tmp_path):
    """A run that takes its worker process down (``os._exit``, as a crash in native code
    would) is recorded as a ``KilledWorker`` error; the runs that shared its Dask task are
    re-run one per task and recorded as results, and the campaign ends (no hang). On the
    engine's own cluster (allowed-failures 0, worker-saturation 1: a crashing run takes down
    2 workers, 3 in a chunk; with Dask's defaults it took 8, and the test 55 s)."""
    sweep = synth_sweep(runs=10, exit_value=2.0)
    with open_client(workers=2) as c:
        df = run_campaign(sweep, tmp_path / "c", client=c, quiet=True, stall_s=20.0)
    assert len(df) == 40 and len(set(zip(df.point_id, df.run_index))) == 40
    for _, row in df.iterrows():
        first = run_generator(sweep.seed, row.run_index).normal(0.0, row["param.scale"], 1)[0]
        assert (row.status == "error") == (first > 2.0), (row.point_id, row.run_index)
    failed = df[df["status"] == "error"]
    assert len(failed) > 0 and failed["error"].str.startswith("KilledWorker").all()


def fingerprints(df) -> dict:
    """(point, run) -> wall time of the execution that wrote it: a re-run changes it."""
    return {(int(r.point_id), int(r.run_index)): r.elapsed_s for r in df.itertuples()}


def test_resume_runs_only_what_is_missing_and_retry_failed(tmp_path, client):
    sweep = synth_sweep(runs=4, fail_value=1.0)
    full = run_campaign(sweep, tmp_path / "ref", client=client, quiet=True)
    out = tmp_path / "c"
    half = run_campaign(synth_sweep(runs=2, fail_value=1.0), out, client=client, quiet=True)
    assert len(half) == 8
    grown = run_campaign(sweep, out, client=client, resume=True, quiet=True)
    pd.testing.assert_frame_equal(comparable(grown), comparable(full))
    before, after = fingerprints(half), fingerprints(grown)
    assert all(after[k] == v for k, v in before.items())          # not run again
    # retry_failed re-runs exactly the recorded failures (still failing: same seed)
    failed = {k for k, s in zip(fingerprints(grown), grown["status"]) if s == "error"}
    assert failed
    again = run_campaign(sweep, out, client=client, resume=True, retry_failed=True, quiet=True)
    pd.testing.assert_frame_equal(comparable(again), comparable(full))
    rerun_keys = {k for k, v in fingerprints(again).items() if after[k] != v}
    assert rerun_keys == failed


def test_existing_results_and_a_different_campaign_are_refused(tmp_path, client):
    out = tmp_path / "c"
    run_campaign(synth_sweep(runs=1), out, client=client, quiet=True)
    with pytest.raises(BadInput, match="already holds campaign results"):
        run_campaign(synth_sweep(runs=1), out, client=client, quiet=True)
    with pytest.raises(BadInput, match="different campaign"):
        run_campaign(synth_sweep(runs=1, seed=12), out, client=client, resume=True, quiet=True)
    with pytest.raises(BadInput, match="not a campaign directory"):
        rerun(tmp_path / "nothing", 0, 0)


def test_arrays_are_written_per_run_and_a_small_window_still_finishes(tmp_path, client):
    sweep = synth_sweep(runs=3, save_arrays=True)
    df = run_campaign(sweep, tmp_path / "c", client=client, quiet=True, max_in_flight=1,
                      max_chunk=1)
    assert len(df) == 12
    arr = ResultStore(tmp_path / "c").read_arrays(2, 1)
    x = run_generator(sweep.seed, 1).normal(0.0, 3.0, 8)
    assert np.array_equal(arr["err.north_m"], np.cumsum(x))
    assert np.allclose(arr["sigma.north_m"], 3.0 * np.sqrt(np.arange(1, 9)))


def test_store_journal_compaction_cut_lines_and_partial_files(tmp_path):
    store = ResultStore(tmp_path, compact_every=3)
    rows = [{"point_id": k % 2, "run_index": k, "status": "ok", "a": float(k)} for k in range(7)]
    for r in rows:
        store.write(r)
    assert len(store.part_files()) == 4 and len(store.journal_files()) == 1   # 2 compactions
    assert store.done() == {(r["point_id"], r["run_index"]) for r in rows}
    # a kill mid-line leaves a cut line; a kill mid-compaction leaves rows in part and journal
    journal = store.journal_files()[0]
    with open(journal, "a") as f:
        f.write(json.dumps(rows[0]) + "\n" + '{"point_id": 1, "run_ind')
    tmp = tmp_path / "results" / "point-0000" / ".part-x.parquet.123.tmp"
    tmp.write_bytes(b"half a file")
    df = ResultStore(tmp_path).table()
    assert df["a"].tolist() == [0.0, 2.0, 4.0, 6.0, 1.0, 3.0, 5.0]
    assert ResultStore(tmp_path).remove_partial() == 1 and not tmp.exists()
    store.close()
    assert store.journal_files() == [] and len(ResultStore(tmp_path).table()) == 7
    # forgetting runs rewrites the parts that hold them
    store.remove([(0, 2), (1, 5)])
    assert sorted(ResultStore(tmp_path).done()) == [(0, 0), (0, 4), (0, 6), (1, 1), (1, 3)]


KILL_SCRIPT = """
import sys
from inmotion.evaluate.sweep import load_sweep
from inmotion.evaluate.montecarlo import run_campaign
if __name__ == "__main__":
    doc = {"name": "kill", "run": "inmotion.evaluate.runs:synthetic_run", "runs": 30, "seed": 3,
           "sleep_s": float(sys.argv[2]), "grid": {"scale": [1.0, 2.0]}}
    run_campaign(load_sweep(doc), sys.argv[1], workers=1, quiet=True)
"""


def test_killed_campaign_resumed_gives_the_uninterrupted_table(tmp_path):
    script = tmp_path / "campaign.py"
    script.write_text(KILL_SCRIPT)
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, str(script), str(out), "0.05"],
                            start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    store = ResultStore(out)
    deadline = time.monotonic() + 60
    try:
        while len(store.done()) < 12 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)   # the campaign, its cluster and its workers
        proc.wait()
    partial = store.table()
    assert 12 <= len(partial) < 60, len(partial)
    doc = {"name": "kill", "run": SYNTH, "runs": 30, "seed": 3, "sleep_s": 0.05,
           "grid": {"scale": [1.0, 2.0]}}
    resumed = run_campaign(load_sweep(doc), out, workers=1, resume=True, quiet=True)
    after = fingerprints(resumed)
    assert all(after[k] == v for k, v in fingerprints(partial).items())   # not run again
    reference = run_campaign(load_sweep(doc), tmp_path / "ref", workers=2, quiet=True)
    assert len(resumed) == 60
    pd.testing.assert_frame_equal(comparable(resumed), comparable(reference))
    pd.testing.assert_frame_equal(comparable(read_results(out)), comparable(reference))


# ------------------------------------------------------------------------------- default run
@pytest.mark.parametrize("value, expected_deg, dist", [
    ("pitch=1deg,roll=30arcmin,yaw=-5deg", [1.0, 0.5, -5.0], "fixed"),
    ({"yaw_deg": 2, "pitch_arcmin": 6, "distribution": "normal"}, [0.1, 0.0, 2.0], "normal"),
    (None, [0, 0, 0], "fixed"),
])
def test_init_error_forms(value, expected_deg, dist):
    spec = parse_init_error(value)
    assert np.allclose(np.degrees(spec["angles_rad"]), expected_deg) and spec["distribution"] == dist


@pytest.mark.parametrize("value, message", [
    ("pitch=1", "expected NAME=VALUEUNIT"),
    ("heading=1deg", "expected NAME=VALUEUNIT"),
    ({"yaw_furlong": 1}, "unknown field 'yaw_furlong'"),
    ({"yaw_deg": "a lot"}, "must be a number"),
    ({"yaw_deg": 1, "distribution": "uniform"}, "'fixed' or 'normal'"),
    (3, "must be a mapping"),
])
def test_bad_init_errors_raise_bad_input(value, message):
    with pytest.raises(BadInput, match=message):
        parse_init_error(value)


def test_initial_state_adds_the_attitude_error_to_truth_row_0():
    from inmotion.core.bundle import Truth
    n = 5
    euler = np.tile(np.radians([2.0, -1.0, 30.0]), (n, 1))
    truth = Truth(np.arange(n) * 0.01, np.full(n, 0.6), np.full(n, 2.0), np.full(n, 50.0),
                  np.tile([1.0, 10.0, 0.0], (n, 1)), euler)
    init, delta = initial_state(truth, "pitch=1deg,yaw=-2deg", np.random.default_rng(0))
    assert np.allclose(np.degrees(init.euler), [3.0, -1.0, 28.0], atol=1e-9)
    assert (init.t, init.lat, init.h) == (0.0, 0.6, 50.0) and np.allclose(init.vel_n, [1, 10, 0])
    _, drawn = initial_state(truth, {"yaw_deg": 2, "distribution": "normal"},
                             np.random.default_rng(9))
    assert np.allclose(drawn, np.random.default_rng(9).normal(0, 1, 3) * np.radians([0, 0, 2]))


def test_unknown_run_function_fails_before_any_run(tmp_path):
    for run in ("inmotion.no_such_module:f", "inmotion.evaluate.runs:no_such_function"):
        with pytest.raises(BadInput, match="cannot be imported"):
            run_campaign(load_sweep({"run": run}), tmp_path / "c", workers=1, quiet=True)


def test_unknown_method_fails_before_any_run(tmp_path):
    sweep = load_sweep({"scenario": {"duration_s": 1}, "method": "no-such-method"})
    with pytest.raises(BadInput, match="unknown method 'no-such-method'"):
        run_campaign(sweep, tmp_path / "c", workers=1, quiet=True)
    assert not (tmp_path / "c" / "results").exists()


# ------------------------------------------------------------------------------- real methods
def short_drive_sweep(runs=2):
    """Paper 004's 20 m/s drive cut to 20 s; pure SINS and dual-velocity IMADA."""
    import yaml
    from inmotion.sim.scenario import find_scenario
    scenario = yaml.safe_load(Path(find_scenario("paper004_v20")).read_text())
    scenario["segments"] = [{"kind": "cruise", "duration_s": 20.0}]
    return load_sweep({"name": "real", "runs": runs, "seed": 21, "scenario": scenario,
                       "init_error": "yaw=5deg", "grid": {"method": ["sins", "imada-dual"]}})


def test_real_method_campaign_is_identical_on_1_worker_and_a_test_cluster(tmp_path, cluster):
    sweep = short_drive_sweep()
    one = run_campaign(sweep, tmp_path / "w1", workers=1, quiet=True)
    ext = run_campaign(sweep, tmp_path / "ext", scheduler=cluster.scheduler_address, quiet=True)
    assert (one["status"] == "ok").all(), one["error"].tolist()
    results = [c for c in one.columns if c.startswith("errors.") or c.startswith("init_error.")]
    assert len(results) > 30
    pd.testing.assert_frame_equal(comparable(one).drop(columns="method_s"),
                                  comparable(ext).drop(columns="method_s"))
    alone = rerun(tmp_path / "ext", 1, 1)
    row = one[(one.point_id == 1) & (one.run_index == 1)].iloc[0]
    assert all(alone[c] == row[c] for c in results)
    # pure SINS keeps the 5 deg heading error it starts with (20 s, 0.01 deg/h gyros)
    sins = one[one["param.method"] == "sins"]
    assert np.allclose(sins["errors.final.yaw_arcmin"], 300.0, atol=0.5)
    assert np.allclose(sins["init_error.yaw_arcmin"], 300.0)
    # the runs see different drives (sensor noise)
    assert sins["errors.final.vE_m_s"].nunique() == len(sins)


# ------------------------------------------------------------------------------- command line
def test_montecarlo_command_runs_resumes_and_reports(tmp_path):
    from click.testing import CliRunner
    from inmotion.cli.main import cli
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(textwrap.dedent(f"""\
        name: cli
        run: {SYNTH}
        runs: 4
        seed: 2
        grid: {{scale: [1.0, 2.0]}}
        """))
    out = tmp_path / "c"
    args = ["montecarlo", str(sweep), "--workers", "1", "-o", str(out), "--json", "--quiet",
            "--save-arrays"]
    res = CliRunner().invoke(cli, args + ["--runs", "2"])
    assert res.exit_code == 0, res.output
    first = json.loads(res.output)
    assert first["runs_done"] == 4 and Path(first["report"]).is_file()
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2 and "--resume" in res.output
    res = CliRunner().invoke(cli, args + ["--resume", "--no-report"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output)
    assert summary["runs_done"] == 8 and [p["runs"] for p in summary["points"]] == [4, 4]
    df = read_results(out)
    x = run_generator(2, 3).normal(0.0, 2.0, 64)
    assert df[(df.point_id == 1) & (df.run_index == 3)]["mean"].iloc[0] == x.mean()


@pytest.mark.parametrize("extra, message", [
    (["--workers", "1", "--scheduler", "tcp://127.0.0.1:1"], "not both"),
    (["--set", "novalue"], "expected key=value"),
    (["--method", "no-such-method"], "unknown method"),
    (["--init-error", "yaw=5furlongs"], "NAME=VALUEUNIT"),
])
def test_montecarlo_command_bad_input_exits_2(tmp_path, extra, message):
    from click.testing import CliRunner
    from inmotion.cli.main import cli
    res = CliRunner().invoke(cli, ["montecarlo", "paper004_v20", "-o", str(tmp_path / "c"),
                                   "--method", "sins", "--runs", "1", "--quiet", *extra])
    assert res.exit_code == 2, res.output
    assert message in res.output


def test_store_compacts_after_a_while_too(tmp_path):
    store = ResultStore(tmp_path, compact_every=1000, compact_after_s=0.0)
    store.write({"point_id": 3, "run_index": 0, "status": "ok"})
    assert store.journal_files() == [] and len(store.part_files()) == 1
    assert pd.read_parquet(store.part_files()[0])["point_id"].tolist() == [3]


def test_a_part_starting_with_an_error_row_keeps_every_result_column(tmp_path):
    store = ResultStore(tmp_path, compact_every=2)
    store.write({"point_id": 0, "run_index": 0, "status": "error", "error": "boom"})
    store.write({"point_id": 0, "run_index": 1, "status": "ok", "error": "", "a": 2.5})
    df = ResultStore(tmp_path).table()
    assert np.isnan(df["a"].iloc[0]) and df["a"].iloc[1] == 2.5


def test_methods_of_one_run_share_one_simulated_drive():
    from inmotion.evaluate import runs
    from inmotion.evaluate.montecarlo import iter_tasks
    from inmotion.sim import load_scenario, simulate
    sweep = short_drive_sweep()
    sweep.points[0].spec["scenario"]["segments"][0]["duration_s"] = 5.0
    scenario = sweep.points[0].spec["scenario"]
    # the cached drive is the fresh one, a copy each time, and the generator ends in the same state
    fresh_rng = run_generator(1, 0).spawn(2)[0]
    fresh = simulate(load_scenario(scenario), fresh_rng)
    runs._LAST_DRIVE.clear()
    got = []
    for _ in range(2):
        rng = run_generator(1, 0).spawn(2)[0]
        got.append(runs.simulate_cached(scenario, rng))
        assert rng.bit_generator.state == fresh_rng.bit_generator.state
    for b in got:
        assert np.array_equal(b.imu.dtheta, fresh.imu.dtheta)
        assert np.array_equal(b.radar.v, fresh.radar.v)
    got[0].imu.dtheta[:] = 0.0                               # a method scribbling on its drive
    again = runs.simulate_cached(scenario, run_generator(1, 0).spawn(2)[0])
    assert np.array_equal(again.imu.dtheta, fresh.imu.dtheta)
    # points with the same scenario are adjacent within a run, whatever the grid order
    grid = load_sweep({"run": "inmotion.evaluate.runs:default_run", "runs": 2,
                       "scenario": {"a": 1}, "method": "sins",
                       "grid": {"method": ["sins", "dr"], "scenario.a": [1, 2]}})
    order = [(t.run_index, t.spec["scenario"]["a"]) for t in iter_tasks(grid)]
    assert order == [(0, 1), (0, 1), (0, 2), (0, 2), (1, 1), (1, 1), (1, 2), (1, 2)]


def test_a_lost_chunk_is_recorded_as_one_error_per_run():
    from inmotion.evaluate.montecarlo import _outcomes
    chunk = [Task(4, k, 1, {"scale": 1.0}, {}, SYNTH, "scale=1.0") for k in (3, 4)]
    exc = RuntimeError("worker lost")
    for result in (exc, (RuntimeError, exc, None)):     # as Dask hands a failed future over
        rows = [r for r, _ in _outcomes(result, chunk)]
        assert [(r["run_index"], r["status"], r["seed"]) for r in rows] == \
            [(3, "error", 4), (4, "error", 4)]
        assert all(r["error"] == "RuntimeError: worker lost" for r in rows)
