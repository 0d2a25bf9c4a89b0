"""A method's attitude NEES over time on paper 003's drive's first 194 s (issue 15, session 15):
cruise, accelerate, cruise, a 90 deg turn, cruise (``consistency_mc.drive_003_start``), each
run with its constant errors and a start error drawn (0.1 / 0.1 / 0.5 deg, the prior the same),
seeds 100 ..; per time, the mean per component of ``(phi / sigma)^2`` (E, N, U), their sum,
and the RMS error and RMS sigma [arcmin]; the last time's per-run values. Usage (from the
repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 python benchmarks/nees_drive_start.py METHOD [RUNS] [CONFIG] [SCENARIO]

``CONFIG``: JSON added to the configuration, e.g. ``'{"false_alarm_rate": 0.05}'``;
``SCENARIO``: JSON changes to the drive: ``pulses_per_m`` (the odometer's),
``lateral_sigma_m_s`` / ``lateral_tau_s`` / ``vertical_sigma_m_s`` (the vehicle's constraint
violation), ``no_violation``. The 95 % band of the sum's mean over 10 runs is 1.68-4.70.

Measured (10 runs, at 193 s):

- The NHC fallback (od-kf, ldv-kf, fkf) read the vehicle's mounting as a velocity: with
  ``mounting_from_meta`` false (the channels estimate the mounting) its rows were in the IMU's
  frame with no mounting columns, and on this drive (10' pitch, 15' yaw) its heading drifted
  from the primary's (seed 104, detection off: 57' apart at 193 s at a 14.6' sigma). At the
  paper's false-alarm rate, ``od-kf '{"false_alarm_rate": 0.05}'``, 3 runs ended on the
  fallback 38', 49', 25' off at 11-13' sigma: NEES 5.93. With the mounting columns
  (``aided_kf._nhc``): 1.48, those runs 5.6', 17.3', 13.4' off at 14-17'. ``fkf`` at 0.05
  (the fallback when both channels are isolated) 3.15 -> 1.47 (heading 15.1' RMS at a 6.0'
  sigma -> 2.9' at 7.0'), ``ldv-kf`` 2.34 -> 2.25.
- Conservative after the turn, detection at its default: ``od-kf`` 0.80 (heading 0.12:
  error 2.3' RMS against a 6.6' sigma; at 85 s 2.83), the paper's rows 1.07; without the
  vehicle's constraint violation 4.53 (heading 3.0' against 2.3'); with only its vertical part
  2.14; with its lateral part white (``'{"lateral_sigma_m_s": 0.0316, "lateral_tau_s":
  0.05}'``, the same white equivalent, ``meta_spec.markov_white_equivalent_sigma``) 2.88
  (heading 6.5' against 6.4'), with it slower (``0.00316``, 5 s) 0.89. So the filter is
  consistent when the violation is white and conservative when it is coloured: the white
  equivalent holds the low-frequency information but the heading is learned over the turn's
  seconds, where a coloured violation has less power. The consistent form is the violation as
  a state (a shaping filter); not done. ``fkf`` 0.45-1.04, ``ldv-kf`` 1.03-1.46 (6 runs).
- The fine odometer (``'{}' '{"pulses_per_m": 20000}'``): 5.82 at 193 s (3.59 at 150 s),
  overconfident after the turn (heading 3.0' against 2.0'); at 85 s on the shorter drive it is
  in band (``tests/test_consistency_nees.py``). With the length row's memory
  (``benchmarks/with_length_knobs.py 0 memory:64 '{}' benchmarks/nees_drive_start.py od-kf 10
  '{}' '{"pulses_per_m": 20000}'``, ``aided_kf.LENGTH_MEMORY_MAX``) 2.44 (heading 2.3' against
  3.0'), as it puts the matched small start in band; not the default, since on this drive it
  makes the usual sensors' filters more conservative still (fkf 0.45, ``fine-mux`` 0.85: the
  comment at ``LENGTH_MEMORY_MAX``).
"""
import json
import sys

import numpy as np
import yaml

from inmotion import registry
from inmotion.core.metrics import error_series
from inmotion.core.solution import NavState
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

ARCMIN = 180.0 / np.pi * 60.0
TIMES_S = (20, 45, 85, 120, 150, 175, 193)
START_SIGMA_DEG = (0.1, 0.1, 0.5)


def scenario(changes: dict):
    d = yaml.safe_load(open(find_scenario("paper003_drive")).read())
    d["segments"] = d["segments"][:5]
    d["imu"]["constant_errors"] = "random"
    cv = d["vehicle"]["constraint_violation"]
    for k in ("lateral_sigma_m_s", "lateral_tau_s", "vertical_sigma_m_s"):
        if k in changes:
            cv[k] = float(changes[k])
    if changes.get("no_violation"):
        d["vehicle"].pop("constraint_violation")
    if "pulses_per_m" in changes:
        d["sensors"]["odometer"]["pulses_per_m"] = float(changes["pulses_per_m"])
    return load_scenario(d)


def main(method, runs=10, config=None, changes=None):
    run, Config = registry.get(method).load()
    sc = scenario(changes or {})
    nees = np.zeros((len(TIMES_S), 3))
    e2 = np.zeros_like(nees)
    s2 = np.zeros_like(nees)
    last = []
    for k in range(runs):
        rng = np.random.default_rng(100 + k)
        b = simulate(sc, rng)
        err = np.radians(START_SIGMA_DEG) * rng.standard_normal(3)
        cfg = dict(init_tilt_sigma_deg=START_SIGMA_DEG[0], init_heading_sigma_deg=START_SIGMA_DEG[2],
                   **(config or {}))
        sol = run(b, Config(**cfg), NavState.from_truth(b.truth, euler_error=err))
        e = error_series(sol, b.truth)
        t = np.asarray(sol.t) - sol.t[0]
        phi = e[["phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin"]].to_numpy()
        sig = np.column_stack([sol.sigma[c] for c in ("phi_E", "phi_N", "phi_U")]) * ARCMIN
        for i, ti in enumerate(TIMES_S):
            j = min(int(np.searchsorted(t, ti)), len(phi) - 1)
            nees[i] += (phi[j] / sig[j]) ** 2
            e2[i] += phi[j] ** 2
            s2[i] += sig[j] ** 2
        last.append((phi[j], sig[j]))
    for i, ti in enumerate(TIMES_S):
        print(f"{ti:4d} s  NEES E/N/U {np.round(nees[i] / runs, 2)} sum {nees[i].sum() / runs:.2f}"
              f"  RMS error {np.round(np.sqrt(e2[i] / runs), 3)}  RMS sigma "
              f"{np.round(np.sqrt(s2[i] / runs), 3)} arcmin")
    for k, (p, s) in enumerate(last):
        print(f"  seed {100 + k}: error {np.round(p, 2)} sigma {np.round(s, 2)} arcmin")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(a[0], int(a[1]) if len(a) > 1 else 10, json.loads(a[2]) if len(a) > 2 else None,
         json.loads(a[3]) if len(a) > 3 else None)
