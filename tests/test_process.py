"""``inmotion process`` and ``sensor: auto`` (issue 14, "One command").

Small simulated drives, each with one kind of velocity sensor (odometer only, LDV only, radar
only) or none, parked first or moving from t = 0, with a navigation-grade IMU (the process
finds the heading) or a MEMS one (it must take the heading from ``--init``). Accuracy is
checked against truth; the bounds are the physics of the drive, stated at each test.
"""
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from inmotion import registry
from inmotion.cli.main import cli
from inmotion.core import earth
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.core.metrics import errors_block, error_series
from inmotion.process import ProcessConfig, heading_observability, run_process
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

LAT = 39.9


def scenario(sensors, parked_s=0.0, speed0=0.0, drift_deg_h=0.005, arw=0.0005, bias_ug=50.0,
             vrw=5.0, name="small", cruise_s=40.0):
    segs = []
    if parked_s > 0:
        segs.append({"kind": "rest", "duration_s": parked_s})
    if speed0 == 0.0:
        segs.append({"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0})
    segs += [{"kind": "cruise", "duration_s": cruise_s},
             {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
             {"kind": "accelerate", "to_speed_m_s": 14.0, "accel_m_s2": 0.5},
             {"kind": "cruise", "duration_s": 30},
             {"kind": "turn", "angle_deg": -60, "rate_deg_s": 4},
             {"kind": "cruise", "duration_s": 20}]
    s = {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0, "scale_factor_sigma_ppm": 2000.0,
                      "lever_arm_m": [-0.8, -1.5, -0.9]},
         "ldv": {"rate_hz": 100.0, "output": "distance", "scale_factor_sigma_ppm": 500.0,
                 "noise_m_s": 0.01, "lever_arm_m": [0.3, 1.2, -0.6]},
         "radar": {"rate_hz": 10.0, "noise_m_s": 0.05, "scale_factor_sigma_ppm": 1000.0},
         "baro": {"rate_hz": 10.0, "noise_m": 0.5}}
    return {"name": name, "start": {"lat_deg": LAT, "lon_deg": 116.4, "h_m": 50.0,
                                    "heading_deg": 60.0, "speed_m_s": speed0},
            "vehicle_mounting_arcmin": [10.0, 0.0, 15.0],
            "segments": segs,
            "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": drift_deg_h, "arw_deg_sqrt_h": arw},
                    "accel": {"bias_ug": bias_ug, "vrw_ug_sqrt_hz": vrw}},
            "sensors": {k: s[k] for k in sensors}}


def bundle(sensors, seed=1, **kw):
    return simulate(load_scenario(scenario(sensors, **kw)), np.random.default_rng(seed))


def final_errors(sol, b):
    e = errors_block(error_series(sol, b.truth))
    f = e["final"]
    return abs(f["yaw_arcmin"]), f["horizontal_m"], e["distance_m"], \
        math.hypot(f["phi_E_arcmin"], f["phi_N_arcmin"])


@pytest.fixture(scope="module")
def od_only():
    return bundle(["odometer"], speed0=10.0, cruise_s=300.0)


@pytest.fixture(scope="module")
def ldv_only():
    return bundle(["ldv", "baro"])


@pytest.fixture(scope="module")
def radar_only():
    return bundle(["radar", "baro"], cruise_s=150.0)


# --------------------------------------------------------------------------- registry

def test_registry_says_what_is_missing_and_what_can_run(od_only):
    assert registry.present_sensors(od_only) == ["odometer"]
    assert registry.missing_sensors("fkf", od_only) == ["ldv"]
    assert registry.missing_sensors("od-kf", od_only) == []
    assert registry.missing_sensors("dr", set()) == ["radar, ldv or odometer"]
    can = registry.runnable(od_only)
    assert {"od-kf", "nhc-kf", "sins-dr", "ausquhe", "fine-mux", "adaptive"} <= set(can)
    assert not {"fkf", "ldv-kf"} & set(can)
    run, Config = registry.get("ldv-kf").load()
    with pytest.raises(BadInput, match=r"ldv-kf needs ldv.*odometer.*can run on it: .*od-kf"):
        run(od_only, Config(), NavState.from_truth(od_only.truth))
    imu_only = type(od_only)(od_only.imu, od_only.meta, truth=od_only.truth)
    assert set(registry.runnable(imu_only)) == {"sins", "parked-kf", "nhc-kf",
                                               "coarse-inertial"}


