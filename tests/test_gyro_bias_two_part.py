"""The constant + Gauss-Markov gyro bias of the shared error model (issue 15, block ``eps_gm``).

* ``F``: ``F[phi, eps_gm]`` is the derivative of the nonlinear attitude error's rate with
  respect to a gyro bias (finite differences of the attitude propagated with and without
  it), the same as ``F[phi, eps]``; ``-1 / tau`` sits on ``eps_gm``'s diagonal and not on
  ``eps``'s; the DR attitude rows see both parts; ``Q_c`` puts ``2 sigma^2 / tau`` on
  ``eps_gm`` and nothing on ``eps``; ``F_pattern`` covers every nonzero;
* the generated sparse predict (:mod:`inmotion.estimation.predict`) handles the new pattern
  (equal to the dense kernel);
* the engine's propagated covariance, no measurement, against the exact laws: ``eps_gm``'s
  variance follows the stationary GM law, ``eps``'s stays (a random constant), and the
  heading variance of a vehicle at rest grows as ``P0 + s_c^2 T^2 + 2 sigma^2 tau^2 (T / tau -
  1 + exp(-T / tau)) + ARW^2 T`` (the variance of the integral of a constant plus a
  stationary GM process);
* against the simulator's nonlinear truth: a gyro bias drawn as a random constant plus a GM
  wander (the simulator's ``drift_deg_h`` + ``drift_markov_*``); ``od-kf`` takes the spec
  from ``meta.yaml``, models it with the two blocks, and its heading NEES lies in the 95 %
  band of the Monte Carlo mean; its level NEES is below the band's top (conservative by
  about 1.4 in sigma, as the one-state model is on the same drive: the test says why).
"""
import numpy as np
import pytest
from scipy.stats import chi2

from inmotion.core import rotations
from inmotion.core.solution import NavState
from inmotion.estimation import error_model as em
from inmotion.estimation.engine import ErrorStateFilter
from inmotion.estimation.kalman import _predict_kernel
from inmotion.estimation.layout import Layout
from inmotion.estimation.predict import make_workspace, predict_sparse
from test_gauss_markov_bias import SCENARIO as GM_SCENARIO
from test_gauss_markov_bias import attitude_nees

DEG_H = np.pi / 180.0 / 3600.0
LAY = Layout(["phi", "dv", "dp", "eps", "nabla", "eps_gm"])
LAY_DR = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk", "eps_gm"])
TAU, SIG = 30.0, 50 * DEG_H


def _noise(**kw):
    return em.ProcessNoise(gyro_arw=1e-4, accel_vrw=1e-3, gyro_bias_sigma=SIG,
                           gyro_bias_tau=TAU, **kw)


def _point(C):
    return em.LinPoint(0.6, 100.0, np.array([3.0, 4.0, 0.1]), C, np.array([0.1, 0.2, 9.8]))


def test_F_rows_of_eps_gm_are_the_nonlinear_attitude_error_rate():
    """phi_dot = -C_b^n b for a gyro bias b: the computed attitude ``C0 exp([(w + b) dt])``
    against the true ``C0 exp([w dt])``, ``C_comp = (I - [phi x]) C_true``, over a short dt."""
    C0 = rotations.dcm_from_euler(np.radians([3.0, -2.0, 40.0]))
    model = em.ErrorModel(LAY, _noise())
    F = model.F(_point(C0))
    w = np.radians([1.0, -2.0, 5.0])              # body rate [rad/s]
    dt = 1e-3
    J = np.zeros((3, 3))
    for j in range(3):
        b = np.zeros(3)
        b[j] = 1e-3                               # rad/s
        C_true = C0 @ rotations.dcm_from_rotvec(w * dt)
        C_comp = C0 @ rotations.dcm_from_rotvec((w + b) * dt)
        E = C_comp @ C_true.T                     # I - [phi x]
        phi = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]]) / -2.0
        J[:, j] = phi / dt / b[j]
    g, e, p = LAY["eps_gm"], LAY["eps"], LAY["phi"]
    # over dt the bias acts through the attitude along the interval: to O(dt^2) that is the
    # mid-interval attitude, whose difference from C0 (|w| dt / 2) the check removes
    C_mid = C0 @ rotations.dcm_from_rotvec(w * dt / 2)
    np.testing.assert_allclose(F[p, g] @ C0.T @ C_mid, J, atol=2e-7)
    np.testing.assert_allclose(F[p, g], J, atol=np.linalg.norm(w) * dt)
    np.testing.assert_array_equal(F[p, g], F[p, e])
    np.testing.assert_array_equal(np.diag(F[g, g]), -1.0 / TAU)
    assert (F[e, e] == 0).all() and (F[g, e] == 0).all() and (F[e, g] == 0).all()
    Q = model.Qc()
    np.testing.assert_allclose(np.diag(Q[g, g]), 2 * SIG ** 2 / TAU, rtol=1e-15)
    assert (Q[e, e] == 0).all()
    # with a random walk on the constant, that alone drives eps
    Qrw = em.ErrorModel(LAY, _noise(gyro_bias_rw=1e-7)).Qc()
    np.testing.assert_allclose(np.diag(Qrw[e, e]), 1e-14, rtol=1e-12)
    pat = model.F_pattern()
    assert (F[~pat] == 0).all() and pat[g, g].diagonal().all() and pat[p, g].all()


