"""PSINS logs (issue 15): the importer on synthetic files and on the two real logs, and every
parked method on the real ring-laser-gyro log against the theory limits.

The real logs are found like the other real-drive tests (``../shared/data/real`` from the
repository root; ``$INMOTION_REAL_DATA`` overrides it, e.g. in a git worktree); the tests that
need them are skipped with the path when the folder is absent.
"""
import os
from pathlib import Path

import numpy as np
import pytest

from inmotion import registry
from inmotion.core import earth, rotations
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.reproductions import psins as rp
from inmotion.io.importers import import_log
from inmotion.io.importers.psins import (ARCSEC, design_euler_from_psins,
                                         psins_from_design_euler)

REAL = Path(os.environ.get("INMOTION_REAL_DATA")
            or Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real")
RLG = REAL / "psins_rlg_parked_1847s" / "lasergyro.imu"
MEMS = REAL / "psins_fog_mems_moving_100s" / "transfer_align_fog_mems.mat"
needs_rlg = pytest.mark.skipif(not RLG.is_file(), reason=f"real PSINS RLG log not found at {RLG}")
needs_mems = pytest.mark.skipif(not MEMS.is_file(),
                                reason=f"real PSINS MEMS log not found at {MEMS}")
D = np.pi / 180.0
ARCMIN = D / 60.0


# ----------------------------------------------------------------------------- conventions
def test_psins_yaw_is_counter_clockwise_and_converts_through_the_dcm():
    rng = np.random.default_rng(0)
    e_psins = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-2, 2, 50),
                               rng.uniform(-np.pi, np.pi, 50)])
    ours = design_euler_from_psins(e_psins)
    np.testing.assert_allclose(ours[:, :2], e_psins[:, :2], atol=1e-12)
    np.testing.assert_allclose(rotations.wrap_pi(ours[:, 2] + e_psins[:, 2]), 0.0, atol=1e-12)
    np.testing.assert_allclose(psins_from_design_euler(ours), e_psins, atol=1e-12)
    # the header yaw of lasergyro.imu: -90.6 deg in PSINS is 90.6 deg clockwise
    assert np.degrees(design_euler_from_psins([0.0, 0.0, np.radians(-90.6)])[0, 2]) == \
        pytest.approx(90.6)


def _write_imu(path, rows, header=None):
    header = header or ["0 0 -90.6 0 0 0", "34.0 108.0 400.0 10.0 10.0 9.78",
                        "0.1 0.1 0.1 125 125 125"]
    text = ["% PSINS-format SIMU log file.", "% comment", ""] + header + \
        [" ".join(str(x) for x in r) for r in rows]
    path.write_text("\n".join(text) + "\n")
    return path


def test_imu_text_counts_times_and_meta(tmp_path):
    rows = np.array([[1, -2, 3, 0, 1, 80], [0, 0, 7, -1, 0, 80], [2, 9, -4, 0, 3, 79],
                     [0, 0, 0, 0, 0, 81]])
    b = import_log("psins", _write_imu(tmp_path / "x.imu", rows.tolist()))
    np.testing.assert_allclose(b.imu.t, 10.0 + 0.01 * np.arange(1, 5))
    np.testing.assert_allclose(b.imu.dtheta, rows[:, :3] * 0.1 * ARCSEC, rtol=1e-15)
    np.testing.assert_allclose(b.imu.dvel, rows[:, 3:] * 125e-6 * 9.78, rtol=1e-15)
    m = b.meta
    assert m["initial_position"] == {"lat_deg": 34.0, "lon_deg": 108.0, "h_m": 400.0}
    assert m["initial_velocity"] == {"vE_m_s": 0.0, "vN_m_s": 0.0, "vU_m_s": 0.0}
    assert m["initial_attitude"]["yaw_deg"] == pytest.approx(90.6)
    assert "maybe inaccurate" in m["initial_attitude_note"]
    assert m["imu"]["source"] == "documented" and m["imu"]["gyro"]["drift_deg_h"] == 0.03
    assert m["imu_axes"]["source"] == ["right", "forward", "up"] and b.truth is None