# --------------------------------------------------------------------------- sensor: auto

@pytest.mark.parametrize("fixture, sensor, fine", [("od_only", "odometer", "od-kf"),
                                                    ("ldv_only", "ldv", "ldv-kf")])
def test_auto_sensor_defaults(request, fixture, sensor, fine):
    """The issue's failures on an odometer-only bundle: ausquhe ('has no velocity sensor
    ldv'), fine-mux and adaptive ('has no ldv (needed by fkf)') now pick what is there and say
    so in info (hence summary.json)."""
    b = request.getfixturevalue(fixture).window(None, 60.0)
    for name in ("ausquhe", "fine-mux", "adaptive"):
        run, Config = registry.get(name).load()
        cfg = Config(update_rate_hz=10.0) if name == "ausquhe" else \
            Config(coarse_window_s=30.0) if name == "fine-mux" else Config(mux={"coarse_window_s": 30.0})
        sol = run(b, cfg, None)
        assert sol.info["sensors_used"] == [sensor], (name, sol.info["sensors_used"])
        assert np.isfinite(sol.euler).all()
        if name != "ausquhe":
            assert sol.info["fine_method"] == fine


def test_auto_sensor_radar_only(radar_only):
    b = radar_only.window(None, 40.0)
    run, Config = registry.get("ausquhe").load()
    sol = run(b, Config(update_rate_hz=10.0), None)
    assert sol.info["sensor"] == "radar" and sol.info["sensors_used"] == ["radar"]
    run, Config = registry.get("fine-mux").load()
    with pytest.raises(BadInput, match="fine-mux needs odometer or ldv.*can run on it"):
        run(b, Config(), None)


# --------------------------------------------------------------------------- process

def _stages(sol):
    return [(s["stage"], s["method"].split()[0]) for s in sol.info["stages"]]


def test_process_odometer_only_moving_from_t0(od_only):
    """Moving at t = 0 (10 m/s from the first sample), no attitude given, 6.6 minutes.
    Heading: gyrocompassing limit drift / (Omega cos L) = 0.005 / (15.04 * 0.77) rad = 1.5'
    1-sigma after convergence (in motion it takes minutes: 25-30' at 4 minutes, 4-5' at 6.6
    minutes on this drive). Position: 4.2 km with an odometer of 2000 ppm scale error,
    estimated: well under 0.5 %."""
    sol = run_process(od_only)
    assert _stages(sol)[1:] == [("moving coarse", "coarse-inertial"),
                                ("fine + navigate", "od-kf")]
    assert sol.info["heading"]["can"] and sol.info["sensors_used"] == ["odometer"]
    yaw, horiz, dist, level = final_errors(sol, od_only)
    assert yaw < 10.0 and level < 1.0, (yaw, level)
    assert horiz < 0.005 * dist, (horiz, dist)


def test_process_takes_noise_from_the_methods_matched_presets(ldv_only):
    """One rule for noise settings (issue 15): process passes the stage's hand-over and the
    user's ``methods`` settings; the method takes the rest from meta.yaml itself, and the
    summary says where each value came from (``info.config_source`` per method)."""
    sol = run_process(ldv_only, {"methods": {"ldv-kf": {"baro_noise_m": 3.0}}})
    src = sol.info["config_source"]["ldv-kf"]
    assert src["gyro_drift_deg_h"] == src["accel_vrw_ug_sqrt_hz"] == "meta.imu (simulated)"
    assert src["ldv_noise_m_s"].startswith("meta.sensors (simulated)")
    assert src["init_heading_sigma_deg"] == "process (stage)"
    assert src["baro_noise_m"] == "config (methods.ldv-kf)"
    fine = [s for s in sol.info["stages"] if s["method"] == "ldv-kf"][0]
    assert fine["config_source"] == src


