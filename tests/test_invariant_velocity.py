"""The invariant velocity feedback (issue 15, session 23; :mod:`inmotion.estimation.engine`,
"Invariant velocity error"): its covariance transform and retraction against closed forms, and
on simulated truth the heading the standard EKF claimed to learn from NHC rows that cannot see
it; session 24: the velocity-aided filters of papers 000 and 002 too."""
import functools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from consistency_mc import ARCMIN, city_scenario, turned_start
from inmotion import registry
from inmotion.core.metrics import error_series
from inmotion.core.solution import NavState
from inmotion.estimation import chi2
from inmotion.estimation.engine import _invariant_velocity, _invariant_velocity_reset
from inmotion.sim.scenario import load_scenario
from inmotion.sim.simulate import simulate


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def test_reset_is_J_P_J_transposed_and_exactly_symmetric():
    """``P <- J P J^T``, ``J = I + E``, ``E[dv, phi] = [dV x]``, ``dV = -dv_fb``: against the
    dense product, for every local and the test covariances; the not-fed-back estimate as
    ``J x``; the result symmetric to the last bit; nothing for ``dV = 0``."""
    rng = np.random.default_rng(1)
    n, o_phi, o_dv = 15, 0, 3
    A = rng.standard_normal((2, n, n))
    P = np.einsum("lij,lkj->lik", A, A) + np.eye(n)
    Pa = P[:1] * 2.0
    X = rng.standard_normal((2, n))
    dv_fb = np.array([0.7, -2.0, 0.3])
    J = np.eye(n)
    J[o_dv:o_dv + 3, o_phi:o_phi + 3] = _skew(-dv_fb)
    want_P = J @ P @ J.T
    want_Pa = J @ Pa @ J.T
    want_X = X @ J.T
    P1, Pa1, X1 = P.copy(), Pa.copy(), X.copy()
    _invariant_velocity_reset(P1, X1, Pa1, o_phi, o_dv, tuple(dv_fb))
    np.testing.assert_allclose(P1, want_P, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Pa1, want_Pa, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(X1, want_X, rtol=1e-12, atol=1e-12)
    assert all(np.array_equal(p, p.T) for p in (*P1, *Pa1))
    P2, X2 = P.copy(), X.copy()
    _invariant_velocity_reset(P2, X2, Pa[:0].copy(), o_phi, o_dv, (0.0, 0.0, 0.0))
    assert np.array_equal(P2, P) and np.array_equal(X2, X)


def test_retraction_turns_the_velocity_with_the_attitude_correction():
    """``v_new = R(phi) (v - dv - phi x v)``, ``R(phi)`` the rotation the attitude feedback
    applies (``q <- q(phi) (x) q``, :func:`inmotion.estimation.nav_ops.correct_nav`), here
    from scipy; it differs from the standard ``v - dv`` by ``-phi x dv`` and terms of order
    ``phi^2 v``."""
    from inmotion.core import _kernels as K
    rng = np.random.default_rng(2)
    xs = np.zeros(K.NX)
    v = np.array([8.0, -5.0, 0.2])
    xs[K.VE:K.VE + 3] = v
    o_phi, o_dv = 0, 3
    for scale in (1e-4, 0.3):
        x_g = np.zeros(9)
        x_g[o_phi:o_phi + 3] = scale * rng.standard_normal(3)
        x_g[o_dv:o_dv + 3] = rng.standard_normal(3)
        v_pre, v_new = np.zeros(3), np.zeros(3)
        _invariant_velocity(xs, x_g, o_phi, o_dv, v_pre, v_new)
        phi, dv = x_g[:3], x_g[3:6]
        want = Rotation.from_rotvec(phi).as_matrix() @ (v - dv - np.cross(phi, v))
        np.testing.assert_allclose(v_new, want, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(v_pre, v)
        if scale < 1e-3:
            np.testing.assert_allclose(v_new, v - dv - np.cross(phi, dv),
                                       atol=np.dot(phi, phi) * np.linalg.norm(v))


def test_the_smoother_undoes_the_reset_exactly():
    """:func:`inmotion.estimation.smoother._undo_invariant_reset` is the inverse of the
    engine's reset (``J^-1 = I - E``): a round trip gives back ``x`` and ``P``."""
    from inmotion.estimation.smoother import _undo_invariant_reset
    rng = np.random.default_rng(3)
    n, o_phi, o_dv = 12, 0, 3
    A = rng.standard_normal((n, n))
    P = A @ A.T + np.eye(n)
    x = rng.standard_normal(n)
    dv_fb = np.array([1.5, -0.4, 0.05])
    P1, X1 = P[None].copy(), x[None].copy()
    _invariant_velocity_reset(P1, X1, P1[:0], o_phi, o_dv, tuple(dv_fb))
    assert not np.allclose(P1[0], P)
    dV = -dv_fb
    _undo_invariant_reset(X1[0], P1[0], o_phi, o_dv, dV[0], dV[1], dV[2])
    np.testing.assert_allclose(P1[0], P, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(X1[0], x, rtol=1e-12, atol=1e-12)


@functools.lru_cache(maxsize=1)
def _city_drives(runs=5):
    """``runs`` city drives with a 100 deg/h gyro (plus 50 deg/h, 60 s Gauss-Markov), seeds
    100 ..."""
    sc = load_scenario(city_scenario(100.0, 50.0, 60.0))
    return tuple(simulate(sc, np.random.default_rng(100 + k)) for k in range(runs))


def _both_feedbacks(method="nhc-kf", **config):
    """``(invariant, bundle, solution)``: ``method`` with either feedback (and ``config``)
    over the five city drives of :func:`_city_drives`, started from the truth."""
    run, Config = registry.get(method).load()
    for b in _city_drives():
        for invariant in (True, False):
            yield invariant, b, run(b, Config(invariant_velocity_error=invariant, **config),
                                    NavState.from_truth(b.truth))


@pytest.mark.parametrize("method, above", [("nhc-kf", 2.0), ("sins-dr", 1.3)])
def test_smoothed_heading_with_a_poor_gyro_is_in_its_band(method, above):
    """Forward-backward over the city drive (100 deg/h gyro, 5 runs): with the invariant
    feedback (the smoother undoing its reset) the smoothed attitude NEES at 60, 120 and 200 s
    lies in the 95 % band of chi-square with 15 degrees of freedom over 5 (1.25-5.49;
    measured nhc-kf 2.71, 3.06, 4.39; sins-dr, ``process --smooth``'s navigator, 2.66, 2.27,
    2.15); with the standard feedback it leaves it by ``above`` times its top at the worst
    (nhc-kf 5.89, 10.45, 14.53; sins-dr 5.92, 6.54, 8.06)."""
    nees = {True: [], False: []}
    for invariant, b, sol in _both_feedbacks(method, smooth=True):
        assert sol.info["velocity_error"] == ("invariant" if invariant else "standard")
        e = error_series(sol, b.truth)
        t = np.asarray(sol.t) - sol.t[0]
        row = []
        for x in (60.0, 120.0, 200.0):
            i = np.searchsorted(t, x)
            row.append(sum((e[f"phi_{a}_arcmin"].iloc[i]
                            / (sol.sigma[f"phi_{a}"][i] * ARCMIN)) ** 2 for a in "ENU"))
        nees[invariant].append(row)
    lo, hi = chi2.isf(0.975, 15) / 5, chi2.isf(0.025, 15) / 5
    inv, std = np.mean(nees[True], axis=0), np.mean(nees[False], axis=0)
    assert np.all((lo < inv) & (inv < hi)), inv
    assert np.max(std) > above * hi, std


def _heading(sol, truth):
    phi = error_series(sol, truth)["phi_U_arcmin"].to_numpy()
    sig = np.asarray(sol.sigma["phi_U"]) * ARCMIN
    return np.asarray(sol.t) - sol.t[0], phi, sig


def test_a_turn_of_the_whole_start_stays_unseen():
    """Started with attitude and velocity turned together by 10 deg about the vertical (the
    direction NHC rows cannot see) and priors that cover it, over a city drive with four 90 deg
    turns and a 30 deg/h gyro: with the invariant feedback the heading sigma holds (it keeps
    at least 0.65 of its 60 s value to the end; measured 435-441 arcmin from 20 s on) and
    covers the error; the standard EKF's falls below 0.3 of its 20 s value by 120 s while the
    error stays above 8 deg (measured: 436 at 20 s -> 44-363 at 60 s, 58-116 at 120 s, the
    error 545-685; ``benchmarks/nees_invariant.py --turned 10``). (At 20 s both have 436 of
    the 591 prior: the prior's heading and velocity are independent, and the part of the
    heading that disagrees with the velocity's direction is seen.)"""
    sc = load_scenario(city_scenario(30.0, 15.0, 60.0))
    run, Config = registry.get("nhc-kf").load()
    for k, sign in enumerate((1.0, -1.0)):
        b = simulate(sc, np.random.default_rng(100 + k))
        init = turned_start(b.truth, sign * np.radians(10.0))
        prior = dict(init_heading_sigma_deg=10.0,
                     init_velocity_sigma_m_s=float(np.linalg.norm(init.vel_n))
                     * np.radians(10.0) + 0.05)
        t, phi, sig = _heading(run(b, Config(**prior), init), b.truth)
        i20, i60, i120 = (np.searchsorted(t, x) for x in (20.0, 60.0, 120.0))
        assert sig[-1] > 0.65 * sig[i60] and np.all(np.abs(phi) < 2.0 * sig), (sig[[i60, -1]])
        t, phi, sig = _heading(run(b, Config(**prior, invariant_velocity_error=False), init),
                               b.truth)
        assert sig[i120] < 0.3 * sig[i20] and abs(phi[i120]) > 480.0, (sig[[i20, i120]],
                                                                        phi[i120])


@pytest.mark.parametrize("method, above", [("nhc-kf", 2.0), ("od-velocity-kf", 1.5),
                                           ("sins-dr", 1.5), ("dr-kf", None)])
def test_heading_nees_with_a_poor_gyro_is_in_its_band(method, above):
    """Five runs of the city drive with a 100 deg/h gyro (plus 50 deg/h, 60 s Gauss-Markov),
    the method matched to it: the final heading NEES mean lies in the 95 % band of chi-square
    with 5 degrees of freedom over 5 (0.17-2.57), where the standard EKF's is above it by
    ``above`` times its top (measured, invariant / standard: nhc-kf 0.61 / 7.19,
    od-velocity-kf 0.80 / 5.23, sins-dr 0.43 / 6.25). dr-kf, whose SINS-minus-DR attitude
    rows tie the heading to the DR's, is in the band with either (2.04 / 2.02)."""
    nees = {True: [], False: []}
    for invariant, b, sol in _both_feedbacks(method):
        assert sol.info["velocity_error"] == ("invariant" if invariant else "standard")
        _, phi, sig = _heading(sol, b.truth)
        nees[invariant].append((phi[-1] / sig[-1]) ** 2)
    lo, hi = chi2.isf(0.975, 5) / 5, chi2.isf(0.025, 5) / 5
    assert lo < np.mean(nees[True]) < hi, nees[True]
    if above is not None:
        assert np.mean(nees[False]) > above * hi, nees[False]