def test_imu_text_bad_input(tmp_path):
    with pytest.raises(BadInput, match="6 columns"):
        import_log("psins", _write_imu(tmp_path / "a.imu", [[1, 2, 3, 4, 5]] * 3,
                                       header=["1 2 3 4 5"] * 3))
    with pytest.raises(BadInput, match="header rows"):
        import_log("psins", _write_imu(tmp_path / "b.imu", [[0] * 6] * 3,
                                       header=["0 0 0 0 0 0", "34 108 400 0 10 0.0",
                                               "0.1 0.1 0.1 125 125 125"]))
    with pytest.raises(BadInput, match="not found"):
        import_log("psins", tmp_path / "none.imu")
    with pytest.raises(BadInput, match="not a readable MATLAB"):
        (tmp_path / "c.mat").write_text("nope")
        import_log("psins", tmp_path / "c.mat")


# ----------------------------------------------------------------------------- real logs
@needs_rlg
def test_real_rlg_imports_with_earth_rate_and_gravity(tmp_path):
    from inmotion.io.bundle import read_bundle, write_bundle

    b = import_log("psins", RLG)
    assert len(b.imu.t) == 184718 and b.imu.dt == pytest.approx(0.01)
    T = b.imu.t[-1] - b.imu.t[0] + b.imu.dt
    lat = np.radians(b.meta["initial_position"]["lat_deg"])
    # a parked navigation-grade IMU: the mean specific force is g (to 5 ug here), the mean rate
    # along it the Earth rate's vertical part; the horizontal part also holds the base's slow
    # tilt change (pitch 0.8 -> 1.0 deg over the log, about 0.2 deg/h)
    f = b.imu.dvel.sum(axis=0) / T
    assert np.linalg.norm(f) == pytest.approx(earth.gravity(lat, 380.0), abs=50e-6 * earth.G0)
    w, u = b.imu.dtheta.sum(axis=0) / T, f / np.linalg.norm(f)
    deg_h = D / 3600.0
    assert w @ u == pytest.approx(earth.OMEGA_IE * np.sin(lat), abs=0.05 * deg_h)
    assert np.linalg.norm(w - (w @ u) * u) == pytest.approx(earth.OMEGA_IE * np.cos(lat),
                                                            abs=0.5 * deg_h)
    back = read_bundle(write_bundle(b, tmp_path / "rlg", "parquet"))
    np.testing.assert_array_equal(back.imu.dtheta, b.imu.dtheta)
    assert back.meta["initial_position"]["lat_deg"] == pytest.approx(34.246048)


def _rates(b):
    """Mean body rates over each reference interval from the IMU and from the reference."""
    imu, tr = b.imu, b.truth
    t_cum = np.concatenate([[imu.t[0] - imu.dt], imu.t])
    cum = np.vstack([np.zeros(3), np.cumsum(imu.dtheta, axis=0)])
    theta = np.column_stack([np.interp(tr.t, t_cum, cum[:, j]) for j in range(3)])
    w_imu = np.diff(theta, axis=0) / np.diff(tr.t)[:, None]
    C = tr.C_nb
    w_ref = rotations.rotvec_from_dcm(np.einsum("kji,kjl->kil", C[:-1], C[1:])) \
        / np.diff(tr.t)[:, None]
    return w_imu, w_ref


def _mounting_residual(b):
    """Least squares ``w_imu = w_ref + bias - mu x w_ref``: ``(bias, mu)`` [rad/s, rad]."""
    w_imu, w_ref = _rates(b)
    A = np.vstack([np.hstack([np.eye(3), rotations.skew(w)]) for w in w_ref])
    x = np.linalg.lstsq(A, (w_imu - w_ref).ravel(), rcond=None)[0]
    return x[:3], x[3:]


