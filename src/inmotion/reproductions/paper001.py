"""Paper 001's two vehicle tests, re-created in simulation and set beside the paper's tables.

Xiang et al., *In-motion initial alignment for a LDV-aided SINS based on an adaptive unscented
quaternion H-infinite filter*, Meas. Sci. Technol. 2022, sec. 4. Five schemes (the paper's
numbering): 1 ``ausquhe``, 2 ``oba``, 3 ``usque``, 4 ``ausque``, 5 ``usque-hinf``.

Set-up (shipped scenarios ``paper001_urban`` and ``paper001_urban_disturbed``): a 300 s urban
drive at 100 Hz; gyro bias instability 0.008 deg/h and random walk 0.003 deg/sqrt(h);
accelerometer 50 ug and 50 ug/sqrt(Hz); LDV at 100 Hz with 0.1 % (1 sigma) scale error. Test 2
disturbs the LDV with the simulator's own fault model: white noise 0.3 m/s and four outlier
bursts (10-15 s windows, 30 % of samples hit by up to +-3 m/s). The filters start from
``q = [1 0 0 0]`` with the paper's initial covariance diag(3, 3, 12 deg)^2, process noise
(1e-7 deg)^2 and initial measurement noise (0.07 m/s)^2, and update at every 100 Hz sample.

Documented choices:

* The IMU constants (gyro drift, accelerometer bias) are drawn per run from zero-mean normals
  with the paper's figures as 1-sigma (``imu.constant_errors: random``): the paper reports one
  car whose actual residual biases are unknown; a fixed value would repeat one deterministic
  error in every run. The LDV scale error is a per-run draw as the scenario ships it.
* Each USQUE scheme runs with two state sets: ``paper`` (the attitude error only, as the paper)
  and ``extended`` (plus the accelerometer bias, the LDV scale factor and the error of the LDV
  sample taken as ``v^b(0)``, see :mod:`inmotion.align.usque_model`). The simulation shows
  why: a 50 ug bias, the 0.1 % scale error and the single-sample ``v^b(0)`` are what limit the
  heading here.
* Statistics as the paper's Tables 1-2: per run the mean and the (time) STD of the heading error
  (estimate minus truth) over each window; the tables give their averages over the runs, and
  the spread of the window means across runs (``+- sd``). Errors are taken on a 1 s grid.
* Compute time (Table 3): each scheme timed in this process on one 300 s drive of each test,
  after a warm run (numba compiles or loads its cache there, so no compile time is counted),
  before the Monte Carlo pool starts (so our own workers do not compete): the fastest of two
  runs, wall and CPU time, with the load average of the machine at the time. The paper's
  MATLAB figures are for its own machine and data length; only the ratios compare. (The
  timing inside the pool workers, used before, measured the machine's load: 6-11 s a run in
  test 1 against 0.5-1 s on a quiet core.)
* ``oba`` runs twice: the coarse-alignment module's default (centred q-method, ``v^b(0)``
  line-fitted over 1 s) and the paper's form (plain q-method, the raw first LDV sample as
  ``v^b(0)``, as ``paper004`` names it), to show how much of our ``oba``'s accuracy is
  the centring.
* Test 3 is NOT in the paper: scenario ``paper001_urban_stale``, test 2's LDV noise with bursts
  that hold a stale value or carry a bias instead of zero-mean outliers (our assumption of
  what could have hurt the paper's ``oba``; see the report's ranking section).
* Ranking: schemes ordered by the RMS over runs and 1-s epochs of the 181-300 s heading error
  (a mean near 0 with a large spread across runs is not an accurate scheme).
* NEES of the attitude: per run and 1-s epoch ``sum_i (phi_i / sigma_i)^2`` over E, N, U (the
  solution carries the three 1-sigma, not their correlations, so this is the NEES of the
  diagonal), averaged over the runs and set against the two-sided 95 % band of
  ``chi2(3 runs) / runs``.

* Whole circle (issue 17): the paper's point is alignment from an unknown attitude (its test
  2 starts about 155-180 deg off in heading; our Tables 1-2 start 8 deg off). Test 2's drive
  is run from the truth's start headings every 30 deg and from 170 deg (the paper's start),
  ``circle_runs`` seeds each (:data:`CIRCLE_RUNS`), with the schemes of :data:`CIRCLE_KEYS`;
  success is |heading error| < 1 deg at 300 s, given with its Clopper-Pearson 95 % interval
  (:func:`binomial_interval`) and the error distribution. The heading 1-sigma each filter
  claims at 2 s is set against the Cramer-Rao bound of the Earth-rate signal
  (:func:`earth_rate_heading_sigma_deg`): the mechanism that keeps the USQUE family from
  large starts (report, "Alignment from an unknown heading"). The attitude-only state's
  ceiling: the v^b(0) sample's noise leaves a heading error that no start and no k0 removes
  (:func:`v0_heading_sigma_deg`, :func:`success_ceiling`).
* Conditions table (issue 17): :func:`conditions` reads "ours" from the scenarios and the
  filter configurations the runs use (a test checks them); the paper's filter settings
  (:data:`PAPER_FILTER`) and our choices where it gives none (:data:`USQUE_TUNING`) are
  passed explicitly (:data:`FILTER`), so a change of the library defaults does not change the
  reproduction.
* k0 sweep (issue 17: can ``ausquhe`` be made robust to the start heading?): ``ausquhe`` with
  each k0 of :data:`K0_SWEEP` in both state sets on tuning drives apart from the circle's
  (:func:`run_k0_one`): success rate against k0 with Clopper-Pearson intervals.

``reproduce(out_dir, runs=30, workers=2, seed=0, progress=True, circle_runs=10, k0_runs=2,
reuse_tables=False)`` writes
``report.md``, ``results.json``, figures ``test{1,2,3}_{state set}_errors.png``,
``circle_success.png``, ``circle_errors.png`` and returns the report text;
``rewrite_report(out_dir)`` re-writes ``report.md`` from ``results.json``.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from .common import conditions_markdown

__all__ = ["reproduce", "rewrite_report", "run_one", "window_stats", "ranking_stats",
           "nees_stats", "PAPER_TABLE1", "PAPER_TABLE2", "PAPER_TABLE3", "SCHEMES", "WINDOWS",
           "STATE_SETS", "TESTS"]

#: the paper's scheme numbers
SCHEMES = {"ausquhe": 1, "oba": 2, "usque": 3, "ausque": 4, "usque-hinf": 5}
SCENARIOS = {1: "paper001_urban", 2: "paper001_urban_disturbed", 3: "paper001_urban_stale"}
#: tests 1 and 2 are the paper's; 3 is our variant (stale / biased LDV bursts)
TESTS = (1, 2, 3)
PAPER_TESTS = (1, 2)
#: Table 1 prints its second window as "1-180 s"; with the STD it gives it cannot hold the
#: first 90 s (whose spread is far larger), so it is read as 91-180 s (issue 17)
WINDOWS = {1: ((1, 90), (91, 180), (181, 300)), 2: ((1, 120), (121, 180), (181, 300)),
           3: ((1, 120), (121, 180), (181, 300))}
#: oba as the paper writes it (reproduce_004's "paper form")
OBA_PAPER_FORM = {"center_vectors": False, "initial_speed_fit_s": 0.0}
STATE_SETS = {"paper": {},
              "extended": {"estimate_accel_bias": True, "estimate_initial_speed_error": True,
                           "estimate_scale": True}}
#: process noise of the attitude per 100 Hz update matched to the simulated gyro angle random
#: walk, 0.003 deg/sqrt(h) = 5e-5 deg/sqrt(s), times sqrt(0.01 s) [deg] (the paper's is 1e-7)
ARW_Q_DEG = 0.003 / 60.0 * np.sqrt(0.01)
#: bounds of the adaptive R wide enough to be no bounds [m/s]: an ablation of ours (the
#: paper bounds every diagonal element of R between R_min and R_max, eq. 44, without values)
UNBOUNDED_R = {"r_min_m_s": 1e-4, "r_max_m_s": 1e3}
#: extra runs beside the paper's schemes, all with the extended states: ausquhe with the
#: process noise from the ARW; ausque and ausquhe with an unbounded adaptive R
EXTRA_VARIANTS = {
    "ausquhe": {"extended-arw-q": {**STATE_SETS["extended"], "process_noise_deg": ARW_Q_DEG},
                "extended-unbounded-r": {**STATE_SETS["extended"], **UNBOUNDED_R}},
    "ausque": {"extended-unbounded-r": {**STATE_SETS["extended"], **UNBOUNDED_R}}}

#: the filter settings of the paper's sec. 4 for schemes 1, 3, 4, 5, passed explicitly (so a
#: change of the library's defaults does not change the reproduction): initial covariance
#: diag(3, 3, 12 deg)^2, process noise (1e-7 deg)^2, initial R (0.07 m/s)^2
PAPER_FILTER = {"sigma0_deg": (3.0, 3.0, 12.0), "process_noise_deg": 1e-7,
                "meas_noise_m_s": 0.07, "noise_preset": "paper"}
#: our choices where the paper gives no value (GRP a, f; sigma points; the extended states'
#: priors; fading factor; R bounds of eq. 44; fixed gamma of scheme 5; k0, gamma bounds and
#: margin of eq. 55-56; v^b(0) fit), pinned here too so that a new library default (issue 15
#: re-derives USQUE's noise and gamma) does not move the reproduction's figures; the values
#: of the library when these runs were made
USQUE_TUNING = {"update_rate_hz": 100.0, "grp_a": 1.0, "grp_f": None, "ut_sigma": 1.0,
                "ut_kappa": 0.0, "ut_zeta": 2.0, "scale_sigma0_ppm": 1000.0,
                "accel_bias_sigma0_ug": 100.0, "initial_speed_sigma0_m_s": 0.1,
                "fading_factor": 0.99, "r_min_m_s": 0.05, "r_max_m_s": 1.0,
                "gamma_deg_sqrt_s": 100.0, "k0": 30.0, "gamma_min_deg": 0.1,
                "gamma_max_deg": 30.0, "hinf_margin": 1.2, "v0_fit_s": 1.0}
#: what every USQUE-family run of the reproduction starts from (variants override it)
FILTER = {**PAPER_FILTER, **USQUE_TUNING}

#: the whole-circle experiment (issue 17). The filters start at yaw 0 (the paper's
#: q = [1 0 0 0]), so the truth's start heading h is a start error of -h. Test 2's drive from
#: every 30 deg of the circle and from the paper's own start, CIRCLE_RUNS seeds each.
CIRCLE_TEST = 2
#: the paper's test 2 starts about 155-180 deg off: Table 2's 1-120 s means 121-178 deg and
#: its fig. 9 (the issue's reading); 170 deg is the value tried in the issue
PAPER_START_DEG = 170.0


def _campaign_doc(name: str) -> dict:
    import yaml
    from .common import campaign_file
    return yaml.safe_load(campaign_file(name).read_text())


#: start headings and seeds per heading of the circle: the grid and runs of
#: ``campaigns/paper001_circle.yaml`` (issue 17: >= 10 seeds, so that a success rate has an
#: interval that means something; 3 before), the paper's start apart
CIRCLE_HEADINGS_DEG = tuple(float(h) for h in _campaign_doc("paper001_circle")["grid"]
                            ["heading_deg"] if float(h) != PAPER_START_DEG)
CIRCLE_RUNS = int(_campaign_doc("paper001_circle")["runs"])
#: success: |heading error| below this at 300 s [deg] (the issue's criterion)
SUCCESS_DEG = 1.0
#: schemes of the circle; ``ausquhe`` (paper) and ``oba (paper-form)`` are the paper's scheme
#: 1 and 2 as written, the others as in the tables
#: (the k0 = CIRCLE_K0 variants of the 3-seed circle are left to the k0 sweep, which runs every
#: k0 from every start on drives of its own: the machine's budget, issue 17's runs)
CIRCLE_KEYS = ("ausquhe/paper", "ausque/paper", "usque/paper", "usque-hinf/paper",
               "oba/paper-form", "oba/-", "ausquhe/extended")
#: k0 of eq. 55 ("determined by experiment"; our default 30 was chosen on test 1 from an
#: 8-deg start): 3 keeps the H-infinity step removing information while the heading is
#: unknown (chosen on tuning drives, seeds 101-102, ``benchmarks/usque_k0_circle.py``)
CIRCLE_K0 = 3.0
#: the k0 sweep (issue 17: is ``ausquhe`` robust for some k0?): ``ausquhe`` with each k0 of
#: eq. 55 and both state sets, on TUNING drives of test 2 apart from the circle's (their
#: Generator is ``SeedSequence(seed, spawn_key=(CIRCLE_TEST, 2, heading + 360, run))``, the
#: circle's has 1 in the second place), from every heading of the circle and the paper's start,
#: K0_TUNING_RUNS seeds each; the other settings are FILTER's
K0_SWEEP = (1.0, 3.0, 10.0, 30.0)
K0_TUNING_RUNS = int(_campaign_doc("paper001_k0")["runs"])
K0_STATE_SETS = ("paper", "extended")
#: variants that exist only in the circle: ausquhe with k0 = CIRCLE_K0
CIRCLE_VARIANTS: dict = {"ausquhe": {"paper-k0-3": {"k0": CIRCLE_K0},
                                     "extended-k0-3": {**STATE_SETS["extended"],
                                                       "k0": CIRCLE_K0}}}

#: paper 001 Table 1 (test 1): scheme -> ((mean, STD) per window of WINDOWS[1]) [deg]
PAPER_TABLE1 = {
    "ausquhe": ((4.5305, 17.9068), (-0.0629, 0.0347), (0.0261, 0.0168)),
    "oba": ((23.8523, 79.8593), (-0.6669, 0.2515), (-0.1545, 0.0799)),
    "usque": ((43.8600, 29.0322), (2.7299, 1.8951), (0.3911, 0.1659)),
    "ausque": ((4.2385, 17.8764), (-0.0176, 0.0285), (0.0426, 0.0186)),
    "usque-hinf": ((4.9030, 22.5246), (-0.0916, 0.0897), (0.0903, 0.0576)),
}
#: paper 001 Table 2 (test 2), windows of WINDOWS[2] [deg]
PAPER_TABLE2 = {
    "ausquhe": ((155.2387, 141.2276), (-0.2596, 0.5144), (-0.6237, 0.1205)),
    "oba": ((65.9164, 61.5175), (24.6140, 3.7126), (12.4455, 2.7695)),
    "usque": ((120.9258, 27.0361), (37.0303, 11.9686), (14.5144, 3.9573)),
    "ausque": ((178.4269, 156.4519), (-32.4598, 12.1312), (-10.1751, 2.6554)),
    "usque-hinf": ((120.6761, 27.0265), (36.9096, 11.9503), (14.4593, 3.9424)),
}
#: paper 001 Table 3: scheme -> (test 1, test 2) compute time [s]
PAPER_TABLE3 = {"ausquhe": (19.5758, 18.4083), "oba": (13.5719, 12.6162),
                "usque": (17.2963, 16.3573), "ausque": (17.7083, 16.6753),
                "usque-hinf": (18.4216, 17.4598)}

GRID_S = np.arange(0.0, 300.0 + 0.5, 1.0)
#: timed runs of each scheme per test (Table 3); the spread of their CPU-time ratios to oba's
#: is the uncertainty of the ratio
TIMING_REPEATS = 3
#: the schemes timed for Table 3: the paper's five as written (and our centred oba)
TIMED_KEYS = ("ausquhe/paper", "oba/-", "oba/paper-form", "usque/paper", "ausque/paper",
              "usque-hinf/paper")


def _scenario_spec(test: int, heading_deg=None) -> dict:
    """The scenario of ``test`` as a dict, IMU constants drawn per run, and the truth's start
    heading set to ``heading_deg`` when given (the whole-circle experiment)."""
    from ..sim.scenario import find_scenario
    import yaml
    with open(find_scenario(SCENARIOS[test])) as fh:
        spec = yaml.safe_load(fh)
    spec.setdefault("imu", {})["constant_errors"] = "random"
    if heading_deg is not None:
        spec["start"]["heading_deg"] = float(heading_deg)
    return spec


def _scenario(test: int, heading_deg=None):
    from ..sim.scenario import load_scenario
    return load_scenario(_scenario_spec(test, heading_deg))


def _errors_on_grid(sol, truth):
    """[pitch, roll, yaw] errors [deg] (estimate - truth, wrapped) on :data:`GRID_S`."""
    from ..core import rotations
    from ..core.metrics import interpolate_truth
    tr = interpolate_truth(truth, sol.t)
    err = np.degrees(rotations.wrap_pi(sol.euler - tr.euler))
    t = sol.t - truth.t[0]
    return np.stack([np.interp(GRID_S, t, err[:, i]) for i in range(3)], -1)


def _run_scheme(name, variant, bundle):
    from .. import registry
    run, Config = registry.get(name).load()
    if name == "oba":
        config = Config(output_interval_s=1.0,
                        **(OBA_PAPER_FORM if variant == "paper-form" else {}))
    else:
        config = Config(**{**FILTER, **{**STATE_SETS, **EXTRA_VARIANTS.get(name, {}),
                                              **CIRCLE_VARIANTS.get(name, {})}[variant]})
    t0 = time.perf_counter()
    sol = run(bundle, config, None)
    return sol, time.perf_counter() - t0


def _variants(name):
    if name == "oba":
        return ("-", "paper-form")
    return tuple(STATE_SETS) + tuple(EXTRA_VARIANTS.get(name, {}))


def _nees_on_grid(sol, truth):
    """``(phi_i / sigma_i)^2`` for E, N, U, (len(GRID_S), 3), at the solution epochs nearest
    :data:`GRID_S` (misalignment ``phi`` of the DESIGN convention); their sum is the NEES of
    the attitude's diagonal."""
    from ..core import rotations
    from ..core.metrics import interpolate_truth
    idx = np.searchsorted(sol.t, truth.t[0] + GRID_S - 1e-6).clip(0, len(sol.t) - 1)
    tr = interpolate_truth(truth, sol.t[idx])
    phi = rotations.misalignment(rotations.dcm_from_euler(sol.euler[idx]),
                                 rotations.dcm_from_euler(tr.euler))
    sig = np.stack([sol.sigma[k][idx] for k in ("phi_E", "phi_N", "phi_U")], -1)
    return (phi / sig) ** 2


