"""``sins-dr`` (paper 002): what is new on top of the shared error model and Kalman blocks.

The shared tests (``test_error_model.py``, ``test_kalman.py``) already check ``euler_rows``,
``dr_velocity_rows`` and the SINS/DR ``F`` against the nonlinear system. Here:

* the assembled measurement rows of both modes (attitude, velocity in the DR body frame,
  position, height) against central differences of the nonlinear SINS-minus-DR measurement,
  heading across North included (every plug-in alone: ``test_engine.py``);
* the allocation-free sequential Joseph update against the shared kernel and the batch update;
  the numba feedback against ``Strapdown.correct`` / ``DeadReckoner.correct``;
* the DR position random walk the filter adds, against Monte Carlo dead reckoning with a noisy
  speed (closed form ``sigma_v^2 T_s t``);
* a 24 h drive (10 Hz IMU, 1 Hz filter): the covariance stays symmetric positive definite and
  bounded, hour after hour, and a six-hour call allocates no more than a one-hour one;
* short drives against simulated truth: errors inside the filter's 3-sigma, and bounds;
* every bad-input path, and ``inmotion navigate --method sins-dr --mode ...``.
"""
import json
import tracemalloc

import numpy as np
import pytest
from click.testing import CliRunner

from inmotion.core import earth, rotations
from inmotion.core.bundle import SpeedData
from inmotion.core.deadreckoning import DeadReckoner, speed_on_epochs
from inmotion.core.mechanization import Strapdown
from inmotion.core.solution import NavState
from inmotion.errors import BadInput
from inmotion.estimation import kalman
from inmotion.estimation import measurements as ms
from inmotion.estimation import nav_ops
from inmotion.core.metrics import error_series
from inmotion.navigate.sins_dr import (LAYOUT_SINS_DR as LAY, SinsDrConfig, build_filter,
                                       run_sins_dr)
from inmotion.sim import simulate
from inmotion.sim.scenario import load_scenario

ARCMIN = np.pi / 180 / 60


def _stack(meas, xs, xd, layout, data=None):
    """The measurements' ``(z, H, r)`` stacked in order (``data``: name -> sample)."""
    data = data or {}
    parts = [m.rows((xs, xd, np.zeros(ms.AUX_SIZE)), data.get(m.name), layout) for m in meas]
    parts = [p for p in parts if len(p[0])]
    return (np.concatenate([p[0] for p in parts]), np.vstack([p[1] for p in parts]),
            np.concatenate([np.diag(p[2]) for p in parts]))


def _paper002_rows(xs, xd, h_baro, r_vel, sig_att=1e-4, sig_pos=0.5, sig_h=2.0):
    meas = [ms.SinsDrAttitude(sig_att), ms.SinsDrVelocity(np.sqrt(r_vel)),
            ms.SinsDrPosition(sig_pos), ms.Height(sig_h)]
    return _stack(meas, xs, xd, LAY, {"height": h_baro})


# -- measurement rows against the nonlinear measurement -----------------------------------

def _nav(lat, lon, h, vel_n, C):
    x = np.empty(10)
    x[:3] = lat, lon, h
    x[3:6] = vel_n
    x[6:] = rotations.quat_from_dcm(C)
    return x


def _nonlinear(err, truth):
    """SINS and DR kernel states of a truth with the errors ``err`` (layout LAY) applied the
    nonlinear way: attitudes ``exp(-[phi x]) C``, the DR's velocity its own attitude times the
    scaled forward speed ``(1 + dk) u`` (paper 000 eq. 7-8)."""
    lat, lon, h, u, C = truth
    e = LAY.as_dict(err)
    blk = {b: err[LAY[b]] for b in ("phi", "dv", "dp", "phi_D", "dp_D")}
    C_S = rotations.apply_misalignment(C, blk["phi"])
    C_D = rotations.apply_misalignment(C, blk["phi_D"])
    v = C @ np.array([0.0, u, 0.0])
    xs = _nav(lat + blk["dp"][0], lon + blk["dp"][1], h + blk["dp"][2], v + blk["dv"], C_S)
    xd = _nav(lat + blk["dp_D"][0], lon + blk["dp_D"][1], h + blk["dp_D"][2],
              C_D @ np.array([0.0, (1 + e["dk"]) * u, 0.0]), C_D)
    return xs, xd


