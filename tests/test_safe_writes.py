"""Issue 16: every writer writes whole or not at all (kill-and-check), readers refuse partial
folders, files get the user's normal permissions, unwritable outputs are one-line errors.

Each kill test runs a writer in a subprocess, stops it with SIGKILL while it is writing (after
its k-th file, where it waits on purpose), and checks that the target holds its old content
byte for byte and reads, or (killed after the swap) the new content, complete; and that the
half-written sibling the kill left behind is refused by the reader.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from inmotion.errors import BadInput
from inmotion.io.bundle import read_bundle, write_bundle
from inmotion.io.result import read_result, write_result
from inmotion.io.safe_write import PARTIAL_MARKER, atomic_write, staged_folder

sys.path.insert(0, str(Path(__file__).parent))
from test_io_bundle import make_bundle  # noqa: E402
from test_io_result import make_solution  # noqa: E402

SRC = str(Path(__file__).resolve().parents[1] / "src")
TESTS = str(Path(__file__).resolve().parent)

#: the child: slows atomic_write down after its k-th file and signals the parent
CHILD_PRELUDE = """
import sys, time, pathlib
sys.path[:0] = [{src!r}, {tests!r}]
import inmotion.io.safe_write as sw
import inmotion.io.bundle, inmotion.io.result, inmotion.evaluate.store
_orig, _n = sw.atomic_write, [0]
def _slow(target, write):
    _orig(target, write)
    _n[0] += 1
    if _n[0] == {k}:
        pathlib.Path({flag!r}).touch()
        time.sleep(60)
for _m in list(sys.modules.values()):
    if getattr(_m, "atomic_write", None) is _orig:
        _m.atomic_write = _slow
"""


def _run_killed(tmp_path, body: str, k: int, timeout=60.0) -> None:
    """Run ``body`` in a child that stops after its k-th atomic file write; SIGKILL it there."""
    flag = tmp_path / f"flag-{k}"
    code = CHILD_PRELUDE.format(src=SRC, tests=TESTS, k=k, flag=str(flag)) + textwrap.dedent(body)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    t0 = time.monotonic()
    try:
        while not flag.exists():
            if proc.poll() is not None:
                out, err = proc.communicate()
                pytest.fail(f"the writer ended before its write {k}: {err.decode()[-2000:]}")
            assert time.monotonic() - t0 < timeout, "the writer never reached the kill point"
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _partials(parent: Path) -> list:
    return [p for p in parent.iterdir() if p.name.endswith(".partial")]


@pytest.mark.parametrize("k", [1, 2, 4])
def test_bundle_killed_while_overwritten_keeps_old_bundle(tmp_path, k):
    """The issue's case: a bundle being overwritten with another seed is killed after its k-th
    table; the folder still holds the old bundle whole, and the partial one is refused."""
    target = tmp_path / "drive"
    write_bundle(make_bundle(np.random.default_rng(1)), target)
    before = _snapshot(target)
    _run_killed(tmp_path, f"""
        import numpy as np
        from test_io_bundle import make_bundle
        from inmotion.io.bundle import write_bundle
        write_bundle(make_bundle(np.random.default_rng(2)), {str(target)!r})
    """, k)
    assert _snapshot(target) == before
    read_bundle(target)
    partial = _partials(tmp_path)
    assert len(partial) == 1
    with pytest.raises(BadInput, match="half-written bundle"):
        read_bundle(partial[0])


def test_bundle_new_write_killed_leaves_nothing_readable(tmp_path):
    target = tmp_path / "fresh"
    _run_killed(tmp_path, f"""
        import numpy as np
        from test_io_bundle import make_bundle
        from inmotion.io.bundle import write_bundle
        write_bundle(make_bundle(np.random.default_rng(2)), {str(target)!r})
    """, 2)
    assert not target.exists()
    with pytest.raises(BadInput, match="does not exist"):
        read_bundle(target)


def test_bundle_completed_write_is_the_new_one(tmp_path):
    target = tmp_path / "drive"
    a, b = make_bundle(np.random.default_rng(1)), make_bundle(np.random.default_rng(2))
    write_bundle(a, target)
    (target / "notes.txt").write_text("mine\n")
    write_bundle(b, target)
    np.testing.assert_array_equal(read_bundle(target).imu.dtheta, read_bundle_copy(b))
    assert (target / "notes.txt").read_text() == "mine\n"      # the user's file survives
    assert not _partials(tmp_path) and not list(tmp_path.glob(".*.old"))


def read_bundle_copy(b):
    return b.imu.dtheta


@pytest.mark.parametrize("k", [1, 3])
def test_result_killed_while_rewritten_keeps_old_result(tmp_path, k):
    target = tmp_path / "res"
    write_result(make_solution(np.random.default_rng(1)), target)
    before = _snapshot(target)
    _run_killed(tmp_path, f"""
        import numpy as np
        from test_io_result import make_solution
        from inmotion.io.result import write_result
        write_result(make_solution(np.random.default_rng(2)), {str(target)!r})
    """, k)
    assert _snapshot(target) == before
    read_result(target)
    partial = _partials(tmp_path)
    assert len(partial) == 1
    with pytest.raises(BadInput, match="half-written result"):
        read_result(partial[0])


def test_campaign_store_killed_during_compaction_keeps_every_run(tmp_path):
    """The store's journal survives a kill while a Parquet part is being written."""
    from inmotion.evaluate.store import ResultStore
    root = tmp_path / "camp"
    _run_killed(tmp_path, f"""
        from inmotion.evaluate.store import ResultStore
        import inmotion.evaluate.store as st
        s = ResultStore({str(root)!r}, compact_every=10**9, compact_after_s=1e9)
        for i in range(7):
            s.write({{"point_id": 0, "run_index": i, "seed": i, "status": "ok", "x": float(i)}})
        _orig_atomic = ResultStore._atomic
        def _slow_atomic(path, write):
            def w(tmp):
                write(tmp)
                pathlib.Path({str(tmp_path / 'flag-99')!r}).touch()
                time.sleep(60)
            _orig_atomic(path, w)
        ResultStore._atomic = staticmethod(_slow_atomic)
        s.compact()
    """, 99)
    store = ResultStore(root)
    df = store.table()
    assert sorted(df["run_index"]) == list(range(7))
    assert store.remove_partial() == 1          # the part cut short, never read