def run_one(task) -> dict:
    """One simulated drive of one test, aligned by every scheme and state set.

    ``task = (test, run_index, seed)``; the run's Generator comes from
    ``SeedSequence(seed, spawn_key=(test, run_index))``, so a run re-run alone is identical.
    Returns ``{"test", "run", "errors": {key: (301, 3)}, "nees": {key: (301, 3)}, "time_s":
    {key: s}}`` with keys ``"<scheme>/<state set>"`` (``oba``: ``"oba/-"`` and
    ``"oba/paper-form"``, no NEES).
    """
    from ..sim import simulate
    test, run_index, seed = task
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(test, run_index)))
    bundle = simulate(_scenario(test), rng)
    out = {"test": test, "run": run_index, "errors": {}, "nees": {}, "time_s": {}}
    for name in SCHEMES:
        for variant in _variants(name):
            sol, dt = _run_scheme(name, variant, bundle)
            key = f"{name}/{variant}"
            out["errors"][key] = _errors_on_grid(sol, bundle.truth)
            if name != "oba":
                out["nees"][key] = _nees_on_grid(sol, bundle.truth)
                out.setdefault("sigma_u_2s_deg", {})[key] = _sigma_u_at(sol, bundle.truth,
                                                                        EARLY_S)
            out["time_s"][key] = dt
    return out


#: time at which the heading 1-sigma is read to show the spurious heading information [s]
EARLY_S = 2.0


def _sigma_u_at(sol, truth, t_s):
    """The filter's heading (phi_U) 1-sigma [deg] at ``t_s`` seconds after the start."""
    i = int(np.searchsorted(sol.t, truth.t[0] + t_s - 1e-6).clip(0, len(sol.t) - 1))
    return float(np.degrees(sol.sigma["phi_U"][i]))


def earth_rate_heading_sigma_deg(t_s, lat_deg, noise_m_s, rate_hz, sigma0_deg):
    """Lower bound on the heading 1-sigma [deg] after ``t_s`` seconds from the Earth-rate signal
    alone (the Cramer-Rao bound of the linearized model at the truth).

    A rotation ``dpsi`` about the vertical changes the model of paper 001 eq. 13-14 only
    through the horizontal part of ``beta`` (eq. 19), ``g Omega cos(L) t^2 / 2``: with white
    measurement noise ``noise_m_s`` per axis at ``rate_hz`` the information is
    ``sum_k (g Omega cos L t_k^2 / 2)^2 / noise^2 ~ rate (g Omega cos L / 2)^2 t^5 / (5 noise^2)``
    [rad^-2], added to the prior's ``1 / sigma0^2``.
    """
    from ..core import earth
    k = 9.79 * earth.OMEGA_IE * np.cos(np.radians(lat_deg)) / 2.0
    info = rate_hz * k ** 2 * t_s ** 5 / (5.0 * noise_m_s ** 2) + 1.0 / np.radians(sigma0_deg) ** 2
    return float(np.degrees(1.0 / np.sqrt(info)))


def v0_heading_sigma_deg(t_s, lat_deg, dv0_m_s, weighting: str = "last") -> float:
    """Heading error [deg] that an error ``dv0_m_s`` of the one LDV sample taken as v^b(0)
    leaves in an attitude-only alignment (paper 001 eq. 13-19: ``dv0`` is a constant in every
    vector pair, the heading's signal is the Earth-rate part of beta,
    ``s(t) = g Omega cos(L) t^2 / 2``).

    ``weighting="last"``: ``dv0 / s(t)``, the error of the last epoch alone (a filter whose
    late, strong measurements dominate; ``inmotion.align.usque_model``); ``"uniform"``: the
    least-squares fit of ``psi s(t)`` to the constant over ``[0, t]`` with equal weights,
    ``dv0 sum s / sum s^2 = (5 / 3) dv0 / s(t)`` (a batch q-method over all epochs such as
    ``oba``'s paper form).
    """
    from ..core import earth
    s = 9.79 * earth.OMEGA_IE * np.cos(np.radians(lat_deg)) * t_s ** 2 / 2.0
    f = {"last": 1.0, "uniform": 5.0 / 3.0}[weighting]
    return float(np.degrees(f * dv0_m_s / s))


def near_far_p_value(near, far) -> float:
    """Two-sided p-value of Fisher's exact test that the success rate from near starts
    ``near = (successes, n)`` equals that from far starts ``far = (successes, n)``."""
    from scipy.stats import fisher_exact
    (a, n1), (b, n2) = near, far
    if n1 == 0 or n2 == 0:
        return float("nan")
    return float(fisher_exact([[a, n1 - a], [b, n2 - b]])[1])


def success_ceiling(sigma_deg: float, success_deg: float = SUCCESS_DEG) -> float:
    """P(|e| < success_deg) for a zero-mean normal error of 1-sigma ``sigma_deg``: the
    success rate a scheme cannot exceed when that error is left in it."""
    from math import erf, sqrt
    return erf(success_deg / (sigma_deg * sqrt(2.0)))