@pytest.mark.parametrize("yaw_deg", [359.995, 127.0])
def test_measurement_rows_are_the_derivative_of_the_nonlinear_differences(yaw_deg):
    C = rotations.dcm_from_euler(np.radians([4.0, -3.0, yaw_deg]))
    truth = (0.6, 1.9, 380.0, 17.0, C)
    h_baro = 379.0
    r_vel = np.array([0.1, 0.2, 0.3]) ** 2

    def rows(err):
        xs, xd = _nonlinear(err, truth)
        return _paper002_rows(xs, xd, h_baro, r_vel)

    z0, H, r = rows(LAY.zeros())
    assert len(z0) == 10
    # at zero error: attitude, velocity and position differences vanish (wrapped near North)
    assert np.allclose(z0[:9], 0.0, atol=1e-12) and z0[9] == pytest.approx(1.0)
    assert np.allclose(r[3:6], r_vel)
    rng = np.random.default_rng(1)
    scale = LAY.zeros()
    for b, s in (("phi", 1e-3), ("dv", 0.1), ("phi_D", 1e-3), ("dk", 1e-3)):
        scale[LAY[b]] = s
    scale[LAY["dp"]] = scale[LAY["dp_D"]] = (1e-6, 1e-6, 1.0)
    for _ in range(5):
        d = rng.standard_normal(LAY.n) * scale
        eps = 1e-3
        num = (rows(eps * d)[0] - rows(-eps * d)[0]) / (2 * eps)
        ref = np.abs(H) @ np.abs(d) + 1e-15
        assert np.all(np.abs(num - H @ d) <= 1e-6 * ref), (num, H @ d)


def test_velocity_rows_are_the_n_frame_rows_resolved_in_the_dr_body_frame():
    """z_b = C_n^b z_n: the along-track row carries the sensor noise, the others do not."""
    C = rotations.dcm_from_euler(np.radians([2.0, 1.0, 63.0]))
    xs, xd = _nonlinear(LAY.zeros(), (0.6, 1.9, 380.0, 20.0, C))
    xs[3:6] += [0.3, -0.2, 0.05]
    z, H, _ = _stack([ms.SinsDrVelocity(1.0)], xs, xd, LAY)
    assert np.allclose(C @ z, [0.3, -0.2, 0.05])
    assert np.allclose(C @ H[:, LAY["dv"]], np.eye(3))
    v = xd[3:6]
    assert np.allclose(C @ H[:, LAY.index("dk")], -v)
    assert np.allclose(C @ H[:, LAY["phi_D"]], -rotations.skew(v))


# -- the update and the feedback kernels ---------------------------------------------------

def _random_problem(rng, n=LAY.n, m=6):
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    return (rng.standard_normal(n), P, rng.standard_normal(m), rng.standard_normal((m, n)),
            rng.uniform(0.5, 2.0, m))


def test_sequential_joseph_equals_the_shared_kernel_and_the_batch_update():
    rng = np.random.default_rng(2)
    x, P, z, H, r = _random_problem(rng)
    xa, Pa = x.copy(), P.copy()
    ok, nis = kalman.sequential_joseph(xa, Pa, z, H, r, 0, 6, 0.0, np.empty(LAY.n),
                                    np.empty((LAY.n, LAY.n)))
    xb, Pb = x.copy(), P.copy()
    ok_b, nis_b = kalman._update_rows_kernel(xb, Pb, z, H, r, 0, 6, 0.0)
    xc, Pc, nu, S = kalman.joseph_update(x, P, z, H, np.diag(r))
    assert ok and ok_b
    assert nis == pytest.approx(nis_b, rel=1e-10)
    assert nis == pytest.approx(nu @ np.linalg.solve(S, nu), rel=1e-10)
    for xx, PP in ((xb, Pb), (xc, Pc)):
        assert np.allclose(xa, xx, rtol=1e-10, atol=1e-12)
        assert np.allclose(Pa, PP, rtol=1e-9, atol=1e-11)
    assert np.array_equal(Pa, Pa.T)


