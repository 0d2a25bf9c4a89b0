"""Small Monte Carlo of a method's final-attitude NEES (issue 15), shared by the
``test_consistency_*`` files.

Each run draws its own IMU constant errors (``constant_errors: random``, the scenario's figures
as 1-sigma) and sensor errors, and starts the method with an attitude error drawn from the
prior the configuration states; the final misalignment ``phi`` against truth, over the
method's final 1-sigma, gives ``NEES = sum_i (phi_i / sigma_i)^2``. For ``R`` independent runs
of a consistent filter the sum is chi-square with ``3 R`` degrees of freedom, so the mean
lies in ``[isf(0.975, 3R), isf(0.025, 3R)] / R`` with probability 0.95 (the diagonal NEES:
cross-covariances are not in the solution; for a consistent filter its mean is still 3).
"""
import copy

import numpy as np
import yaml

from inmotion import registry
from inmotion.core.metrics import error_series
from inmotion.core.solution import NavState
from inmotion.estimation import chi2
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

ARCMIN = 180.0 / np.pi * 60.0
#: the simulated IMU of paper 003's scenarios, as configuration fields
IMU_003 = dict(gyro_drift_deg_h=0.005, gyro_arw_deg_sqrt_h=0.0005, accel_bias_ug=50.0,
               accel_vrw_ug_sqrt_hz=5.0)


def drive_003():
    """Paper 003's drive cut to 85 s: cruise, accelerate, a 60 deg turn at 4 deg/s, cruise."""
    d = yaml.safe_load(open(find_scenario("paper003_drive")).read())
    d["segments"] = [{"kind": "cruise", "duration_s": 20},
                     {"kind": "accelerate", "to_speed_m_s": 14, "accel_m_s2": 0.5},
                     {"kind": "turn", "angle_deg": 60, "rate_deg_s": 4},
                     {"kind": "cruise", "duration_s": 40}]
    d["imu"]["constant_errors"] = "random"
    return load_scenario(d)


def drive_003_start():
    """Paper 003's 10-minute drive's first 194 s (cruise, accelerate, cruise, a 90 deg turn,
    cruise), constant errors drawn."""
    d = yaml.safe_load(open(find_scenario("paper003_drive")).read())
    d["segments"] = d["segments"][:5]
    d["imu"]["constant_errors"] = "random"
    return load_scenario(d)


def parked_003(duration_s=120.0):
    """Paper 003's parked start (engine vibration, rocking), parked for ``duration_s``."""
    d = yaml.safe_load(open(find_scenario("paper003_parked_then_drive")).read())
    d["segments"] = [{"kind": "rest", "duration_s": duration_s}]
    for v in d["disturbances"]["vibration"]:
        v["end_s"] = min(v["end_s"], duration_s)
    d["imu"]["constant_errors"] = "random"
    return load_scenario(d)


def city_scenario(gyro_deg_h=300.0, gm_deg_h=150.0, tau_s=60.0, rate_hz=20.0) -> dict:
    """An EMS-like city drive as a scenario dict (issue 15, session 23; ``benchmarks/nees_invariant.py``): 325 s, four 90 deg turns, 5-14 m/s; IMU at ``rate_hz``
with a gyro bias of a random constant (1-sigma ``gyro_deg_h`` per axis) plus a Gauss-Markov
wander (``gm_deg_h``, ``tau_s``), accelerometer bias 20 mg, ARW 1 deg/sqrt(h), VRW 500
ug/sqrt(Hz)."""
    turn = {"kind": "turn", "angle_deg": 90, "rate_deg_s": 10}
    segs = [{"kind": "accelerate", "to_speed_m_s": 12.0, "accel_m_s2": 1.0},
            {"kind": "cruise", "duration_s": 30}, turn,
            {"kind": "cruise", "duration_s": 40},
            {"kind": "decelerate", "to_speed_m_s": 5.0, "decel_m_s2": 1.5},
            {**turn, "angle_deg": -90},
            {"kind": "accelerate", "to_speed_m_s": 14.0, "accel_m_s2": 1.0},
            {"kind": "cruise", "duration_s": 60}, {**turn, "rate_deg_s": 8},
            {"kind": "cruise", "duration_s": 60}, {**turn, "rate_deg_s": 8},
            {"kind": "cruise", "duration_s": 60}]
    return {"name": "city_mems", "description": "EMS-like city drive (nees_invariant.py)",
            "start": {"lat_deg": 43.7, "lon_deg": -79.4, "h_m": 100.0, "heading_deg": 30.0,
                      "speed_m_s": 5.0},
            "segments": segs,
            "imu": {"rate_hz": rate_hz, "constant_errors": "random",
                    "gyro": {"drift_deg_h": gyro_deg_h, "arw_deg_sqrt_h": 1.0,
                             "drift_markov_deg_h": gm_deg_h, "drift_markov_tau_s": tau_s},
                    "accel": {"bias_ug": 20000.0, "vrw_ug_sqrt_hz": 500.0}},
            "sensors": {"odometer": {"rate_hz": rate_hz, "pulses_per_m": 1000.0}}}