def conditions(runs=None, circle_runs: int = CIRCLE_RUNS, k0_runs: int = K0_TUNING_RUNS) -> list:
    """The conditions table: ``(parameter, paper, ours, why)`` rows, "ours" read from the
    scenarios and the filter configurations the experiment really uses."""
    from .. import registry
    sp = {t: _scenario_spec(t) for t in TESTS}
    s1, s2 = sp[1], sp[2]
    ldv1, ldv2 = s1["sensors"]["ldv"], s2["sensors"]["ldv"]
    cfg = {n: registry.get(n).load()[1](**FILTER) for n in SCHEMES if n != "oba"}
    a = cfg["ausquhe"]
    oba = registry.get("oba").load()[1]()
    bursts = ", ".join(f"{f['start_s']:g}-{f['end_s']:g} s" for f in s2.get("faults", []))
    f0 = s2["faults"][0] if s2.get("faults") else {}
    return [
        ("latitude [deg]", "Changsha (about 28.2)", f"{s1['start']['lat_deg']:g}", "same"),
        ("drive", "one urban car run per test, 300 s (fig. 2-3)",
         f"simulated `{SCENARIOS[1]}` / `{SCENARIOS[2]}`, {s1['start']['speed_m_s']:g} m/s "
         "start, 6-14 m/s, three turns, a stop, a slope", "the car's trajectory is not given"),
        ("start heading, Tables 1-2 [deg]", "test 1 unknown; test 2 about 155-180 off "
         "(Table 2's 1-120 s means 121-178, fig. 9)",
         f"{s1['start']['heading_deg']:g} (test 1), {s2['start']['heading_deg']:g} (test 2); "
         "filters start at yaw 0", "Tables 1-2 keep the scenario's small start; the paper's "
         "start is tested in the whole-circle section"),
        ("start heading, whole circle [deg]", "-",
         f"{', '.join(f'{h:g}' for h in CIRCLE_HEADINGS_DEG)} and {PAPER_START_DEG:g} "
         f"(test {CIRCLE_TEST}), {circle_runs} runs each",
         "issue 17: the paper's point is alignment from an unknown attitude (test 1's "
         "circle not run: the machine's budget for issue 17's re-run)"),
        ("schemes in the whole circle", "-", ", ".join(k.replace("/", " ") for k in CIRCLE_KEYS),
         "the paper's five as written, our centred oba and the extended ausquhe; other k0 in "
         "the k0 sweep"),
        ("gyro drift [deg/h]", "0.008 (bias instability)",
         f"{s1['imu']['gyro']['drift_deg_h']:g}, 1-sigma, drawn per run "
         f"(constant_errors: {s1['imu']['constant_errors']})",
         "one car's actual residual bias is unknown; a fixed value repeats one error"),
        ("gyro random walk [deg/sqrt(h)]", "0.003", f"{s1['imu']['gyro']['arw_deg_sqrt_h']:g}",
         "same"),
        ("accelerometer bias [ug]", "50 (bias instability)",
         f"{s1['imu']['accel']['bias_ug']:g}, 1-sigma, drawn per run", "as the gyro drift"),
        ("accelerometer random walk", "50 ug/sqrt(h)",
         f"{s1['imu']['accel']['vrw_ug_sqrt_hz']:g} ug/sqrt(Hz)",
         "a velocity random walk needs acceleration per sqrt(Hz); read as a typo"),
        ("IMU and LDV rate [Hz]", "100, 100",
         f"{s1['imu']['rate_hz']:g}, {ldv1['rate_hz']:g}", "same"),
        ("LDV scale error", "0.1 % (1 sigma), calibrated",
         f"{ldv1['scale_factor_sigma_ppm'] / 1e4:g} % (1 sigma), drawn per run", "same"),
        ("LDV noise, test 1 [m/s]", "not given (normal LDV)", f"{ldv1['noise_m_s']:g}",
         "a small white noise of a good LDV"),
        ("LDV disturbance, test 2", "\"seriously disturbed by noise\" (fig. 3), no figures",
         f"white {ldv2['noise_m_s']:g} m/s + outlier bursts {bursts} "
         f"({100 * f0.get('probability', 0):g} % of samples, uniform +-"
         f"{f0.get('magnitude_m_s', 0):g} m/s)", "read from fig. 3"),
        ("initial attitude", "q = [1 0 0 0]", "q = [1 0 0 0] (yaw, pitch, roll 0)", "same"),
        ("initial covariance [deg]", "diag(3, 3, 12)^2",
         f"diag({', '.join(f'{v:g}' for v in a.sigma0_deg)})^2", "same"),
        ("process noise Q [deg per update]", "(1e-7)^2 per axis",
         f"({a.process_noise_deg:g})^2 per axis", "same (set explicitly)"),
        ("initial R [m/s]", "(0.07)^2 per axis", f"({a.meas_noise_m_s:g})^2 per axis", "same"),
        ("update rate [Hz]", "100 (every IMU sample; no other rate stated)",
         f"{a.update_rate_hz:g}", "same"),
        ("GRP a, f (eq. 20)", "not given (MRP for a = f = 1)",
         f"a = {a.grp_a:g}, f = {2 * (a.grp_a + 1) if a.grp_f is None else a.grp_f:g}",
         "f = 2 (a + 1) makes the GRP the rotation angle to first order"),
        ("unscented sigma, kappa, zeta (eq. 24-26)", "sigma in 1e-4..1, kappa 0 or 3n, not "
         "given", f"{a.ut_sigma:g}, {a.ut_kappa:g}, {a.ut_zeta:g}", "values not given"),
        ("adaptive R bounds R_min, R_max (eq. 44) [m/s]", "bounded, values not given",
         f"{a.r_min_m_s:g}, {a.r_max_m_s:g} (as 1-sigma)", "see `inmotion.align.usque`"),
        ("fading factor c (eq. 43)", "0.9 to 0.999", f"{a.fading_factor:g}", "inside the range"),
        ("k0 (eq. 55)", "\"determined by experiment\", not given", f"{a.k0:g}",
         "chosen on test 1 (see the whole-circle section)"),
        ("k0 sweep (eq. 55)", "-", f"k0 in {', '.join(f'{k:g}' for k in K0_SWEEP)}, state sets "
         f"{', '.join(K0_STATE_SETS)}; test {CIRCLE_TEST} tuning drives (not the circle's), "
         f"the circle's start headings, {k0_runs} drive(s) each", "issue 17: can ausquhe be "
         "made robust to the start heading?"),
        ("gamma_min, gamma_max (eq. 55-56) [deg]", "not given",
         f"{a.gamma_min_deg:g}, {a.gamma_max_deg:g}", "values not given"),
        ("fixed gamma of scheme 5 (eq. 52)", "not given",
         f"{cfg['usque-hinf'].gamma_deg_sqrt_s:g} deg sqrt(s) per unit time",
         "the existence condition (54) over the first 50 s, `inmotion.align.usque`"),
        ("state", "attitude error only (\"other parameters are not estimated\")",
         "`paper`: attitude only; `extended`: + accelerometer bias, LDV scale, v^b(0) error",
         "the extended state shows what limits the heading"),
        ("oba (scheme 2)", "ref. [9]: q-method, raw first LDV sample as v^b(0)",
         f"`oba (paper-form)` as the paper; `oba`: centred vectors "
         f"({oba.center_vectors}), v^b(0) fitted over {oba.initial_speed_fit_s:g} s",
         "to show what the centring is worth"),
        ("statistics, Tables 1-2", "one run: window mean and time-STD",
         f"per run the same, over {runs if runs else 'N'} runs per test; "
         "row uncertainty: 2.5-97.5 % of the single-run values",
         "the paper's figure is one run's"),
        ("success (whole circle)", "-", f"abs(heading error) < {SUCCESS_DEG:g} deg at 300 s",
         "issue 17"),
        ("test 3", "not in the paper", f"`{SCENARIOS[3]}`: test 2's noise, LDV bursts stale "
         "or biased instead of outliers", "our assumption of what hurt the paper's oba"),
        ("compute time (Table 3)", "MATLAB, its machine, seconds",
         f"numba, one core here; CPU time, {TIMING_REPEATS} repeats; compared as ratios to "
         "oba's", "absolute seconds on different machines do not compare"),
    ]


def circle_tasks(seed: int, runs: int = CIRCLE_RUNS) -> list:
    """``(heading_deg, run_index, seed)`` of the whole-circle experiment: every heading of
    :data:`CIRCLE_HEADINGS_DEG` and :data:`PAPER_START_DEG`, ``runs`` seeds each, run by run
    (a prefix of the list is a smaller complete experiment)."""
    heads = list(CIRCLE_HEADINGS_DEG) + ([PAPER_START_DEG] if PAPER_START_DEG not in
                                         CIRCLE_HEADINGS_DEG else [])
    # run-major: the first k x len(heads) tasks are k complete runs of every heading
    return [(h, r, seed) for r in range(runs) for h in heads]


def run_circle_one(task) -> dict:
    """One drive of :data:`CIRCLE_TEST` with the truth's start heading ``heading_deg`` (the
    filters start at yaw 0, so the start error is ``-heading_deg``), aligned by every scheme of
    :data:`CIRCLE_KEYS`.

    ``task = (heading_deg, run_index, seed)``; the Generator is ``SeedSequence(seed,
    spawn_key=(CIRCLE_TEST, 1, round(heading_deg) + 360, run_index))`` (apart from the tables'
    drives). Returns ``{"heading_deg", "run", "yaw": {key: heading error on GRID_S [deg]},
    "sigma_u_2s_deg": {key: heading 1-sigma at EARLY_S}}``.
    """
    from ..sim import simulate
    heading, run_index, seed = task
    rng = np.random.default_rng(np.random.SeedSequence(
        seed, spawn_key=(CIRCLE_TEST, 1, int(round(heading)) + 360, run_index)))
    bundle = simulate(_scenario(CIRCLE_TEST, heading), rng)
    out = {"heading_deg": float(heading), "run": run_index, "yaw": {}, "sigma_u_2s_deg": {}}
    for key in CIRCLE_KEYS:
        name, variant = key.split("/")
        sol, _ = _run_scheme(name, variant, bundle)
        out["yaw"][key] = _errors_on_grid(sol, bundle.truth)[:, 2]
        if name != "oba":
            out["sigma_u_2s_deg"][key] = _sigma_u_at(sol, bundle.truth, EARLY_S)
    return out


def k0_tasks(seed: int, runs: int = K0_TUNING_RUNS) -> list:
    """``(heading_deg, run_index, seed)`` of the k0 sweep: the circle's headings and the
    paper's start, ``runs`` tuning drives each (:func:`run_k0_one`)."""
    return circle_tasks(seed, runs)


def run_k0_one(task) -> dict:
    """One TUNING drive of :data:`CIRCLE_TEST` (``SeedSequence(seed, spawn_key=(CIRCLE_TEST,
    2, round(heading_deg) + 360, run_index))``: none of the circle's or the tables' drives),
    aligned by ``ausquhe`` with every k0 of :data:`K0_SWEEP` (eq. 55) in each state set of
    :data:`K0_STATE_SETS`. Returns ``{"heading_deg", "run", "final_deg": {"<state>/k0=<k0>":
    heading error at 300 s [deg]}}``."""
    from .. import registry
    from ..sim import simulate
    heading, run_index, seed = task
    rng = np.random.default_rng(np.random.SeedSequence(
        seed, spawn_key=(CIRCLE_TEST, 2, int(round(heading)) + 360, run_index)))
    bundle = simulate(_scenario(CIRCLE_TEST, heading), rng)
    run, Config = registry.get("ausquhe").load()
    out = {"heading_deg": float(heading), "run": run_index, "final_deg": {}}
    for state in K0_STATE_SETS:
        for k0 in K0_SWEEP:
            sol = run(bundle, Config(**{**FILTER, **STATE_SETS[state], "k0": k0}), None)
            out["final_deg"][f"{state}/k0={k0:g}"] = float(
                _errors_on_grid(sol, bundle.truth)[-1, 2])
    return out


# ------------------------------------------------------------------------------ campaigns
#: the campaign files of this reproduction (``campaigns/<name>.yaml``): Tables 1-2 and test 3,
#: the whole circle, the k0 sweep
CAMPAIGNS = {"tables": "paper001", "circle": "paper001_circle", "k0": "paper001_k0"}


def run(spec: dict, rng) -> dict:
    """Run function of ``campaigns/paper001.yaml``: run ``k`` of test ``spec["test"]``,
    :func:`run_one` on ``(test, k, seed)`` with ``(seed, k)`` the campaign generator's
    :func:`~inmotion.reproductions.common.run_key` (the drive's stream is ``SeedSequence(seed,
    spawn_key=(test, k))`` as before the campaign form); the record travels as
    :func:`~inmotion.reproductions.common.pack_record`."""
    from .common import pack_record, run_key
    seed, k = run_key(rng)
    return pack_record(run_one((int(spec["test"]), k, seed)))


def run_circle(spec: dict, rng) -> dict:
    """Run function of ``campaigns/paper001_circle.yaml``: :func:`run_circle_one` on
    ``(spec["heading_deg"], k, seed)``."""
    from .common import pack_record, run_key
    seed, k = run_key(rng)
    return pack_record(run_circle_one((float(spec["heading_deg"]), k, seed)))


def run_k0(spec: dict, rng) -> dict:
    """Run function of ``campaigns/paper001_k0.yaml``: :func:`run_k0_one` on
    ``(spec["heading_deg"], k, seed)``."""
    from .common import pack_record, run_key
    seed, k = run_key(rng)
    return pack_record(run_k0_one((float(spec["heading_deg"]), k, seed)))


def _validate_test(spec: dict) -> None:
    from ..errors import BadInput
    if spec.get("test") not in TESTS:
        raise BadInput(f"test must be one of {list(TESTS)}, got {spec.get('test')!r}")


def _validate_heading(spec: dict) -> None:
    from ..errors import BadInput
    h = spec.get("heading_deg")
    if isinstance(h, bool) or not isinstance(h, (int, float)) or not -180.0 <= h < 360.0:
        raise BadInput(f"heading_deg must be a number in [-180, 360), got {h!r}")


run.validate_spec = _validate_test
run_circle.validate_spec = _validate_heading
run_k0.validate_spec = _validate_heading


def _campaign(key: str, out: Path, runs, seed, workers, progress) -> list:
    """The records of campaign ``CAMPAIGNS[key]`` run (or resumed) into ``out/campaign/``."""
    from .common import run_campaign_file
    camp = run_campaign_file(CAMPAIGNS[key], out, runs=runs, seed=seed, workers=workers,
                             progress=progress)
    return camp.records()


def _summarize_k0(results) -> dict:
    """Per state set and k0: :func:`circle_stats` over all tuning drives, and
    :func:`circle_bins` (starts within NEAR_DEG / beyond FAR_DEG: successes, n, gross)."""
    out = {"k0": list(K0_SWEEP), "state_sets": list(K0_STATE_SETS), "stats": {},
           "runs_per_heading": (max(r["run"] for r in results) + 1) if results else 0,
           "headings_deg": sorted({r["heading_deg"] for r in results})}
    for state in K0_STATE_SETS:
        for k0 in K0_SWEEP:
            key = f"{state}/k0={k0:g}"
            rows = [[r["heading_deg"], r["run"], r["final_deg"][key]] for r in results]
            if rows:
                out["stats"][key] = {**circle_stats([f for _, _, f in rows]),
                                     **circle_bins(rows)}
    return out


def binomial_interval(successes: int, n: int, level: float = 0.95) -> tuple:
    """Clopper-Pearson (exact) interval of a success probability from ``successes`` of ``n``."""
    from scipy.stats import beta
    if n <= 0:
        return (0.0, 1.0)
    a = (1.0 - level) / 2.0
    lo = 0.0 if successes == 0 else float(beta.ppf(a, successes, n - successes + 1))
    hi = 1.0 if successes == n else float(beta.ppf(1.0 - a, successes + 1, n - successes))
    return (lo, hi)


def single_run_interval(successes: int, n: int, level: float = 0.95) -> tuple:
    """Where ONE run's success (1) or failure (0) falls under our model, ``level`` sure: [0, 1]
    unless the binomial interval of :func:`binomial_interval` puts the success probability
    below ``(1 - level) / 2`` (then [0, 0]) or above ``(1 + level) / 2`` (then [1, 1]). The
    paper reports one run per test, so its outcome contradicts ours only then."""
    lo, hi = binomial_interval(successes, n, level)
    a = (1.0 - level) / 2.0
    return (0.0 if lo < 1.0 - a else 1.0, 1.0 if hi > a else 0.0)


