"""What the update-kernel tests share (issue 15): a random measurement-update problem."""
import numpy as np


def random_rows_problem(rng, n: int = 9, m: int = 3, density: float = 0.5):
    """``(P, x, H, z, rl, rt)``: a symmetric positive definite ``P`` (n, n), an estimate ``x``,
    ``m`` sparse rows in an ``H`` of ``m + 1`` rows (the engine's buffers are longer than a
    sample's rows), ``z`` (m + 1,), the update's noise ``rl`` and the test's ``rt`` (the
    length row's larger for the update, as ``fkf``'s)."""
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    x = rng.standard_normal(n)
    H = np.zeros((m + 1, n))
    H[:m] = rng.standard_normal((m, n)) * (rng.random((m, n)) < density)
    z = rng.standard_normal(m + 1)
    rl = np.array([0.5, 2.0, 0.3])[:m]
    rt = np.array([0.5, 0.6, 0.3])[:m]
    return P, x, H, z, rl, rt