@needs_mems
def test_real_mems_imports_with_fog_reference_in_our_conventions():
    b = import_log("psins", MEMS)
    assert len(b.imu.t) == 10001 and len(b.truth.t) == 1000
    assert np.median(np.diff(b.truth.t)) == pytest.approx(0.1)      # truth at 10 Hz
    w_imu, w_ref = _rates(b)
    for j in range(3):                                  # axes: MEMS rates follow the FOG's
        assert np.corrcoef(w_imu[:, j], w_ref[:, j])[0, 1] > 0.97
        assert np.polyfit(w_ref[:, j], w_imu[:, j], 1)[0] == pytest.approx(1.0, abs=0.05)
    bias, mu = _mounting_residual(b)
    # the gyro bias the rates show is the author's eb0 (up to 200 deg/h)
    np.testing.assert_allclose(np.degrees(bias) * 3600, [-214, 159, 84], atol=15)
    # mu0 applied with the right sign: the residual mounting about x and z shrinks
    _, mu_none = _mounting_residual(import_log("psins", MEMS, mounting="none"))
    assert abs(mu[0]) < abs(mu_none[0]) / 3 and abs(mu[2]) < abs(mu_none[2]) / 2
    # yaw clockwise: it follows the course (constant few-degree offset, README) to 0.3 deg,
    # where PSINS's counter-clockwise yaw would scatter by 1.3 deg
    tr = b.truth
    course = np.arctan2(tr.vel_n[:, 0], tr.vel_n[:, 1])
    assert np.degrees(rotations.wrap_pi(course - tr.euler[:, 2])).std() < 0.3
    assert np.degrees(rotations.wrap_pi(course + tr.euler[:, 2])).std() > 1.0


@needs_mems
def test_real_mems_evaluates_against_the_10hz_truth(tmp_path):
    from inmotion.core.metrics import error_series
    from inmotion.navigate.pure import SinsConfig, run_sins

    b = import_log("psins", MEMS).window(None, 5.0)
    tr = b.truth
    init = NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0],
                               tr.euler[0])
    sol = run_sins(b, SinsConfig(), init)
    e = error_series(sol, tr)
    assert len(e) > 1 and np.isfinite(e.horizontal_m).all()
    assert e.horizontal_m.iloc[-1] < 5.0                # 5 s of a 200 deg/h MEMS from truth


# ----------------------------------------------------------------------------- parked methods
@needs_rlg
def test_real_rlg_every_parked_method_within_the_bias_limits_with_honest_sigma():
    """Issue 15: on 300 s windows of the RLG log every parked method (the integral methods,
    and parked-kf started 2 deg off in heading) ends within 1.5x the theory limits of the
    documented sensor in heading (drift / (Omega cos L)) and level (bias / g), measured
    against the integral methods' consensus (all share the bias error itself); parked-kf's
    sigma covers its error, and the consensus heading is stable across windows within the
    limit."""
    b = import_log("psins", RLG)
    res = rp.run_psins_rlg(b)
    lim = res["limits"]
    assert res["n_windows"] == 6
    assert lim["heading_limit_arcmin"] == pytest.approx(8.3, abs=0.2)
    assert lim["level_limit_arcmin"] == pytest.approx(0.34, abs=0.01)
    for label in list(rp.PARKED_INTEGRAL) + ["parked-kf", "parked-kf from 30'"]:
        s = res["summary"][label]
        assert s["within_1p5_limits"], (label, s)
    for r in res["runs"]:
        if r["run"] in ("parked-kf", "parked-kf from 30'"):
            assert abs(r["heading_dev_arcmin"]) <= r["sigma_heading_arcmin"], r
            assert r["level_dev_arcmin"] <= r["sigma_level_arcmin"], r
            assert r["sigma_heading_arcmin"] <= 1.5 * lim["heading_limit_arcmin"], r
    assert res["consensus_yaw_spread_arcmin"] <= 1.5 * lim["heading_limit_arcmin"]