def circle_stats(final_deg, success_deg: float = SUCCESS_DEG) -> dict:
    """Success rate and error distribution of the heading errors at 300 s of one scheme.

    ``final_deg``: the runs' heading errors at 300 s [deg]. Returns ``n``, ``successes``
    (``|error| < success_deg``), ``rate``, ``interval`` (Clopper-Pearson 95 %), and the median,
    90th percentile and maximum of ``|error|``.
    """
    a = np.abs(np.asarray(final_deg, dtype=float))
    k = int(np.sum(a < success_deg))
    return {"n": int(len(a)), "successes": k, "rate": k / len(a) if len(a) else float("nan"),
            "interval": binomial_interval(k, len(a)),
            "median_abs_deg": float(np.median(a)), "p90_abs_deg": float(np.percentile(a, 90)),
            "max_abs_deg": float(a.max())}


def _summarize_circle(results) -> dict:
    """Per scheme: the whole circle, the paper's start, and each start heading."""
    out = {"test": CIRCLE_TEST, "runs_per_heading": 0, "success_deg": SUCCESS_DEG,
           "headings_deg": sorted({r["heading_deg"] for r in results}),
           "paper_start_deg": PAPER_START_DEG, "circle": {}, "paper_start": {},
           "per_heading": {}, "sigma_u_2s_deg": {}}
    if not results:
        return out
    out["runs_per_heading"] = max(r["run"] for r in results) + 1
    out["carried_over"] = sorted({r["carried_over"] for r in results if r.get("carried_over")})
    out["carried_over_runs"] = sum(1 for r in results if r.get("carried_over"))
    circle = [r for r in results if r["heading_deg"] in CIRCLE_HEADINGS_DEG]
    start = [r for r in results if r["heading_deg"] == PAPER_START_DEG]
    for key in CIRCLE_KEYS:
        fin = lambda rs: [float(np.asarray(r["yaw"][key])[-1]) for r in rs]   # noqa: E731
        out["circle"][key] = circle_stats(fin(circle))
        out["paper_start"][key] = circle_stats(fin(start))
        out["per_heading"][key] = {
            f"{h:g}": circle_stats(fin([r for r in results if r["heading_deg"] == h]))["rate"]
            for h in out["headings_deg"]}
        out.setdefault("final_deg", {})[key] = [
            [r["heading_deg"], r["run"], float(np.asarray(r["yaw"][key])[-1])] for r in results]
        sig = [r["sigma_u_2s_deg"][key] for r in results if key in r["sigma_u_2s_deg"]]
        if sig:     # runs carried over from an earlier circle keep only their final errors
            out["sigma_u_2s_deg"][key] = float(np.median(sig))
    return out


def window_stats(err_yaw_deg, windows):
    """Per run, the (mean, time-STD) of the heading error over each window of :data:`GRID_S`."""
    res = []
    for a, b in windows:
        m = (GRID_S >= a) & (GRID_S <= b)
        res.append((float(np.mean(err_yaw_deg[m])), float(np.std(err_yaw_deg[m]))))
    return res


def ranking_stats(err_yaw_deg, window=(181, 300), off_deg=1.0) -> dict:
    """Accuracy of one scheme over the runs in one window, for the ranking.

    Parameters
    ----------
    err_yaw_deg : (runs, len(GRID_S)) array, heading error [deg] of each run on the grid.
    window : (a, b) [s], inclusive.
    off_deg : a run counts as "off" when its window mean exceeds this in magnitude [deg].

    Returns
    -------
    dict: ``rms`` (over runs and 1-s epochs), ``mean`` and ``sd`` (of the runs' window means),
    ``max_abs_mean`` (worst run), ``runs_off`` (how many runs off by more than ``off_deg``).
    """
    E = np.asarray(err_yaw_deg, dtype=float)
    m = (GRID_S >= window[0]) & (GRID_S <= window[1])
    means = E[:, m].mean(1)
    return {"rms": float(np.sqrt(np.mean(E[:, m] ** 2))), "mean": float(means.mean()),
            "sd": float(means.std(ddof=1)) if len(means) > 1 else 0.0,
            "max_abs_mean": float(np.abs(means).max()),
            "runs_off": int(np.sum(np.abs(means) > off_deg)), "runs": int(len(means))}


def nees_stats(nees, windows, dof=3) -> dict:
    """Ensemble NEES of the attitude against its 95 % band, per window.

    ``nees`` (runs, len(GRID_S)): each run's NEES on the grid. The average over ``N`` runs of a
    consistent filter is ``chi2(dof N) / N`` at each epoch; the band is its 2.5 and 97.5 %
    quantiles. Returns ``{"band": (lo, hi), "mean": [per window], "inside": [fraction of the
    window's 1-s epochs with the average inside the band]}``.
    """
    from ..estimation import chi2
    A = np.asarray(nees, dtype=float)
    n = A.shape[0]
    lo, hi = chi2.ppf([0.025, 0.975], dof * n) / n
    avg = A.mean(0)
    out = {"band": (float(lo), float(hi)), "mean": [], "inside": []}
    for a, b in windows:
        m = (GRID_S >= a) & (GRID_S <= b)
        out["mean"].append(float(avg[m].mean()))
        out["inside"].append(float(np.mean((avg[m] >= lo) & (avg[m] <= hi))))
    return out


def _warm_up():
    """Compile (or load from numba's cache) the filter kernel once before the workers start."""
    from ..align import usque
    from ..core.bundle import Bundle, ImuData, SpeedData
    t = np.arange(0.0, 0.2, 0.01)
    n = len(t)
    imu = ImuData(t, np.zeros((n, 3)), np.tile([0.0, 0.0, 0.098], (n, 1)))
    b = Bundle(imu, {"initial_position": {"lat_deg": 28.0, "lon_deg": 113.0, "h_m": 0.0}},
               ldv=SpeedData(t, v=np.zeros(n)))
    for variant in STATE_SETS.values():
        for C in (usque.UsqueConfig, usque.AusquheConfig, usque.UsqueHinfConfig):
            usque.run(b, C(**variant))


def _time_schemes(seed: int, repeats: int = TIMING_REPEATS) -> dict:
    """Table 3: every scheme on one drive of each paper test, in this process, one core.

    A first (untimed) run of each scheme compiles or loads numba's cache; then the fastest of
    ``repeats`` runs, wall (``perf_counter``) and CPU (``process_time``) time [s]. Called before
    the Monte Carlo pool starts, so only other users' processes share the machine; their load
    is recorded (1-minute load average).
    """
    import os
    from ..sim import simulate
    res = {"wall_s": {}, "cpu_s": {}, "load_1min": float(os.getloadavg()[0])}
    warm = set()
    for test in PAPER_TESTS:
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(test, 0)))
        bundle = simulate(_scenario(test), rng)
        res["wall_s"][str(test)], res["cpu_s"][str(test)] = {}, {}
        for key in TIMED_KEYS:
            name, variant = key.split("/")
            if key not in warm:
                _run_scheme(name, variant, bundle)
                warm.add(key)
            wall, cpu = [], []
            for _ in range(repeats):
                c0 = time.process_time()
                _, dt = _run_scheme(name, variant, bundle)
                cpu.append(time.process_time() - c0)
                wall.append(dt)
            res["wall_s"][str(test)][key] = min(wall)
            res["cpu_s"][str(test)][key] = min(cpu)
            res.setdefault("cpu_repeats_s", {}).setdefault(str(test), {})[key] = cpu
    res["load_1min_after"] = float(os.getloadavg()[0])
    return res


def reproduce(out_dir, runs: int = 30, workers: int = 2, seed: int = 0,
              progress: bool = True, circle_runs: int = CIRCLE_RUNS,
              k0_runs: int = K0_TUNING_RUNS, reuse_tables: bool = False) -> str:
    """Run the tests ``runs`` times with the five schemes, the whole-circle experiment with
    ``circle_runs`` seeds per start heading (0: none) and the k0 sweep with ``k0_runs``
    tuning drives per start heading (0: none); write the report; return its text.

    The Monte Carlo runs are the campaigns of :data:`CAMPAIGNS` (``campaigns/paper001*.yaml``)
    on the campaign engine, into ``out_dir/campaign/<name>/``: a second call with the same
    folder runs only what is missing.

    ``reuse_tables``: keep Tables 1-3, the ranking, the NEES and the test figures of the
    ``results.json`` already in ``out_dir`` (a run of the same code and seed) and run only the
    whole circle and the k0 sweep; the report says which sections were reused and from which
    run. ``python -m inmotion.reproductions.paper001 OUT --reuse-tables`` does this.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    _warm_up()
    if reuse_tables:
        old = json.loads((out / "results.json").read_text())
        if old.get("seed") != seed:
            from ..errors import BadInput
            raise BadInput(f"the results to reuse were made with seed {old.get('seed')}, "
                           f"not {seed}", file=out / "results.json")
        summary = {k: v for k, v in old.items() if k not in ("whole_circle", "k0_sweep")}
        summary["reused_tables"] = old.get("reused_tables") or {
            "elapsed_s": old["elapsed_s"] - old.get("circle_s", 0.0), "runs": old["runs"],
            "workers": old["workers"]}
        results = None
    else:
        timing = _time_schemes(seed)
        t_mc = time.perf_counter()
        results = _campaign("tables", out, runs, seed, workers, progress)
        summary = _summarize(results)
        summary["time_cpu_repeats_s"] = timing.get("cpu_repeats_s", {})
        summary["time_s"] = timing["wall_s"]
        summary["time_cpu_s"] = timing["cpu_s"]
        summary["timing_load_1min"] = (timing["load_1min"], timing["load_1min_after"])
        summary["timing_pass_s"] = t_mc - t0
        summary["monte_carlo_s"] = time.perf_counter() - t_mc
        summary["runs"], summary["seed"], summary["workers"] = runs, seed, workers
    t_circle = time.perf_counter()
    circle = _campaign("circle", out, circle_runs, seed, workers, progress) if circle_runs else []
    summary["whole_circle"] = _summarize_circle(circle)
    summary["circle_s"] = time.perf_counter() - t_circle
    t_k0 = time.perf_counter()
    k0 = _campaign("k0", out, k0_runs, seed, workers, progress) if k0_runs else []
    summary["k0_sweep"] = _summarize_k0(k0)
    summary["k0_s"] = time.perf_counter() - t_k0
    summary["circle_workers"] = workers
    summary["elapsed_s"] = (summary["reused_tables"]["elapsed_s"] + summary["circle_s"]
                            + summary["k0_s"]) if reuse_tables else time.perf_counter() - t0
    (out / "results.json").write_text(json.dumps(summary, indent=1))
    if results is not None:
        _figures(results, out)
    _circle_figures(circle, out)
    text = _report(summary)
    (out / "report.md").write_text(text)
    return text


def rewrite_report(out_dir) -> str:
    """Re-write ``report.md`` from the ``results.json`` in ``out_dir`` (no run)."""
    out = Path(out_dir)
    summary = json.loads((out / "results.json").read_text())
    text = _report(summary)
    (out / "report.md").write_text(text)
    return text


def _keys():
    return [f"{n}/{v}" for n in SCHEMES for v in _variants(n)]


def _summarize(results) -> dict:
    summ = {"tables": {}, "time_mc_mean_s": {}, "final": {}, "ranking": {}, "nees": {}}
    for test in TESTS:
        rs = [r for r in results if r["test"] == test]
        if not rs:
            continue
        t = str(test)
        summ["tables"][t], summ["time_mc_mean_s"][t] = {}, {}
        summ["ranking"][t], summ["nees"][t] = {}, {}
        for key in _keys():
            yaw = np.array([np.asarray(r["errors"][key])[:, 2] for r in rs])   # (runs, grid)
            per_run = np.array([window_stats(y, WINDOWS[test]) for y in yaw])  # (runs, win, 2)
            summ["tables"][t][key] = {
                "mean": per_run[:, :, 0].mean(0).tolist(),
                "std": per_run[:, :, 1].mean(0).tolist(),
                "sd_of_means": per_run[:, :, 0].std(0, ddof=1).tolist() if len(rs) > 1
                else [0.0] * len(WINDOWS[test]),
                "rms_of_means": np.sqrt((per_run[:, :, 0] ** 2).mean(0)).tolist(),
                # where ONE run's window mean / time-STD falls (the paper's are one run's)
                "mean_interval": np.percentile(per_run[:, :, 0], [2.5, 97.5], 0).T.tolist(),
                "std_interval": np.percentile(per_run[:, :, 1], [2.5, 97.5], 0).T.tolist()}
            if key in rs[0].get("sigma_u_2s_deg", {}):
                summ.setdefault("sigma_u_2s_deg", {}).setdefault(t, {})[key] = float(
                    np.median([r["sigma_u_2s_deg"][key] for r in rs]))
            summ["ranking"][t][key] = ranking_stats(yaw, WINDOWS[test][-1])
            if key in rs[0]["nees"]:
                z2 = np.array([r["nees"][key] for r in rs])                  # (runs, grid, 3)
                summ["nees"][t][key] = nees_stats(z2.sum(-1), WINDOWS[test])
                m = GRID_S >= WINDOWS[test][-1][0]
                summ["nees"][t][key]["per_axis_last"] = z2[:, m].mean((0, 1)).tolist()
            summ["time_mc_mean_s"][t][key] = float(np.mean([r["time_s"][key] for r in rs]))
            last = np.array([np.asarray(r["errors"][key])[-1] for r in rs])
            summ["final"].setdefault(t, {})[key] = {
                "pitch_roll_rms_arcmin": (60 * np.sqrt((last[:, :2] ** 2).mean(0))).tolist(),
                "yaw_rms_deg": float(np.sqrt((last[:, 2] ** 2).mean()))}
    return summ


def _fmt(x):
    return f"{x:.4f}" if abs(x) < 100 else f"{x:.1f}"


def _label(key):
    name, variant = key.split("/")
    return f"{SCHEMES[name]} `{name}`" + ("" if variant == "-" else f" ({variant})")


def _table(summary, test, paper) -> list:
    wins = WINDOWS[test]
    if paper is None:
        head = "| scheme | | " + " | ".join(f"{a}-{b} s measured" for a, b in wins) + " |"
        lines = [head, "|" + "---|" * (2 + len(wins))]
    else:
        head = "| scheme | | " + " | ".join(f"{a}-{b} s paper" + f" | {a}-{b} s measured"
                                              for a, b in wins) + " |"
        lines = [head, "|" + "---|" * (2 + 2 * len(wins))]
    for key in _keys():
        name, _ = key.split("/")
        row = summary["tables"][str(test)][key]
        for stat, idx in (("Mean", "mean"), ("STD", "std")):
            cells = []
            for w in range(len(wins)):
                if paper is not None:
                    cells.append(_fmt(paper[name][w][0 if idx == "mean" else 1]))
                meas = _fmt(row[idx][w])
                if idx == "mean":
                    meas += f" +- {_fmt(row['sd_of_means'][w])}"
                cells.append(meas)
            lines.append(f"| {_label(key) if stat == 'Mean' else ''} | {stat} | "
                         + " | ".join(cells) + " |")
    return lines


def _paper_rank(paper) -> dict:
    """Scheme -> rank by |mean| of the paper's last window (its one car run)."""
    order = sorted(paper, key=lambda n: abs(paper[n][-1][0]))
    return {n: i + 1 for i, n in enumerate(order)}


