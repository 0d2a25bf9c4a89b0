"""Start-up cost: what importing the package and the command line pulls in (issue 13, "Speed
and memory": a CLI run's fixed cost). The chi-square quantiles without scipy:
``tests/test_chi2_quantiles.py``.
"""
import subprocess
import sys

import pytest


def _modules_after(code):
    out = subprocess.run([sys.executable, "-c", code + "\nimport sys; print(' '.join(sys.modules))"],
                         capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_methods_that_gate_do_not_import_scipy_stats():
    mods = _modules_after("import inmotion.navigate.sins_dr, inmotion.align.dr_kalman, "
                          "inmotion.align.aided_kf, inmotion.align.strategy")
    assert "scipy.stats" not in mods


def _cli_modules(*args):
    code = ("import sys\nsys.argv = ['inmotion', *%r]\nfrom inmotion.cli.main import main\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "print('MODULES', ' '.join(sys.modules))" % (list(args),))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    return set(out.rsplit("MODULES", 1)[1].split())


@pytest.mark.parametrize("args", [("--help",), ("methods",), ("navigate", "--help"),
                                  ("montecarlo", "--help"), ("import", "--help")])
def test_the_cli_help_and_listing_import_nothing_heavy(args):
    mods = _cli_modules(*args)
    heavy = {m.split(".")[0] for m in mods} & {"numpy", "numba", "scipy", "pandas", "pyarrow",
                                               "matplotlib", "dask", "pydantic", "yaml"}
    assert not heavy, f"inmotion {' '.join(args)} imports {sorted(heavy)}"


def test_the_warm_up_runs_every_demo_step_and_install_calls_it():
    """``make install`` compiles the demo's kernels (``python -m inmotion.warmup``), so a fresh
    clone's first ``make demo`` only loads them (measured: 51 s cold, 5 s after warm-up)."""
    from inmotion import registry
    from inmotion.warmup import warm_up
    res = warm_up(30.0)
    assert res["failed"] == []
    names = {m.name for m in registry.methods("navigate")} | {"process"}
    ran = {label.split(": ")[-1] for label in res["steps"]}
    assert names <= ran
    from pathlib import Path
    make = (Path(__file__).resolve().parents[1] / "Makefile").read_text()
    stamp_rule = make.split("$(STAMP): pyproject.toml", 1)[1].split("\n\n", 1)[0]
    assert "-m inmotion.warmup" in stamp_rule