def test_import_killed_keeps_old_bundle(tmp_path):
    """``inmotion import`` over an existing bundle, killed mid-write."""
    src = tmp_path / "log.csv"
    b = make_bundle(np.random.default_rng(3), n=300)
    import pandas as pd
    pd.DataFrame({"time": b.imu.t, **{f"g{i}": b.imu.dtheta[:, i] / 0.01 for i in range(3)},
                  **{f"a{i}": b.imu.dvel[:, i] / 0.01 for i in range(3)}}).to_csv(src, index=False)
    mapping = tmp_path / "map.yaml"
    mapping.write_text(textwrap.dedent("""
        name: imported
        time: {column: time, unit: s}
        initial_position: {lat_deg: 34.2, lon_deg: 108.9, h_m: 400.0}
        imu:
          kind: rate
          axes: [right, forward, up]
          gyro: {columns: [g0, g1, g2], unit: rad/s}
          accel: {columns: [a0, a1, a2], unit: m/s^2}
    """))
    target = tmp_path / "bundle"
    write_bundle(make_bundle(np.random.default_rng(1)), target)
    before = _snapshot(target)
    _run_killed(tmp_path, f"""
        from inmotion.cli.main import cli
        cli.main(["import", "csv", {str(src)!r}, "--mapping", {str(mapping)!r},
                  "-o", {str(target)!r}])
    """, 1)
    assert _snapshot(target) == before


def test_export_killed_keeps_old_file(tmp_path):
    from inmotion.io.importers.kf_gins import export_kf_gins
    out = tmp_path / "sol.nav"
    export_kf_gins(make_solution(np.random.default_rng(1)), out)
    before = out.read_bytes()
    _run_killed(tmp_path, f"""
        import numpy as np
        from test_io_result import make_solution
        import inmotion.io.importers.kf_gins as kg
        import inmotion.io.safe_write as sw
        kg_orig = np.savetxt
        def slow(path, *a, **kw):
            kg_orig(path, *a, **kw)
            pathlib.Path({str(tmp_path / 'flag-99')!r}).touch()
            time.sleep(60)
        np.savetxt = slow
        kg.export_kf_gins(make_solution(np.random.default_rng(2)), {str(out)!r})
    """, 99)
    assert out.read_bytes() == before


def test_files_get_normal_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        write_bundle(make_bundle(np.random.default_rng(1)), tmp_path / "b")
        write_result(make_solution(np.random.default_rng(1)), tmp_path / "r")
        atomic_write(tmp_path / "f.txt", lambda p: Path(p).write_text("x"))
    finally:
        os.umask(old)
    for p in [tmp_path / "b", tmp_path / "r", *(tmp_path / "b").iterdir(),
              *(tmp_path / "r").iterdir(), tmp_path / "f.txt"]:
        want = 0o755 if p.is_dir() else 0o644
        assert p.stat().st_mode & 0o777 == want, p