def _ranking_table(summary, test) -> list:
    rk = summary["ranking"][str(test)]
    order = sorted(rk, key=lambda k: rk[k]["rms"])
    paper = {1: PAPER_TABLE1, 2: PAPER_TABLE2}.get(test)
    prank = _paper_rank(paper) if paper else {}
    a, b = WINDOWS[test][-1]
    L = [f"| our rank | scheme | RMS {a}-{b} s [deg] | mean +- SD of run means [deg] | "
         f"worst run [deg] | runs off > 1 deg | paper mean [deg] | paper rank |",
         "|---|---|---|---|---|---|---|---|"]
    for i, key in enumerate(order, start=1):
        r, name = rk[key], key.split("/")[0]
        p = (f"{paper[name][-1][0]:.4g} | {prank[name]}" if paper else "- | -")
        L.append(f"| {i} | {_label(key)} | {r['rms']:.3f} | {r['mean']:.3f} +- {r['sd']:.3f} | "
                 f"{r['max_abs_mean']:.2f} | {r['runs_off']} / {r['runs']} | {p} |")
    return L


def _r(summary, test, key, field="rms"):
    return summary["ranking"][str(test)][key][field]


def _span(values) -> str:
    """``"a-b"`` of the smallest and largest value (3 decimals), or ``"all a"``."""
    v = sorted(values)
    lo, hi = f"{v[0]:.3f}", f"{v[-1]:.3f}"
    return f"all {lo}" if lo == hi else f"{lo}-{hi}"


def _order(S, test):
    rk = S["ranking"][str(test)]
    return sorted(rk, key=lambda k: rk[k]["rms"])


def _ranking_text(S) -> list:
    """The words of the ranking section, with the measured figures of ``S``."""
    r = lambda test, key, f="rms": _r(S, test, key, f)   # noqa: E731
    n = S["runs"]
    o2 = _order(S, 2)
    pos = {k: i + 1 for i, k in enumerate(o2)}
    top = ", ".join(f"{i + 1} `{k}` {r(2, k):.2f}" for i, k in enumerate(o2[:6]))
    ext = [f"{k}/extended" for k in SCHEMES if k != "oba"]
    L = [f"The paper's test 2, 181-300 s, by |mean| of its one car run: 1 `ausquhe` (-0.62 deg), "
         f"2 `ausque` (-10.18), 3 `oba` (12.45), 4 `usque-hinf` (14.46), 5 `usque` (14.51): "
         f"only `ausquhe` is within 1 deg. Ours, by RMS over {n} runs and the window's 1-s "
         f"epochs [deg]: {top}, ... (full tables below). Where the two differ, and why:", "",
         f"* **A mean near 0 is not accuracy.** With the paper's attitude-only state every "
         f"USQUE scheme has window means spread across runs: `usque` (paper states) "
         f"{r(2, 'usque/paper', 'mean'):.2f} +- {r(2, 'usque/paper', 'sd'):.2f} deg, worst run "
         f"{r(2, 'usque/paper', 'max_abs_mean'):.1f} deg, {r(2, 'usque/paper', 'runs_off')} of "
         f"{n} runs off by more than 1 deg; `ausquhe` (paper states) "
         f"{r(2, 'ausquhe/paper', 'mean'):.2f} +- {r(2, 'ausquhe/paper', 'sd'):.2f} deg, worst "
         f"{r(2, 'ausquhe/paper', 'max_abs_mean'):.1f} deg, {r(2, 'ausquhe/paper', 'runs_off')} "
         f"of {n} runs off. One car run, as the paper's, can land anywhere in that spread. The "
         f"spread comes from what the paper's state leaves out (the error of the single LDV "
         f"sample taken as v^b(0), the 50 ug accelerometer bias, the 0.1 % LDV scale factor): "
         f"with them estimated (`extended`), `ausquhe` is at {r(2, 'ausquhe/extended'):.2f} deg "
         f"RMS, {r(2, 'ausquhe/extended', 'runs_off')} of {n} runs off by more than 1 deg "
         f"(worst {r(2, 'ausquhe/extended', 'max_abs_mean'):.2f} deg).",
         f"* **Robust against plain USQUE: as the paper.** With the extended state the two "
         f"adaptive-R schemes lead test 2 (`ausque` {r(2, 'ausque/extended'):.2f}, `ausquhe` "
         f"{r(2, 'ausquhe/extended'):.2f} deg RMS) and `usque` is off by more than 1 deg in "
         f"{r(2, 'usque/extended', 'runs_off')} of {n} runs ({r(2, 'usque/extended'):.2f} deg "
         f"RMS): its R of 0.07 m/s, four times below the LDV noise, over-weights the disturbed "
         f"LDV. Unlike the paper, `ausque` is as good as `ausquhe` "
         f"({r(2, 'ausque/extended'):.2f} vs {r(2, 'ausquhe/extended'):.2f} deg extended; "
         f"{r(2, 'ausque/paper'):.2f} vs {r(2, 'ausquhe/paper'):.2f} paper states), where the "
         f"paper's `ausque` lost 10 deg: our adaptive R is bounded (0.05 .. 1 m/s, "
         f"`inmotion.align.usque`). The paper bounds it too (eq. 44: R_min, R_max on each "
         f"diagonal element) but gives no values, so where its bounds lay is unknown. With "
         f"bounds too wide to act (R free in 1e-4 .. 1e3 m/s, rows `extended-unbounded-r`, "
         f"an ablation of ours, not the paper's scheme) `ausque` is off by "
         f"{r(2, 'ausque/extended-unbounded-r'):.2f} deg RMS (mean "
         f"{r(2, 'ausque/extended-unbounded-r', 'mean'):.2f} +- "
         f"{r(2, 'ausque/extended-unbounded-r', 'sd'):.2f}, worst run "
         f"{r(2, 'ausque/extended-unbounded-r', 'max_abs_mean'):.1f}; paper -10.18): the "
         f"estimated R follows the innovations of a wrong heading and de-weights the very "
         f"measurements that would correct it, or falls on the quiet axes until the filter "
         f"over-trusts them. The paper's failure of `ausque` is reproduced this way, which "
         f"suggests its bounds were wide; its rescue by the adaptive gamma is not: `ausquhe` "
         f"with the same wide bounds is off by "
         f"{r(2, 'ausquhe/extended-unbounded-r'):.2f} deg RMS (worst run "
         f"{r(2, 'ausquhe/extended-unbounded-r', 'max_abs_mean'):.1f}). In our runs the "
         f"bounds on R, not the H-infinity update, are what keeps the adaptive filters on "
         f"the heading.",
         f"* **`oba` ranks {pos['oba/-']} of {len(o2)} here, off by 12.4 deg in the paper.** "
         f"`oba` integrates the velocity equation from the start (paper eq. 12-19) and solves "
         f"Wahba's problem over all epochs: a zero-mean LDV error (our test 2: white noise "
         f"0.3 m/s and outliers uniform in +-3 m/s) enters each vector only through its end "
         f"values and averages out over the hundreds of vector pairs. Our `oba` also centres "
         f"the vectors (which removes the constant error of v^b(0)) and line-fits v^b(0) over "
         f"1 s. In the paper's form (plain q-method, the raw first LDV sample as v^b(0)) its "
         f"RMS is {r(2, 'oba/paper-form'):.2f} deg in test 2 (mean "
         f"{r(2, 'oba/paper-form', 'mean'):.2f} +- {r(2, 'oba/paper-form', 'sd'):.2f}, worst "
         f"run {r(2, 'oba/paper-form', 'max_abs_mean'):.1f} deg, "
         f"{r(2, 'oba/paper-form', 'runs_off')} of {n} runs off by more than 1 deg) against "
         f"{r(2, 'oba/-'):.2f} deg centred: "
         + ("most of our `oba`'s accuracy is the centring and the fitted v^b(0); in the "
            "paper's form it ranks with the paper-state filters."
            if r(2, 'oba/paper-form') > 3 * r(2, 'oba/-') else
            "the centring is not what makes our `oba` accurate.")
         + " Even so, 12.4 deg is beyond what zero-mean noise does to the paper-form `oba` "
           "here: the car's LDV errors must have had a non-zero mean over seconds (an output "
           "held while the signal is lost, a bias while the beam sees a moving surface), which "
           "our test 2 does not model; test 3 below does.",
         f"* **`usque-hinf` with a feasible fixed gamma is `usque`.** The paper's two are within "
         f"0.06 deg of each other in test 2 (14.46 vs 14.51 deg); ours: "
         f"{r(2, 'usque-hinf/paper'):.3f} vs {r(2, 'usque/paper'):.3f} deg (paper states), "
         f"{r(2, 'usque-hinf/extended'):.3f} vs {r(2, 'usque/extended'):.3f} deg (extended). "
         f"A fixed gamma that satisfies the existence condition over the whole run (see "
         f"`inmotion.align.usque`) removes little information at 100 Hz.",
         f"* **Test 1: the schemes are within each other's spread.** Paper: `ausquhe` 0.026, "
         f"`ausque` 0.043, `usque-hinf` 0.090, `oba` -0.155, `usque` 0.391 deg. Ours: the four "
         f"extended filters {_span(r(1, k) for k in ext)} deg RMS (mean {r(1, 'ausquhe/extended', 'mean'):.3f} +- "
         f"{r(1, 'ausquhe/extended', 'sd'):.3f} for `ausquhe`), then `ausquhe` paper states "
         f"{r(1, 'ausquhe/paper'):.3f}, `oba` {r(1, 'oba/-'):.3f}, `usque` paper states "
         f"{r(1, 'usque/paper'):.3f}: with a clean LDV the robust parts have nothing to do, and "
         f"the ranking is set by the state (extended or not), not by the scheme."]
    if "3" in S["ranking"]:
        o3 = _order(S, 3)
        pos3 = {k: i + 1 for i, k in enumerate(o3)}
        L += [f"* **Test 3 (our assumption, not the paper's): LDV bursts that hold a stale value "
              f"or carry a bias.** Same noise as test 2, but the four bursts are: the output "
              f"stuck for 40-50 s and for 110-125 s (in the last 3 s of it the car brakes from 13 "
              f"to 7 m/s while the LDV keeps reading 13 m/s), and +0.5 m/s for 190-200 s and "
              f"240-255 s (the windows of test 2's bursts). `oba` is now biased: mean "
              f"{r(3, 'oba/-', 'mean'):.2f} +- {r(3, 'oba/-', 'sd'):.2f} deg, "
              f"{r(3, 'oba/-', 'runs_off')} of {n} runs off by more than 1 deg (RMS "
              f"{r(3, 'oba/-'):.2f}, rank {pos3['oba/-']}; paper form {r(3, 'oba/paper-form'):.2f}"
              f"). `ausque` (extended) {r(3, 'ausque/extended'):.2f} (rank "
              f"{pos3['ausque/extended']}), `ausquhe` {r(3, 'ausquhe/extended'):.2f} (extended, "
              f"rank {pos3['ausquhe/extended']}) / {r(3, 'ausquhe/paper'):.2f} (paper states), "
              f"`usque` {r(3, 'usque/extended'):.2f} / {r(3, 'usque/paper'):.2f}. A "
              f"non-zero-mean LDV error is what takes `oba` off zero; it hurts every filter. "
              f"Among the extended filters, `usque` and `ausquhe` suffer most, `ausque` least: "
              f"likely the extra states absorb the held speed as a scale-factor or v^b(0) "
              f"error and keep it, unless the innovations it causes inflate R first (we have "
              f"not isolated this)."]
    return L