def turned_start(truth, psi_rad: float) -> NavState:
    """The truth's first state with attitude and velocity turned by ``psi_rad`` about the
    vertical (DESIGN: ENU, heading clockwise from north, so the velocity turns by ``-psi``
    about up as the heading grows by ``psi``)."""
    init = NavState.from_truth(truth, euler_error=np.array([0.0, 0.0, psi_rad]))
    c, s = np.cos(psi_rad), np.sin(psi_rad)
    init.vel_n = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) @ init.vel_n
    return init


def drawn_truth(sc, mode, rng, Config, config: dict):
    """``(bundle, config)`` of one run of the scenario ``sc`` whose truth is drawn from the
    filter's priors as its start error is (issue 15, session 16): ``mode`` ``True`` draws the
    vehicle mounting's pitch and yaw from ``N(0, mount_sigma_arcmin)`` and offsets the lever
    arms written in ``meta`` from the true ones by ``N(0, lever_sigma_m)`` per axis (the
    configuration's values, else its defaults); ``"mount"`` / ``"lever"``: that part alone
    (the other as the scenario has it); ``"control"``: neither, with the same random streams
    (a run differs from the draws' only by what they draw; the plain :func:`simulate` of the
    scenario draws the drive from another stream). The scale priors ``od_scale_sigma_ppm`` /
    ``ldv_scale_sigma_ppm`` are set to the simulated sensors' spreads unless ``config`` gives
    them. A scenario's fixed mounting inside a wider prior, exact lever arms and a scale
    spread below its prior make a consistent filter look conservative (od-kf's 0.80 on the
    194 s drive, 1.55 with the truth drawn: ``benchmarks/nees_drive_start.py``). The draws,
    in this order: the mounting, the drive, the lever arms."""
    from inmotion.align.aided_kf import AidedKfConfig
    defaults = Config()
    if not hasattr(defaults, "mount_sigma_arcmin"):    # a two-stage method: its fine filter's
        defaults = AidedKfConfig()
    mount = float(config.get("mount_sigma_arcmin", defaults.mount_sigma_arcmin))
    lever = float(config.get("lever_sigma_m", defaults.lever_sigma_m))
    drawn = [mount * rng.standard_normal(), 0.0, mount * rng.standard_normal()]
    if mode in ("lever", "control"):     # the lever arms only / nothing
        drawn = list(sc.vehicle_mounting_arcmin)
    if mode in ("mount", "control"):     # the mounting only / nothing
        lever = 0.0
    b = simulate(sc.model_copy(update={"vehicle_mounting_arcmin": drawn}), rng)
    b.meta = copy.deepcopy(b.meta)
    for name, arm in b.meta.get("lever_arms_m", {}).items():
        b.meta["lever_arms_m"][name] = list(np.asarray(arm, float)
                                            + lever * rng.standard_normal(3))
    cfg = dict(config)
    target = cfg               # where the method takes the fine filter's settings
    if "od_scale_sigma_ppm" not in Config.model_fields:
        if "fine" in Config.model_fields:                  # fine-mux
            target = cfg["fine"] = dict(cfg.get("fine", {}))
        elif "mux" in Config.model_fields:                 # adaptive
            cfg["mux"] = dict(cfg.get("mux", {}))
            target = cfg["mux"]["fine"] = dict(cfg["mux"].get("fine", {}))
    for short, name in (("od", "odometer"), ("ldv", "ldv")):
        target.setdefault(f"{short}_scale_sigma_ppm",
                          float(getattr(sc.sensors, name).scale_factor_sigma_ppm))
    return b, cfg


