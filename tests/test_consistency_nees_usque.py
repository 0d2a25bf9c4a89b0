"""Issue 15: paper 001's USQUE family has a sigma that covers its error with its default
``noise_preset: matched`` (:mod:`inmotion.align.usque_model`, "What the measurement's error
is"), and the paper's own setting (``noise_preset: paper`` with the paper's explicit figures,
the reproduction's ``PAPER_FILTER``) fails the same check.

A small Monte Carlo (:mod:`consistency_mc`): 6 runs of paper 001's test-1 drive cut to its
first 82 s (cruise, accelerate, cruise, decelerate, a 90 deg turn, cruise), each with its own
IMU constants and LDV errors drawn from the scenario's figures; the filters start from the
paper's ``q = [1 0 0 0]`` (8 deg off in heading, inside the 12 deg prior) whatever ``init``
says. Updates at 10 Hz to keep the file fast (the 100 Hz default over the whole 300 s drive:
``benchmarks/nees_usque.py``). The mean final-attitude NEES must lie in the 95 % band of its
chi-square.
"""
import pytest
import yaml

from consistency_mc import final_nees
from inmotion.reproductions.paper001 import PAPER_FILTER
from inmotion.sim.scenario import find_scenario, load_scenario

RUNS = 6
SCHEMES = ("usque", "ausque", "usque-hinf", "ausquhe")
FAST = {"update_rate_hz": 10.0}


@pytest.fixture(scope="module")
def drive():
    d = yaml.safe_load(open(find_scenario("paper001_urban")).read())
    d["imu"]["constant_errors"] = "random"
    d["segments"] = d["segments"][:5] + [{"kind": "cruise", "duration_s": 10.0}]
    return load_scenario(d)


@pytest.mark.parametrize("method", SCHEMES)
def test_matched_preset_nees_in_band(drive, method):
    m, (lo, hi), v = final_nees(method, FAST, drive, RUNS, (0.0, 0.0, 0.0))
    assert lo <= m <= hi, (method, m, (lo, hi), v)


@pytest.mark.parametrize("method", SCHEMES)
def test_paper_preset_is_overconfident(drive, method):
    """The paper's process noise (1e-7 deg per update) and white R (0.07 m/s) with the
    attitude state alone: far above the band (the measurement's integrated IMU errors,
    biases and the LDV scale factor are not in its model)."""
    m, (lo, hi), v = final_nees(method, {**FAST, **PAPER_FILTER}, drive, RUNS, (0.0, 0.0, 0.0))
    assert m > hi, (method, m, (lo, hi), v)