def test_sequential_joseph_gate_rejects_whole_group_and_leaves_the_state():
    rng = np.random.default_rng(3)
    x, P, z, H, r = _random_problem(rng)
    z = z + 100.0
    xa, Pa = x.copy(), P.copy()
    ok, nis = kalman.sequential_joseph(xa, Pa, z, H, r, 2, 5, 5.0, np.empty(LAY.n),
                                    np.empty((LAY.n, LAY.n)))
    ok_b, nis_b = kalman._update_rows_kernel(x.copy(), P.copy(), z, H, r, 2, 5, 5.0)
    assert not ok and not ok_b and nis == pytest.approx(nis_b, rel=1e-10) and nis > 5.0
    assert np.array_equal(xa, x) and np.array_equal(Pa, P)


def _moving(obj, rng, dr):
    dth = rng.standard_normal((20, 3)) * 1e-3
    t = 0.01 * np.arange(1, 21)
    if dr:
        obj.run(dth, t, np.full(20, 0.1), np.full(20, 10.0))
    else:
        obj.run(dth, rng.standard_normal((20, 3)) * 1e-2 + [0, 0, 0.098], t)


@pytest.mark.parametrize("dr", [False, True])
def test_numba_feedback_equals_the_mechanization_correct(dr):
    rng = np.random.default_rng(4)
    init = NavState.from_euler(0.0, 0.6, 1.9, 380.0, [3.0, 4.0, 0.1], np.radians([1, 2, 30]))
    a = DeadReckoner(init) if dr else Strapdown(init)
    b = DeadReckoner(init) if dr else Strapdown(init)
    for o in (a, b):
        _moving(o, np.random.default_rng(5), dr)
    phi, dv, dp = rng.standard_normal(3) * 1e-3, rng.standard_normal(3) * 0.1, [1e-6, -2e-6, 3.0]
    if dr:
        a.correct(phi=phi, dpos=dp)
    else:
        a.correct(phi=phi, dvel_n=dv, dpos=dp)
    nav_ops.correct_nav(b._x, b._mem, phi, dv, np.array(dp), not dr)
    assert np.allclose(a._x, b._x, rtol=0, atol=1e-15)
    assert np.allclose(a._mem, b._mem, rtol=0, atol=1e-15)


# -- the DR position random walk of the model ----------------------------------------------

def test_dr_position_random_walk_density_is_sigma_squared_times_sensor_period():
    """White speed noise sigma_v at period T_s walks the DR distance with variance
    sigma_v^2 T_s t (the trapezoid sum of the samples; the density the driver adds)."""
    rng = np.random.default_rng(6)
    sigma_v, T_s, dur, u = 0.1, 0.1, 60.0, 10.0
    n_runs = 300
    t_imu = np.arange(1, int(dur / 0.02) + 1) * 0.02
    ts = np.arange(0, int(dur / T_s) + 1) * T_s
    init = NavState.from_euler(0.0, 0.6, 1.9, 380.0, [0.0, u, 0.0], [0.0, 0.0, 0.0])
    r_m, _ = earth.radii(0.6)
    north = np.empty(n_runs)
    for i in range(n_runs):
        speed = SpeedData(ts, v=u + sigma_v * rng.standard_normal(len(ts)))
        ds, v, _, _ = speed_on_epochs(speed, np.concatenate([[0.0], t_imu]))
        dr = DeadReckoner(init)
        dr.run(np.zeros((len(t_imu), 3)), t_imu, ds, v)
        north[i] = (dr._x[0] - 0.6) * (r_m + 380.0) - u * dur
    var_model = sigma_v ** 2 * T_s * dur
    # sample variance of 300 normal draws: relative 1-sigma sqrt(2/299) = 8 %
    assert np.var(north, ddof=1) == pytest.approx(var_model, rel=0.25)


# -- long runs: covariance health --------------------------------------------------------------