@needs_rlg
def test_real_rlg_parked_kf_takes_the_documented_spec_from_meta():
    b = import_log("psins", RLG).window(0.0, 60.0)
    run, cls = registry.get("parked-kf").load()
    init = NavState.from_euler(0.0, np.radians(34.246048), np.radians(108.909664), 380.0,
                               np.zeros(3), np.radians([0.8, 0.3, 90.6]))
    sol = run(b, cls(gyro_arw_deg_sqrt_h=0.002), init)
    src = sol.info["config_source"]
    assert src["gyro_drift_deg_h"] == "meta.imu (documented)"
    assert src["gyro_arw_deg_sqrt_h"] == "config"
    assert src["accel_vrw_ug_sqrt_hz"] == "default"
    assert sol.info["config"]["gyro_drift_deg_h"] == 0.03


# ----------------------------------------------------------------------------- parked-kf model
def _parked_sim(vibration_m_s, seed=0):
    """300 s parked (paper 003's scenario, no disturbances), documented-class IMU, and a
    broadband jitter of the accelerometer increments (white velocity noise of
    ``vibration_m_s`` per 10 ms row, differenced, then quantized at the RLG's 125 ug*s count
    with carry): what the real parked log shows, unlike the simulator's sinusoids."""
    import yaml

    from inmotion.core.bundle import Bundle, ImuData
    from inmotion.sim.scenario import find_scenario, load_scenario
    from inmotion.sim.simulate import simulate

    d = yaml.safe_load(open(find_scenario("paper003_parked_then_drive")).read())
    d["segments"] = [{"kind": "rest", "duration_s": 300}]
    d.pop("disturbances")
    d["vehicle"].pop("constraint_violation", None)    # none at rest; it would draw first
    d["imu"] = {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.001},
                "accel": {"bias_ug": 100.0, "vrw_ug_sqrt_hz": 10.0}}
    b = simulate(load_scenario(d), np.random.default_rng(seed))
    v = np.random.default_rng(seed + 1).normal(0.0, vibration_m_s, (len(b.imu.t) + 1, 3))
    q = 125e-6 * 9.78
    c = np.round(np.cumsum(b.imu.dvel + np.diff(v, axis=0), axis=0) / q) * q
    dvel = np.diff(np.vstack([np.zeros(3), c]), axis=0)
    return Bundle(ImuData(b.imu.t, b.imu.dtheta, dvel), dict(b.meta), truth=b.truth)


def test_parked_kf_model_uses_the_step_mean_specific_force_under_broadband_vibration():
    """Issue 15's cause on the simulator: with broadband accelerometer jitter (0.15 m/s^2 rms
    per row, as on the RLG log) the last row's specific force in ``A`` makes the heading
    look observable; parked-kf's model (the step mean, the engine's) reaches the heading limit
    from 2 deg off with a sigma that covers the error. (The former model, the last row's
    specific force, ended 9.3 arcmin off at 3.7 sigma on this drive.)"""
    from inmotion.align.parked_kf import run_parked_kf

    b = _parked_sim(1.0e-3)
    assert np.all((b.imu.dvel[:, :2] / 0.01).std(axis=0) > 0.1)
    tr = b.truth
    C = tr.C_nb[-1]
    errs = b.meta["simulated_errors"]["imu"]
    eps = C @ np.radians(errs["gyro_drift_deg_h"]) / 3600
    nab = C @ (np.array(errs["accel_bias_ug"]) * 1e-6 * earth.G0)
    L = tr.lat[0]
    theory = np.array([-nab[1] / earth.G0, nab[0] / earth.G0,
                       -eps[0] / (earth.OMEGA_IE * np.cos(L)) + np.tan(L) * nab[0] / earth.G0])
    init = NavState.from_euler(0.0, tr.lat[0], tr.lon[0], tr.h[0], np.zeros(3),
                               tr.euler[0] + np.radians([0.0, 0.0, 2.0]))
    sol = run_parked_kf(b, {}, init)
    d = rotations.misalignment(sol.C_nb[-1], C) - theory
    s = np.array([sol.sigma[k][-1] for k in ("phi_E", "phi_N", "phi_U")])
    assert abs(d[2]) < 1.0 * ARCMIN and abs(d[2]) < s[2]
    assert np.all(np.abs(d[:2]) < 0.3 * ARCMIN)