def _claims_text(S) -> list:
    """Issue 6's "To show" items against the measured figures."""
    r = lambda test, key, f="rms": _r(S, test, key, f)   # noqa: E731
    n = S["runs"]
    t1 = S["tables"]["1"]["ausquhe/extended"]
    t1p = S["tables"]["1"]["ausquhe/paper"]
    ok2 = r(2, "ausquhe/extended", "max_abs_mean") < 1.0
    return [
        f"* Test 2, `ausquhe` at 181-300 s under 1 deg (paper -0.62): extended state "
        f"{r(2, 'ausquhe/extended', 'mean'):.2f} +- {r(2, 'ausquhe/extended', 'sd'):.2f} deg, "
        f"worst of {n} runs {r(2, 'ausquhe/extended', 'max_abs_mean'):.2f}, RMS "
        f"{r(2, 'ausquhe/extended'):.2f}: " + ("met" if ok2 else "not met") + f"; paper state "
        f"{r(2, 'ausquhe/paper', 'mean'):.2f} +- {r(2, 'ausquhe/paper', 'sd'):.2f} deg with "
        f"{r(2, 'ausquhe/paper', 'runs_off')} of {n} runs beyond 1 deg: not met per run.",
        f"* ... where `usque` and `oba` are off by several degrees: `usque` yes (RMS "
        f"{r(2, 'usque/paper'):.2f} deg paper state, worst run "
        f"{r(2, 'usque/paper', 'max_abs_mean'):.1f}; {r(2, 'usque/extended'):.2f} extended, "
        f"{r(2, 'usque/extended', 'runs_off')} of {n} runs beyond 1 deg); `oba` no with our "
        f"zero-mean LDV disturbance (RMS {r(2, 'oba/-'):.2f}; paper form "
        f"{r(2, 'oba/paper-form'):.2f}), yes by a degree with stale / biased bursts (test 3: "
        f"{r(3, 'oba/-', 'mean'):.2f} +- {r(3, 'oba/-', 'sd'):.2f} deg): see the ranking "
        f"section for why." if "3" in S["ranking"] else "",
        f"* Test 1, `ausquhe` at 181-300 s within 0.05 deg (paper 0.026): mean over runs "
        f"{t1['mean'][-1]:.3f} deg (extended), {t1p['mean'][-1]:.3f} (paper state): met on "
        f"average; single runs spread by {t1['sd_of_means'][-1]:.3f} / "
        f"{t1p['sd_of_means'][-1]:.3f} deg (SD of the run means), so a single run is often "
        f"outside 0.05 deg.",
        "* The ranking of the schemes: where ours differs from the paper's, and why, in "
        "\"Ranking against the paper\" below."] + _circle_claim(S)


def _circle_claim(S) -> list:
    """Issue 17's claim (alignment from an unknown attitude) against the whole circle."""
    C = S.get("whole_circle") or {}
    if not C.get("circle"):
        return []
    c = lambda k, w="circle": C[w][k]    # noqa: E731
    f = lambda k, w="circle": f"{c(k, w)['successes']} of {c(k, w)['n']}"   # noqa: E731
    return [
        f"* Alignment from an unknown attitude (issue 17; test {C['test']}, start headings "
        f"over the whole circle, success = |heading error| < {C['success_deg']:g} deg at 300 s): "
        f"`ausquhe` as in Tables 1-2 (paper states, k0 = 30) succeeds in "
        f"{f('ausquhe/paper')} runs (95 % {c('ausquhe/paper')['interval'][0]:.2f}-"
        f"{c('ausquhe/paper')['interval'][1]:.2f}), {f('ausquhe/paper', 'paper_start')} from "
        f"the paper's start ({C['paper_start_deg']:g} deg); with the extended state "
        f"{f('ausquhe/extended')}; `usque` {f('usque/paper')}, `ausque` {f('ausque/paper')}, "
        f"`usque-hinf` {f('usque-hinf/paper')}, `oba` (paper form) "
        f"{f('oba/paper-form')}, `oba` centred {f('oba/-')}. Why, and whether any k0 of eq. 55 "
        "makes `ausquhe` robust, in \"Alignment from an unknown heading\" below."]


def _nees_text(S) -> list:
    """Words of the NEES section, with the measured figures."""
    nz = S["nees"]
    g = lambda t, k, w=-1: nz[t][k]["mean"][w]                 # noqa: E731
    ax = lambda t, k: nz[t][k]["per_axis_last"]                # noqa: E731
    L = [f"* The paper-state filters are far from honest (test 1, 181-300 s: `ausquhe` NEES "
         f"{g('1', 'ausquhe/paper'):.3g}, `usque` {g('1', 'usque/paper'):.3g}): their state "
         f"has no room for the accelerometer bias, the LDV scale factor and the v^b(0) sample "
         f"error, which set their errors.",
         f"* With the extended state, test 1: NEES {g('1', 'ausquhe/extended', 1):.3g} over "
         f"91-180 s and {g('1', 'ausquhe/extended'):.3g} over 181-300 s for `ausquhe` (per axis "
         f"E, N, U: {', '.join(f'{v:.3g}' for v in ax('1', 'ausquhe/extended'))}): the "
         f"covariance shrinks faster than the errors. The paper's process noise, 1e-7 deg per "
         f"update (1e-6 deg/sqrt(s) at 100 Hz), is 50 times below the simulated gyro angle "
         f"random walk (0.003 deg/sqrt(h) = 5e-5 deg/sqrt(s)). With the process noise set from "
         f"it (`ausquhe (extended-arw-q)`, {ARW_Q_DEG:.1e} deg per update) the NEES is "
         f"{g('1', 'ausquhe/extended-arw-q'):.3g} in test 1 and "
         f"{g('2', 'ausquhe/extended-arw-q'):.3g} in test 2 at 181-300 s, and the heading RMS "
         f"{_r(S, 1, 'ausquhe/extended-arw-q'):.3f} / {_r(S, 2, 'ausquhe/extended-arw-q'):.3f} "
         f"deg (paper's Q: {_r(S, 1, 'ausquhe/extended'):.3f} / "
         f"{_r(S, 2, 'ausquhe/extended'):.3f})"
         + (": an honest covariance, paid for in test 2 by a heading that follows the "
            "disturbed LDV more (a larger Q keeps the gain up). We keep the paper's Q in the "
            "tables; a user who needs the 1-sigma to mean something sets Q from the gyro's "
            "random walk." if _r(S, 2, 'ausquhe/extended-arw-q') > _r(S, 2, 'ausquhe/extended')
            else "."),
         f"* Test 2, `ausquhe` extended: NEES {g('2', 'ausquhe/extended'):.3g} at 181-300 s "
         f"(per axis {', '.join(f'{v:.3g}' for v in ax('2', 'ausquhe/extended'))}); `usque` "
         f"extended {g('2', 'usque/extended'):.3g}: with R fixed at 0.07 m/s against 0.3 m/s "
         f"of LDV noise it claims a heading it does not have.",
         f"* Test 3 (stale / biased LDV): no filter is honest (`ausquhe` extended "
         f"{g('3', 'ausquhe/extended'):.3g}): a held or biased speed is not noise, and no R "
         f"describes it."] if "3" in nz else []
    return L


def _nees_table(S) -> list:
    tests = [t for t in ("1", "2", "3") if t in S["nees"]]
    any_key = next(iter(S["nees"][tests[0]].values()))
    lo, hi = any_key["band"]
    head = "| scheme | " + " | ".join(
        f"test {t} {a}-{b} s: NEES, in band" for t in tests
        for a, b in (WINDOWS[int(t)][1], WINDOWS[int(t)][2])) + " | " + " | ".join(
        f"test {t} 181-300 s: E, N, U" for t in tests) + " |"
    L = [f"Ensemble NEES of the attitude (3 degrees of freedom; a consistent filter averages 3, "
         f"95 % band of the average over {S['runs']} runs: {lo:.2f} .. {hi:.2f}). Each cell: the "
         f"window's mean of the ensemble NEES, and the share of its 1-s epochs inside the band. "
         f"Above the band the filter claims more than it knows. Last columns: the mean of "
         f"(phi_i / sigma_i)^2 per axis over 181-300 s (1 for an honest axis).", "", head,
         "|---|" + "---|" * (3 * len(tests))]
    for key in _keys():
        if key not in S["nees"][tests[0]]:
            continue
        cells = []
        for t in tests:
            n = S["nees"][t][key]
            for w in (1, 2):
                cells.append(f"{n['mean'][w]:.3g}, {100 * n['inside'][w]:.0f} %")
        for t in tests:
            cells.append(", ".join(f"{v:.3g}" for v in S["nees"][t][key]["per_axis_last"]))
        L.append(f"| {_label(key)} | " + " | ".join(cells) + " |")
    return L


#: start-error bins of the circle report [deg]: near (|start| <= 60), far (|start| >= 120); a
#: gross failure is an error above GROSS_DEG at 300 s
NEAR_DEG, FAR_DEG, GROSS_DEG = 60.0, 120.0, 5.0


def circle_bins(final_deg) -> dict:
    """``{"near": (successes, n, gross), "far": (...)}`` from ``[[heading, run, final error]]``
    rows: start errors |h| <= NEAR_DEG and >= FAR_DEG (wrapped), success |error| < SUCCESS_DEG,
    gross |error| > GROSS_DEG."""
    out = {}
    for name, sel in (("near", lambda a: a <= NEAR_DEG), ("far", lambda a: a >= FAR_DEG)):
        e = [abs(f) for h, _, f in final_deg if sel(abs(((h + 180.0) % 360.0) - 180.0))]
        out[name] = (int(sum(a < SUCCESS_DEG for a in e)), len(e),
                     int(sum(a > GROSS_DEG for a in e)))
    return out


def _agree(C, key, ref="oba/paper-form") -> str:
    """``"k of n"``: runs where ``key`` and ``ref`` both succeed or both miss."""
    a = {(h, r): abs(f) < SUCCESS_DEG for h, r, f in C.get("final_deg", {}).get(key, [])}
    b = {(h, r): abs(f) < SUCCESS_DEG for h, r, f in C.get("final_deg", {}).get(ref, [])}
    common = set(a) & set(b)
    return f"{sum(a[x] == b[x] for x in common)} of {len(common)}"


def _circle_summary_bullet(C) -> str:
    """The first finding of the circle section, from the runs' final errors."""
    b = {k: circle_bins(C.get("final_deg", {}).get(k, [])) for k in CIRCLE_KEYS}
    f = lambda k, w: f"{b[k][w][0]} of {b[k][w][1]}"    # noqa: E731
    g = lambda k, w: b[k][w][2]                          # noqa: E731
    worst = min(C["circle"], key=lambda k: C["circle"][k]["rate"])
    worst_note = ("; the adaptive R without the H-infinity step is the worst here; in the "
                  "paper's test 2 it was -10 deg against `usque`'s 14.5"
                  if worst == "ausque/paper" else "")
    return (
        f"* **The start heading matters for every filter, not for `oba`.** `ausquhe` (paper "
        f"states, k0 = 30) succeeds in {f('ausquhe/paper', 'near')} runs that start within "
        f"{NEAR_DEG:g} deg ({g('ausquhe/paper', 'near')} gross failures) and in "
        f"{f('ausquhe/paper', 'far')} that start beyond {FAR_DEG:g} deg "
        f"({g('ausquhe/paper', 'far')} gross, up to {C['circle']['ausquhe/paper']['max_abs_deg']:.0f}"
        f" deg off); `usque` {f('usque/paper', 'near')} / {f('usque/paper', 'far')} "
        f"({g('usque/paper', 'far')} gross far), `ausque` {f('ausque/paper', 'near')} / "
        f"{f('ausque/paper', 'far')} ({g('ausque/paper', 'near') + g('ausque/paper', 'far')} "
        f"gross{worst_note}), with the extended state `ausquhe` {f('ausquhe/extended', 'near')} / "
        f"{f('ausquhe/extended', 'far')} ({g('ausquhe/extended', 'far')} gross far). `oba` "
        f"solves Wahba's problem over all epochs at once, so the start does not enter it: "
        f"paper form {f('oba/paper-form', 'near')} / {f('oba/paper-form', 'far')} with "
        f"{g('oba/paper-form', 'near') + g('oba/paper-form', 'far') or 'no'} gross "
        f"failure(s) (its misses, up to "
        f"{C['circle']['oba/paper-form']['max_abs_deg']:.1f} deg, are the error of the raw "
        f"v^b(0) sample), centred "
        f"{f('oba/-', 'near')} / {f('oba/-', 'far')}. So `ausquhe` as written is not robust "
        f"to the start heading in our model, where the paper's one run from about 170 deg "
        f"succeeded; the paper's start alone (one run) cannot contradict a success rate of "
        f"{C['paper_start']['ausquhe/paper']['successes']} of "
        f"{C['paper_start']['ausquhe/paper']['n']} there.")