def test_process_smooth_odometer_only(od_only):
    """``smooth``: the odometer drive through ``od-kf`` with its NHC fallback and FDI (a bank:
    the bank decides, a central filter over the accepted samples is smoothed),
    forward-backward, against the same filter forward only. The heading is at the
    gyrocompassing limit (1.5' here) all along, the backward pass carrying the final heading
    to the start; the position error at its worst point falls to well under half (measured:
    33.3 m forward, 4.8 m smoothed over 4 km; worst heading error 4.5' forward, 4.2'
    smoothed)."""
    fwd = run_process(od_only, ProcessConfig(smooth=True,
                                             methods={"od-kf": {"smooth": False}}))
    smo = run_process(od_only, ProcessConfig(smooth=True))
    assert _stages(smo)[-1] == ("fine + navigate", "od-kf")
    assert _stages(fwd)[-1] == ("fine + navigate", "od-kf")
    assert "smoothed" in smo.info["stages"][-1]["why"]
    t_nav = [s for s in smo.info["stages"] if s["stage"] == "fine + navigate"][0]["start_s"]
    ef, es = error_series(fwd, od_only.truth), error_series(smo, od_only.truth)
    nav_f, nav_s = ef["t"] >= t_nav, es["t"] >= t_nav
    assert es["horizontal_m"][nav_s].max() < 0.5 * ef["horizontal_m"][nav_f].max()
    assert np.abs(es["yaw_arcmin"][nav_s]).max() < 4.5              # 3 x the drift limit
    yaw, horiz, dist, level = final_errors(smo, od_only)
    assert yaw < 10.0 and level < 1.0 and horiz < 0.005 * dist, (yaw, level, horiz)


def test_process_ldv_only_parked_first():
    """Parked 150 s (>= 60 s: parked coarse + parked-kf), then drives: the parked stage
    gyrocompasses (parked-kf's heading sigma ~4' after 150 s) and the LDV filter keeps it."""
    b = bundle(["ldv", "baro"], parked_s=150.0, seed=2)
    sol = run_process(b)
    st = _stages(sol)
    assert st[1:] == [("parked coarse", "coarse-inertial"), ("parked fine", "parked-kf"),
                      ("fine + navigate", "ldv-kf")], st
    assert 149.0 < sol.info["motion"]["t_move"] < 152.0
    yaw, horiz, dist, level = final_errors(sol, b)
    assert yaw < 6.0 and level < 1.0, (yaw, level)
    assert horiz < 0.005 * dist, (horiz, dist)


def test_process_radar_only(radar_only):
    """Radar: in-motion coarse, dr-kf fine alignment until its heading sigma is 10' (at least
    fine_s, shortened to 100 s here), then sins-dr navigation to the end. Heading: 1.5'
    gyrocompass limit, a few arcmin after 4 minutes; position: 3 km with a 1000 ppm radar."""
    sol = run_process(radar_only, ProcessConfig(fine_s=100.0))
    assert [m for _, m in _stages(sol)[1:]] == ["coarse-inertial", "dr-kf", "sins-dr"]
    yaw, horiz, dist, level = final_errors(sol, radar_only)
    assert yaw < 10.0 and level < 2.0, (yaw, level)
    assert horiz < 0.01 * dist, (horiz, dist)