def test_spec_from_meta():
    from inmotion.align.parked_kf import ParkedKfConfig, config_with_spec, spec_from_meta

    meta = {"simulated": True,
            "imu": {"gyro": {"drift_deg_h": [0.01, -0.02, 0.005], "drift_markov_deg_h": 0.02,
                             "arw_deg_sqrt_h": 0.003},
                    "accel": {"bias_ug": 50.0, "vrw_m_s_sqrt_h": 0.06}}}
    spec, origin = spec_from_meta(meta)
    assert origin == "meta.imu (simulated)"
    assert spec["gyro_drift_deg_h"] == pytest.approx(np.hypot(0.02, 0.02))
    assert spec["accel_vrw_ug_sqrt_hz"] == pytest.approx(0.06 / 60 / (earth.G0 * 1e-6))
    cfg, src = config_with_spec(ParkedKfConfig(accel_bias_ug=10.0), meta)
    assert cfg.accel_bias_ug == 10.0 and src["accel_bias_ug"] == "config"
    assert cfg.gyro_arw_deg_sqrt_h == 0.003 and src["gyro_arw_deg_sqrt_h"] == origin
    cfg, src = config_with_spec(ParkedKfConfig(), {"name": "no spec"})
    assert cfg == ParkedKfConfig() and set(src.values()) == {"default"}


@needs_mems
def test_real_mems_no_method_claims_a_sigma_far_below_its_error():
    """Issue 15: on the MEMS log (gyro drift up to 214 deg/h, every coarse method outside its
    envelope) no method reports a sigma smaller than its error by more than 3x, in heading
    or level, against the FOG reference; ``fine-mux`` and ``adaptive`` say in their warnings
    that the coarse stage is outside its envelope, and still improve the level on the coarse
    answer (the fine filter must not make it worse)."""
    res = rp.run_psins_mems(import_log("psins", MEMS))
    rows = {r["run"]: r for r in res["runs"]}
    assert set(rows) == set(rp.MEMS_COARSE + rp.MEMS_FINE)
    coarse_level = min(rows[m]["level_err_arcmin"] for m in rp.MEMS_COARSE)
    for name, r in rows.items():
        assert "error" not in r, r
        if r["sigma_heading_arcmin"] is None:           # the coarse methods report none
            assert name in rp.MEMS_COARSE
            continue
        assert abs(r["heading_err_arcmin"]) <= 3 * r["sigma_heading_arcmin"], r
        assert r["level_err_arcmin"] <= 3 * r["sigma_level_arcmin"], r
    for name in rp.MEMS_FINE:
        r = rows[name]
        assert any("outside its envelope" in w for w in r["warnings"]), r["warnings"]
        assert r["level_err_arcmin"] < coarse_level


