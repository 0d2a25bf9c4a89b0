"""``inmotion process`` opens the truth table for reading in chunks (issue 13: memory flat in
the log's length): the run never reads the truth but for its errors, so the result is the
same, file for file, as with the truth loaded whole; where the start position would come
from the truth (no position in ``meta.yaml``), the truth is loaded whole as before."""
from types import SimpleNamespace

import numpy as np
import yaml
from click.testing import CliRunner

import inmotion.cli.main as cli_main
import inmotion.process
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.bundle_stream import TruthStream
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario
from test_process import scenario


def _run(path, out, monkeypatch, whole=False):
    seen = []
    real = inmotion.process.run_process

    def spy(bundle, *a, **k):
        seen.append(bundle.truth)
        return real(bundle, *a, **k)
    monkeypatch.setattr(inmotion.process, "run_process", spy)
    if whole:
        monkeypatch.setattr(cli_main, "_process_bundle",
                            lambda ctx, p, gaps, init: cli_main._read_bundle(ctx, p, gaps))
    r = CliRunner().invoke(cli_main.cli, ["-q", "process", str(path), "-o", str(out),
                                          "--no-report"], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    monkeypatch.undo()
    return seen[0]


def _same_tables(a, b):
    for name in ("solution.csv", "states.csv", "errors.csv"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_process_reads_the_truth_in_chunks_and_writes_the_same_result(tmp_path, monkeypatch):
    b = simulate(load_scenario(scenario(["radar", "baro"], speed0=10.0, cruise_s=40.0)),
                 np.random.default_rng(4))
    write_bundle(b, tmp_path / "b", fmt="parquet")
    truth = _run(tmp_path / "b", tmp_path / "chunks", monkeypatch)
    assert isinstance(truth, TruthStream)
    truth = _run(tmp_path / "b", tmp_path / "whole", monkeypatch, whole=True)
    assert not isinstance(truth, TruthStream)
    _same_tables(tmp_path / "chunks", tmp_path / "whole")
    # no position in meta.yaml: the start position would be the truth's first row (where a
    # stage has the truth), so the truth is loaded whole; with --init it is not needed
    meta_path = tmp_path / "b" / "meta.yaml"
    meta = yaml.safe_load(meta_path.read_text())
    for k in ("lat_deg", "lon_deg", "h_m", "initial_position"):
        meta.pop(k, None)
    meta_path.write_text(yaml.safe_dump(meta))
    ctx = SimpleNamespace(obj=None)
    whole = cli_main._process_bundle(ctx, tmp_path / "b", False, None).truth
    assert not isinstance(whole, TruthStream)
    assert np.array_equal(whole.lat, read_bundle(tmp_path / "b").truth.lat)
    assert isinstance(cli_main._process_bundle(ctx, tmp_path / "b", False, "truth").truth,
                      TruthStream)
