"""The reproductions as campaign specifications (issue 17, "Where the reproductions live").

Each paper's Monte Carlo is a sweep file shipped in ``inmotion/reproductions/campaigns/``;
``common.run_campaign_file`` runs it on the campaign engine. Checked here: the files load and
their grids are the experiments' own tables; a run's generator names its (seed, run) so the
papers keep their streams; a nested record survives the results table value for value; and
the same file runs with the ordinary ``inmotion montecarlo`` command, giving the same table as
the reproduction's harness, which resumes instead of running again.
"""
import json
import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from inmotion.cli.main import cli
from inmotion.evaluate.campaign import TIMING_COLUMNS, run_generator
from inmotion.evaluate.sweep import load_sweep
from inmotion.reproductions import common
from inmotion.reproductions import paper000 as p0
from inmotion.reproductions import paper002 as p2
from inmotion.reproductions import paper003 as p3
from inmotion.reproductions import suite


def test_pack_and_unpack_give_back_the_record_value_for_value():
    rec = {"run": 3, "x": np.float64(0.1 + 0.2), "flag": np.bool_(True), "nan": float("nan"),
           "rows": [{"fkf": [1.0 / 3.0, -2e-17], "n": np.int64(7)}],
           "series": {"a": (np.arange(4.0) / 7.0, np.eye(2)), "events": [{"t_s": 1.5}]},
           "deep": {"m": np.array([[1, 2], [3, 4]], dtype=np.int32)}}
    packed = common.pack_record(rec)
    assert set(packed) == {"record", "arrays"} and len(packed["arrays"]) == 3
    back = common.unpack_record(packed["record"], packed["arrays"])
    assert back["run"] == 3 and back["x"] == 0.1 + 0.2 and back["flag"] is True
    assert math.isnan(back["nan"])
    assert back["rows"] == [{"fkf": [1.0 / 3.0, -2e-17], "n": 7}]
    t, eye = back["series"]["a"]                  # a tuple comes back as a list
    np.testing.assert_array_equal(t, np.arange(4.0) / 7.0)
    np.testing.assert_array_equal(eye, np.eye(2))
    assert back["series"]["events"] == [{"t_s": 1.5}]
    assert back["deep"]["m"].dtype == np.int32 and back["deep"]["m"].tolist() == [[1, 2], [3, 4]]


def test_run_key_names_the_run_and_the_stream_is_the_former_spawn():
    rng = run_generator(11, 4)
    assert common.run_key(rng) == (11, 4)
    # paper 003's former seeding, SeedSequence(seed).spawn(runs)[r], is the run's stream
    former = np.random.default_rng(np.random.SeedSequence(11).spawn(6)[4])
    assert rng.random(5).tolist() == former.random(5).tolist()


@pytest.mark.parametrize("name, issue", [("paper000", "000"), ("paper001", "001"),
                                         ("paper002", "002"), ("paper003", "003"),
                                         ("paper004", "004")])
def test_shipped_campaigns_load_with_the_issue_runs(name, issue):
    sweep = load_sweep(common.campaign_file(name))
    assert sweep.name == name and sweep.runs == suite.get(issue).issue_runs
    from inmotion.evaluate.campaign import _resolve
    run = _resolve(sweep.run)
    for p in sweep.points:
        run.validate_spec(p.spec)


def test_the_grids_are_the_experiments_tables():
    grid = {n: load_sweep(common.campaign_file(n)).grid
            for n in ("paper000", "paper000_z2", "paper002")}
    assert grid["paper000"] == {"experiment": list(p0.EXPERIMENTS)}
    assert grid["paper000_z2"] == {"condition": list(p0.Z2_STUDY)}
    assert load_sweep(common.campaign_file("paper000_z2")).runs == p0.Z2_RUNS
    assert grid["paper002"] == {"variant": list(p2.METHODS)}
    assert p2.PAPER == common.campaign_paper("paper002")
    assert load_sweep(common.campaign_file("paper003")).base["windows"] == p3.N_WINDOWS


def test_a_typo_in_a_grid_fails_before_the_campaign(tmp_path):
    from inmotion.errors import BadInput
    doc = {"name": "t", "run": "inmotion.reproductions.paper002:run",
           "grid": {"variant": ["attitude-positoin"]}}
    from inmotion.evaluate.montecarlo import run_campaign
    with pytest.raises(BadInput, match="not one of paper002.METHODS"):
        run_campaign(load_sweep(doc), tmp_path / "c", workers=1, quiet=True)
    with pytest.raises(BadInput, match="no reproduction campaign 'nope'"):
        common.campaign_file("nope")


#: what a paper 000 record measures of the machine (its filters' wall and CPU time): the only
#: values that differ between two executions of a run, besides the engine's own timing columns
RECORD_TIMINGS = {"wall_s", "cpu_s"}


def _without_timings(x):
    if isinstance(x, dict):
        return {k: _without_timings(v) for k, v in x.items() if k not in RECORD_TIMINGS}
    if isinstance(x, list):
        return [_without_timings(v) for v in x]
    return x


def _comparable(df):
    return df.drop(columns=[*TIMING_COLUMNS, "record"]) \
        .sort_values(["point_id", "run_index"]).reset_index(drop=True)


def _assert_same_records(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        np.testing.assert_equal(_without_timings(x), _without_timings(y))


def test_the_file_runs_with_the_ordinary_campaign_command_and_the_harness_alike(tmp_path):
    """Paper 000's file (one run: about 1 CPU-s a point) by ``inmotion montecarlo`` and by
    the reproduction's harness: the same table; the harness's second call resumes (runs
    nothing) and its records are those of the former run function."""
    from inmotion.evaluate.montecarlo import read_results
    path = common.campaign_file("paper000")
    res = CliRunner().invoke(cli, ["montecarlo", str(path), "--runs", "1", "--workers", "1",
                                   "--no-report", "--quiet", "--json", "-o",
                                   str(tmp_path / "cli")], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["runs_done"] == 3
    camp = common.run_campaign_file("paper000", tmp_path / "repro", runs=1, progress=False)
    assert camp.directory == tmp_path / "repro" / "campaign" / "paper000"
    cli_table = read_results(tmp_path / "cli")
    pd.testing.assert_frame_equal(_comparable(cli_table), _comparable(camp.table))
    cli_camp = common.CampaignResult(camp.sweep, tmp_path / "cli", cli_table, 0.0)
    _assert_same_records(cli_camp.records(), camp.records())
    again = common.run_campaign_file("paper000", tmp_path / "repro", runs=1, progress=False)
    pd.testing.assert_frame_equal(again.table, camp.table)     # resumed: nothing ran again
    recs = again.records()
    assert [r["experiment"] for r in recs] == list(p0.EXPERIMENTS)
    # the former task loop's run of trajectory 2, in this process: the same numbers
    _assert_same_records([recs[1]], [p0.run_one(("traj2", 0, 0))])
