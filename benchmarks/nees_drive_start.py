"""A method's attitude NEES over time on paper 003's drive's first 194 s (issue 15, session 15):
cruise, accelerate, cruise, a 90 deg turn, cruise (``consistency_mc.drive_003_start``), each
run with its constant errors and a start error drawn (0.1 / 0.1 / 0.5 deg, the prior the same),
seeds ``SEED0`` (100) ..; per time, the mean per component of ``(phi / sigma)^2`` (E, N, U), their sum,
and the RMS error and RMS sigma [arcmin]; the last time's per-run values. Usage (from the
repository root)::

    PYTHONPATH=src:tests OPENBLAS_NUM_THREADS=1 python benchmarks/nees_drive_start.py METHOD [RUNS] [CONFIG] [SCENARIO] [SEED0]

``CONFIG``: JSON added to the configuration, e.g. ``'{"false_alarm_rate": 0.05}'``;
``SCENARIO``: JSON changes to the drive: ``pulses_per_m`` (the odometer's),
``lateral_sigma_m_s`` / ``lateral_tau_s`` / ``vertical_sigma_m_s`` (the vehicle's constraint
violation), ``no_violation``, ``prior_drawn`` (the truth drawn from the filter's priors as
the start already is: per run the vehicle mounting's pitch and yaw from ``N(0,
mount_sigma_arcmin)``, the lever arms in ``meta`` off the true ones by ``N(0, lever_sigma_m)``
per axis; ``"mount"`` / ``"lever"`` instead of ``true``: that part alone; the configuration then sets ``od_scale_sigma_ppm`` / ``ldv_scale_sigma_ppm`` to
the simulated spreads unless given). The 95 % band of the sum's mean over 10 runs is 1.68-4.70.

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
  (heading 6.5' against 6.4'), with it slower (``0.00316``, 5 s) 0.89. Read in session 15 as
  "consistent when the violation is white, conservative when it is coloured"; **measured
  false in session 16**:

  - the violation as the filter's own states (a shaping filter, built and measured, not
    kept): two first-order Gauss-Markov states per channel (lateral, vertical, vehicle frame,
    ``F = -1 / tau``), the rows' ``T C_v^b0 [cv_x, 0, cv_z]`` columns, the interval means
    modelled as the end samples of a process with the same ``tau`` and ``s^2 = (2 sigma^2 tau
    / T) (1 - rho) / (1 + rho)`` (``rho = exp(-T / tau)``: equal to the means' spectrum at
    zero frequency, above it elsewhere), the rows' lateral / vertical noise left at the model
    part: od-kf 0.79 at 193 s (heading 2.19' RMS at a 6.68' sigma) against 0.80 (2.29' at
    6.64'), every time step within 0.15 of the white-equivalent rows; on
    ``benchmarks/perfect_sensors.py filter 10 '{"viol": true}'`` (the violation the only
    error, 0.1 / 0.1 / 0.5 deg start) 2.89 against 3.06. The heading's information is at low
    frequency, where both models hold the same ``2 sigma^2 tau``;
  - the simulator's violation is what ``meta`` says: the truth's vehicle-frame velocity,
    means over 5-10 s windows (6 drives), ``Var * L`` = 0.79e-4 lateral, 1.7e-4 vertical
    m^2/s against the spec's ``2 sigma^2 tau`` 1.0e-4, 1.6e-4, and the IMU's increments carry
    it (truth minus the integrated increments, high-passed at 5 s: 4e-5 m/s RMS against the
    violation's 8.5e-3);
  - the same rows' noise (``'{"od_noise_m_s": [0.01418, 0.00408, 0.01792]}'``, the matched
    values) on the drive without the violation: 1.43 (heading 4.35' RMS at 6.59'). The
    heading's error is about the same with and without the violation (2.3', 4.35', 3.0' with
    the small rows), while its sigma follows the rows' noise (6.6' against 2.3'): the cause of
    the low NEES after the turn is still open (the white 0.05 s violation's 2.88 may be its
    accelerations, 0.0316 m/s over 0.05 s, not its colour: not measured).
  ``fkf`` 0.45-1.04, ``ldv-kf`` 1.03-1.46 (6 runs).
- **The drive's truth is not drawn from the filters' priors** (session 16), and that is most
  of od-kf's low NEES: the vehicle mounting is the scenario's fixed 10' pitch, 15' yaw inside
  a 30' prior (the heading after the turn is tied to the mounting's yaw), the lever arms in
  ``meta`` are the true ones against a 5 cm prior, the odometer's scale is drawn with 2000 ppm
  against a 3000 ppm prior. With ``'{"prior_drawn": true}'`` (the truth drawn from the priors,
  the scale priors set to the simulated spreads), 10 runs, at 193 s (band of the sum 1.68-4.70,
  of one component 0.32-2.05):

  ===========  =====================  ===================================  ==================
  method       NEES sum (E / N / U)   heading RMS error / sigma [arcmin]   fixed truth (sum)
  ===========  =====================  ===================================  ==================
  od-kf        1.38 (0.24/0.60/0.54)  4.69 / 6.47                          0.80 (U 0.12)
  ldv-kf       4.53 (0.98/1.01/2.54)  6.51 / 4.06                          1.03-1.46 (6 runs)
  fkf          4.19 (0.95/0.96/2.29)  6.53 / 4.32                          0.45-1.04 (6 runs)
  ===========  =====================  ===================================  ==================

  od-kf's heading is then in its band (0.54); the LDV filters' heading is overconfident after
  the turn (2.0-2.5 from 120 s on), which the fixed 15' mounting had hidden: not the LDV's scale
  prior (``'{"ldv_scale_sigma_ppm": 1000}'``: 4.48, heading 2.49), not the mounting's size
  (``'{"mount_sigma_arcmin": 10}'``, the truth drawn from the 10' prior: 3.92, heading 2.23,
  5.9' at 3.9'); ``'{"linearization_floor": true}'`` (the rows' second order in an unresolved
  heading, ``aided_kf.linearization_floor_per_m``) takes it to 3.72, heading 2.00 (6.2' at
  4.4'). The same 10 seeds in every row, so these are not independent; one run (seed 107,
  11.5' at 4.2') is 7.4 of the heading's 25.4.

  Over 30 runs (``SEED0`` 100, 110, 120; band of the sum 2.19-3.94, of one component
  0.56-1.57): ldv-kf 3.87 (4.53, 1.56, 5.51 by ten; heading 1.62: 2.54, 0.39, 1.93), at the
  top of its band, the heading at its edge; od-kf 1.55 (1.38, 0.57, 2.70; heading 0.51, RMS
  error 4.45' against a sigma of about 6.5'; seed 110 ended on the fallback, 2.0' at 16.8'),
  still conservative, but no longer the 0.80 / 0.12 of the fixed truth. The groups of ten
  differ by more than their bands (heavy tails: a few runs whose heading the turn did not
  resolve), so ten runs do not judge one method here.

  The length row's memory (``benchmarks/with_length_knobs.py 0 memory:64 '{}'
  benchmarks/nees_drive_start.py ... '{"prior_drawn": true}'``, seeds 100-109): ldv-kf 4.53
  -> 3.27 (heading 2.54 -> 1.84), od-kf 1.38 -> 0.98 (0.54 -> 0.37): on the drawn truth too
  it moves every filter the conservative way, so the trade-off at
  ``aided_kf.LENGTH_MEMORY_MAX`` stands.
- The fine odometer (``'{}' '{"pulses_per_m": 20000}'``): 5.82 at 193 s (3.59 at 150 s),
  overconfident after the turn (heading 3.0' against 2.0'); at 85 s on the shorter drive it is
  in band (``tests/test_consistency_nees.py``). With the length row's memory
  (``benchmarks/with_length_knobs.py 0 memory:64 '{}' benchmarks/nees_drive_start.py od-kf 10
  '{}' '{"pulses_per_m": 20000}'``, ``aided_kf.LENGTH_MEMORY_MAX``) 2.44 (heading 2.3' against
  3.0'), as it puts the matched small start in band; not the default, since on this drive it
  makes the usual sensors' filters more conservative still (fkf 0.45, ``fine-mux`` 0.85: the
  comment at ``LENGTH_MEMORY_MAX``).

  With the truth drawn (``'{"prior_drawn": true, "pulses_per_m": 20000}'``, session 16) it is
  10.46 at 193 s (heading 6.80: 5.2' RMS at 2.1'; seed 105 10.5' at 2.0'), and the mounting's
  draw is what does it: ``"mount"`` alone 10.46 (per run within 0.1' of the full draw: the
  lever arm's offset, estimated in the turn, moves nothing), ``"lever"`` alone (the fixed 10' /
  15' mounting) 10.76 but from two runs (seed 107 on the fallback, 44' at 7.7'; seed 105 11.3'
  at 1.9'). Not the scale prior (fixed truth with ``od_scale_sigma_ppm`` 2000: 6.04 against
  5.82). Fixed by either of the two named settings: the length row's memory (``memory:64``:
  3.15, heading 1.24) or ``'{"linearization_floor": true}'`` (the rows' second order in an
  unresolved heading, ``aided_kf.linearization_floor_per_m``: 3.81, heading 1.74). A larger
  mounting leaves a larger heading error until the turn separates the two (the rows see ``psi
  - gamma``), and the first-order rows' ``psi^2 / 2`` grows with it: the floor's model. Neither
  is the default (the floor costs the coarse hand-over and the PSINS MEMS log their accuracy,
  the memory makes the usual sensors conservative: above); a fine odometer's user sets one
  (issue 15, open: a floor whose ``s`` follows the heading's unresolved part without shrinking
  with the sigma it keeps honest). Since session 17 the floor is on by default for such a
  sensor alone (``linearization_floor: auto``, ``aided_kf.floor_on``: the 20,000 pulses/m
  odometer's forward row is 20 times finer than the rows' second order at a 0.5 deg heading
  error, the usual odometer's 0.23, the LDV's 0.65), so ``'{"prior_drawn": true,
  "pulses_per_m": 20000}'`` now gives the floor's 3.81; ``'{"linearization_floor": false}'``
  gives the 10.46 above. Over 30 runs (``SEED0`` 100, 110, 120) under the default: 3.81,
  1.65, 2.64, so 2.70 (band 2.19-3.94; heading 1.74, 0.49, 0.90: 1.04, band 0.56-1.57).

  ``ldv-kf`` with the floor (``'{"linearization_floor": true}' '{"prior_drawn": true}'``, not
  its default: its ratio is 0.65): 3.72, 1.21, 5.10 over the three groups, so 3.34 against
  the default's 3.87 (heading 2.00, 0.26, 1.68: 1.31 against 1.62, band 0.56-1.57). It
  moves the LDV's heading off its band's edge; not made the LDV's default (every figure of
  paper 003's reproduction and the process drives would move).

  Forty more runs under the default (session 18, ``SEED0`` 130, 140, 150, 160): 2.41, 2.30,
  2.34, 3.96 (heading 0.91, 0.84, 1.06, 1.50: 1.08, band for 40 runs 0.61-1.48). Over the 70
  runs (100-169) ldv-kf is 3.23 (band of the sum 2.45-3.60) and its heading 1.31 (band
  0.70-1.36): in band, in its upper part. The 30 runs' 1.62 was its first three groups' Monte
  Carlo spread (the heavy tail above), not a shifted mean.
"""
import json
import sys

