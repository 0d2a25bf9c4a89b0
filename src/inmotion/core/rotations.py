"""Attitude representations and their conversions, vectorized over any leading shape.

Every function takes arrays whose last axis (or last two axes for matrices) hold one
rotation, and any number of leading axes: ``(3,)``, ``(N, 3)``, ``(N, M, 3)`` ... A single
rotation in gives a single rotation out. Shape errors say what they got.

Conventions (package charter): ``C = C_b^n`` takes b-vectors to n; Euler angles are
``[pitch, roll, yaw]`` with ``C_b^n = R_z(-yaw) R_x(pitch) R_y(roll)``; quaternions are
scalar-first Hamilton ``q_nb`` with ``v_n = q (x) v_b (x) q*``; the rotation vector ``r`` gives
``C = exp([r x])``; the misalignment ``phi`` is defined by ``C_computed = (I - [phi x]) C_true``.

Generalized Rodrigues parameters (paper 001 eq. 20-21, after Crassidis & Markley 2003):
``p = f * q_vec / (a + q0)``; ``a = 0, f = 1`` gives the Gibbs vector, ``a = 1, f = 1`` the
modified Rodrigues parameters; the USQUE default is ``a = 1, f = 2 (a + 1)``.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "skew", "vee", "rot_x", "rot_y", "rot_z",
    "dcm_from_euler", "euler_from_dcm", "quat_from_dcm", "dcm_from_quat",
    "quat_from_euler", "euler_from_quat", "quat_multiply", "quat_conjugate",
    "quat_normalize", "quat_rotate", "quat_from_rotvec", "rotvec_from_quat",
    "dcm_from_rotvec", "rotvec_from_dcm", "grp_from_quat", "quat_from_grp",
    "gibbs_from_quat", "quat_from_gibbs", "mrp_from_quat", "quat_from_mrp",
    "misalignment", "apply_misalignment", "correct_attitude", "wrap_pi", "wrap_2pi",
    "mounting_dcm",
]


def _check(x, tail, name):
    x = np.asarray(x, dtype=float)
    if x.shape[x.ndim - len(tail):] != tail or x.ndim < len(tail):
        raise ValueError(f"{name} must have shape (..., {', '.join(map(str, tail))}), "
                         f"got {x.shape}")
    return x


def skew(v: ArrayLike) -> np.ndarray:
    """Skew-symmetric matrix ``[v x]`` with ``[v x] @ w = cross(v, w)``; (..., 3) -> (..., 3, 3)."""
    v = _check(v, (3,), "v")
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def vee(m: ArrayLike) -> np.ndarray:
    """Inverse of :func:`skew` (antisymmetric part): (..., 3, 3) -> (..., 3)."""
    m = _check(m, (3, 3), "m")
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2],
                           m[..., 0, 2] - m[..., 2, 0],
                           m[..., 1, 0] - m[..., 0, 1]], axis=-1)


def _elementary(angle, i, j):
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    k = 3 - i - j
    out = np.zeros(angle.shape + (3, 3))
    out[..., k, k] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def rot_x(angle: ArrayLike) -> np.ndarray:
    """Active rotation about x by ``angle`` [rad]: ``[[1,0,0],[0,c,-s],[0,s,c]]``."""
    return _elementary(angle, 1, 2)


def rot_y(angle: ArrayLike) -> np.ndarray:
    """Active rotation about y by ``angle`` [rad]: ``[[c,0,s],[0,1,0],[-s,0,c]]``."""
    return _elementary(angle, 2, 0)


def rot_z(angle: ArrayLike) -> np.ndarray:
    """Active rotation about z by ``angle`` [rad]: ``[[c,-s,0],[s,c,0],[0,0,1]]``."""
    return _elementary(angle, 0, 1)


def dcm_from_euler(euler: ArrayLike) -> np.ndarray:
    """``C_b^n = R_z(-yaw) R_x(pitch) R_y(roll)`` from ``[pitch, roll, yaw]`` [rad]."""
    e = _check(euler, (3,), "euler")
    return rot_z(-e[..., 2]) @ rot_x(e[..., 0]) @ rot_y(e[..., 1])


def euler_from_dcm(C: ArrayLike) -> np.ndarray:
    """``[pitch, roll, yaw]`` [rad] from ``C_b^n``; pitch in [-pi/2, pi/2], yaw in [0, 2 pi)."""
    C = _check(C, (3, 3), "C")
    pitch = np.arcsin(np.clip(C[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-C[..., 2, 0], C[..., 2, 2])
    yaw = wrap_2pi(np.arctan2(C[..., 0, 1], C[..., 1, 1]))
    return np.stack([pitch, roll, yaw], axis=-1)


def quat_normalize(q: ArrayLike) -> np.ndarray:
    """Unit quaternion with non-negative scalar part (the canonical sign)."""
    q = _check(q, (4,), "q")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def dcm_from_quat(q: ArrayLike) -> np.ndarray:
    """``C_b^n`` from the scalar-first quaternion ``q_nb`` (normalized first)."""
    q = _check(q, (4,), "q")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    C = np.empty(q.shape[:-1] + (3, 3))
    C[..., 0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    C[..., 0, 1] = 2 * (q1 * q2 - q0 * q3)
    C[..., 0, 2] = 2 * (q1 * q3 + q0 * q2)
    C[..., 1, 0] = 2 * (q1 * q2 + q0 * q3)
    C[..., 1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    C[..., 1, 2] = 2 * (q2 * q3 - q0 * q1)
    C[..., 2, 0] = 2 * (q1 * q3 - q0 * q2)
    C[..., 2, 1] = 2 * (q2 * q3 + q0 * q1)
    C[..., 2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    return C


def quat_from_dcm(C: ArrayLike) -> np.ndarray:
    """Scalar-first ``q_nb`` from ``C_b^n`` (Shepperd's method: largest pivot, no cancellation)."""
    C = _check(C, (3, 3), "C")
    tr = C[..., 0, 0] + C[..., 1, 1] + C[..., 2, 2]
    piv = np.stack([tr, C[..., 0, 0], C[..., 1, 1], C[..., 2, 2]], axis=-1)
    k = np.argmax(piv, axis=-1)
    q = np.empty(C.shape[:-2] + (4,))
    with np.errstate(divide="ignore", invalid="ignore"):
        # candidate quaternions, each exact where its pivot is the largest
        cands = []
        s = np.sqrt(np.maximum(1.0 + tr, 0.0)) * 2
        cands.append(np.stack([s / 4, (C[..., 2, 1] - C[..., 1, 2]) / s,
                               (C[..., 0, 2] - C[..., 2, 0]) / s, (C[..., 1, 0] - C[..., 0, 1]) / s], -1))
        s = np.sqrt(np.maximum(1.0 + C[..., 0, 0] - C[..., 1, 1] - C[..., 2, 2], 0.0)) * 2
        cands.append(np.stack([(C[..., 2, 1] - C[..., 1, 2]) / s, s / 4,
                               (C[..., 0, 1] + C[..., 1, 0]) / s, (C[..., 0, 2] + C[..., 2, 0]) / s], -1))
        s = np.sqrt(np.maximum(1.0 - C[..., 0, 0] + C[..., 1, 1] - C[..., 2, 2], 0.0)) * 2
        cands.append(np.stack([(C[..., 0, 2] - C[..., 2, 0]) / s, (C[..., 0, 1] + C[..., 1, 0]) / s,
                               s / 4, (C[..., 1, 2] + C[..., 2, 1]) / s], -1))
        s = np.sqrt(np.maximum(1.0 - C[..., 0, 0] - C[..., 1, 1] + C[..., 2, 2], 0.0)) * 2
        cands.append(np.stack([(C[..., 1, 0] - C[..., 0, 1]) / s, (C[..., 0, 2] + C[..., 2, 0]) / s,
                               (C[..., 1, 2] + C[..., 2, 1]) / s, s / 4], -1))
        for i, cand in enumerate(cands):
            q = np.where((k == i)[..., None], cand, q)
    return quat_normalize(q)


def quat_multiply(p: ArrayLike, q: ArrayLike) -> np.ndarray:
    """Hamilton product ``p (x) q`` of scalar-first quaternions (broadcasts)."""
    p = _check(p, (4,), "p")
    q = _check(q, (4,), "q")
    p0, p1, p2, p3 = np.moveaxis(p, -1, 0)
    q0, q1, q2, q3 = np.moveaxis(q, -1, 0)
    return np.stack([p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
                     p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
                     p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
                     p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0], axis=-1)


def quat_conjugate(q: ArrayLike) -> np.ndarray:
    """``q*``: the inverse rotation of a unit quaternion."""
    q = _check(q, (4,), "q")
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(q: ArrayLike, v: ArrayLike) -> np.ndarray:
    """``q (x) v (x) q*``: the vector ``v`` (..., 3) rotated by ``q`` (..., 4)."""
    return np.einsum("...ij,...j->...i", dcm_from_quat(q), _check(v, (3,), "v"))


def quat_from_rotvec(r: ArrayLike) -> np.ndarray:
    """Quaternion of the rotation vector ``r`` [rad] (exact, series near zero)."""
    r = _check(r, (3,), "r")
    a = np.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * a
    small = a < 1e-4
    # sin(a/2)/a with its Taylor series for small a
    k = np.where(small, 0.5 - a * a / 48.0, np.sin(half) / np.where(small, 1.0, a))
    return np.concatenate([np.cos(half), k * r], axis=-1)


def rotvec_from_quat(q: ArrayLike) -> np.ndarray:
    """Rotation vector [rad] of ``q``, angle in [0, pi] (the canonical sign is taken first)."""
    q = quat_normalize(q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    small = s < 1e-8
    k = np.where(small, 2.0 / q[..., :1] * (1.0 - s * s / (3.0 * q[..., :1] ** 2)),
                 angle / np.where(small, 1.0, s))
    return k * q[..., 1:]


def dcm_from_rotvec(r: ArrayLike) -> np.ndarray:
    """``exp([r x])`` by Rodrigues' formula (series near zero)."""
    r = _check(r, (3,), "r")
    a = np.linalg.norm(r, axis=-1)[..., None, None]
    small = a < 1e-4
    a_safe = np.where(small, 1.0, a)
    s = np.where(small, 1.0 - a * a / 6.0, np.sin(a_safe) / a_safe)
    c = np.where(small, 0.5 - a * a / 24.0, (1.0 - np.cos(a_safe)) / a_safe ** 2)
    K = skew(r)
    return np.eye(3) + s * K + c * (K @ K)


def rotvec_from_dcm(C: ArrayLike) -> np.ndarray:
    """Rotation vector [rad] of ``C`` (through the quaternion, robust near pi)."""
    return rotvec_from_quat(quat_from_dcm(C))


def quat_from_euler(euler: ArrayLike) -> np.ndarray:
    """``q_nb`` from ``[pitch, roll, yaw]`` [rad]."""
    e = _check(euler, (3,), "euler")
    z = np.zeros(e.shape[:-1])
    qz = quat_from_rotvec(np.stack([z, z, -e[..., 2]], -1))
    qx = quat_from_rotvec(np.stack([e[..., 0], z, z], -1))
    qy = quat_from_rotvec(np.stack([z, e[..., 1], z], -1))
    return quat_normalize(quat_multiply(quat_multiply(qz, qx), qy))


def euler_from_quat(q: ArrayLike) -> np.ndarray:
    """``[pitch, roll, yaw]`` [rad] from ``q_nb``."""
    return euler_from_dcm(dcm_from_quat(q))


def grp_from_quat(q: ArrayLike, a: float = 1.0, f: Optional[float] = None) -> np.ndarray:
    """Generalized Rodrigues parameters ``p = f q_vec / (a + q0)`` (paper 001 eq. 20).

    ``f`` defaults to ``2 (a + 1)``, which makes ``p`` equal the rotation angle for small angles.
    The quaternion's canonical sign (``q0 >= 0``) is used, so ``a + q0 > 0`` for ``a > 0``.
    """
    q = quat_normalize(q)
    f = 2.0 * (a + 1.0) if f is None else f
    return f * q[..., 1:] / (a + q[..., :1])


def quat_from_grp(p: ArrayLike, a: float = 1.0, f: Optional[float] = None) -> np.ndarray:
    """Inverse of :func:`grp_from_quat` (paper 001 eq. 21).

    ``q0 = (-a |p|^2 + f sqrt(f^2 + (1 - a^2) |p|^2)) / (f^2 + |p|^2)``,
    ``q_vec = (a + q0) p / f``.
    """
    p = _check(p, (3,), "p")
    f = 2.0 * (a + 1.0) if f is None else f
    n2 = np.sum(p * p, axis=-1, keepdims=True)
    q0 = (-a * n2 + f * np.sqrt(f * f + (1.0 - a * a) * n2)) / (f * f + n2)
    return np.concatenate([q0, (a + q0) * p / f], axis=-1)


def gibbs_from_quat(q: ArrayLike) -> np.ndarray:
    """Gibbs vector ``q_vec / q0`` (GRP with a = 0, f = 1)."""
    return grp_from_quat(q, a=0.0, f=1.0)


def quat_from_gibbs(g: ArrayLike) -> np.ndarray:
    """Inverse of :func:`gibbs_from_quat`."""
    return quat_from_grp(g, a=0.0, f=1.0)


def mrp_from_quat(q: ArrayLike) -> np.ndarray:
    """Modified Rodrigues parameters ``q_vec / (1 + q0)`` (GRP with a = 1, f = 1)."""
    return grp_from_quat(q, a=1.0, f=1.0)


def quat_from_mrp(p: ArrayLike) -> np.ndarray:
    """Inverse of :func:`mrp_from_quat`."""
    return quat_from_grp(p, a=1.0, f=1.0)


def misalignment(C_computed: ArrayLike, C_true: ArrayLike) -> np.ndarray:
    """Misalignment ``phi`` [rad] with ``C_computed = exp(-[phi x]) C_true``.

    To first order this is the DESIGN definition ``C_computed = (I - [phi x]) C_true``;
    the exponential form makes it exact for large angles too.
    """
    return -rotvec_from_dcm(_check(C_computed, (3, 3), "C_computed")
                            @ np.swapaxes(_check(C_true, (3, 3), "C_true"), -1, -2))


def apply_misalignment(C_true: ArrayLike, phi: ArrayLike) -> np.ndarray:
    """``exp(-[phi x]) C_true``: the attitude a system with misalignment ``phi`` computes."""
    return dcm_from_rotvec(-_check(phi, (3,), "phi")) @ _check(C_true, (3, 3), "C_true")


def correct_attitude(C_computed: ArrayLike, phi: ArrayLike) -> np.ndarray:
    """Remove an estimated misalignment: ``exp([phi x]) C_computed`` (closed-loop feedback)."""
    return dcm_from_rotvec(_check(phi, (3,), "phi")) @ _check(C_computed, (3, 3), "C_computed")


def wrap_pi(angle: ArrayLike) -> np.ndarray:
    """Angle wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def wrap_2pi(angle: ArrayLike) -> np.ndarray:
    """Angle wrapped to [0, 2 pi)."""
    return np.asarray(angle) % (2 * np.pi)


def mounting_dcm(angles: ArrayLike) -> np.ndarray:
    """``C_v^b = exp([A x])`` of mounting angles ``A = [alpha, beta, gamma]`` [rad].

    The one mounting convention of the package (``docs/ARCHITECTURE.md``, "Vehicle frame and
    mounting"; paper 000 eq. 4-9): ``A`` are the small angles of the vehicle frame v seen from
    the IMU frame b, about b's x (right), y (forward), z (up) axes. Paper 000 writes the
    first-order ``I + [A x]``; the exact rotation vector form has no rotation order and agrees
    with every Euler order of the three angles to second order. The vehicle's forward axis in b
    is ``C_v^b [0, 1, 0] = [-gamma, 1, alpha]`` to first order. A velocity sensor's own beam
    misalignment relative to v uses the same form, ``C_s^v = mounting_dcm(A_s)``.
    """
    return dcm_from_rotvec(_check(angles, (3,), "angles"))
