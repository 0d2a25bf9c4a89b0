"""Quaternion averaging (Markley et al. 2007) against closed forms and invariances."""
import numpy as np
import pytest

from inmotion.core import rotations
from inmotion.estimation.quat_average import quat_average, quat_average_matrix


def _same_rotation(p, q, tol):
    assert abs(abs(np.dot(p, q)) - 1.0) < tol


def test_single_rotation_either_sign():
    q = rotations.quat_from_euler(np.radians([10.0, -20.0, 135.0]))
    qs = np.array([q, -q, q])
    avg = quat_average(qs, np.array([0.2, 0.5, 0.3]))
    _same_rotation(avg, q, 1e-14)
    assert avg[0] >= 0.0


@pytest.mark.parametrize("w1", [0.5, 0.2, 0.9])
def test_two_rotations_about_one_axis_closed_form(w1):
    # q_i = [cos(a_i/2), sin(a_i/2) u]: the eigenvector of sum w q q^T lies in their plane at
    # angle phi with tan(2 phi) = sum w sin a / sum w cos a, i.e. rotation angle
    # atan2(sum w sin a_i, sum w cos a_i) about u.
    u = np.array([1.0, 2.0, -2.0]) / 3.0
    a = np.radians([10.0, 70.0])
    w = np.array([w1, 1.0 - w1])
    qs = rotations.quat_from_rotvec(a[:, None] * u)
    expected_angle = np.arctan2(np.sum(w * np.sin(a)), np.sum(w * np.cos(a)))
    _same_rotation(quat_average(qs, w), rotations.quat_from_rotvec(expected_angle * u), 1e-14)


def test_symmetric_sigma_set_averages_to_centre_with_negative_weight():
    rng = np.random.default_rng(3)
    q0 = rotations.quat_normalize(rng.normal(size=4))
    d = np.radians(5.0) * np.eye(3)
    dq = np.vstack([[1, 0, 0, 0], rotations.quat_from_rotvec(d), rotations.quat_from_rotvec(-d)])
    qs = rotations.quat_multiply(dq, q0)
    w = np.array([-0.5] + [0.25] * 6)
    _same_rotation(quat_average(qs, w), q0, 1e-13)


def test_right_multiplication_invariance():
    rng = np.random.default_rng(7)
    qs = rotations.quat_normalize(rotations.quat_from_rotvec(rng.normal(scale=0.3, size=(9, 3))))
    w = rng.uniform(0.1, 1.0, 9)
    p = rotations.quat_normalize(rng.normal(size=4))
    lhs = quat_average(rotations.quat_multiply(qs, p), w)
    rhs = rotations.quat_multiply(quat_average(qs, w), p)
    _same_rotation(lhs, rhs, 1e-12)


def test_average_maximizes_the_weighted_attitude_fit():
    rng = np.random.default_rng(11)
    qs = rotations.quat_normalize(rotations.quat_from_rotvec(rng.normal(scale=0.5, size=(6, 3))))
    w = rng.uniform(0.1, 1.0, 6)
    avg = quat_average(qs, w)
    M = quat_average_matrix(qs, w)
    best = avg @ M @ avg
    for _ in range(50):
        trial = rotations.quat_normalize(avg + rng.normal(scale=0.05, size=4))
        assert trial @ M @ trial <= best + 1e-12