import numpy as np
import yaml

import consistency_mc
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


def main(method, runs=10, config=None, changes=None, seed0=100):
    run, Config = registry.get(method).load()
    changes = dict(changes or {})
    prior_drawn = changes.get("prior_drawn", False)
    sc = scenario({k: v for k, v in changes.items() if k != "prior_drawn"})
    nees = np.zeros((len(TIMES_S), 3))
    e2 = np.zeros_like(nees)
    s2 = np.zeros_like(nees)
    last = []
    for k in range(runs):
        rng = np.random.default_rng(seed0 + k)
        cfg = dict(init_tilt_sigma_deg=START_SIGMA_DEG[0], init_heading_sigma_deg=START_SIGMA_DEG[2],
                   **(config or {}))
        if prior_drawn:
            b, cfg = consistency_mc.drawn_truth(sc, prior_drawn, rng, Config, cfg)
        else:
            b = simulate(sc, rng)
        err = np.radians(START_SIGMA_DEG) * rng.standard_normal(3)
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
        print(f"  seed {seed0 + k}: error {np.round(p, 2)} sigma {np.round(s, 2)} arcmin")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(a[0], int(a[1]) if len(a) > 1 else 10, json.loads(a[2]) if len(a) > 2 else None,
         json.loads(a[3]) if len(a) > 3 else None, int(a[4]) if len(a) > 4 else 100)
