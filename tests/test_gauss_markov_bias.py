"""The Gauss-Markov bias option of the shared error model (issue 15).

* the model: ``F`` carries ``-1 / tau`` on the gyro and accelerometer bias diagonals (and
  :func:`F_pattern` reports them, so sparsity-specialised predicts include them), ``Q_c``
  carries ``2 sigma^2 / tau``; with ``tau = inf`` nothing changes;
* the filter's propagated bias variance follows the stationary GM law
  ``sigma^2 + (P0 - sigma^2) exp(-2 t / tau)`` (the engine's discrete predict, no
  measurement);
* against the simulator's nonlinear truth: the simulator draws a GM gyro and accelerometer
  bias (:func:`inmotion.sim.random_processes.markov`); ``od-kf`` given that spec from
  ``meta.yaml`` (no configuration) is consistent (attitude NEES per axis in the 95 % band
  of the Monte Carlo mean), while the same filter with a random-constant bias of the same
  1-sigma is overconfident by orders of magnitude.
"""
import numpy as np
import pytest
from scipy.stats import chi2

from inmotion.align.aided_kf import AidedKfConfig, config_with_spec, run_od_kf
from inmotion.core.metrics import error_series
from inmotion.core.solution import NavState
from inmotion.estimation import error_model as em
from inmotion.estimation.engine import ErrorStateFilter
from inmotion.estimation.layout import Layout
from inmotion.sim.scenario import load_scenario
from inmotion.sim.simulate import simulate

DEG_H = np.pi / 180.0 / 3600.0
LAY = Layout(["phi", "dv", "dp", "eps", "nabla"])


def _noise(**kw):
    return em.ProcessNoise(gyro_arw=1e-4, accel_vrw=1e-3, **kw)


def test_F_and_Q_carry_the_gauss_markov_terms_and_F_pattern_reports_them():
    tau_g, tau_a, s_g, s_a = 30.0, 120.0, 50 * DEG_H, 5e-3
    model = em.ErrorModel(LAY, _noise(gyro_bias_sigma=s_g, gyro_bias_tau=tau_g,
                                      accel_bias_sigma=s_a, accel_bias_tau=tau_a))
    pt = em.LinPoint(0.6, 100.0, np.array([3.0, 4.0, 0.1]), np.eye(3), np.array([0, 0, 9.8]))
    F = model.F(pt)
    e, a = LAY["eps"], LAY["nabla"]
    np.testing.assert_array_equal(np.diag(F[e, e]), -1.0 / tau_g)
    np.testing.assert_array_equal(np.diag(F[a, a]), -1.0 / tau_a)
    Q = model.Qc()
    np.testing.assert_allclose(np.diag(Q[e, e]), 2 * s_g ** 2 / tau_g, rtol=1e-15)
    np.testing.assert_allclose(np.diag(Q[a, a]), 2 * s_a ** 2 / tau_a, rtol=1e-15)
    pat = model.F_pattern()
    assert pat[e, e].diagonal().all() and pat[a, a].diagonal().all()
    assert (F[~pat] == 0).all()                       # every nonzero is in the pattern
    # without the option: no diagonal entry, no bias noise, pattern as before
    plain = em.ErrorModel(LAY, _noise())
    assert (np.diag(plain.F(pt)[e, e]) == 0).all() and (plain.Qc()[e, e] == 0).all()
    assert not plain.F_pattern()[e, e].diagonal().any()
    np.testing.assert_array_equal(plain.F_pattern(), em.F_pattern(LAY.n, em._offsets(LAY)))


def test_tau_must_be_positive():
    with pytest.raises(ValueError, match="gyro_bias_tau"):
        em.ProcessNoise(gyro_bias_tau=0.0)


def test_engine_propagates_the_bias_variance_as_the_stationary_gm_law():
    """No measurement: the engine's discrete predict of the eps / nabla variance against the
    exact law of a first-order GM process started with variance P0."""
    tau_g, s_g, tau_a, s_a = 20.0, 80 * DEG_H, 60.0, 3e-3
    model = em.ErrorModel(LAY, _noise(gyro_bias_sigma=s_g, gyro_bias_tau=tau_g,
                                      accel_bias_sigma=s_a, accel_bias_tau=tau_a))
    P0 = LAY.diag({"phi": 1e-6, "dv": 1e-2, "dp": np.array([1e-12, 1e-12, 1.0]),
                   "eps": (5 * s_g) ** 2, "nabla": (0.1 * s_a) ** 2})
    init = NavState.from_euler(0.0, 0.6, 1.9, 100.0, np.zeros(3), np.zeros(3))
    f = ErrorStateFilter(init, LAY, model, P0, [], step_rows=10, out_every=10 ** 6)
    dt, n = 0.01, 6000                              # 60 s at 100 Hz, 10 Hz filter
    t = dt * np.arange(1, n + 1)
    g = np.array([0.0, 0.0, 9.80])
    f.add_imu(t, np.zeros((n, 3)), np.tile(g * dt, (n, 1)), flush=True)
    P = f.covariance()
    T = t[-1]
    for blk, sig, tau, p0 in (("eps", s_g, tau_g, (5 * s_g) ** 2),
                              ("nabla", s_a, tau_a, (0.1 * s_a) ** 2)):
        want = sig ** 2 + (p0 - sig ** 2) * np.exp(-2 * T / tau)
        got = np.diag(P[LAY[blk], LAY[blk]])
        np.testing.assert_allclose(got, want, rtol=2e-3)


