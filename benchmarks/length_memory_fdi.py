"""The residual test's statistic at ``tests/test_paper003_filters.py``'s faults (fkf,
displacement rows, 0.2 s intervals, false-alarm rate 1e-5, seed 11) under a choice of the
length row's second-order variance (issue 15, helper h15nees6): the first detection in each
fault window with its statistic and threshold. Usage (from the repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 python benchmarks/length_memory_fdi.py KNOB [CONFIG_JSON]

``KNOB``: a number (``aided_kf.LENGTH_VAR_SCALE``), or ``memory`` / ``memory:N``
(``aided_kf.LENGTH_MEMORY_MAX``: the variance times the intervals the filter has combined since
its start, at most ``N``), or ``walk:Q[:N]`` (``aided_kf.LENGTH_SCALE_WALK``: a random walk of
``Q`` ppm / sqrt(s) on the scale state, the variance ``N`` times, default 1); ``CONFIG_JSON`` adds to the configuration (default: both issue 15
settings on, ``'{"exact_attitude_columns": false, "second_order_length": false}'`` for paper
003's rows).

Measured (seed 11; faults: odometer idle 30-35 s, LDV +0.5 m/s 50-55 s, odometer slip and
LDV -0.5 m/s 70-75 s; statistic / threshold, odometer 7.6, LDV 19.8): paper 003's rows
(any knob) odometer 2059.5, LDV 101.9, odometer 4483.1, LDV 141.5; both settings at
``4``: 529.7, 1245.0, 2125.3, 2406.8; ``memory:16``: 159.4, 259.6, 713.8, 451.0;
``memory:32``: 82.1, 123.3, 364.8, 210.0; ``memory:64``: 41.8, 59.6, 180.3, 99.7;
``memory`` (no bound): 18.1, the LDV's 50 s fault not detected, 34.6, 22.7; ``walk:20``:
1246.6, 8198.1, 3585.2, 41.7 (at 70.0 s). The inflation
that makes the NEES honest deflates the single-row test by the same factor (the test takes
the filter's ``R``; its weights, ``aided_kf.residual_test_weights``, are per channel, not per
interval), so an unbounded memory blinds the detection as a run goes on.

Since helper h15split the test takes the length row's single-interval variance (the
sensor's plus its second order's ``Var(e2)``; ``Measurement.test_variance``), the update the
inflated one: both settings at ``4``: 1442.4, 7400.8, 3876.3, 36.1 (the last at 70.0 s);
``memory:64``: 789.5, 1782.4, 2574.9, 2978.6 (at 70.2 s); ``memory``: 612.1, 786.9, 1497.8,
1072.4 (at 70.2 s): every fault detected at its first or second test, the memory no longer
blinds it (its false-alarm rate: ``benchmarks/fdi_calibration.py``'s docstring).
"""
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from test_paper003_filters import FAULTS, _base, _init  # noqa: E402

from inmotion.align import aided_kf as ak  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

knob = sys.argv[1]
if knob.startswith("memory"):
    ak.LENGTH_MEMORY_MAX = float(knob.partition(":")[2] or "inf")
elif knob.startswith("walk:"):
    walk, _, scale = knob[5:].partition(":")
    ak.LENGTH_SCALE_WALK = float(walk)
    ak.LENGTH_VAR_SCALE = float(scale or 1.0)
else:
    ak.LENGTH_VAR_SCALE = float(knob)
cfg = {"exact_attitude_columns": True, "second_order_length": True, "measurement":
       "displacement", "measurement_period_s": 0.2, "false_alarm_rate": 1e-5}
cfg.update(json.loads(sys.argv[2]) if len(sys.argv) > 2 else {})
d = _base()
d["faults"] = FAULTS
b = simulate(load_scenario(d), np.random.default_rng(11))
ev = ak.run_fkf(b, cfg, _init(b)).info["events"]
for f in FAULTS:
    det = [e for e in ev if e["event"] == "detected" and e["channel"] == f["sensor"]
           and f["start_s"] <= e["t_s"] <= f["end_s"]]
    got = (f"at {det[0]['t_s']:.1f} s statistic {det[0]['test_value']:.1f} threshold "
           f"{det[0]['threshold']:.1f}" if det else "not detected")
    print(f"{knob} {f['sensor']} {f['kind']} {f['start_s']}-{f['end_s']} s: {got}", flush=True)
