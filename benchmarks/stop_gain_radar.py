"""The zero-velocity updates' gain at the stops of ``tests/test_process.py``'s stop-and-go radar
drive (issue 15): per seed, the largest velocity error at the stops with the updates over the
same without them (the test asks for < 0.6), and where ``dr-kf``'s noise settings came from,
for ``inmotion process`` as it is and with the ``methods`` settings given as JSON, e.g.
``'{"sway 0.02": {"dr-kf": {"zupt_noise_m_s": 0.02}}}'``. Usage (repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 nice -n 10 python benchmarks/stop_gain_radar.py [JSON]

About 20 s a variant.
"""
import json
import sys

import numpy as np

sys.path.insert(0, "tests")
from test_process import _nav_errors, _stop_and_go, scenario  # noqa: E402

from inmotion.core.solution import NavState  # noqa: E402
from inmotion.process import run_process  # noqa: E402
from inmotion.sim import simulate  # noqa: E402
from inmotion.sim.scenario import load_scenario  # noqa: E402

variants = {"as is": {}, **(json.loads(sys.argv[1]) if len(sys.argv) > 1 else {})}
ii = {"source": "truth", "has_attitude": True, "heading_sigma_deg": 0.1, "tilt_sigma_deg": 0.05}
for seed in (0, 1, 2):
    d = scenario(["radar"], speed0=10.0, drift_deg_h=1.0, arw=0.05, bias_ug=300.0, vrw=30.0)
    d["segments"] = _stop_and_go(seed, segments_only=True)
    b = simulate(load_scenario(d), np.random.default_rng(seed))
    init = NavState.from_truth(b.truth)
    for name, methods in variants.items():
        res = {z: run_process(b, {"zupt": z, "methods": methods}, init, ii) for z in (False, True)}
        (_, dv, _, sv, stopped), (_, dv0, _, _, _) = (_nav_errors(res[z], b.truth)
                                                      for z in (True, False))
        a, a0 = np.abs(dv[stopped]).max(), np.abs(dv0[stopped]).max()
        worst = float((np.abs(dv[1:]) / sv[1:]).max())
        src = res[True].info["config_source"].get("dr-kf", {})
        print(f"seed {seed} {name:12s} stops max |dv| {a:.4f} (without updates {a0:.4f}) "
              f"ratio {a / a0:.2f}; worst |dv|/sigma {worst:.2f}; dr-kf "
              + ", ".join(f"{k}: {src.get(k)}" for k in ("zupt_noise_m_s", "velocity_noise_m_s",
                                                         "gyro_drift_deg_h")), flush=True)
