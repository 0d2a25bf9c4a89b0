"""Davenport q-method: exact recovery, kernel/batch agreement, recursion with fading."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.estimation import qmethod


def _random_rotation(rng):
    return rotations.dcm_from_quat(rotations.quat_normalize(rng.normal(size=4)))


@pytest.mark.parametrize("seed", range(5))
def test_recovers_known_rotation_from_noiseless_vectors(seed):
    rng = np.random.default_rng(seed)
    C_true = _random_rotation(rng)
    alpha = rng.normal(size=(7, 3)) * rng.uniform(0.1, 10, size=(7, 1))
    beta = alpha @ C_true.T
    sol = qmethod.solve(qmethod.k_matrix(alpha, beta, rng.uniform(0.5, 2.0, 7)))
    assert np.max(np.abs(sol.C - C_true)) < 1e-10
    # the optimal gain equals sum w |alpha|^2 for exact data, and the gap is positive
    assert sol.gap > 0


def test_two_vectors_are_enough_and_parallel_vectors_have_no_gap():
    rng = np.random.default_rng(7)
    C_true = _random_rotation(rng)
    alpha = np.array([[0.0, 0.0, 9.8], [0.3, 0.0, 9.8]])
    sol = qmethod.solve(qmethod.k_matrix(alpha, alpha @ C_true.T))
    assert np.max(np.abs(sol.C - C_true)) < 1e-10
    par = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]])
    sol_par = qmethod.solve(qmethod.k_matrix(par, par @ C_true.T))
    assert sol_par.gap_rel < 1e-12


def test_kernel_increment_equals_batch_matrix():
    rng = np.random.default_rng(3)
    alpha, beta, w = rng.normal(size=(5, 3)), rng.normal(size=(5, 3)), rng.uniform(size=5)
    K = np.zeros((4, 4))
    for a, b, wi in zip(alpha, beta, w):
        qmethod.k_increment(K, a, b, wi)
    np.testing.assert_allclose(K, qmethod.k_matrix(alpha, beta, w), atol=1e-13)
    np.testing.assert_allclose(K, K.T, atol=0)


def test_recursive_form_with_fading_equals_exponentially_weighted_batch():
    rng = np.random.default_rng(4)
    alpha, beta = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    rec = qmethod.RecursiveQMethod(fading=0.8)
    for a, b in zip(alpha, beta):
        rec.update(a, b)
    w = 0.8 ** np.arange(5, -1, -1)
    np.testing.assert_allclose(rec.K, qmethod.k_matrix(alpha, beta, w), atol=1e-13)
    with pytest.raises(ValueError):
        qmethod.RecursiveQMethod(fading=0.0)


def test_vectorized_solve_over_a_stack():
    rng = np.random.default_rng(5)
    Cs = np.stack([_random_rotation(rng) for _ in range(4)])
    alpha = rng.normal(size=(3, 3))
    Ks = np.stack([qmethod.k_matrix(alpha, alpha @ C.T) for C in Cs])
    sol = qmethod.solve(Ks)
    assert sol.C.shape == (4, 3, 3)
    assert np.max(np.abs(sol.C - Cs)) < 1e-10


def test_centred_form_removes_a_constant_offset_exactly():
    rng = np.random.default_rng(8)
    C_true = _random_rotation(rng)
    alpha = rng.normal(size=(20, 3)) * np.arange(1, 21)[:, None]
    offset = np.array([0.3, -0.2, 0.5])
    beta = alpha @ C_true.T
    w = rng.uniform(0.5, 1.5, 20)
    K = qmethod.k_matrix(alpha + offset, beta, w)
    Kc = qmethod.k_centered(K, w @ (alpha + offset), w @ beta, w.sum())
    assert np.max(np.abs(qmethod.solve(Kc).C - C_true)) < 1e-10
    assert np.max(np.abs(qmethod.solve(K).C - C_true)) > 1e-4    # the offset does bias plain K
    # equals K of the explicitly centred vectors
    a_c = alpha + offset - (w @ (alpha + offset)) / w.sum()
    b_c = beta - (w @ beta) / w.sum()
    np.testing.assert_allclose(Kc, qmethod.k_matrix(a_c, b_c, w), atol=1e-9)


def test_triad_equals_q_method_for_two_exact_vectors():
    rng = np.random.default_rng(11)
    C_true = _random_rotation(rng)
    a1, a2 = rng.normal(size=3), rng.normal(size=3)
    C = qmethod.triad(a1, a2, C_true @ a1, C_true @ a2)
    assert np.max(np.abs(C - C_true)) < 1e-12
    Cq = qmethod.solve(qmethod.k_matrix(np.stack([a1, a2]), np.stack([C_true @ a1, C_true @ a2]))).C
    assert np.max(np.abs(C - Cq)) < 1e-10
    with pytest.raises(ValueError):
        qmethod.triad(a1, 2 * a1, a1, 2 * a1)
