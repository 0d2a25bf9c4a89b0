"""Rotations: property-based round trips of every conversion, and the DESIGN conventions."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from inmotion.core import rotations as R

#: per-test settings (no global profile: other test files keep theirs)
FAST = settings(max_examples=60, deadline=None)

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
vec3 = arrays(float, 3, elements=st.floats(-10, 10, allow_nan=False, allow_infinity=False,
                                           allow_subnormal=False))


@st.composite
def unit_quats(draw, min_q0=None):
    """Unit quaternions, canonical sign (q0 >= 0), optionally with q0 >= min_q0."""
    q = np.array([draw(finite) for _ in range(4)])
    n = np.linalg.norm(q)
    if n < 1e-3:
        q, n = np.array([1.0, 0, 0, 0]), 1.0
    q = q / n
    q = -q if q[0] < 0 else q
    if min_q0 is not None and q[0] < min_q0:
        q = R.quat_normalize(np.concatenate([[min_q0 + 0.1], q[1:]]))
    return q


@st.composite
def eulers(draw):
    """[pitch, roll, yaw] away from the pitch singularity, roll in [-pi, pi), yaw in [0, 2 pi)."""
    return np.array([draw(st.floats(-1.5, 1.5)), draw(st.floats(-np.pi, np.pi - 1e-9)),
                     draw(st.floats(0.0, 2 * np.pi - 1e-9))])


@st.composite
def rotvecs(draw, max_angle=np.pi - 1e-3):
    axis = draw(vec3)
    n = np.linalg.norm(axis)
    axis = np.array([1.0, 0, 0]) if n < 1e-6 else axis / n
    return axis * draw(st.floats(0.0, max_angle, allow_subnormal=False))


def same_rotation(p, q, tol=1e-12):
    """Quaternions equal up to sign."""
    return min(np.abs(p - q).max(), np.abs(p + q).max()) < tol


# ---------------------------------------------------------------- round trips
@FAST
@given(vec3)
def test_skew_vee_and_cross(v):
    w = np.array([0.3, -1.2, 2.0])
    assert np.allclose(R.skew(v) @ w, np.cross(v, w), atol=1e-12)
    assert np.allclose(R.vee(R.skew(v)), v, atol=0)
    assert np.allclose(R.skew(v), -R.skew(v).T)


@FAST
@given(eulers())
def test_euler_dcm_round_trip(e):
    C = R.dcm_from_euler(e)
    assert np.allclose(C @ C.T, np.eye(3), atol=1e-14) and np.linalg.det(C) > 0
    e2 = R.euler_from_dcm(C)
    assert np.allclose(R.wrap_pi(e2 - e), 0, atol=1e-9)
    assert 0 <= e2[2] < 2 * np.pi


@FAST
@given(unit_quats())
def test_quat_dcm_round_trip(q):
    C = R.dcm_from_quat(q)
    assert np.allclose(C @ C.T, np.eye(3), atol=1e-14)
    assert same_rotation(R.quat_from_dcm(C), q, 1e-12)


@FAST
@given(eulers())
def test_quat_euler_round_trip_and_agreement(e):
    q = R.quat_from_euler(e)
    assert np.allclose(R.dcm_from_quat(q), R.dcm_from_euler(e), atol=1e-14)
    assert np.allclose(R.wrap_pi(R.euler_from_quat(q) - e), 0, atol=1e-9)


@FAST
@given(rotvecs())
def test_rotvec_round_trips(r):
    q = R.quat_from_rotvec(r)
    assert abs(np.linalg.norm(q) - 1) < 1e-14
    assert np.allclose(R.rotvec_from_quat(q), r, atol=1e-11)
    C = R.dcm_from_rotvec(r)
    assert np.allclose(C, R.dcm_from_quat(q), atol=1e-14)
    assert np.allclose(R.rotvec_from_dcm(C), r, atol=1e-7)


@FAST
@given(rotvecs(max_angle=1e-3))
def test_small_rotvec_series_match_exact_forms(r):
    a = np.linalg.norm(r)
    C = R.dcm_from_rotvec(r)
    K = R.skew(r)
    exact = np.eye(3) + (np.sin(a) / a if a else 1.0) * K \
        + ((1 - np.cos(a)) / a ** 2 if a else 0.5) * K @ K
    assert np.allclose(C, exact, atol=1e-15)


@FAST
@given(unit_quats(), unit_quats())
def test_quat_product_composes_dcms(p, q):
    assert np.allclose(R.dcm_from_quat(R.quat_multiply(p, q)),
                       R.dcm_from_quat(p) @ R.dcm_from_quat(q), atol=1e-13)
    assert np.allclose(R.quat_multiply(q, R.quat_conjugate(q)), [1, 0, 0, 0], atol=1e-14)
    v = np.array([1.0, -2.0, 0.5])
    assert np.allclose(R.quat_rotate(q, v), R.dcm_from_quat(q) @ v, atol=1e-13)


@FAST
@given(unit_quats(), st.floats(0.0, 1.0), st.floats(0.5, 4.0))
def test_grp_round_trip(q, a, f):
    """Generalized Rodrigues parameters (paper 001 eq. 20-21), any ``a`` in [0, 1], ``f`` > 0."""
    if a + q[0] < 0.1:                # singular where a + q0 = 0 (Gibbs: at 180 deg)
        q = R.quat_normalize(np.concatenate([[0.2], q[1:]]))
    p = R.grp_from_quat(q, a=a, f=f)
    assert same_rotation(R.quat_from_grp(p, a=a, f=f), q, 1e-9)


@FAST
@given(unit_quats(min_q0=0.05))
def test_gibbs_and_mrp_round_trips(q):
    g = R.gibbs_from_quat(q)
    assert np.allclose(g, q[1:] / q[0])
    assert same_rotation(R.quat_from_gibbs(g), q, 1e-9)
    m = R.mrp_from_quat(q)
    assert np.allclose(m, q[1:] / (1 + q[0]))
    assert np.linalg.norm(m) <= 1 + 1e-12
    assert same_rotation(R.quat_from_mrp(m), q, 1e-12)


@FAST
@given(rotvecs(max_angle=1e-2))
def test_default_grp_is_the_rotation_angle_for_small_angles(r):
    """``a = 1, f = 2 (a + 1)``: ``p ~ r`` to third order."""
    p = R.grp_from_quat(R.quat_from_rotvec(r))
    assert np.allclose(p, r, rtol=0, atol=np.linalg.norm(r) ** 3 + 1e-300)


def test_vectorized_shapes():
    rng = np.random.default_rng(0)
    e = np.stack([rng.uniform(-1, 1, (4, 5)), rng.uniform(-3, 3, (4, 5)),
                  rng.uniform(0, 6, (4, 5))], -1)
    assert R.dcm_from_euler(e).shape == (4, 5, 3, 3)
    q = R.quat_from_euler(e)
    assert q.shape == (4, 5, 4)
    assert np.allclose(R.euler_from_quat(q), e)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        R.dcm_from_euler(np.zeros(4))


# ---------------------------------------------------------------- conventions
def test_forward_axis_east_is_yaw_90_deg():
    """Body y (forward) pointing East, x (right) South, z Up: heading 90 deg."""
    C_nb = np.column_stack([[0, -1, 0], [1, 0, 0], [0, 0, 1]]).astype(float)
    assert np.allclose(R.euler_from_dcm(C_nb), [0, 0, np.pi / 2])
    assert np.allclose(R.dcm_from_euler([0, 0, np.pi / 2]) @ [0, 1, 0], [1, 0, 0])


def test_pitch_up_and_roll_right_down():
    """Positive pitch lifts the nose, positive roll lowers the right side."""
    assert (R.dcm_from_euler([0.1, 0, 0]) @ [0, 1, 0])[2] > 0
    assert (R.dcm_from_euler([0, 0.1, 0]) @ [1, 0, 0])[2] < 0


@FAST
@given(eulers(), rotvecs(max_angle=0.5))
def test_misalignment_round_trip(e, phi):
    C = R.dcm_from_euler(e)
    Cc = R.apply_misalignment(C, phi)
    assert np.allclose(R.misalignment(Cc, C), phi, atol=1e-9)
    assert np.allclose(R.correct_attitude(Cc, phi), C, atol=1e-13)


@FAST
@given(eulers(), rotvecs(max_angle=1e-6))
def test_misalignment_first_order_is_design_definition(e, phi):
    """``C_computed = (I - [phi x]) C_true`` to first order."""
    C = R.dcm_from_euler(e)
    Cc = R.apply_misalignment(C, phi)
    assert np.allclose(Cc, (np.eye(3) - R.skew(phi)) @ C, atol=1e-12)


@FAST
@given(eulers())
def test_paper000_eq25_27_hold_as_printed(e):
    """Euler-angle errors from misalignment, paper 000 eq. 25-27 (SINS part, ``T = C_b^n``):

    ``dpsi = -T12 T32/(T12^2+T22^2) phi_E - T32 T22/(T12^2+T22^2) phi_N + phi_U``,
    ``dtheta = -T22/sqrt(1-T32^2) phi_E + T12/sqrt(1-T32^2) phi_N``,
    ``dgamma = (T21 T33 - T23 T31)/(T31^2+T33^2) phi_E + (T13 T31 - T11 T33)/(T31^2+T33^2) phi_N``.
    """
    T = R.dcm_from_euler(e)
    t = lambda i, j: T[i - 1, j - 1]                       # noqa: E731 (1-based, as printed)
    den_y, den_p, den_r = t(1, 2) ** 2 + t(2, 2) ** 2, np.sqrt(1 - t(3, 2) ** 2), \
        t(3, 1) ** 2 + t(3, 3) ** 2
    J_printed = np.array([
        [-t(2, 2) / den_p, t(1, 2) / den_p, 0.0],
        [(t(2, 1) * t(3, 3) - t(2, 3) * t(3, 1)) / den_r,
         (t(1, 3) * t(3, 1) - t(1, 1) * t(3, 3)) / den_r, 0.0],
        [-t(1, 2) * t(3, 2) / den_y, -t(3, 2) * t(2, 2) / den_y, 1.0]])
    h = 1e-7
    J = np.empty((3, 3))
    for i in range(3):
        phi = np.zeros(3)
        phi[i] = h
        J[:, i] = R.wrap_pi(R.euler_from_dcm(R.apply_misalignment(T, phi)) - e) / h
    assert np.allclose(J, J_printed, atol=2e-5 * max(1.0, np.abs(J_printed).max()))


def test_wraps():
    assert R.wrap_pi(np.pi) == pytest.approx(-np.pi)
    assert R.wrap_2pi(-0.5) == pytest.approx(2 * np.pi - 0.5)