SCENARIO = {
    "name": "gm_drive", "description": "a 2-minute drive with a Gauss-Markov gyro and "
    "accelerometer bias (issue 15 test)",
    "start": {"lat_deg": 34.0, "lon_deg": 108.0, "h_m": 400.0, "heading_deg": 30.0,
              "speed_m_s": 10.0},
    "segments": [{"kind": "cruise", "duration_s": 20},
                 {"kind": "turn", "angle_deg": 90, "rate_deg_s": 6},
                 {"kind": "accelerate", "to_speed_m_s": 15, "accel_m_s2": 0.5},
                 {"kind": "cruise", "duration_s": 20},
                 {"kind": "turn", "angle_deg": -90, "rate_deg_s": 6},
                 {"kind": "cruise", "duration_s": 20}],
    "imu": {"rate_hz": 100.0,
            "gyro": {"drift_deg_h": 0.0, "drift_markov_deg_h": 100.0, "drift_markov_tau_s": 20.0,
                     "arw_deg_sqrt_h": 0.05},
            "accel": {"bias_ug": 0.0, "bias_markov_ug": 500.0, "bias_markov_tau_s": 60.0,
                      "vrw_ug_sqrt_hz": 30.0}},
    "sensors": {"odometer": {"rate_hz": 10.0, "pulses_per_m": 200.0}},
}
#: od-kf started from truth with tight priors on what the run does not perturb, so that the
#: attitude error is driven by the biases
START = dict(measurement="velocity", fdi=False, use_baro=False, nhc_fallback=False,
             init_tilt_sigma_deg=0.01, init_heading_sigma_deg=0.01,
             init_velocity_sigma_m_s=0.01, init_position_sigma_m=0.1, mount_sigma_arcmin=1.0,
             od_scale_sigma_ppm=100.0, lever_sigma_m=0.01)
RUNS = 16


def attitude_nees(model_cfg, scenario=None, seed=15, runs=RUNS):
    """Per run, epoch and axis the attitude NEES ``(phi / sigma)^2`` of od-kf (:data:`START`
    plus ``model_cfg``) started from truth on ``runs`` simulated drives of ``scenario``
    (default :data:`SCENARIO`); returns ``(nees (runs, epochs, 3), the last solution)``."""
    sc = load_scenario(SCENARIO if scenario is None else scenario)
    out = []
    for k in range(runs):
        b = simulate(sc, np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(k,))))
        tr = b.truth
        init = NavState.from_euler(tr.t[0], tr.lat[0], tr.lon[0], tr.h[0], tr.vel_n[0],
                                   tr.euler[0])
        sol = run_od_kf(b, {**START, **model_cfg}, init)
        e = error_series(sol, tr)
        phi = np.radians(np.column_stack([e.phi_E_arcmin, e.phi_N_arcmin, e.phi_U_arcmin])
                         / 60.0)
        sig = np.column_stack([sol.sigma[k_] for k_ in ("phi_E", "phi_N", "phi_U")])
        out.append(((phi / sig) ** 2)[1:])
    return np.array(out), sol


def test_od_kf_with_the_gm_spec_from_meta_is_consistent_on_simulated_gm_biases():
    nees, sol = attitude_nees({})
    src = sol.info["config_source"]
    assert src["gyro_markov_tau_s"] == "meta.imu (simulated)"
    assert sol.info["config"]["gyro_markov_tau_s"] == 20.0
    assert sol.info["config"]["accel_markov_tau_s"] == 60.0
    # the Monte Carlo mean per axis at the end and over the run, against the 95 % band of a
    # mean of RUNS chi-square(1) values
    lo, hi = chi2.ppf([0.025, 0.975], RUNS) / RUNS
    end = nees[:, -1, :].mean(axis=0)
    assert ((end > lo) & (end < hi)).all(), end
    run_mean = nees.mean(axis=(0, 1))
    assert ((run_mean > lo) & (run_mean < hi)).all(), run_mean
    # the same filter with random-constant biases of the same 1-sigma: overconfident
    const, _ = attitude_nees({"gyro_drift_deg_h": 100.0, "gyro_markov_deg_h": 0.0,
                               "gyro_markov_tau_s": None, "accel_bias_ug": 500.0,
                               "accel_markov_ug": 0.0, "accel_markov_tau_s": None})
    assert const[:, -1, 2].mean() > 10 * hi


def test_config_with_spec_keeps_what_the_config_sets():
    meta = {"simulated": True, "imu": SCENARIO["imu"]}
    cfg, src = config_with_spec(AidedKfConfig(gyro_markov_tau_s=5.0), meta)
    assert cfg.gyro_markov_tau_s == 5.0 and src["gyro_markov_tau_s"] == "config"
    assert cfg.gyro_markov_deg_h == 100.0 and src["gyro_markov_deg_h"] == "meta.imu (simulated)"
    assert cfg.gyro_drift_deg_h == 0.0                 # the constant alone, not folded
    cfg, src = config_with_spec(AidedKfConfig(), {"name": "no spec"})
    # without a mounting in meta the mounting prior is an unknown installation's (session 19)
    assert src.pop("mount_sigma_arcmin") == "meta.yaml has no vehicle_mounting_arcmin"
    assert set(src.values()) == {"default"} and cfg.gyro_markov_tau_s is None
