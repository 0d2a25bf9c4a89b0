"""Federated Kalman filter: information sharing and global fusion (paper 003 sec. 3.1.1).

Carlson's federated filter (paper 003 ref. 40) runs local filters that share a common
reference state (here the SINS errors). Their information about that state would be counted
several times, so the process-noise information and the initial information are split
(eq. 33-35)::

    Q^-1 = sum_i beta_i Q^-1 + beta_m Q^-1,   P^-1 = sum_i beta_i P^-1 + beta_m P^-1,
    sum_i beta_i + beta_m = 1

i.e. local filter ``i`` runs with ``Q / beta_i`` and ``P(0) / beta_i`` (the upper bound that
lets the cross-covariances ``P_ij`` be ignored). The global estimate is eq. 36::

    P_g = (sum_i P_ii^-1)^-1,     X_g = P_g sum_i P_ii^-1 X_i

which, for local estimates that really are independent, is the centralized estimate (the test
suite checks this in the linear Gaussian case).

Why ``P_g`` bounds the fused error when the locals are not independent (issue 15; the paper
states the sharing, this is the argument for it). Stack the local errors: their joint
dynamics are driven by the common process noise, ``[Q Q; Q Q] <= diag(Q / beta_1,
Q / beta_2)`` when ``beta_1 + beta_2 <= 1`` (the difference ``[(1/beta_1 - 1) Q, -Q; -Q,
(1/beta_2 - 1) Q]`` is positive semi-definite iff ``(1/beta_1 - 1)(1/beta_2 - 1) >= 1``, i.e.
``beta_1 + beta_2 <= 1``), likewise the common start error and a measurement noise common to
the channels (the barometer; the vehicle's constraint violation on the odometer's and LDV's
lateral and vertical rows, shared by ``1 / beta`` in ``align.aided_kf``), while each
sensor's own noise is independent. Each local filter's covariance ``P_ii`` is propagated with
its own gains and the bounding noises, so ``diag(P_11, P_22)`` bounds the joint error
covariance (the same Riccati / Lyapunov recursion with larger inputs), and for eq. 36's
fusion ``E[e_g e_g^T] = P_g (sum_ij P_ii^-1 P_ij P_jj^-1) P_g <= P_g``. The non-reset mode's
feedback shifts every local by the same known amount and leaves the errors unchanged. This
holds for the linear model; the engine's local filters are extended ones, where what is
left over is measured (``align.aided_kf``'s docstring: fkf's final-attitude NEES tracks the
single-channel ldv-kf's, run by run). Only the common states are fused; the
states private to one local filter (a sensor's scale factor, mounting, lever arm) stay there.

Sharing at the fusion (issue 15, session 25; ``fkf``'s ``information_sharing: fusion``).
The same bound can be taken at the fusion instead of in the sub-filters: each local runs
with the full ``P(0)``, ``Q`` and ``R`` (it is then the single-sensor filter of its channel)
and eq. 36 weighs its information by ``beta_i``::

    P_g = (sum_i beta_i P_ii^-1)^-1,     X_g = P_g sum_i beta_i P_ii^-1 X_i

This is covariance intersection with fixed weights (Julier and Uhlmann 1997): for
``sum_i beta_i = 1`` and locals whose ``P_ii`` bound their errors, ``P_g`` bounds the fused
error whatever the locals' cross-covariances (``[[P_11, P_12], [P_21, P_22]] <=
diag(P_11 / beta_1, P_22 / beta_2)`` for any joint covariance with those diagonal blocks,
the same inequality as above, here on the locals' covariances rather than on ``Q`` and
``P(0)``). In the linear model both give one bound at the start (``beta_i (P / beta_i)^-1
= P^-1``); they differ in the sub-filters: with the sharing in them each sub-filter's gain
is that of a filter whose ``Q`` and ``P(0)`` are ``1 / beta_i`` times the true ones, larger
steps that an extended filter linearised about a heading several degrees off takes at the
cost of its accuracy (measured in ``align.aided_kf``: ``FkfConfig.information_sharing``);
with the sharing at the fusion each sub-filter keeps its own channel's gains.
"""
from __future__ import annotations

import numpy as np

from .._jit import njit

__all__ = ["fuse", "fuse_kernel", "share"]


def fuse(xs, Ps, weights=None):
    """Global estimate of eq. 36 from local estimates of the same state.

    Parameters
    ----------
    xs : sequence of (n,) local estimates;  Ps : sequence of (n, n) their covariances
    weights : sequence of the locals' information weights (default 1 each: eq. 36 as
        printed; ``beta_i``: the sharing taken at the fusion, module docstring)

    Returns
    -------
    x_g : (n,);  P_g : (n, n)
    """
    w = [1.0] * len(Ps) if weights is None else [float(v) for v in weights]
    info = sum(wi * np.linalg.inv(P) for wi, P in zip(w, Ps))
    P_g = np.linalg.inv(info)
    x_g = P_g @ sum(wi * np.linalg.solve(P, x) for wi, x, P in zip(w, xs, Ps))
    return x_g, 0.5 * (P_g + P_g.T)


def share(P, beta: float):
    """A local filter's share ``P / beta`` of a covariance (eq. 33-34); ``beta`` in (0, 1]."""
    if not 0.0 < beta <= 1.0:
        raise ValueError(f"an information sharing factor must be in (0, 1], got {beta}")
    return np.asarray(P, dtype=float) / beta


@njit(cache=True)
def fuse_kernel(X, P, use, n, x_g, P_g, w):
    """Eq. 36 over the leading ``n`` states of the local filters ``i`` with ``use[i]``, each
    local's information weighted by ``w[i]`` (1: eq. 36 as printed; ``beta_i``: the sharing
    at the fusion, module docstring).

    ``X`` (L, N) local states, ``P`` (L, N, N) covariances, ``w`` (L,); writes ``x_g`` (n,)
    and ``P_g`` (n, n). Returns False when no filter is in use (outputs untouched).
    """
    info = np.zeros((n, n))
    vec = np.zeros(n)
    any_used = False
    for i in range(X.shape[0]):
        if not use[i]:
            continue
        any_used = True
        Pi = np.ascontiguousarray(P[i, :n, :n])
        Ii = np.linalg.inv(0.5 * (Pi + Pi.T))
        if w[i] != 1.0:
            Ii = w[i] * Ii
        info += Ii
        vec += Ii @ np.ascontiguousarray(X[i, :n])
    if not any_used:
        return False
    Pg = np.linalg.inv(info)
    x_g[:] = Pg @ vec
    P_g[:, :] = 0.5 * (Pg + Pg.T)
    return True
