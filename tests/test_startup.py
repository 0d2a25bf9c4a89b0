"""Start-up cost: the chi-square quantiles without ``scipy.stats``, and what importing the
package and the command line pulls in (issue 13, "Speed and memory": a CLI run's fixed cost).
"""
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import chi2 as stats_chi2

from inmotion.estimation import chi2


@pytest.mark.parametrize("dof", [1, 2, 3, 6, 15])
def test_chi2_quantiles_are_scipy_stats_values(dof):
    p = np.array([0.0, 1e-9, 0.025, 0.5, 0.95, 0.975, 0.99, 0.999, 0.9999, 1 - 1e-9, 1.0])
    assert np.array_equal(chi2.ppf(p, dof), stats_chi2.ppf(p, dof))
    assert np.array_equal(chi2.isf(p, dof), stats_chi2.isf(p, dof))
    for q in (0.01, 0.999):                  # scalars in, floats out, as scipy.stats gives
        assert isinstance(chi2.ppf(q, dof), float)
        assert chi2.ppf(q, dof) == float(stats_chi2.ppf(q, dof))
        assert chi2.threshold(q, dof) == float(stats_chi2.isf(q, dof))


def test_chi2_quantiles_broadcast_and_refuse_what_scipy_refuses():
    got = chi2.ppf([0.025, 0.975], 3 * 50)     # the reproductions' NEES band
    assert np.array_equal(got, stats_chi2.ppf([0.025, 0.975], 150))
    assert np.array_equal(chi2.ppf(0.9, [1, 2, 3]), stats_chi2.ppf(0.9, [1, 2, 3]))
    bad = chi2.ppf([-0.1, 1.1, np.nan], 3)
    assert np.all(np.isnan(bad)) and np.all(np.isnan(stats_chi2.ppf([-0.1, 1.1, np.nan], 3)))
    assert np.isnan(chi2.ppf(0.5, 0)) and np.isnan(stats_chi2.ppf(0.5, 0))


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