def _day_scenario(hours):
    segs = [{"kind": "rest", "duration_s": 60}]
    for i in range(hours):
        segs += [{"kind": "accelerate", "to_speed_m_s": 15.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 1600},
                 {"kind": "turn", "angle_deg": 90 if i % 2 else -120, "rate_deg_s": 5},
                 {"kind": "cruise", "duration_s": 1600},
                 {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 345}]
    return load_scenario({
        "name": "day", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
        "segments": segs,
        "imu": {"rate_hz": 10.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
                "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
        "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1, "scale_markov_sigma_ppm": 1000,
                              "scale_markov_tau_s": 300}}})


def _truth_init(bundle):
    return NavState.from_euler(**bundle.truth.at(bundle.truth.t[0]))


def test_covariance_stays_symmetric_positive_definite_for_24_hours():
    b = simulate(_day_scenario(24), np.random.default_rng(7))
    assert b.imu.t[-1] >= 24 * 3600
    cfg = SinsDrConfig(mode="attitude-position", filter_rate_hz=1.0, measurement_rate_hz=1.0,
                       output_rate_hz=0.01)
    filt, rows, (name, speed) = build_filter(b, cfg, _truth_init(b))
    t, dth, dvl = b.imu.t[rows], b.imu.dtheta[rows], b.imu.dvel[rows]
    build_filter(b, cfg, _truth_init(b))[0].run(t[:100], dth[:100], dvl[:100], speed)  # warm-up
    per_hour = 36000
    peaks = {}
    spans = [(0, 6 * per_hour)] + [(a, a + per_hour) for a in range(6 * per_hour, len(t),
                                                                    per_hour)]
    for a, b_ in spans:                               # six hours at once, then hour by hour
        tracemalloc.start()
        out = filt.run(t[a:b_], dth[a:b_], dvl[a:b_], speed)
        peaks.setdefault((b_ - a) // per_hour, tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        P = filt.filter.covariance()
        assert np.array_equal(P, P.T)
        d = np.sqrt(np.diagonal(P))
        assert np.all(np.isfinite(P)) and np.all(d > 0)
        corr = P / np.outer(d, d)
        assert np.linalg.eigvalsh(corr).min() > 0.0
        np.linalg.cholesky(P)
        sig = out["sigma"][-1]
        # no drift of the covariance: heading and height sigma stay bounded
        assert sig[LAY.index("phi_U")] < 5 * ARCMIN
        assert sig[LAY.index("dp_h")] < 20.0
    # memory: six hours in one call need no more than one hour (outputs at 0.01 Hz are tiny)
    assert peaks[6] < peaks[1] + 2**18
    errs = error_series(run_sins_dr(b, cfg, _truth_init(b)), b.truth)
    assert errs.horizontal_m.max() < 200.0          # 0.05 % of the 1 250 km driven
    assert filt.counts()["attitude"]["rejected"] == 0


# -- short runs against simulated truth --------------------------------------------------------

SHORT = {
    "name": "short", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "segments": [{"kind": "rest", "duration_s": 20},
                 {"kind": "accelerate", "to_speed_m_s": 15.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 100},
                 {"kind": "turn", "angle_deg": 90, "rate_deg_s": 5},
                 {"kind": "climb", "pitch_deg": 3, "duration_s": 60},
                 {"kind": "turn", "angle_deg": -120, "rate_deg_s": 4},
                 {"kind": "cruise", "duration_s": 100},
                 {"kind": "stop", "decel_m_s2": 1.0}, {"kind": "wait", "duration_s": 20}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
            "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1, "scale_markov_sigma_ppm": 1000,
                          "scale_markov_tau_s": 300},
                "odometer": {"rate_hz": 10.0, "pulses_per_m": 1000},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}


@pytest.fixture(scope="module")
def short_drive():
    return simulate(load_scenario(SHORT), np.random.default_rng(8))


def _perturbed(bundle, d_euler_arcmin):
    s = _truth_init(bundle)
    return NavState.from_euler(s.t, s.lat, s.lon, s.h, s.vel_n,
                               s.euler + np.asarray(d_euler_arcmin) * ARCMIN)


@pytest.mark.parametrize("mode", ["attitude-position", "velocity-position"])
def test_short_drive_errors_inside_three_sigma_and_bounded(short_drive, mode):
    init = _perturbed(short_drive, [0.5, -0.5, 3.0])
    sol = run_sins_dr(short_drive, {"mode": mode, "init_heading_sigma_arcmin": 3.0}, init)
    err = error_series(sol, short_drive.truth)
    i = np.searchsorted(sol.t, err.t.to_numpy())
    for axis in ("E", "N", "U"):
        ratio = np.abs(err[f"phi_{axis}_arcmin"]) * ARCMIN / sol.sigma[f"phi_{axis}"][i]
        assert np.mean(ratio > 3.0) < 0.05, axis
    horiz_sigma = np.hypot(sol.sigma["north"], sol.sigma["east"])[i]
    assert np.mean(err.horizontal_m > 3.0 * horiz_sigma) < 0.05
    # bounds: 4.8 km with 0.1 % speed-scale noise and a 3' heading: a few metres, not tens
    assert err.horizontal_m.max() < 10.0
    assert np.abs(err.vertical_m).max() < 5.0
    assert np.abs(err.phi_U_arcmin).max() < 4.0
    # before the turns, a 100 ug bias and the tilt are one (0.34'); after the two turns
    # (ending near 250 s) the filter has told them apart
    late = err.t > 260
    assert np.abs(err.phi_E_arcmin[late]).max() < 0.2 and np.abs(err.phi_N_arcmin[late]).max() < 0.2
    assert sol.info["mode"] == mode
    assert sol.info["rows_without_speed"] == 0 and sol.info["rows_in_speed_gaps"] == 0
    assert set(sol.info["measurements"]) == {"attitude" if mode[0] == "a" else "velocity",
                                              "position"}


def test_error_free_sensors_and_exact_start_stay_on_truth(short_drive):
    """No sensor errors, exact start: the closed loop must not invent corrections."""
    d = dict(SHORT)
    d["imu"] = {"rate_hz": 100.0}
    d["sensors"] = {"radar": {"rate_hz": 10.0, "noise_m_s": 0.0}}
    b = simulate(load_scenario(d), np.random.default_rng(9))
    sol = run_sins_dr(b, {}, _truth_init(b))
    err = error_series(sol, b.truth)
    assert err.horizontal_m.max() < 0.05
    assert np.abs(err.vertical_m).max() < 0.05
    assert np.abs(err[["phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin"]]).to_numpy().max() < 0.01


@pytest.mark.parametrize("sensor", ["odometer", "radar"])
def test_other_velocity_source_and_baro(short_drive, sensor):
    init = _perturbed(short_drive, [0.5, -0.5, 3.0])
    sol = run_sins_dr(short_drive, {"velocity_sensor": sensor, "use_baro": True,
                                    "output_rate_hz": 1.0}, init)
    assert sol.info["velocity_sensor"] == sensor
    assert sol.info["measurements"]["height"]["used"] > 0
    assert np.median(np.diff(sol.t)) == pytest.approx(1.0)
    err = error_series(sol, short_drive.truth)
    assert err.horizontal_m.max() < 15.0 and np.abs(err.vertical_m).max() < 3.0


def test_chunked_run_equals_one_call(short_drive):
    init = _truth_init(short_drive)
    cfg = SinsDrConfig()
    f1, rows, (_, speed) = build_filter(short_drive, cfg, init)
    f2, _, _ = build_filter(short_drive, cfg, init)
    imu = short_drive.imu
    t, dth, dvl = imu.t[rows], imu.dtheta[rows], imu.dvel[rows]
    f1.run(t, dth, dvl, speed)
    for a in range(0, len(t), 7000):                 # 700 rows = 70 epochs per call
        f2.run(t[a:a + 7000], dth[a:a + 7000], dvl[a:a + 7000], speed)
    # the same run up to rounding (the sensor is resampled in different windows)
    assert np.allclose(f1.filter.kernel_states()[0], f2.filter.kernel_states()[0], rtol=1e-12,
                       atol=1e-8)
    assert np.allclose(f1.filter.covariance(), f2.filter.covariance(), rtol=1e-6, atol=1e-30)
    assert f1.filter.epochs == f2.filter.epochs


# -- bad input -----------------------------------------------------------------------------------

def test_bad_inputs_raise_one_clear_message(short_drive):
    init = _truth_init(short_drive)
    with pytest.raises(BadInput, match="needs an initial state"):
        run_sins_dr(short_drive, {}, None)
    with pytest.raises(BadInput, match="mode"):
        run_sins_dr(short_drive, {"mode": "attitude-only"}, init)
    with pytest.raises(BadInput, match="must not exceed"):
        run_sins_dr(short_drive, {"filter_rate_hz": 1, "measurement_rate_hz": 10}, init)
    with pytest.raises(BadInput, match="output_rate_hz"):
        run_sins_dr(short_drive, {"filter_rate_hz": 1, "measurement_rate_hz": 1,
                                  "output_rate_hz": 10}, init)
    with pytest.raises(BadInput, match="no ldv|velocity sensor"):
        run_sins_dr(short_drive, {"velocity_sensor": "ldv"}, init)
    no_baro = short_drive.window(None, None)
    no_baro.baro = None
    with pytest.raises(BadInput, match="no barometer"):
        run_sins_dr(no_baro, {"use_baro": True}, init)
    late = NavState(short_drive.imu.t[-1] + 1.0, init.lat, init.lon, init.h, init.vel_n,
                    init.q_nb)
    with pytest.raises(BadInput, match="no IMU rows after"):
        run_sins_dr(short_drive, {}, late)
    for k in (50, 3000):                   # rows are counted in the whole table
        bad = short_drive.window(None, None)
        v = bad.radar.v.copy()
        v[k] = np.nan
        bad.radar = SpeedData(bad.radar.t, v=v)
        with pytest.raises(BadInput, match="radar.*not a finite") as e:
            run_sins_dr(bad, {"velocity_sensor": "radar"}, init)
        assert e.value.row == k + 1 and e.value.time == pytest.approx(bad.radar.t[k])
    bad = short_drive.window(None, None)
    ts = bad.radar.t.copy()
    ts[2000] = ts[1999]
    bad.radar = SpeedData(ts, v=bad.radar.v)
    with pytest.raises(BadInput, match="not strictly increasing") as e:
        run_sins_dr(bad, {}, init)
    assert e.value.row == 2001


# -- the command line --------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["attitude-position", "velocity-position"])
def test_cli_navigate_sins_dr_with_mode(tmp_path, short_drive, mode):
    from inmotion.cli.main import cli
    from inmotion.io.bundle import write_bundle
    from inmotion.io.result import read_result
    bpath = tmp_path / "b"
    write_bundle(short_drive.window(None, 120.0), bpath)
    out = tmp_path / "r"
    res = CliRunner().invoke(cli, ["--quiet", "navigate", str(bpath), "--method", "sins-dr",
                                   "--mode", mode, "--output-rate", "all", "-o", str(out)],
                       catch_exceptions=False)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["method"] == "sins-dr" and summary["config"]["mode"] == mode
    assert summary["errors"]["max_abs_last_100s"]["horizontal_m"] < 5.0
    assert len(read_result(out).t) == 1201                 # 10 Hz over 120 s, and t = 0
    res = CliRunner().invoke(cli, ["--quiet", "navigate", str(bpath), "--method", "sins-dr",
                                   "--mode", "sideways", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2


# -- the reproduction's statistics ---------------------------------------------------------------

def test_reproduce_002_statistics_on_a_known_error_table():
    import pandas as pd
    from inmotion.reproductions import paper002 as rep
    t = np.arange(0.0, 3601.0)
    hor = np.where(t < rep.SETTLE_S, 100.0, 3.0 + 4.0 * (t == 2000))   # spike before settling
    err = pd.DataFrame({"t": t, "horizontal_m": hor, "vertical_m": -2.0 * np.ones_like(t),
                        "yaw_arcmin": np.where(t > 3000, -1.5, 0.5),
                        "pitch_arcmin": 0.2 * np.ones_like(t), "roll_arcmin": -0.3 * np.ones_like(t),
                        "distance_m": t * 14.0})
    s = rep.run_statistics(err)
    assert s["horizontal_max_m"] == 7.0 and s["horizontal_max_hour_m"] == 100.0
    n_late = np.sum(t >= rep.SETTLE_S)
    assert s["horizontal_rms_m"] == pytest.approx(np.sqrt((9.0 * (n_late - 1) + 49.0) / n_late))
    assert s["horizontal_max_pct"] == pytest.approx(100 * 7.0 / (3600 * 14.0))
    assert s["height_max_m"] == 2.0 and s["heading_max_arcmin"] == 1.5
    assert s["level_max_arcmin"] == pytest.approx(0.3)
    runs = [{lab: {"stats": dict(s, horizontal_max_m=k + (lab == "velocity-position")),
                   "wall_s": 1.0} for lab in rep.METHODS} for k in (1.0, 2.0, 30.0)]
    agg = rep.aggregate(runs)
    assert agg["attitude-position"]["horizontal_max_m"]["median"] == 2.0
    ver = rep.verdicts(agg)
    assert ver["ap_meets_paper"] == {"horizontal_m": True, "heading_arcmin": True,
                                     "level_arcmin": True}
    assert ver["ap_beats_vp"]["horizontal_m"] and not ver["ap_beats_vp"]["heading_arcmin"]


def test_rows_without_speed_are_counted(short_drive):
    late = short_drive.window(None, None)
    late.radar = late.radar.window(10.0, None)           # the radar starts 10 s late
    sol = run_sins_dr(late, {"velocity_sensor": "radar"}, _truth_init(late))
    assert sol.info["rows_without_speed"] == 1000        # (0, 10] s at 100 Hz


# ------------------------------------------------------------------ mounting not given
def _phone_drive_without_mounting(seed):
    """:func:`inmotion.reproductions.real.comma_like_scenario` (the IMU pitched 3.8 deg, yawed
    -0.8 deg in the car) with ``vehicle_mounting_arcmin`` taken out of ``meta.yaml`` and the
    comma2k19 importer's assumed phone spec, as a real log would come."""
    from inmotion.io.importers.comma2k19 import PHONE_IMU_SPEC
    from inmotion.reproductions import real
    b = simulate(load_scenario(real.comma_like_scenario()), np.random.default_rng(seed))
    meta = {k: v for k, v in b.meta.items() if k != "vehicle_mounting_arcmin"}
    b.meta = {**meta, "imu": {"rate_hz": 100.0, **PHONE_IMU_SPEC}}
    return b, NavState.from_truth(b.truth)


def _final_ratios(sol, truth):
    e = error_series(sol, truth).iloc[-1]
    r = [abs(e[f"phi_{k}_arcmin"]) / (np.degrees(sol.sigma[f"phi_{k}"][-1]) * 60.0)
         for k in "ENU"]
    return np.array(r + [e.horizontal_m / np.hypot(sol.sigma["north"][-1],
                                                   sol.sigma["east"][-1])])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sins_dr_estimates_a_mounting_nobody_gave(seed):
    """Paper 002 assumes the installation angles calibrated out; on a log whose meta.yaml
    gives none, sins-dr adds paper 000 eq. 11's mounting block (``estimates_mounting``) with
    the unknown installation's 300 arcmin prior. Against simulated truth the angles come out
    within 3 sigma (measured over seeds 0-9: pitch within 4 arcmin at a 7 arcmin sigma, yaw
    within 22 at 45) and the attitude and position within 3 sigma. Paper 002's 22 states on
    the same drives, with the invariant velocity feedback (the default since issue 15's
    session 24): honest (final error within 0.73 of its sigma, seeds 0-2; asserted within 3x) but 43-72 m off
    after the minute where the mounting block ends 4.5-11 m off; asserted (at least 3x), so
    the test fails if the block stops mattering. With the standard feedback the mounting
    turned its heading 27-28 deg (5.5x its floored 300 arcmin sigma), 205-207 m off."""
    from inmotion.align.meta_spec import UNKNOWN_MOUNTING_SIGMA_ARCMIN
    from inmotion.reproductions.real import SIM_MOUNT_ARCMIN
    b, init = _phone_drive_without_mounting(seed)
    sol = run_sins_dr(b, {}, init)
    assert "mount_x" in sol.info["layout"] and not sol.info.get("warnings")
    assert "not given" in sol.info["config_source"]["estimate_mounting"]
    assert sol.info["config"]["mount_sigma_arcmin"] == UNKNOWN_MOUNTING_SIGMA_ARCMIN
    for name, true_arcmin in (("mount_x", SIM_MOUNT_ARCMIN[0]), ("mount_z", SIM_MOUNT_ARCMIN[2])):
        est = np.degrees(sol.states[name][-1]) * 60.0
        sig = np.degrees(sol.states[f"sigma_{name}"][-1]) * 60.0
        assert abs(est - true_arcmin) < 3.0 * sig < 0.5 * UNKNOWN_MOUNTING_SIGMA_ARCMIN, \
            (name, est, true_arcmin, sig)
    assert np.all(_final_ratios(sol, b.truth) < 3.0), _final_ratios(sol, b.truth)
    paper = run_sins_dr(b, {"estimate_mounting": False}, init)
    assert "mount_x" not in paper.info["layout"]
    assert any(w.startswith("the vehicle's mounting is not given") for w in paper.info["warnings"])
    assert np.all(_final_ratios(paper, b.truth) < 3.0), _final_ratios(paper, b.truth)
    assert (error_series(paper, b.truth).horizontal_m.iloc[-1]
            > 3.0 * error_series(sol, b.truth).horizontal_m.iloc[-1])
    standard = run_sins_dr(b, {"estimate_mounting": False, "invariant_velocity_error": False},
                           init)
    assert _final_ratios(standard, b.truth).max() > 3.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sins_dr_across_a_speed_gap_reads_no_made_up_speed(seed):
    """Across a gap in the speed sensor the DR's distance is interpolated; the samples that
    read it there (the DR's velocity and position, the sensor's speed: ``velocity_aided.
    READS_SPEED``) are skipped, not made up from the interpolation. On the phone drive with
    the odometer out from 5 to 40 s (the car speeding up and slowing down inside), before:
    the final level up to 32-35 times its sigma and 230-235 m off at about 23 m (seeds 0-2);
    after: within 3 sigma (measured 0.1-2.9x in attitude, 0.8-1.3x in position). Over 20 runs
    the final-attitude NEES across the gap was 7.82 against 2.02-4.16 (1083.7 before; 0.66
    without the gap): the DR's position still held the distance interpolated across the gap.
    Since session 21 the DR restarts at the SINS as the speed comes back (0.75; consistency:
    ``tests/test_bilinear_rows.py``); what is asserted here is the per-run bound."""
    from inmotion.io.importers.comma2k19 import PHONE_IMU_SPEC
    from inmotion.reproductions import real
    b = simulate(load_scenario(real.comma_like_scenario()), np.random.default_rng(seed))
    b.meta = {**b.meta, "imu": {"rate_hz": 100.0, **PHONE_IMU_SPEC}}
    t0 = float(b.imu.t[0])
    cut = type(b)(b.imu, b.meta, odometer=b.odometer.dropout(t0 + 5.0, t0 + 40.0), truth=b.truth)
    sol = run_sins_dr(cut, {}, NavState.from_truth(b.truth))
    assert sol.info["rows_in_speed_gaps"] > 3000 and sol.info["samples_skipped_blind"] > 300
    assert np.all(_final_ratios(sol, b.truth) < 3.0), _final_ratios(sol, b.truth)


def test_speed_dropout_keeps_the_distance_and_removes_the_samples():
    """``SpeedData.dropout``: the samples strictly inside the window go; a distance sensor's
    total is kept (the first sample after carries the gap's distance), a speed sensor's
    values stay as they were."""
    t = np.arange(0.0, 10.01, 0.5)
    ds = np.full(len(t), 0.25)
    out = SpeedData(t, ds=ds).dropout(2.0, 5.0)
    assert np.array_equal(out.t, t[(t <= 2.0) | (t >= 5.0)])
    assert out.ds.sum() == pytest.approx(ds.sum())
    assert out.ds[out.t == 5.0][0] == pytest.approx(0.25 * 6)       # 2.5 .. 5.0 s
    v = SpeedData(t, v=t * 2.0).dropout(2.0, 5.0)
    assert np.array_equal(v.v, 2.0 * v.t) and v.ds is None