def test_dr_rows_see_both_parts_and_the_printed_form_neither():
    C0 = rotations.dcm_from_euler(np.radians([1.0, 2.0, -70.0]))
    pt = _point(C0)
    F = em.ErrorModel(LAY_DR, _noise()).F(pt)
    d, g = LAY_DR["phi_D"], LAY_DR["eps_gm"]
    np.testing.assert_array_equal(F[d, g], -C0)
    np.testing.assert_array_equal(F[d, g], F[d, LAY_DR["eps"]])
    printed = em.ErrorModel(LAY_DR, _noise(), dr_sees_gyro_drift=False)
    assert (printed.F(pt)[d, g] == 0).all()
    assert not printed.F_pattern()[d, g].any()


def test_eps_gm_needs_eps_and_a_finite_tau():
    with pytest.raises(ValueError, match="eps_gm"):
        em.ErrorModel(LAY, em.ProcessNoise(gyro_arw=1e-4))
    with pytest.raises(ValueError, match="eps_gm"):
        em.ErrorModel(Layout(["phi", "dv", "dp", "eps_gm"]), _noise())


def test_generated_predict_handles_the_eps_gm_pattern():
    model = em.ErrorModel(LAY_DR, _noise())
    n = LAY_DR.n
    rng = np.random.default_rng(5)
    Qc = model.Qc() + np.diag(rng.uniform(1e-9, 1e-8, n))
    pat = model.F_pattern()
    ws = make_workspace(pat, Qc != 0)
    assert set(range(LAY_DR["eps_gm"].start, LAY_DR["eps_gm"].stop)) <= set(ws.act)
    for trial in range(4):
        C = rotations.dcm_from_euler(rng.uniform(-1, 1, 3))
        F = model.F(_point(C)) if trial % 2 == 0 else np.where(pat, rng.normal(0, 0.3, (n, n)),
                                                                0.0)
        A = rng.standard_normal((n, n))
        P = A @ A.T + n * np.eye(n)
        x = rng.standard_normal(n)
        for dt in (0.01, 0.1, 1.0):
            x0, P0, x1, P1 = x.copy(), P.copy(), x.copy(), P.copy()
            _predict_kernel(x0, P0, F, Qc, dt)
            predict_sparse(x1, P1, F, Qc, dt, ws)
            scale = np.abs(P0).max()
            np.testing.assert_allclose(P1, P0, rtol=0, atol=1e-12 * scale)
            np.testing.assert_allclose(x1, x0, rtol=0, atol=1e-12 * np.abs(x0).max())


def test_engine_propagates_constant_plus_gm_as_the_exact_laws():
    """At rest, level, heading north, no measurement, 60 s: the eps_gm variance follows the
    GM law from its prior, eps keeps its prior, and the heading variance is that of the
    integral of a constant plus a GM process started stationary (plus the ARW)."""
    arw, s_c = 1e-4, 100 * DEG_H
    model = em.ErrorModel(LAY, _noise())
    P0 = LAY.diag({"phi": np.array([1e-8, 1e-8, 1e-6]), "dv": 1e-4,
                   "dp": np.array([1e-14, 1e-14, 1.0]), "eps": s_c ** 2, "nabla": 1e-8,
                   "eps_gm": SIG ** 2})
    init = NavState.from_euler(0.0, 0.6, 1.9, 100.0, np.zeros(3), np.zeros(3))
    f = ErrorStateFilter(init, LAY, model, P0, [], step_rows=10, out_every=10 ** 6)
    dt, n = 0.01, 6000
    t = dt * np.arange(1, n + 1)
    g = np.array([0.0, 0.0, 9.80])
    f.add_imu(t, np.zeros((n, 3)), np.tile(g * dt, (n, 1)), flush=True)
    P = f.covariance()
    T = t[-1]
    np.testing.assert_allclose(np.diag(P[LAY["eps_gm"], LAY["eps_gm"]]), SIG ** 2, rtol=2e-3)
    np.testing.assert_allclose(np.diag(P[LAY["eps"], LAY["eps"]]), s_c ** 2, rtol=1e-9)
    want = (1e-6 + s_c ** 2 * T ** 2 + 2 * SIG ** 2 * TAU ** 2 * (T / TAU - 1 + np.exp(-T / TAU))
            + arw ** 2 * T)
    u = LAY.index("phi_U")
    np.testing.assert_allclose(P[u, u], want, rtol=1e-2)
    # and the two parts are separately visible: the GM part alone would give much less
    gm_only = 1e-6 + 2 * SIG ** 2 * TAU ** 2 * (T / TAU - 1 + np.exp(-T / TAU)) + arw ** 2 * T
    assert P[u, u] > 3 * gm_only