def sign_flipped_headings(method, config, scenario, seed, start_sigma_deg):
    """``(start_heading, [(error, sigma) as drawn, (error, sigma) with the start heading's sign
    flipped])`` [arcmin] of the final heading, one run of ``method`` on :func:`drawn_truth`'s
    truth (seed ``seed``), the flipped run otherwise the same (drive, sensors, draws, tilt
    errors). A linear filter's sigma would not depend on the sign
    (``benchmarks/heading_sign.py``, issue 15 session 17)."""
    run, Config = registry.get(method).load()
    rng = np.random.default_rng(seed)
    b, cfg = drawn_truth(scenario, True, rng, Config, dict(config))
    err = np.radians(np.asarray(start_sigma_deg, float)) * rng.standard_normal(3)
    out = []
    for sign in (1.0, -1.0):
        e = err * np.array([1.0, 1.0, sign])
        sol = run(b, Config(**cfg), NavState.from_truth(b.truth, euler_error=e))
        phi = error_series(sol, b.truth)["phi_U_arcmin"].to_numpy()[-1]
        out.append((float(phi), float(sol.sigma["phi_U"][-1] * ARCMIN)))
    return float(err[2] * ARCMIN), out


def final_nees(method, config, scenario, runs, start_sigma_deg, seed0=100,
               velocity_sigma_m_s=0.0, prior_drawn=False):
    """``(mean, (lo, hi), per_run)``: the final-attitude NEES over ``runs`` runs and the 95 %
    band of its mean (module docstring); ``start_sigma_deg`` = 1-sigma of the drawn start
    error [pitch, roll, yaw] [deg]; ``velocity_sigma_m_s``: 1-sigma of a start velocity error
    drawn per axis too (0: the true velocity), for a method whose prior states one that its
    measurements observe together with the attitude (velocity matching); ``prior_drawn``:
    the mounting and lever arms drawn from the priors too (:func:`drawn_truth`'s ``mode``)."""
    run, Config = registry.get(method).load()
    vals = []
    for k in range(runs):
        rng = np.random.default_rng(seed0 + k)
        cfg = dict(config)
        if prior_drawn:
            b, cfg = drawn_truth(scenario, prior_drawn, rng, Config, cfg)
        else:
            b = simulate(scenario, rng)
        err = np.radians(np.asarray(start_sigma_deg, float)) * rng.standard_normal(3)
        init = NavState.from_truth(b.truth, euler_error=err)
        if velocity_sigma_m_s:
            init.vel_n = init.vel_n + velocity_sigma_m_s * rng.standard_normal(3)
        sol = run(b, Config(**cfg), init)
        e = error_series(sol, b.truth)
        phi = e[["phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin"]].to_numpy()[-1] / ARCMIN
        sig = np.array([sol.sigma[c][-1] for c in ("phi_E", "phi_N", "phi_U")])
        vals.append(float(np.sum((phi / sig) ** 2)))
    vals = np.array(vals)
    lo, hi = chi2.isf(0.975, 3 * runs) / runs, chi2.isf(0.025, 3 * runs) / runs
    return float(vals.mean()), (float(lo), float(hi)), vals


def pooled_fkf_nis(config: dict, runs: int, seed0: int, velocity_sigma_m_s: float = 0.0):
    """``fkf`` (detection off) over ``runs`` drives of paper 003's scenario, seeds ``seed0 ..``,
    started from truth turned by an attitude error drawn from the prior (0.1, 0.1, 0.5 deg)
    and, with ``velocity_sigma_m_s``, a velocity error drawn per axis (the prior's
    ``init_velocity_sigma_m_s`` set to it; 0: the true velocity, the prior fkf's default):
    ``({channel: NIS per degree of freedom pooled over the runs}, the last bundle)``."""
    from inmotion.align import aided_kf as ak
    sc = drive_003()
    sums = {"odometer": [0.0, 0], "ldv": [0.0, 0]}
    b = None
    for k in range(runs):
        rng = np.random.default_rng(seed0 + k)
        b = simulate(sc, rng)
        init = NavState.from_truth(b.truth, euler_error=np.radians([0.1, 0.1, 0.5])
                                   * rng.standard_normal(3))
        vel = {}
        if velocity_sigma_m_s:
            init.vel_n = init.vel_n + velocity_sigma_m_s * rng.standard_normal(3)
            vel = {"init_velocity_sigma_m_s": velocity_sigma_m_s}
        sol = ak.run_fkf(b, {"fdi": False, "init_tilt_sigma_deg": 0.1,
                             "init_heading_sigma_deg": 0.5, **vel, **config}, init)
        for ch in sums:
            n = sol.info["nis"][ch]
            sums[ch][0] += n["mean_per_dof"] * n["dof"]
            sums[ch][1] += n["dof"]
    return {ch: s / d for ch, (s, d) in sums.items()}, b
