"""H-infinity covariance update (paper 001 eq. 46-56) and the adaptive R (eq. 38-45)."""
import numpy as np
import pytest

from inmotion.estimation import hinf
from inmotion.estimation.adaptive_noise import adapt_noise


def _linear_case(seed, n=4, m=3):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    P = A @ A.T + 0.1 * np.eye(n)
    H = rng.normal(size=(m, n))
    B = rng.normal(size=(m, m))
    R = B @ B.T + 0.2 * np.eye(m)
    return P, P @ H.T, H @ P @ H.T + R, H, R


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_information_form_equals_block_form_eq51(seed):
    P, Pxy, Py, H, R = _linear_case(seed)
    gamma = 2.0 * hinf.gamma_floor(P, Pxy, Py)
    assert np.allclose(hinf.hinf_covariance(P, Pxy, Py, gamma),
                       hinf.hinf_covariance_block(P, Pxy, Py, gamma), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_eq53_information_identity_linear(seed):
    # P+^-1 = P^-1 + H^T R^-1 H - gamma^-2 I for a linear measurement
    P, Pxy, Py, H, R = _linear_case(seed)
    gamma = 3.0 * hinf.gamma_floor(P, Pxy, Py)
    P_plus = hinf.hinf_covariance(P, Pxy, Py, gamma)
    info = np.linalg.inv(P) + H.T @ np.linalg.solve(R, H) - np.eye(len(P)) / gamma ** 2
    assert np.allclose(np.linalg.inv(P_plus), info, rtol=1e-9)


def test_floor_matches_printed_eq54_for_linear_measurement():
    P, Pxy, Py, H, R = _linear_case(5)
    assert np.isclose(hinf.gamma_floor(P, Pxy, Py), hinf.gamma_floor_paper(P, Pxy, R))


def test_positive_definite_exactly_above_the_floor():
    P, Pxy, Py, _, _ = _linear_case(3)
    g_a = hinf.gamma_floor(P, Pxy, Py)
    assert np.linalg.eigvalsh(hinf.hinf_covariance(P, Pxy, Py, 1.001 * g_a))[0] > 0
    assert np.linalg.eigvalsh(hinf.hinf_covariance(P, Pxy, Py, 0.999 * g_a))[0] < 0


def test_large_gamma_gives_kalman_and_small_gamma_inflates():
    P, Pxy, Py, _, _ = _linear_case(4)
    P_kf = hinf.kalman_covariance(P, Pxy, Py)
    assert np.allclose(hinf.hinf_covariance(P, Pxy, Py, 1e6), P_kf, rtol=1e-8)
    g_a = hinf.gamma_floor(P, Pxy, Py)
    P_h = hinf.hinf_covariance(P, Pxy, Py, 1.5 * g_a)
    assert np.linalg.eigvalsh(P_h - P_kf)[0] > 0        # H-infinity is more cautious
    # eq. 56: above gamma_max the Kalman update is used
    assert np.allclose(hinf.hinf_update(P, Pxy, Py, 2 * g_a, gamma_max=g_a), P_kf)
    assert np.allclose(hinf.hinf_update(P, Pxy, Py, 2 * g_a, gamma_max=3 * g_a),
                       hinf.hinf_covariance(P, Pxy, Py, 2 * g_a))


def test_adaptive_gamma_eq55():
    Py = np.diag([1.0, 2.0, 3.0])
    g_a, k0 = 0.01, 2.0
    small = hinf.adaptive_gamma(g_a, Py, np.array([0.1, 0.1, 0.1]), k0, 0.0)
    large = hinf.adaptive_gamma(g_a, Py, np.array([10.0, 10.0, 10.0]), k0, 0.0)
    assert np.isclose(small, (1 + k0 * np.sqrt(6.0 / 0.03)) * g_a)
    assert g_a < large < small                 # an outlier brings gamma down to gamma_a
    assert hinf.adaptive_gamma(g_a, Py, np.array([1e3, 0, 0]), k0, 0.05) == 0.05


# ------------------------------------------------------------------ adaptive R (eq. 42-45)
def _run_noise(rng, sigmas, S=0.01, c=0.98, R0=0.07 ** 2, R_min=1e-4, R_max=4.0):
    """Innovations e ~ N(0, S + sigma_k^2) fed to the estimator; returns the R history."""
    R, eta = np.array([R0]), 1.0
    hist = []
    for s in sigmas:
        e = rng.normal(scale=np.sqrt(S + s * s), size=1)
        R, eta = adapt_noise(R, eta, e, np.array([S]) + R, c, np.array([R_min]),
                             np.array([R_max]))
        hist.append(R[0])
    return np.array(hist)


def test_adaptive_r_follows_a_step_of_the_true_noise():
    rng = np.random.default_rng(0)
    sig = np.r_[np.full(3000, 0.1), np.full(3000, 0.5)]
    R = _run_noise(rng, sig)
    # fading memory ~ 1 / (1 - c) = 50 updates; average over the settled part of each regime
    before, after = np.mean(R[2000:3000]), np.mean(R[4000:6000])
    assert before == pytest.approx(0.1 ** 2, rel=0.3)
    assert after == pytest.approx(0.5 ** 2, rel=0.3)
    # and it gets there within a few memory lengths
    assert np.mean(R[3300:3600]) > 0.5 * 0.5 ** 2


def test_adaptive_r_stays_within_bounds():
    rng = np.random.default_rng(1)
    sig = np.r_[np.zeros(500), np.full(500, 30.0), np.zeros(500)]
    R_min, R_max = 1e-3, 1.0
    R = _run_noise(rng, sig, R_min=R_min, R_max=R_max, S=0.0)
    assert np.all(R >= R_min * (1 - 1e-12)) and np.all(R <= R_max * (1 + 1e-12))
    assert np.isclose(R[700], R_max)          # an outlier sets R_max at once (eq. 44)
    assert R[-1] < 0.1                        # and it decays back once the noise is gone


def test_fading_weight_sequence_eq43():
    eta, c = 1.0, 0.95
    R, e = np.array([1.0]), np.array([0.0])
    for k in range(200):
        R, eta = adapt_noise(R, eta, e, np.array([1.0]), c, np.array([1e-6]), np.array([1e6]))
    assert np.isclose(eta, 1.0 - c, rtol=1e-3)


def test_bound_on_a_subset_of_states():
    # S = L x with L selecting the first two states: P+^-1 = P_KF^-1 - gamma^-2 L^T L
    P, Pxy, Py, H, R = _linear_case(8)
    w = np.array([1.0, 1.0, 0.0, 0.0])
    P_kf = hinf.kalman_covariance(P, Pxy, Py)
    g_a = hinf.gamma_floor(P, Pxy, Py, w)
    assert np.isclose(g_a, np.sqrt(np.linalg.eigvalsh(P_kf[:2, :2])[-1]))
    gamma = 1.5 * g_a
    P_plus = hinf.hinf_covariance(P, Pxy, Py, gamma, w)
    assert np.allclose(np.linalg.inv(P_plus), np.linalg.inv(P_kf) - np.diag(w) / gamma ** 2,
                       rtol=1e-9)
    assert np.linalg.eigvalsh(hinf.hinf_covariance(P, Pxy, Py, 1.001 * g_a, w))[0] > 0
    assert np.linalg.eigvalsh(hinf.hinf_covariance(P, Pxy, Py, 0.999 * g_a, w))[0] < 0