def test_staged_folder_failure_leaves_old_content(tmp_path):
    target = tmp_path / "x"
    target.mkdir()
    (target / "a.txt").write_text("old")
    with pytest.raises(RuntimeError):
        with staged_folder(target) as tmp:
            atomic_write(tmp / "a.txt", lambda p: Path(p).write_text("new"))
            raise RuntimeError("boom")
    assert (target / "a.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"]


def test_reader_refuses_folder_with_marker(tmp_path):
    write_bundle(make_bundle(np.random.default_rng(1)), tmp_path / "b")
    (tmp_path / "b" / PARTIAL_MARKER).touch()
    with pytest.raises(BadInput, match="half-written"):
        read_bundle(tmp_path / "b")


@pytest.mark.parametrize("case", ["under_file", "dangling", "too_long", "is_file"])
def test_bad_output_paths_are_bad_input(tmp_path, case):
    b = make_bundle(np.random.default_rng(1), n=50)
    (tmp_path / "file").write_text("x")
    out = {"under_file": tmp_path / "file" / "b",
           "dangling": tmp_path / "link",
           "too_long": tmp_path / ("n" * 300),
           "is_file": tmp_path / "file"}[case]
    if case == "dangling":
        os.symlink(tmp_path / "nowhere", out)
    with pytest.raises(BadInput) as ei:
        write_bundle(b, out)
    assert "\n" not in str(ei.value) and str(out)[:40] in str(ei.value)


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_unwritable_output_is_bad_input(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(BadInput, match="permission"):
            write_bundle(make_bundle(np.random.default_rng(1), n=50), ro / "b")
    finally:
        ro.chmod(0o700)


def test_an_unrelated_folder_is_never_replaced(tmp_path):
    """Writing a result or a bundle onto a user's folder that is not one (a home, /tmp, a
    project) is refused, and the folder is left as it was; an empty folder is fine and keeps
    its permissions."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    with pytest.raises(BadInput, match="not a result folder"):
        write_result(make_solution(np.random.default_rng(1)), mine)
    with pytest.raises(BadInput, match="not a bundle folder"):
        write_bundle(make_bundle(np.random.default_rng(1), n=50), mine)
    assert sorted(p.name for p in mine.iterdir()) == ["thesis.tex"]
    empty = tmp_path / "empty"
    empty.mkdir()
    empty.chmod(0o750)
    write_result(make_solution(np.random.default_rng(1)), empty)
    assert empty.stat().st_mode & 0o777 == 0o750
    assert (empty / "summary.json").is_file()


def test_simulate_killed_while_overwriting_keeps_old_bundle(tmp_path):
    """The issue's report: ``simulate`` killed with -9 while overwriting a bundle left the new
    imu.csv with the old other tables, and ``inmotion info`` accepted it."""
    from click.testing import CliRunner
    from inmotion.cli.main import cli
    sys.path.insert(0, TESTS)
    from fuzz_common import SCENARIO
    (tmp_path / "s.yaml").write_text(SCENARIO)
    target = tmp_path / "drive"
    r = CliRunner().invoke(cli, ["--quiet", "simulate", str(tmp_path / "s.yaml"), "-o",
                                 str(target), "--seed", "1"])
    assert r.exit_code == 0, r.output
    before = _snapshot(target)
    _run_killed(tmp_path, f"""
        from inmotion.cli.main import cli
        cli.main(["--quiet", "simulate", {str(tmp_path / 's.yaml')!r}, "-o", {str(target)!r},
                  "--seed", "2"])
    """, 2)
    assert _snapshot(target) == before
    partial = _partials(tmp_path)
    assert len(partial) == 1
    r = CliRunner().invoke(cli, ["--quiet", "info", str(partial[0])])
    assert r.exit_code == 2 and "half-written bundle" in r.stderr, r.stderr
    assert CliRunner().invoke(cli, ["--quiet", "info", str(target)]).exit_code == 0


def test_a_killed_writers_sibling_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "drive"
    write_bundle(make_bundle(np.random.default_rng(1)), target)
    _run_killed(tmp_path, f"""
        import numpy as np
        from test_io_bundle import make_bundle
        from inmotion.io.bundle import write_bundle
        write_bundle(make_bundle(np.random.default_rng(2)), {str(target)!r})
    """, 1)
    assert len(_partials(tmp_path)) == 1
    write_bundle(make_bundle(np.random.default_rng(3)), target)
    assert _partials(tmp_path) == []
    read_bundle(target)
