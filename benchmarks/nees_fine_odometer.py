"""od-kf's final-attitude NEES with a fine and a coarse odometer (issue 15): the drive and
start of ``tests/test_consistency_nees.py`` (paper 003's drive cut to 85 s, 0.1 / 0.1 / 0.5
deg start, seeds 100 ..) with the odometer at each ``pulses_per_m``, mean, 95 % band and per
run. Usage (from the repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/nees_fine_odometer.py [RUNS] [PULSES_PER_M,...] [CONFIG_JSON] [START_DIVISOR] [VELOCITY_SIGMA_M_S]

Defaults: 10 runs, 20000,200 pulses/m; ``CONFIG_JSON`` adds to the test's prior, e.g.
``'{"fdi": false}'`` (the channel alone) or ``'{"gyro_markov_deg_h": 0.003,
"gyro_markov_tau_s": 300}'`` (the two-part gyro bias); ``START_DIVISOR`` divides the drawn
start error (not the prior: give the matching ``init_*_sigma_deg`` in ``CONFIG_JSON``, e.g.
``'{"init_tilt_sigma_deg": 0.02, "init_heading_sigma_deg": 0.1}' 5``). About 3 s a run on one
core.

Measured (issue 15, seeds 100-109): 20,000 pulses/m under the defaults 45.69 with the rows in
the body's axes, 50.55 with them in the sensor displacement's frame
(``aided_kf._rows_to_displacement_frame``); ``'{"linearization_floor": true}'`` 4.44 -> 4.33;
200 pulses/m 3.02 -> 3.01 (band 1.68-4.70). With ``'{"exact_attitude_columns": true}'``
(the rows' exact attitude columns, ``benchmarks/heading_symmetry.py``): 59.51 under the
detection, 139.3 with ``"fdi": false`` (per run 372.3, 77.0, 63.4, 4.6, 508.0, 30.6, 19.6,
152.5, 153.1, 12.1: no divergence), with ``"linearization_floor": true`` 4.61.

With ``'{"exact_attitude_columns": true, "second_order_length": true}'`` (the length row's
second order under the filter's own covariance, ``aided_kf._length_second_order``, issue 15,
helper h15nees4): 20,000 pulses/m 6.85 (per run 10.4, 0.3, 17.5, 3.3, 4.7, 0.5, 11.4, 5.8,
8.5, 6.0), 200 pulses/m 2.98 (per run 5.0, 0.6, 0.1, 2.7, 6.7, 0.0, 0.8, 3.2, 3.5, 7.1). The
variants measured on the way (20,000 pulses/m, exact columns): the mean and variance alone
42.4; the floor from the filter's own heading variance alone (``E[psi^4] d^2 / 4`` on the
along row; on the lateral and vertical rows it changes nothing) 36.3; the mean taken as
noise (its square in the variance) 24.4, with that floor 7.13; ``b_perp`` from the
velocity's covariance alone (the heading's share left out, wrong) 57.0, with the floor 10.7.

Since (issue 15, helper h15nees5): that second order's variance taken 4 times
(``aided_kf.LENGTH_VAR_SCALE``: its error repeats over about 5 intervals,
``benchmarks/heading_rows.py``), measured with ``benchmarks/with_length_knobs.py MEAN_MODE
VAR_SCALE '{}' benchmarks/nees_fine_odometer.py 10 20000 '{"exact_attitude_columns": true,
"second_order_length": true}'``: 20,000 pulses/m 3.20 (per run 7.7, 0.1, 4.5, 1.6, 4.8, 0.1,
1.6, 2.4, 3.8, 5.3; band 1.68-4.70); 16 times 2.81 (8.2, 0.6, 0.3, 1.3, 4.9, 0.0, 0.8, 2.6,
2.8, 6.4); once 6.85 (as above); the second-order mean left out of the innovation
(``MEAN_MODE`` 1, once) 8.32 (13.1, 0.2, 23.3, 4.6, 4.6, 0.2, 11.6, 6.9, 13.0, 5.9). 200
pulses/m at 4 times: 3.04 (5.9, 0.9, 0.1, 2.4, 6.3, 0.0, 0.9, 3.1, 3.7, 7.1). At 2 times
4.43 (7.1, 0.1, 11.1, 2.0, 4.5, 0.2, 5.3, 2.7, 5.5, 5.7). Seeds 100-119 at 4 times (the code's,
``nees_fine_odometer.py 20 20000 CONFIG``): 3.22 (band 2.02-4.16).

Since (issue 15, helper h15nees6): a start 5 times smaller with the prior matched to it,
``nees_fine_odometer.py 10 20000 '{"init_tilt_sigma_deg": 0.02, "init_heading_sigma_deg":
0.1}' 5`` (``benchmarks/heading_symmetry.py``'s ``small-start`` keeps the 0.1 / 0.5 deg prior:
5 times the start error): the default settings 24.21 (per run 139.5, 31.5, 6.5, 5.2, 19.0,
6.5, 24.1, 1.9, 5.3, 2.7; with ``"fdi": false`` 3.5e9, diverged), both settings at 4 times
9.41 (21.6, 1.1, 21.1, 8.2, 15.8, 3.3, 7.4, 5.3, 5.1, 5.2), with the second order's variance
taken as many times as the filter has combined intervals (``with_length_knobs.py 0 memory``,
``aided_kf.LENGTH_MEMORY_MAX``) 3.80 (11.8, 0.3, 3.2, 1.6, 6.1, 0.2, 0.4, 2.9, 5.3, 6.2), at
most 64 times 4.05, at most 16 times 5.20; the usual start under that memory form 2.75 (7.1,
0.7, 0.1, 1.2, 4.8, 0.0, 0.6, 2.9, 2.7, 7.3), seeds 100-119 2.48. The memory form stays off
for the fault detection it costs (``benchmarks/length_memory_fdi.py``).
Since (issue 15, helper h15def) ``exact_attitude_columns`` and ``second_order_length`` are
the defaults: "the defaults" / "the default settings" in the figures above mean paper 003's
rows, now ``'{"exact_attitude_columns": false, "second_order_length": false}'``. Under the
new defaults ``10 20000`` gives 3.20 (per run as above at 4 times).
Since (issue 15, helper h16perfect) the displacement rows carry the VRW integrated within
the interval (``aided_kf.displacement_vrw_m_s``): ``10 20000`` 3.20 (per run as before to
0.1), the matched small start 9.41 -> 9.06 (per run 21.2, 1.1, 20.2, 7.4, 15.4, 3.0, 6.8, 5.1,
5.0, 5.2); with the inflation off (``with_length_knobs.py 0 1 '{}'``) 6.85 -> 6.70 and 14.66
-> 14.30. What the 4 times covers: ``benchmarks/perfect_sensors.py`` (no model mismatch;
the start's heading error squared at the usual start, the IMU's errors with the precise row
at the small one).
"""
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from consistency_mc import final_nees  # noqa: E402
from test_consistency_nees import PRIOR, START_SIGMA_DEG, fine_odometer_drive  # noqa: E402

runs = int(sys.argv[1]) if len(sys.argv) > 1 else 10
ppms = [float(x) for x in sys.argv[2].split(",")] if len(sys.argv) > 2 else [20000.0, 200.0]
cfg = dict(PRIOR, **(json.loads(sys.argv[3]) if len(sys.argv) > 3 else {}))
div = float(sys.argv[4]) if len(sys.argv) > 4 else 1.0
# the start velocity drawn per axis with this sigma [m/s] (0: the true velocity; give the
# matching prior ``init_velocity_sigma_m_s`` in CONFIG_JSON)
vdraw = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
start = np.asarray(START_SIGMA_DEG) / div
for ppm in ppms:
    mean, (lo, hi), v = final_nees("od-kf", cfg, fine_odometer_drive(ppm), runs, start,
                                   velocity_sigma_m_s=vdraw)
    print(f"od-kf {ppm:.0f} pulses/m {cfg} start error / {div:g} runs {runs} mean NEES {mean:.2f} band "
          f"[{lo:.2f}, {hi:.2f}] runs {np.round(v, 1).tolist()}", flush=True)