def _circle_text(S) -> list:
    """The whole-circle section: the table, and what the runs show."""
    C = S.get("whole_circle") or {}
    if not C.get("circle"):
        return ["Not run (``circle_runs=0``)."]
    nh = len([h for h in C["headings_deg"] if h in CIRCLE_HEADINGS_DEG])
    L = [f"Test {C['test']}'s drive from {nh} start headings over the whole circle "
         f"({', '.join(f'{h:g}' for h in CIRCLE_HEADINGS_DEG)} deg: the truth's heading; the "
         f"filters start at yaw 0, so the start error is its negative) and from the paper's "
         f"own start ({C['paper_start_deg']:g} deg), {C['runs_per_heading']} runs each. "
         f"Success: |heading error| < {C['success_deg']:g} deg at 300 s. Rate with its "
         "Clopper-Pearson 95 % interval; error distribution of |heading error| at 300 s; by "
         f"start error: success and gross failures (|error| > {GROSS_DEG:g} deg at 300 s). "
         "Within one start heading all schemes see the same drives.", "",
         "| scheme | whole circle: success | 95 % interval | median abs [deg] | 90 % abs "
         "[deg] | max abs [deg] | paper's start: success | median abs [deg] | start within "
         f"{NEAR_DEG:g} deg: success, gross | start beyond {FAR_DEG:g} deg: success, gross | "
         f"heading 1-sigma at {EARLY_S:g} s [deg] |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for key in CIRCLE_KEYS:
        c, p = C["circle"][key], C["paper_start"][key]
        sig = C["sigma_u_2s_deg"].get(key)
        b = circle_bins(C.get("final_deg", {}).get(key, []))
        bins = " | ".join(f"{k} / {n}, {g}" for k, n, g in (b["near"], b["far"]))
        L.append(f"| {_label(key)} | {c['successes']} / {c['n']} | {c['interval'][0]:.2f}-"
                 f"{c['interval'][1]:.2f} | {c['median_abs_deg']:.2f} | {c['p90_abs_deg']:.1f} "
                 f"| {c['max_abs_deg']:.1f} | {p['successes']} / {p['n']} | "
                 f"{p['median_abs_deg']:.2f} | {bins} | "
                 + (f"{sig:.2f}" if sig is not None else "-") + " |")
    L += ["", "Success rate per start heading (truth heading in deg; runs per cell "
          f"{C['runs_per_heading']}):", "",
          "| scheme | " + " | ".join(f"{h:g}" for h in C["headings_deg"]) + " |",
          "|---|" + "---|" * len(C["headings_deg"])]
    for key in CIRCLE_KEYS:
        ph = C["per_heading"][key]
        L.append(f"| {_label(key)} | " + " | ".join(f"{ph[f'{h:g}']:.2f}"
                                                    for h in C["headings_deg"]) + " |")
    sg = S.get("sigma_u_2s_deg", {})
    s1 = sg.get("1", {}).get("usque/paper")
    s2 = sg.get("2", {}).get("usque/paper")
    lat = _scenario_spec(2)["start"]["lat_deg"]
    noise = _scenario_spec(2)["sensors"]["ldv"]["noise_m_s"]
    bound = earth_rate_heading_sigma_deg(EARLY_S, lat, noise, 100.0,
                                         PAPER_FILTER["sigma0_deg"][2])
    r = lambda k, f="rate": C["circle"][k][f]    # noqa: E731
    L += ["", "What the runs show, and why `ausquhe` is not robust to the start heading here:",
          "",
          _circle_summary_bullet(C),
          f"* **Spurious heading information in the first seconds.** From the data, the "
          f"heading of this model is observable only through the Earth-rate part of beta "
          f"(eq. 19), g Omega cos(L) t^2 / 2: after {EARLY_S:g} s with {noise:g} m/s of LDV "
          f"noise at 100 Hz the Cramer-Rao bound leaves the heading 1-sigma at {bound:.1f} deg "
          f"(the prior's 12 deg; `earth_rate_heading_sigma_deg`). The filters' own heading "
          f"1-sigma at {EARLY_S:g} s (median over runs, `usque` paper states, start 8 deg): "
          + (f"{s1:.2f} deg in test 1 (LDV noise 0.01 m/s), {s2:.2f} deg in test 2"
             if s1 is not None and s2 is not None else "n/a")
          + ". In test 2 the filter claims within two seconds a heading it cannot know. "
          "Mechanism: the LDV noise (0.3 m/s on v^b(t) and on the one sample taken as v^b(0)) "
          "against a gravity term g t of a few m/s tilts the estimated vertical by degrees in "
          "the first second; a rotation about the i-frame vertical then moves the predicted "
          "gravity vector by g t sin(tilt error), so every update credits the heading with "
          "information that belongs to the tilt, along a direction that turns with the noisy "
          "estimate (the known inconsistency of a filter linearized at its moving estimate in "
          "an unobservable direction). With a 1-sigma of a few degrees the gain on the heading "
          "is small, and the filter leaves a 170-deg start error only as the real Earth-rate "
          "information (growing as t^5) overtakes this false one: in a development trace "
          "(`usque`, paper states, 170 deg, seed 0) the heading was 89 deg off at 100 s and 8 "
          "deg at 300 s.",
          "* **What the paper's tools do.** The adaptive R (eq. 42-45) raises R along the "
          "LDV axis but does not undo the tilt error the first noisy samples cause. The "
          "adaptive gamma of eq. 55 removes gamma^-2 of information per update from every "
          "attitude direction, which is what can hold the heading's covariance open against "
          "the false information; with k0 = 30 (our default, chosen on test 1 from an 8-deg "
          "start) gamma stays far above the heading's 1-sigma and removes almost nothing. k0 "
          "is the paper's free parameter (\"determined by experiment\"); a smaller one keeps "
          "the heading open longer, but a heading held open also follows the noise and, with "
          "the extended state, wanders with the accelerometer-bias, LDV-scale and v^b(0) "
          "states (a wrong heading's residual grows like t^2, partly like those states' t and "
          "constant signatures). How this trades out, measured: the k0 sweep below.",
          f"* **The small misses come from the drive, not from the start**: the single LDV "
          f"sample taken as v^b(0) carries 0.3 m/s of noise that the attitude-only state cannot "
          f"absorb; it biases the heading by about dv0 / (g Omega cos(L) t^2 / 2) (1.4 deg at "
          f"200 s for 0.3 m/s; `inmotion.align.usque_model`), in the filters as in `oba`'s "
          f"paper form. On the same drives they succeed or miss together: `usque` (paper "
          f"states) agrees with `oba` (paper form) in {_agree(C, 'usque/paper')} runs, "
          f"`ausquhe` in {_agree(C, 'ausquhe/paper')}.",
          "* **The attitude parametrization is not the cause**: the error state is a GRP "
          "(a = 1, f = 4) about a reference quaternion that carries the large attitude, reset "
          "at every update; its sigma points span sqrt(3) x 12 deg = 21 deg, far from the "
          "GRP's singularity at 360 deg, so a 180-deg start error never enters the GRP."]
    return L + _k0_text(S)


def _k0_text(S) -> list:
    """The k0 sweep on the tuning drives and the quantitative answer to "can ausquhe be
    robust?" (issue 17)."""
    K = S.get("k0_sweep") or {}
    C = S.get("whole_circle") or {}
    if not K.get("stats"):
        return []
    lat = _scenario_spec(CIRCLE_TEST)["start"]["lat_deg"]
    noise = _scenario_spec(CIRCLE_TEST)["sensors"]["ldv"]["noise_m_s"]
    sl, su = (v0_heading_sigma_deg(GRID_S[-1], lat, noise, w) for w in ("last", "uniform"))
    cl, cu = success_ceiling(sl), success_ceiling(su)
    pct = lambda a: f"{a[0]} of {a[1]}"     # noqa: E731
    ci = lambda k, n: "{:.2f}-{:.2f}".format(*binomial_interval(k, n))   # noqa: E731
    L = ["", f"### Can `ausquhe` be made robust? k0 of eq. 55 on tuning drives", "",
         f"`ausquhe` with k0 in {', '.join(f'{k:g}' for k in K['k0'])} (the paper: "
         "\"determined by experiment\", no value), both state sets, on tuning drives of test "
         f"{CIRCLE_TEST} that are none of the circle's or the tables' (Generator spawn key "
         f"({CIRCLE_TEST}, 2, heading, run)), from the same {len(K['headings_deg'])} start "
         f"headings, {K['runs_per_heading']} drive(s) each; everything else as in the tables "
         "(`FILTER`). Success |heading error| < "
         f"{SUCCESS_DEG:g} deg at 300 s, Clopper-Pearson 95 %; within {NEAR_DEG:g} / beyond "
         f"{FAR_DEG:g} deg: successes of runs, gross (> {GROSS_DEG:g} deg).", "",
         "| state set | k0 | success | 95 % | start within 60 deg: success, gross | start "
         "beyond 120 deg: success, gross | median abs [deg] | 90 % abs [deg] | max abs [deg] |",
         "|---|---|---|---|---|---|---|---|---|"]
    best = {}
    for key, st in K["stats"].items():
        state, k0 = key.split("/k0=")
        n, f = st["near"], st["far"]
        L.append(f"| {state} | {k0} | {st['successes']} / {st['n']} | {st['interval'][0]:.2f}-"
                 f"{st['interval'][1]:.2f} | {n[0]} / {n[1]}, {n[2]} | {f[0]} / {f[1]}, {f[2]} | "
                 f"{st['median_abs_deg']:.2f} | {st['p90_abs_deg']:.1f} | "
                 f"{st['max_abs_deg']:.1f} |")
        if state not in best or st["successes"] > best[state][1]["successes"]:
            best[state] = (k0, st)
    fish = []
    for key in ("ausquhe/paper", "ausquhe/extended", "usque/paper", "oba/paper-form"):
        if key in C.get("final_deg", {}):
            b = circle_bins(C["final_deg"][key])
            p = near_far_p_value(b["near"][:2], b["far"][:2])
            fish.append(f"{_label(key)} {b['near'][0]} of {b['near'][1]} near against "
                        f"{b['far'][0]} of {b['far'][1]} far (p = {p:.2g})")
    L += ["", "What this settles:", "",
          "* **Does the start heading lower the success rate? The circle's drives** "
          f"({C.get('runs_per_heading', 0)} per start heading; Fisher's exact test, two-sided, "
          f"of success from starts within {NEAR_DEG:g} deg against beyond {FAR_DEG:g} deg; a "
          "small p: the start matters): " + "; ".join(fish) + ".",
          f"* **A ceiling for the attitude-only state, from any start.** The one LDV sample "
          f"taken as v^b(0) carries the test's {noise:g} m/s of noise, a constant in every "
          f"vector pair that the paper's state cannot absorb. Against the heading's signal, "
          f"the Earth-rate part of beta, it leaves a heading error of 1-sigma {sl:.2f} deg at "
          f"300 s if the last epoch dominates, {su:.2f} deg for a least-squares fit with equal "
          f"weights over 0-300 s (`v0_heading_sigma_deg`); the share of runs within "
          f"{SUCCESS_DEG:g} deg can then be at most {cl:.2f} and {cu:.2f} "
          f"(`success_ceiling`; which of the two depends on how the scheme weighs its epochs), "
          f"whatever the start and whatever k0. Measured from starts "
          f"within {NEAR_DEG:g} deg (where the start cannot be the cause): "]
    parts = []
    for key in ("ausquhe/paper", "oba/paper-form", "usque/paper"):
        if key in C.get("final_deg", {}):
            b = circle_bins(C["final_deg"][key])["near"]
            parts.append(f"{_label(key)} {b[0]} of {b[1]} (95 % {ci(b[0], b[1])})")
    L[-1] += ", ".join(parts) + (". So a success rate near 1 is out of reach for the paper's "
                                 "scheme as written, with or without a large start; "
                                 "\"robust\" can only mean that the start does not lower it.")
    for state, (k0, st) in best.items():
        n, f = st["near"], st["far"]
        lo_f, hi_f = binomial_interval(f[0], f[1])
        same = n[1] and lo_f <= n[0] / n[1] <= hi_f
        L.append(
            f"* **{state} state, best k0 on the tuning drives: {k0}** ({st['successes']} of "
            f"{st['n']}, 95 % {st['interval'][0]:.2f}-{st['interval'][1]:.2f}): from within "
            f"{NEAR_DEG:g} deg {pct(n)}, from beyond {FAR_DEG:g} deg {pct(f)} (95 % "
            f"{lo_f:.2f}-{hi_f:.2f}, {f[2]} gross): the far starts "
            + ("succeed as often as the near ones within the sample's uncertainty"
               if same else "succeed less often than the near ones (the near rate lies "
               "outside the far rate's interval)") + ".")
    for state in K["state_sets"]:
        rows = [(k0, K["stats"][f"{state}/k0={k0:g}"]) for k0 in K["k0"]]
        L.append(f"* {state} state across k0 ({', '.join(f'{k:g}' for k, _ in rows)}): "
                 "successes from within 60 deg "
                 + ", ".join(str(st["near"][0]) for _, st in rows)
                 + f" of {rows[0][1]['near'][1]}; from beyond 120 deg "
                 + ", ".join(str(st["far"][0]) for _, st in rows)
                 + f" of {rows[0][1]['far'][1]}; gross failures "
                 + ", ".join(str(st["near"][2] + st["far"][2]) for _, st in rows) + ".")
    ext = [st for key, st in K["stats"].items() if key.startswith("extended/")]
    if ext and "oba/-" in C.get("circle", {}):
        o = C["circle"]["oba/-"]
        top = max(ext, key=lambda st: st["successes"])
        L.append(f"* **Against what the data allow.** With the v^b(0) error estimated "
                 f"(`extended`) the ceiling is gone: `oba` centred (v^b(0) fitted) succeeds "
                 f"in {o['successes']} of {o['n']} circle runs. The best extended `ausquhe` "
                 f"of the sweep: {top['successes']} of {top['n']} (95 % "
                 f"{top['interval'][0]:.2f}-{top['interval'][1]:.2f}). "
                 + ("No k0 of the sweep brings it to `oba`'s level: within this sweep "
                    "`ausquhe` is not robust to the start heading, and the reason is the "
                    "spurious early heading information above, which no setting of eq. 55's "
                    "k0 removes without also opening the heading to the noise."
                    if top["interval"][1] < o["interval"][0] else
                    f"Its interval reaches `oba`'s: on {top['n']} tuning drives the sweep "
                    "cannot tell that k0 from the batch solution; the circle's own runs of "
                    "k0 = 30 (above, near against far) are the larger sample."))
    return L


def _report(summary) -> str:
    S = summary
    table = conditions_markdown(conditions(S.get("runs"), S.get("whole_circle", {})
                                           .get("runs_per_heading") or CIRCLE_RUNS,
                                           S.get("k0_sweep", {}).get("runs_per_heading")
                                           or K0_TUNING_RUNS))
    L = ["# Paper 001 reproduction: LDV-aided in-motion alignment, five schemes", ""]
    L += table[:2] + ["Each parameter of the experiment, the paper's value, ours (read from "
                      "the scenarios and filter settings the runs use) and why ours differs.",
                      ""] + table[2:]
    L += ["## The runs", "",
         f"{S['runs']} Monte Carlo runs per test, seed {S['seed']}, {S['workers']} worker(s); "
         + (f"{S['elapsed_s']:.0f} s in all ({S.get('timing_pass_s', 0):.0f} s of it the "
            f"timing pass of Table 3, {S.get('monte_carlo_s', S['elapsed_s']):.0f} s the "
            f"Monte Carlo, {S.get('circle_s', 0):.0f} s the whole circle, "
            f"{S.get('k0_s', 0):.0f} s the k0 sweep). "
            if not any((S.get("checkpointed_before") or {}).values()) else
            f"Tables 1-3: {S.get('timing_pass_s', 0):.0f} s the timing pass, "
            f"{S.get('monte_carlo_s', 0):.0f} s the Monte Carlo. ")
         + f"Whole circle: {S.get('whole_circle', {}).get('runs_per_heading', 0)} runs per "
         f"start heading; k0 sweep: {S.get('k0_sweep', {}).get('runs_per_heading', 0)} tuning "
         "drive(s) per start heading. "
         + ("Tables 1-3, the ranking, the NEES and the test figures are those of an earlier "
            "run of the same code and seed (`reuse_tables`); the whole circle and the k0 sweep "
            "were re-run. " if S.get("reused_tables") else "")
         + (f"{S['whole_circle']['carried_over_runs']} of the circle's drives (its first "
            "seeds) are carried over, final errors only, from "
            + "; ".join(S["whole_circle"]["carried_over"])
            + ": the same seeds and settings (a fresh run of one of them gave the same final "
            "errors to the last bit), so only the new seeds were run. "
            if (S.get("whole_circle") or {}).get("carried_over_runs") else "")
         + ("The circle's and the sweep's runs were kept as they finished "
            "and ran over several calls on a shared, loaded "
            "machine (circle: {circle}, k0 sweep: {k0} runs done before the last call), so "
            "their wall time is not given. ".format(**S["checkpointed_before"])
            if any((S.get("checkpointed_before") or {}).values()) else "")
         + "Heading error "
         "(estimate minus truth) in deg. Measured Mean: average over the runs of each run's "
         "window mean, +- the SD of those means across runs; measured STD: average of each "
         "run's time-STD in the window (the paper's figures are its one car run). State sets: "
         "`paper` = attitude only (as the paper); `extended` = + accelerometer bias + LDV "
         "scale factor + error of the LDV sample taken as v^b(0). `oba` is the "
         "coarse-alignment module's q-method (centred vectors, v^b(0) line-fitted over 1 s); "
         "`oba (paper-form)` the paper's (plain q-method, raw first LDV sample as v^b(0)). "
         "`usque-hinf` uses the fixed gamma per unit time, 100 deg sqrt(s) (the existence "
         "condition over the first 50 s, see `inmotion.align.usque`).", "",
         "## The issue's claims, measured", ""]
    L += [c for c in _claims_text(S) if c]
    L += ["", "## Table 1: test 1, normal LDV", ""]
    L += _table(S, 1, PAPER_TABLE1)
    L += ["", "## Table 2: test 2, LDV with heavy noise (0.3 m/s) and outlier bursts", "",
          "The paper's test 2 started about 155-180 deg off in heading, these runs 8 deg off: "
          "the summary rows mark this table not comparable, and the paper's start is compared "
          "in \"Alignment from an unknown heading\" below.", ""]
    L += _table(S, 2, PAPER_TABLE2)
    if "3" in S["tables"]:
        L += ["", "## Table 2b (not in the paper): test 3, LDV noise with stale and biased "
              "bursts", "",
              "Our assumption, scenario `paper001_urban_stale`: noise as test 2; LDV stuck "
              "40-50 s and 110-125 s, +0.5 m/s 190-200 s and 240-255 s.", ""]
        L += _table(S, 3, None)
    L += ["", "## Alignment from an unknown heading: the whole circle", ""]
    L += _circle_text(S)
    L += ["", "## Ranking against the paper", ""]
    L += _ranking_text(S)
    for test, title in ((1, "test 1"), (2, "test 2"), (3, "test 3 (our variant)")):
        if str(test) in S["ranking"]:
            L += ["", f"Ranking, {title}, by RMS of the 181-300 s heading error:", ""]
            L += _ranking_table(S, test)
    L += ["", "## NEES of the attitude", ""]
    L += _nees_table(S)
    L += [""] + _nees_text(S)
    load = S.get("timing_load_1min")
    L += ["", "## Table 3: compute time per 300 s run", "",
          "Each scheme on one drive of each test in one process (one core), after a warm run "
          "(no numba compile counted), before the Monte Carlo workers start; fastest of "
          f"{TIMING_REPEATS} runs; the ratio to `oba` (paper form)'s CPU time is what compares "
          "with the paper's ratio (its seconds are MATLAB on another machine)."
          + (f" Load average of the machine (other users) {load[0]:.1f} before, "
                     f"{load[1]:.1f} after." if load else ""), "",
          "| scheme | paper test 1 [s] | paper test 2 [s] | test 1 wall [s] | test 1 CPU [s] "
          "| test 2 wall [s] | test 2 CPU [s] | paper ratio to oba, test 1, 2 | our CPU "
          "ratio to oba (paper form), test 1, 2 |", "|---|---|---|---|---|---|---|---|---|"]
    cpu = S.get("time_cpu_s", {})
    nan = float("nan")
    for key in _keys():
        if key not in S["time_s"].get("1", {}):
            continue
        name, _ = key.split("/")
        p1, p2 = PAPER_TABLE3[name]
        po1, po2 = PAPER_TABLE3["oba"]
        w1, w2 = S["time_s"]["1"][key], S["time_s"]["2"].get(key, nan)
        c1 = cpu.get("1", {}).get(key, nan)
        c2 = cpu.get("2", {}).get(key, nan)
        o1 = cpu.get("1", {}).get("oba/paper-form", nan)
        o2 = cpu.get("2", {}).get("oba/paper-form", nan)
        L.append(f"| {_label(key)} | {p1:.2f} | {p2:.2f} | {w1:.3f} | {c1:.3f} | {w2:.3f} | "
                 f"{c2:.3f} | {p1 / po1:.2f}, {p2 / po2:.2f} | {c1 / o1:.2f}, {c2 / o2:.2f} |")
    L += ["", "## Level errors at 300 s (RMS over runs)", "",
          "| scheme | " + " | ".join(f"test {t} pitch, roll [arcmin] | test {t} yaw [deg]"
                                     for t in S["final"]) + " |",
          "|---|" + "---|---|" * len(S["final"])]
    for key in _keys():
        cells = []
        for t in S["final"]:
            f = S["final"][t][key]
            cells.append(f"{f['pitch_roll_rms_arcmin'][0]:.2f}, "
                         f"{f['pitch_roll_rms_arcmin'][1]:.2f} | {f['yaw_rms_deg']:.3f}")
        L.append(f"| {_label(key)} | " + " | ".join(cells) + " |")
    figs = ", ".join(f"`test{t}_{v}_errors.png`" for t in S["final"] for v in STATE_SETS)
    L += ["", f"Figures: {figs} (mean and +-1 SD over the runs of the pitch, roll and heading "
          "errors; both `oba` forms in each)."]
    return "\n".join(L) + "\n"


def _circle_figures(results, out: Path) -> None:
    """``circle_success.png`` (success rate against the start heading) and
    ``circle_errors.png`` (|heading error| at 300 s of every run, per scheme)."""
    if not results:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    heads = sorted({r["heading_deg"] for r in results})
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for i, key in enumerate(CIRCLE_KEYS):
        rate = [np.mean([abs(np.asarray(r["yaw"][key])[-1]) < SUCCESS_DEG
                         for r in results if r["heading_deg"] == h]) for h in heads]
        ax.plot(heads, rate, marker="o", lw=1, label=_label(key).replace("`", ""),
                ls="-" if key.endswith("/paper") or key == "oba/paper-form" else "--")
    ax.axvline(PAPER_START_DEG, color="k", lw=0.8, ls=":")
    ax.set_xlabel("truth's start heading [deg] (start error = minus this; dotted: the "
                  "paper's start)")
    ax.set_ylabel(f"success rate (|err| < {SUCCESS_DEG:g} deg at 300 s)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    fig.suptitle(f"paper 001 test {CIRCLE_TEST}: alignment from the whole circle, "
                 f"{len(results)} drives")
    fig.tight_layout()
    fig.savefig(out / "circle_success.png", dpi=90)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for i, key in enumerate(CIRCLE_KEYS):
        a = np.array([abs(np.asarray(r["yaw"][key])[-1]) for r in results])
        jitter = np.linspace(-0.25, 0.25, len(a))
        ax.scatter(i + jitter, np.maximum(a, 1e-3), s=8, alpha=0.6)
    ax.axhline(SUCCESS_DEG, color="k", lw=0.8, ls=":")
    ax.set_yscale("log")
    ax.set_xticks(range(len(CIRCLE_KEYS)))
    ax.set_xticklabels([_label(k).replace("`", "") for k in CIRCLE_KEYS], rotation=30,
                       ha="right", fontsize=7)
    ax.set_ylabel("|heading error| at 300 s [deg]")
    ax.grid(alpha=0.3)
    fig.suptitle(f"paper 001 test {CIRCLE_TEST}, every start heading: error at 300 s")
    fig.tight_layout()
    fig.savefig(out / "circle_errors.png", dpi=90)
    plt.close(fig)


def _figures(results, out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for test in TESTS:
        rs = [r for r in results if r["test"] == test]
        if not rs:
            continue
        for variant in STATE_SETS:
            fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
            keys = [f"{n}/{variant}" for n in SCHEMES if n != "oba"] + ["oba/-",
                                                                         "oba/paper-form"]
            for key in keys:
                name, v = key.split("/")
                E = np.array([np.asarray(r["errors"][key]) for r in rs])     # (runs, t, 3)
                mu, sd = E.mean(0), E.std(0)
                lab = f"{SCHEMES[name]} {name}" + (" paper form" if v == "paper-form" else "")
                for i, ax in enumerate(axes):
                    scale = 60.0 if i < 2 else 1.0
                    line, = ax.plot(GRID_S, mu[:, i] * scale, lw=1, label=lab,
                                    ls="--" if v == "paper-form" else "-")
                    ax.fill_between(GRID_S, (mu[:, i] - sd[:, i]) * scale,
                                    (mu[:, i] + sd[:, i]) * scale, alpha=0.12,
                                    color=line.get_color())
            for ax, lab in zip(axes, ("pitch error [arcmin]", "roll error [arcmin]",
                                      "heading error [deg]")):
                ax.set_ylabel(lab)
                ax.grid(alpha=0.3)
            axes[0].set_ylim(-10, 10)
            axes[1].set_ylim(-10, 10)
            axes[2].set_yscale("symlog", linthresh=0.1)
            axes[2].set_xlabel("time [s]")
            axes[0].legend(fontsize=7, ncol=3)
            what = "our variant, not in the paper" if test == 3 else "paper"
            fig.suptitle(f"paper 001 test {test} ({what}; {variant} states), {len(rs)} runs")
            fig.tight_layout()
            fig.savefig(out / f"test{test}_{variant}_errors.png", dpi=90)
            plt.close(fig)


if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(description=reproduce.__doc__.split("\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--circle-runs", type=int, default=CIRCLE_RUNS)
    ap.add_argument("--k0-runs", type=int, default=K0_TUNING_RUNS)
    ap.add_argument("--reuse-tables", action="store_true")
    a = ap.parse_args()
    from inmotion.reproductions import paper001 as _m   # the workers import it by name
    _m.reproduce(a.out_dir, runs=a.runs, workers=a.workers, seed=a.seed,
              circle_runs=a.circle_runs, k0_runs=a.k0_runs, reuse_tables=a.reuse_tables)