@needs_mems
def test_real_mems_nhc_kf_without_a_mounting_covers_its_track():
    """The one Kalman method a user can run on the MEMS log as imported (no speed sensor):
    ``nhc-kf`` with its defaults from the reference. The MEMS sits about 4.8 deg off the
    direction of travel (the reference velocity in its axes), which ``meta.yaml`` does not
    give, so the NHC holds the velocity along the wrong axis. Before session 20 the attitude
    sigma was floored but not the track: 216 m off at a 50 m horizontal sigma (4.4x);
    :func:`inmotion.align.meta_spec.floor_unknown_mounting` keeps position and velocity at
    what the unknown mounting leaves. With the standard feedback the track turned (210 m,
    heading -371 arcmin at the 300 arcmin floor); with the invariant velocity feedback, the
    default since session 23, it does not (38 m at a 123 m sigma, heading -183 arcmin):
    the standard EKF's heading took information the NHC rows do not hold
    (:mod:`inmotion.estimation.engine`, "Invariant velocity error")."""
    from inmotion.core.metrics import error_series
    from inmotion.reproductions.real import _init_from_truth
    b = import_log("psins", MEMS)
    run, Config = registry.get("nhc-kf").load()
    horizontal = {}
    for invariant in (True, False):
        sol = run(b, Config(invariant_velocity_error=invariant),
                  _init_from_truth(b, b.imu.t[0]))      # as reproduce real's tables
        assert sol.info["velocity_error"] == ("invariant" if invariant else "standard")
        assert any("mounting is not given" in w for w in sol.info["warnings"])
        e = error_series(sol, b.truth).iloc[-1]
        sig_h = float(np.hypot(sol.sigma["north"][-1], sol.sigma["east"][-1]))
        horizontal[invariant] = e.horizontal_m
        assert e.horizontal_m < 3.0 * sig_h, (invariant, e.horizontal_m, sig_h)
        for k in "ENU":
            assert abs(e[f"phi_{k}_arcmin"]) < 3.0 * np.degrees(
                sol.sigma[f"phi_{k}"][-1]) * 60.0, (invariant, k)
    assert horizontal[False] > 100.0 > 2.0 * horizontal[True], horizontal


@needs_mems
def test_real_mems_rolling_window_matches_the_data_readme():
    """The README: the MEMS platform rolls by about +-32 deg between 33 and 73 s; the window
    the reproduction cuts (``real.rolling_window``, roll more than 2 deg off its start, 1 s
    padding) spans it."""
    from inmotion.reproductions.real import rolling_window
    b = import_log("psins", MEMS)
    t0, t1 = (w - b.imu.t[0] for w in rolling_window(b))
    assert 28.0 < t0 < 34.0 and 72.0 < t1 < 79.0, (t0, t1)
    roll = np.degrees(b.truth.euler[:, 1])
    assert roll.max() - roll.min() > 60.0


@needs_mems
def test_real_mems_every_kalman_method_with_its_defaults_covers_its_error():
    """Issue 15 ("on the MEMS log no method reports a sigma smaller than its error by more
    than 3x"), the Kalman methods with their defaults from the reference and the
    reproduction's pseudo-odometer (``real.psins_mems_defaults``), throughout and left out
    while the platform rolls: the final error over the final 1-sigma in East, North and up
    attitude and in horizontal position at most 3. Session 21 measured 4.8-36x: the filters
    took the IMU as fixed in the vehicle and the +-32 deg roll as information separating the
    attitude from the mounting. The importer now writes what the dataset documents: the
    platform's wandering mounting (``vehicle.mounting_rw_arcmin_sqrt_s``, derived from the
    README and the file's gyro) and the toolbox demo's noise densities."""
    from inmotion.io.importers.psins import (MEMS_DEMO_ARW_DEG_SQRT_H,
                                             MEMS_PLATFORM_RW_ARCMIN_SQRT_S)
    from inmotion.reproductions.real import HONEST_RATIO, MEMS_DEFAULT_METHODS, \
        psins_mems_defaults
    b = import_log("psins", MEMS)
    assert b.meta["vehicle"]["mounting_rw_arcmin_sqrt_s"] == MEMS_PLATFORM_RW_ARCMIN_SQRT_S
    assert b.meta["imu"]["gyro"]["arw_deg_sqrt_h"] == MEMS_DEMO_ARW_DEG_SQRT_H
    out = psins_mems_defaults(b)
    for label in ("throughout", "out while rolling"):
        rows = {r["method"]: r for r in out[label]}
        assert set(rows) == set(MEMS_DEFAULT_METHODS)
        for name, r in rows.items():
            assert r["largest_ratio"] <= HONEST_RATIO, (label, name, r)