#: the drive of test_gauss_markov_bias, its gyro bias a constant plus a Gauss-Markov part
SCENARIO = {
    **GM_SCENARIO, "name": "two_part_drive",
    "description": "a 2-minute drive with a constant plus Gauss-Markov gyro bias (issue 15 test)",
    "imu": {"rate_hz": 100.0, "constant_errors": "random",
            "gyro": {"drift_deg_h": 100.0, "drift_markov_deg_h": 50.0,
                     "drift_markov_tau_s": 20.0, "arw_deg_sqrt_h": 0.05},
            "accel": {"bias_ug": 300.0, "vrw_ug_sqrt_hz": 30.0}},
}
RUNS = 24


def test_od_kf_with_a_constant_plus_gm_spec_is_consistent_on_simulated_truth():
    nees, sol = attitude_nees({}, SCENARIO, seed=1515, runs=RUNS)
    assert sol.info["gyro_bias_model"] == "constant + gauss-markov"
    assert sol.info["config_source"]["gyro_drift_deg_h"] == "meta.imu (simulated)"
    assert "eps_gm_z" in sol.states and "sigma_eps_gm_z" in sol.states
    lo, hi = chi2.ppf([0.025, 0.975], RUNS) / RUNS
    end = nees[:, -1, :].mean(axis=0)
    run_mean = nees.mean(axis=(0, 1))
    # heading (what the gyro bias model decides): in the 95 % band of the Monte Carlo mean
    assert lo < end[2] < hi and lo < run_mean[2] < hi, (end, run_mean)
    # level: never overconfident; conservative by about 1.4 in sigma (NEES 0.5-0.7 over 32
    # runs), as the one-state Gauss-Markov model is on the same drive with a GM-only bias
    # (0.53-0.56): the 200 pulses/m odometer's row noise, not the bias model (issue 15
    # report); the one-state model given this constant + GM bias (prior = root sum of
    # squares) is at 0.13-0.16
    assert (end[:2] < hi).all() and (run_mean[:2] < hi).all(), (end, run_mean)
    assert (run_mean[:2] > 0.3).all(), run_mean


def test_fkf_fused_reports_the_gauss_markov_part():
    """fkf's bank fuses only the common block, so in fused mode its global estimate had no
    ``eps_gm`` (empty in the states, issue 15 session 24); it now reports the sub-filters'
    estimates fused per axis as eq. 36 fuses the common block (``aided_kf._gm_outputs``): finite
    at every output row, its sigma never above the 50 deg/h prior."""
    from consistency_mc import city_scenario
    from inmotion.align import aided_kf as ak
    from inmotion.sim.scenario import load_scenario
    from inmotion.sim.simulate import simulate
    d = city_scenario(100.0, 50.0, 60.0)
    d["segments"] = d["segments"][:3]
    d["sensors"]["ldv"] = {"rate_hz": 20.0, "output": "distance",
                           "scale_factor_sigma_ppm": 500.0, "noise_m_s": 0.01}
    b = simulate(load_scenario(d), np.random.default_rng(101))
    sol = ak.run_fkf(b, {}, NavState.from_truth(b.truth))
    assert sol.info["gyro_bias_model"] == "constant + gauss-markov"
    for a in "xyz":
        x = np.asarray(sol.states[f"eps_gm_{a}"])
        s = np.asarray(sol.states[f"sigma_eps_gm_{a}"]) * 180 / np.pi * 3600
        assert np.all(np.isfinite(x)) and np.all(np.isfinite(s))
        assert np.all(s <= 50.0 + 1e-6) and s[-1] > 0.0