def test_process_mems_takes_the_heading_from_init():
    """A MEMS IMU (100 deg/h drift: gyrocompass sigma ~500 deg) cannot find the heading: without
    init it says so (BadInput); with init the heading comes from it with its sigma, and the
    result's heading sigma covers the error."""
    b = bundle(["odometer"], drift_deg_h=100.0, arw=0.3, bias_ug=2000.0, vrw=100.0,
               speed0=10.0, seed=3)
    h = heading_observability(b, math.radians(LAT), 0.0, None)
    assert not h["can"] and h["sigma_deg"] > 100
    with pytest.raises(BadInput, match="heading cannot be found.*--init"):
        run_process(b)
    init = NavState.from_truth(b.truth)
    sol = run_process(b, None, init, {"source": "truth", "has_attitude": True,
                                      "heading_sigma_deg": 0.1, "tilt_sigma_deg": 0.05})
    assert sol.info["heading"]["source"] == "init (truth)"
    yaw, horiz, dist, level = final_errors(sol, b)
    sig_yaw = math.degrees(sol.sigma["phi_U"][-1]) * 60
    # 100 deg/h (of which the filter learns part) over the drive's 2.8 min: a few deg at most
    assert yaw < 3 * sig_yaw + 5.0, (yaw, sig_yaw)
    assert horiz < 0.05 * dist, (horiz, dist)


def test_parked_gyros_decide_without_a_spec():
    """No IMU spec in meta: the parked Earth-rate check decides (navigation grade passes,
    MEMS fails)."""
    good = bundle(["odometer"], parked_s=40.0, seed=4)
    bad = bundle(["odometer"], parked_s=40.0, drift_deg_h=50.0, arw=0.2, seed=4)
    for b, can in ((good, True), (bad, False)):
        b.meta.pop("imu", None)
        h = heading_observability(b, math.radians(LAT), float(b.imu.t[0]), 39.0)
        assert h["from"] == "parked gyros" and h["can"] is can, h


# --------------------------------------------------------------------------- CLI

def test_cli_process_writes_one_result_with_its_log(od_only, tmp_path):
    from inmotion.io.bundle import write_bundle
    write_bundle(od_only, tmp_path / "b")
    r = CliRunner().invoke(cli, ["-q", "--json", "process", str(tmp_path / "b"), "-o",
                                 str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["method"] == "process" and s["stages"][0]["stage"] == "detect"
    assert "<h3>Stages</h3>" in (tmp_path / "r" / "report.html").read_text()
    assert (tmp_path / "r" / "errors.csv").is_file()
    disk = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert disk["info"]["heading"]["can"] and disk["info"]["sensors_used"] == ["odometer"]
    r = CliRunner().invoke(cli, ["-q", "--json", "process", str(tmp_path / "b"), "-o",
                                 str(tmp_path / "r2"), "--smooth"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    nav = [e for e in s["stages"] if e["stage"] == "fine + navigate"][-1]
    assert nav["method"] == "od-kf" and "smoothed" in nav["why"]
    assert nav["smoothing"]["isolated_s"] == {"odometer": []}


# --------------------------------------------------------------------------- real logs

def _real_root():
    from inmotion.reproductions.real import default_data_root
    return default_data_root()


#: (importer, path under the data folder, --init, bound on the final horizontal error in % of
#: the distance): the phone (comma2k19, CAN speed) and EMS (no speed sensor: NHC only, the
#: still start's gyro bias removed) MEMS take their heading from the reference; the PSINS MEMS
#: log has no speed sensor and moves from t = 0 (NHC alone over 100 s); the parked ring-laser
#: gyro log finds its own heading
REAL_LOGS = [("comma2k19", "comma2k19_rav4_60s", "truth", 6.0),
             ("ems", "ems_toronto_511s/ems_data_for_lc.mat", "truth", 6.0),
             ("psins", "psins_fog_mems_moving_100s/transfer_align_fog_mems.mat", "truth", 15.0),
             ("psins", "psins_rlg_parked_1847s/lasergyro.imu", None, None)]


@pytest.mark.slow
@pytest.mark.parametrize("fmt, path, init, pct", REAL_LOGS)
def test_process_on_real_logs(tmp_path, fmt, path, init, pct):
    src = _real_root() / path
    if not src.exists():
        pytest.skip(f"real data not found: {src}")
    run = lambda *a: CliRunner().invoke(cli, ["-q", *map(str, a)])  # noqa: E731
    r = run("import", fmt, src, "-o", tmp_path / "b")
    assert r.exit_code == 0, r.output
    args = ["--json", "process", tmp_path / "b", "-o", tmp_path / "r", "--no-report"]
    if init is None:
        r = run(*args)
    else:
        r = run(*args)                       # a MEMS: no heading without --init
        assert r.exit_code == 2 and "--init" in r.stderr, r.stderr
        r = run(*args, "--init", init)
    assert r.exit_code == 0, (r.output, r.stderr)
    s = json.loads(r.stdout)
    assert all(np.isfinite(v) for v in s["final"].values() if isinstance(v, float))
    if pct is not None:
        e = s["errors"]
        assert s["info"]["heading"]["source"].startswith("init")
        assert e["final"]["horizontal_m"] < pct / 100 * e["distance_m"], e["final"]
    else:                                    # parked RLG: gyrocompassed, near the header's
        assert s["info"]["heading"]["can"]   # 90.6 deg ("maybe inaccurate")
        assert abs(s["final"]["yaw_deg"] - 90.6) < 1.0, s["final"]


def _stop_and_go(seed, segments_only=False, **kw):
    """A drive that stops twice (30 s, 40 s) between legs, a turn between the stops."""
    d = scenario(["odometer"], speed0=10.0, **kw)
    d["segments"] = [{"kind": "cruise", "duration_s": 60},
                     {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 30},
                     {"kind": "accelerate", "to_speed_m_s": 12.0, "accel_m_s2": 1.0},
                     {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                     {"kind": "cruise", "duration_s": 40},
                     {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 40},
                     {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                     {"kind": "cruise", "duration_s": 60}]
    if segments_only:
        return d["segments"]
    return simulate(load_scenario(d), np.random.default_rng(seed))


def _nav_errors(sol, truth):
    k = np.searchsorted(truth.t, sol.t)
    r_m, r_n = earth.radii(truth.lat[k])
    dp = np.column_stack([(sol.lat - truth.lat[k]) * r_m,
                          (sol.lon - truth.lon[k]) * r_n * np.cos(truth.lat[k])])
    dv = sol.vel_n[:, :2] - truth.vel_n[k, :2]
    sp = np.column_stack([sol.sigma["north"], sol.sigma["east"]])
    sv = np.column_stack([sol.sigma["vE"], sol.sigma["vN"]])
    stopped = np.linalg.norm(truth.vel_n[k], axis=1) < 1e-3
    return dp, dv, sp, sv, stopped


@pytest.mark.parametrize("smooth", [False, True])
def test_process_zero_velocity_updates_at_stops(smooth):
    """Stop-and-go with an odometer and a MEMS IMU (100 deg/h drift, heading from init), two
    seeds: process finds both stops (truth: ~71-102 s and ~190-231 s), logs them, and its
    zero-velocity and zero-rate updates there (forward and smoothed) cut the horizontal
    position error and the velocity error at the stops against truth, the sigma covering the
    errors; without stops (zupt off) the same run drifts."""
    ii = {"source": "truth", "has_attitude": True, "heading_sigma_deg": 0.1,
          "tilt_sigma_deg": 0.05}
    for seed in (0, 1):
        b = _stop_and_go(seed, drift_deg_h=100.0, arw=0.3, bias_ug=2000.0, vrw=100.0)
        init = NavState.from_truth(b.truth)
        res = {}
        for zupt in (False, True):
            sol = run_process(b, {"zupt": zupt, "smooth": smooth}, init, ii)
            res[zupt] = (sol, _nav_errors(sol, b.truth))
        sol, (dp, dv, sp, sv, stopped) = res[True]
        st = [s for s in sol.info["stages"] if s["stage"] == "stops"]
        assert len(st) == 1 and len(st[0]["stops_s"]) == 2, st
        (a1, b1), (a2, b2) = st[0]["stops_s"]
        assert 70 < a1 < 73 and 100 < b1 < 103 and 188 < a2 < 192 and 228 < b2 < 232
        k = np.searchsorted(b.truth.t, sol.t)
        assert np.all(np.linalg.norm(b.truth.vel_n[k][(sol.t >= a1) & (sol.t <= b1)], axis=1)
                      < 1e-3)
        _, (dp0, dv0, _, _, _) = res[False]
        hor, hor0 = np.hypot(*dp.T), np.hypot(*dp0.T)
        # the run without stops is the reference; with the length row, the odometer's
        # quantization at interval ends and the matched presets (issue 15) it drifts far less
        # than it did (seed 1: 37.9 m at the end before, 8.9 m now), and its error is not
        # monotone (seed 1 passes 0.3 m at 150 s), so its largest error (reached before the
        # first stop on seed 1, where both runs are the same) is no reference. Measured at the
        # end, forward / smoothed: seed 0 6.1 / 18.4 and 6.1 / 18.6 m, seed 1 3.1 / 9.0 and
        # 3.1 / 9.2 m (ratios 0.33-0.35); before these changes 0.11-0.2. With the displacement
        # rows in the frame of the sensor's displacement (aided_kf._rows_to_displacement_frame,
        # issue 15) the runs with stops are unchanged (seed 0 6.10 / 6.10 m, seed 1 3.14 /
        # 3.11 m) and seed 1's run without them drifts less again (5.42 / 5.63 m against 8.98
        # / 9.17; seed 0 18.50 / 18.65): ratios 0.33 and 0.55-0.58
        assert hor[-1] < 0.65 * hor0[-1], (seed, hor[-1], hor0[-1])
        assert (np.abs(dv[stopped]).max() < np.abs(dv0[stopped]).max()
                and np.abs(dv[stopped]).max() < 0.03)
        assert np.all(np.abs(dv[1:]) <= 4 * sv[1:]) and np.all(np.abs(dp) <= 4 * sp), seed


def test_radar_filters_take_zero_velocity_updates_at_stops():
    """The radar path (dr-kf; sins-dr shares the run): with the stop windows (the truth's
    stops, 1 s margins) the velocity error inside the stops against truth falls on average over
    3 seeds (the radar already reads zero there, so the gain is the tighter noise), every
    sigma still covers its error, and the updates are counted."""
    from inmotion.align.dr_kalman import DrKfConfig, run_dr_kf
    imu = {"gyro_drift_deg_h": 1.0, "accel_bias_ug": 300.0, "gyro_arw_deg_sqrt_h": 0.05,
           "accel_vrw_ug_sqrt_hz": 30.0}
    worst = {False: [], True: []}
    for seed in (0, 1, 2):
        d = scenario(["radar"], speed0=10.0, drift_deg_h=1.0, arw=0.05, bias_ug=300.0, vrw=30.0)
        d["segments"] = _stop_and_go(seed, segments_only=True)
        b = simulate(load_scenario(d), np.random.default_rng(seed))
        still = np.flatnonzero(np.linalg.norm(b.truth.vel_n, axis=1) < 1e-3)
        cut = np.flatnonzero(np.diff(still) > 1)
        wins = [[float(b.truth.t[i]) + 1.0, float(b.truth.t[j]) - 1.0]
                for i, j in zip(np.r_[still[0], still[cut + 1]], np.r_[still[cut], still[-1]])]
        assert len(wins) == 2, wins
        for use in (False, True):
            sol = run_dr_kf(b, {**imu, "stops_s": wins if use else []}, NavState.from_truth(b.truth))
            dp, dv, sp, sv, _ = _nav_errors(sol, b.truth)
            inside = np.any([(sol.t >= a) & (sol.t <= e) for a, e in wins], axis=0)
            worst[use].append(np.abs(dv[inside]).max())
            assert np.all(np.abs(dv[1:]) <= 4 * sv[1:]) and np.all(np.abs(dp) <= 4 * sp), seed
            n = sol.info["measurements_used"].get("zero velocity", 0)
            rate = DrKfConfig().measurement_rate_hz      # one update per measurement epoch inside
            most = sum(e - a for a, e in wins) * rate + len(wins)
            assert (0.9 * (most - 2 * len(wins)) <= n <= most) if use else n == 0, (n, most)
    assert np.mean(worst[True]) < 0.8 * np.mean(worst[False]), worst


def test_process_finds_the_stops_of_a_radar_drive_and_updates_at_them():
    """With a radar (noisier at a standstill than an odometer, so its zero-speed runs start
    while the vehicle still brakes) process still finds both stops, cut to where the IMU is
    still (truth: 71.7-102.3 s, 189.7-230.3 s), and its zero-velocity updates lower the
    velocity error at the stops against truth (3 seeds), sigma covering the errors."""
    ii = {"source": "truth", "has_attitude": True, "heading_sigma_deg": 0.1,
          "tilt_sigma_deg": 0.05}
    for seed in (0, 1, 2):
        d = scenario(["radar"], speed0=10.0, drift_deg_h=1.0, arw=0.05, bias_ug=300.0, vrw=30.0)
        d["segments"] = _stop_and_go(seed, segments_only=True)
        b = simulate(load_scenario(d), np.random.default_rng(seed))
        init = NavState.from_truth(b.truth)
        res = {z: run_process(b, {"zupt": z}, init, ii) for z in (False, True)}
        st = [s for s in res[True].info["stages"] if s["stage"] == "stops"]
        assert len(st) == 1 and len(st[0]["stops_s"]) == 2, st
        for (a, e), (ta, te) in zip(st[0]["stops_s"], [(71.7, 102.3), (189.7, 230.3)]):
            assert ta - 0.5 < a < ta + 2.0 and te - 2.0 < e < te + 0.5, st
        (_, dv, _, sv, stopped), (_, dv0, _, _, _) = (_nav_errors(res[z], b.truth)
                                                      for z in (True, False))
        assert np.abs(dv[stopped]).max() < 0.6 * np.abs(dv0[stopped]).max(), seed
        assert np.all(np.abs(dv[1:]) <= 4 * sv[1:]), seed


def test_stop_windows_refuse_a_zero_speed_the_imu_does_not_confirm():
    """An odometer reading zero during a turn (scale fault -100 %) is a zero speed the IMU
    does not confirm: no stop is declared there; the real stop is found."""
    from inmotion.process import stop_windows
    d = scenario(["odometer"], speed0=10.0)
    d["segments"] = [{"kind": "cruise", "duration_s": 30}, {"kind": "stop", "decel_m_s2": 1.0},
                     {"kind": "wait", "duration_s": 20},
                     {"kind": "accelerate", "to_speed_m_s": 10.0, "accel_m_s2": 1.0},
                     {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                     {"kind": "cruise", "duration_s": 40}]
    d["faults"] = [{"sensor": "odometer", "kind": "scale", "start_s": 75.0, "end_s": 87.0,
                    "scale_ppm": -1e6}]
    b = simulate(load_scenario(d), np.random.default_rng(0))
    stops, why = stop_windows(b, ProcessConfig(), 0.0)
    assert len(stops) == 1 and 40 < stops[0][0] < 43 and 60 < stops[0][1] < 63, stops
    assert "refused" in why


@pytest.mark.parametrize("method", ["dr-kf", "sins-dr", "od-kf"])
@pytest.mark.parametrize("stops, message", [
    ([[10.0]], r"stops_s: each stop is \[start, end\] seconds$"),
    ([[20.0, 10.0]], r"stops_s: each stop is \[start, end\] seconds with end >= start"),
    ([[10.0, float("nan")]], r"stops_s: each stop is \[start, end\] seconds with end >= start"),
])
def test_bad_stop_windows_are_bad_input(od_only, radar_only, method, stops, message):
    """Every filter that takes stop windows refuses a malformed one with one message."""
    from inmotion import registry
    from inmotion.errors import BadInput
    b = radar_only if method in ("dr-kf", "sins-dr") else od_only
    run, cls = registry.get(method).load()
    with pytest.raises(BadInput, match=message):
        run(b, cls(stops_s=stops), NavState.from_truth(b.truth))
