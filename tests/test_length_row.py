"""Issue 15: the paper 003 displacement rows' along-sensor row compared as a length
(``aided_kf._length_fill``), checked against plane geometry: a SINS displacement of length
``L`` at an angle ``c`` off the sensor's distance ``d`` leaves ``L - d`` on that row, where the
first-order rows leave ``L cos c - d``; the lateral and vertical rows and ``H`` are the plain
fill's; a slow or stopped interval (angle beyond ``LENGTH_MAX_ANGLE``) keeps the plain rows."""
import numpy as np
import pytest

from inmotion.align import aided_kf as ak
from inmotion.estimation import measurements as ms
from inmotion.estimation.aiding_rows import SUB_LAYOUT


def _rows(fill, dD_n, dP_n, T=0.5, exact=False):
    xs = np.zeros(10)
    xs[6] = 1.0                       # identity attitude: n and b axes coincide
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    acc[ms.ACC_D:ms.ACC_D + 3] = dD_n
    acc[ms.ACC_W:ms.ACC_W + 3] = dD_n
    acc[ms.ACC_DP:ms.ACC_DP + 3] = dP_n
    m = ms.DisplacementIncrement(np.array([0.01, 0.0014, 0.02]), exact_attitude_columns=exact)
    p = np.asarray(m.params(), dtype=float)
    z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(3)
    n = fill(xs, xs, np.zeros(ms.AUX_SIZE), acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
    return n, z, H, r


@pytest.mark.parametrize("c_deg, L", [(0.5, 7.0), (2.0, 7.003), (-1.0, 6.99)])
def test_along_sensor_row_is_the_length_residual(c_deg, L):
    d = 7.0
    c = np.radians(c_deg)
    dD = np.array([0.0, d, 0.0])
    dP = L * np.array([np.sin(c) * 0.6, np.cos(c), np.sin(c) * 0.8])   # off in both axes
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP)
    assert plain[0] == length[0] == 3
    np.testing.assert_allclose(plain[1][1], L * np.cos(c) - d, atol=1e-12)
    np.testing.assert_allclose(length[1][1], L - d, atol=1e-12)
    np.testing.assert_allclose(length[1][[0, 2]], plain[1][[0, 2]], atol=0)
    np.testing.assert_array_equal(length[2], plain[2])
    np.testing.assert_array_equal(length[3], plain[3])


@pytest.mark.parametrize("c_deg, L", [(0.5, 7.0), (2.0, 7.003), (-1.0, 6.99)])
def test_length_row_with_exact_attitude_columns(c_deg, L):
    """``exact_attitude_columns`` (issue 15): the attitude columns from the SINS's
    displacement, ``-[Delta P_b x]``; the along row, the length ``|Delta P_b| - |Delta D_b|``,
    differentiates the SINS side along the SINS's displacement ``u_P`` and the sensor side
    along the sensor's."""
    d = 7.0
    c = np.radians(c_deg)
    dD = np.array([0.0, d, 0.0])
    dP = L * np.array([np.sin(c) * 0.6, np.cos(c), np.sin(c) * 0.8])
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP, exact=True)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP, exact=True)
    np.testing.assert_allclose(length[1][1], L - d, atol=1e-12)
    np.testing.assert_array_equal(length[2][[0, 2]], plain[2][[0, 2]])
    # identity attitude: the plain rows' attitude columns are -[Delta P_b x]
    np.testing.assert_allclose(plain[2][:, SUB_LAYOUT["phi"]],
                               -np.array([[0.0, -dP[2], dP[1]], [dP[2], 0.0, -dP[0]],
                                          [-dP[1], dP[0], 0.0]]), atol=1e-15)
    u = dP / np.linalg.norm(dP)
    sensor = np.zeros(SUB_LAYOUT.n, bool)
    for b in ("dk", "mount", "lever"):
        sensor[SUB_LAYOUT[b]] = True
    np.testing.assert_allclose(length[2][1, ~sensor], (u @ plain[2])[~sensor], atol=1e-15)
    np.testing.assert_array_equal(length[2][1, sensor], plain[2][1, sensor])
    # a length has no attitude column (none here: no specific force given)
    np.testing.assert_allclose(length[2][1, SUB_LAYOUT["phi"]], 0.0, atol=1e-12)


def test_slow_interval_keeps_the_first_order_rows():
    """Stopped (2 mm of distance, 1 cm across: 0.46 rad): the plain rows."""
    dD = np.array([0.0, 0.002, 0.0])
    dP = np.array([0.01, 0.002, 0.0])
    assert np.arctan2(0.01, 0.002) > ak.LENGTH_MAX_ANGLE
    plain = _rows(ms.DisplacementIncrement.fill, dD, dP)
    length = _rows(ak._length_fill(ms.DisplacementIncrement.fill), dD, dP)
    np.testing.assert_array_equal(length[1], plain[1])


def _symmetry_rows(a_fwd, gamma, k, exact, T=0.5, n=50, v0=10.0):
    """One straight interval at forward acceleration ``a_fwd``: the SINS displacement exact,
    the sensor's turned by a mounting ``gamma`` [rad] and scaled by ``1 + k``; identity
    attitude (n = b)."""
    dt = T / n
    t = np.arange(1, n + 1) * dt
    xs = np.zeros(10)
    xs[6] = 1.0

    def v(tt):
        return np.array([0.0, v0 + a_fwd * tt, 0.0])
    dP = sum(0.5 * (v(tt - dt) + v(tt)) * dt for tt in t)
    Rg = np.array([[np.cos(gamma), -np.sin(gamma), 0.0], [np.sin(gamma), np.cos(gamma), 0.0],
                   [0.0, 0.0, 1.0]])
    dD = (1.0 + k) * (Rg @ dP)
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    acc[ms.ACC_DP:ms.ACC_DP + 3] = dP
    acc[ms.ACC_D:ms.ACC_D + 3] = dD
    acc[ms.ACC_W:ms.ACC_W + 3] = dD
    acc[ms.ACC_FN:ms.ACC_FN + 3] = [0.0, a_fwd * T, 9.8 * T]
    m = ms.DisplacementIncrement(np.array([0.001, 4e-5, 0.001]), exact_attitude_columns=exact)
    p = np.asarray(m.params(), dtype=float)
    z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(3)
    ak._length_fill(ms.DisplacementIncrement.fill)(
        xs, xs, np.zeros(ms.AUX_SIZE), acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
    return z, H, v(T)


@pytest.mark.parametrize("a_fwd, gamma_arcmin, k", [(0.0, 15.0, 2e-3), (0.5, 15.0, 2e-3),
                                                    (0.5, -30.0, -2e-3), (0.0, 0.0, 0.0)])
def test_rows_are_blind_to_a_rotation_about_the_vertical(a_fwd, gamma_arcmin, k):
    """Issue 15: a SINS whose attitude and velocity are both turned by ``psi`` about the
    vertical (``phi = [0, 0, psi]``, ``dv = v x phi``) has exactly the true body-frame
    displacement, so the rows ``z = C_n^b Delta P_n - Delta D_b`` do not change: ``H`` must
    give 0 in that direction, whatever the sensor's own errors in ``z``. With the attitude
    columns from the sensor's displacement (before) ``H x = -[z x] psi``: a 15' mounting
    (2.2 cm over 7 m) at psi = 1e-3 gives 2.2e-5 m on the along row, a 20,000 pulses/m
    odometer's whole noise, so the filter reads the heading from the mounting's residual
    (``benchmarks/heading_symmetry.py``); ``exact_attitude_columns`` gives 0."""
    psi = 1e-3
    phi = np.array([0.0, 0.0, psi])
    hx = {}
    for exact in (True, False):
        z, H, v_end = _symmetry_rows(a_fwd, np.radians(gamma_arcmin / 60.0), k, exact)
        x = np.zeros(SUB_LAYOUT.n)
        x[SUB_LAYOUT["phi"]] = phi
        x[SUB_LAYOUT["dv"]] = np.cross(v_end, phi)
        hx[exact] = H @ x
    np.testing.assert_allclose(hx[True], 0.0, atol=1e-12)
    # paper 003's form (the sensor's displacement) sees psi against the residual z (the
    # sensor's mounting and scale): psi |z| on the along row, a fine odometer's noise
    if gamma_arcmin:
        assert abs(z[0]) > 1e-2
        assert np.abs(hx[False]).max() > 0.9 * psi * abs(z[0])


def _rot(phi):
    """``exp(-[phi x])``: the turn that takes a true vector to the SINS's, ``C_b^n`` computed
    ``= (I - [phi x]) C_b^n`` true to first order."""
    a = np.linalg.norm(phi)
    if a == 0.0:
        return np.eye(3)
    k = phi / a
    K_ = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) - np.sin(a) * K_ + (1.0 - np.cos(a)) * K_ @ K_


def _straight_interval(d, T):
    """A straight interval of ``d`` [m] over ``T`` [s] along the body's forward axis whose SINS
    and sensor displacements agree: ``(dD, xs, acc)`` for a displacement fill."""
    dD = np.array([0.0, d, 0.0])
    xs = np.zeros(10)
    xs[6] = 1.0
    acc = np.zeros(ms.ACC_SIZE)
    acc[ms.ACC_T] = T
    for o in (ms.ACC_D, ms.ACC_W, ms.ACC_DP):
        acc[o:o + 3] = dD
    return dD, xs, acc


def _heading_quadrature(s, v, H):
    """``(w, psi, hx)``: Gauss-Hermite weights, the headings and the rows ``H`` applied to the error state of a
    SINS turned as a whole by a heading ``psi ~ N(0, s^2)`` (its velocity ``v`` turned with
    it: ``dv = v_SINS - v_true``), at the 40 nodes."""
    nodes, w = np.polynomial.hermite_e.hermegauss(40)
    hx = []
    for psi in s * nodes:
        phi = np.array([0.0, 0.0, psi])
        x = np.zeros(SUB_LAYOUT.n)
        x[SUB_LAYOUT["phi"]] = phi
        x[SUB_LAYOUT["dv"]] = (np.eye(3) - _rot(phi).T) @ v
        hx.append(H @ x)
    return w / w.sum(), s * nodes, np.array(hx)


def _second_order_rows(P6, d=7.0, T=0.5):
    """The length fill with ``second_order_length`` on a straight interval whose SINS and
    sensor displacements agree (``z = 0``), the filter's ``[phi, dv]`` at zero with
    covariance ``P6``; and the same without: ``(z, r)`` of each, ``H``."""
    return _fills(P6, d, T, 1.0, 3)


def _fills(P6, d, T, var_scale, n_r):
    """The length fill without and with ``second_order_length`` (its variance ``var_scale``
    times) on :func:`_straight_interval`, handed ``n_r`` noise entries: ``[(z, r, H)] * 2``."""
    dD, xs, acc = _straight_interval(d, T)
    m = ms.DisplacementIncrement(np.array([0.01, 4e-5, 0.02]), exact_attitude_columns=True)
    p = np.r_[m.params(), np.zeros(6), P6.ravel(), np.zeros(ms.STATE_PARAMS - 42)]
    out = []
    for second in (False, True):
        z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(n_r)
        ak._length_fill(ms.DisplacementIncrement.fill, second, 0, var_scale)(
            xs, xs, np.zeros(ms.AUX_SIZE), acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
        out.append((z, r, H))
    return out


@pytest.mark.parametrize("s_deg", [0.5, 2.0])
def test_second_order_length_for_a_sins_turned_as_a_whole(s_deg):
    """Issue 15 (``second_order_length``, ``aided_kf._length_second_order``): a SINS turned
    as a whole by ``psi`` about the vertical (attitude and velocity: the true velocity is
    ``R^T v`` of the SINS's ``v``, ``dv = (I - R^T) v``)
    shows no residual on any row (the same displacement in b), while the first-order
    length row predicts ``H x = d (1 - cos psi)`` (the velocity turned with the heading,
    read along the SINS's track). Over ``psi ~ N(0, s^2)`` (Gauss-Hermite, 40 nodes) the
    fill must move ``z`` by the mean of ``H x`` (``d s^2 / 2`` to second order) and add its
    variance (``d^2 s^4 / 2``) plus the heading floor ``E[psi^4] d^2 / 4``; the lateral rows
    must see nothing of that direction to first order."""
    d, T = 7.0, 0.5
    s = np.radians(s_deg)
    v = np.array([0.0, d / T, 0.0])
    J = np.r_[[0.0, 0.0, 1.0], np.cross(v, [0.0, 0.0, 1.0])]     # d x / d psi at 0
    (z0, r0, H), (z1, r1, _) = _second_order_rows(s * s * np.outer(J, J), d, T)
    w, psi, hx = _heading_quadrature(s, v, H)
    mean, var = w @ hx[:, 1], w @ (hx[:, 1] - w @ hx[:, 1]) ** 2
    e4 = w @ psi ** 4
    np.testing.assert_allclose(mean, d * (1.0 - np.exp(-s * s / 2)), rtol=1e-9)  # geometry
    assert np.abs(w @ hx[:, 0]) < 1e-3 * mean            # the lateral row: blind
    rel = 3.0 * s * s                                    # the expansion's next order
    np.testing.assert_allclose(z1[1] - z0[1], mean, rtol=rel)
    np.testing.assert_allclose(r1[1] - r0[1], var + e4 * d * d / 4, rtol=rel)
    np.testing.assert_array_equal(z1[[0, 2]], z0[[0, 2]])
    np.testing.assert_array_equal(r1[[0, 2]], r0[[0, 2]])


def test_second_order_length_for_a_heading_error_alone():
    """The heading alone off (the SINS's velocity true): the SINS's displacement is the
    true one in length, and the lateral row sees ``psi d``, so the length row's model error
    is 0 (``d psi^2 / 2`` of the turned track less ``|b_perp|^2 / (2 d)``, the same): the
    fill moves ``z`` by nothing (to 1e-9 of ``d s^2 / 2``). Beyond ``LENGTH_MAX_ANGLE`` of
    attitude sigma it adds nothing at all."""
    s = np.radians(0.5)
    J = np.r_[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    (z0, r0, _), (z1, r1, _) = _second_order_rows(s * s * np.outer(J, J))
    assert abs(z1[1] - z0[1]) < 1e-9 * 7.0 * s * s / 2
    big = np.radians(10.0)
    assert big > ak.LENGTH_MAX_ANGLE
    (z0, r0, _), (z1, r1, _) = _second_order_rows(big * big * np.outer(J, J))
    np.testing.assert_array_equal(z1, z0)
    np.testing.assert_array_equal(r1, r0)


@pytest.mark.parametrize("t, memory_max, n", [(15.0, np.inf, 30.0), (0.2, np.inf, 1.0),
                                              (15.0, 16.0, 16.0)])
def test_length_memory_takes_the_second_order_variance_n_times(t, memory_max, n):
    """``aided_kf.LENGTH_MEMORY_MAX`` (issue 15, helper h15nees6): the length row's
    second-order variance (the same as taken once, the other rows and the innovation
    untouched) times the intervals the filter has combined since its start, ``(t - t0) / T``
    (the filter started at 5 s, 0.5 s intervals: 30 at 20 s), at least 1 and at most the
    bound."""
    d, T, t0 = 7.0, 0.5, 5.0
    s = np.radians(0.5)
    v = np.array([0.0, d / T, 0.0])
    J = np.r_[[0.0, 0.0, 1.0], np.cross(v, [0.0, 0.0, 1.0])]
    P6 = s * s * np.outer(J, J)
    dD, xs, acc = _straight_interval(d, T)
    aux = np.zeros(ms.AUX_SIZE)
    aux[ms.AUX_T] = t0 + t
    m = ak._LengthIncrement(np.array([0.01, 4e-5, 0.02]), exact_attitude_columns=True,
                            start_s=t0)
    p = np.r_[m.params(), np.zeros(6), P6.ravel(), np.zeros(ms.STATE_PARAMS - 42)]
    assert p[ak.P_START] == t0
    out = []
    for fill in (ak._length_fill(ms.DisplacementIncrement.fill, False),
                 ak._length_fill(ms.DisplacementIncrement.fill, True),
                 ak._length_fill(ms.DisplacementIncrement.fill, True, 0, 1.0, memory_max)):
        z, H, r = np.zeros(3), np.zeros((3, SUB_LAYOUT.n)), np.zeros(3)
        fill(xs, xs, aux, acc, np.zeros(1), p, SUB_LAYOUT.offsets(), z, H, r)
        out.append((z, r))
    (z0, r0), (z1, r1), (z2, r2) = out
    assert r1[1] > r0[1]
    np.testing.assert_allclose(r2[1] - r0[1], n * (r1[1] - r0[1]), rtol=1e-12)
    np.testing.assert_array_equal(z2, z1)
    np.testing.assert_array_equal(r2[[0, 2]], r1[[0, 2]])


def _split_rows(P6, d=7.0, T=0.5):
    """The default's length fill (``second_order_length``, the variance taken
    ``LENGTH_VAR_SCALE`` times) handed ``2 dof`` noise entries, as the engine hands them:
    ``(r, r_first_order)``, ``r[3:]`` the residual test's variances (``test_variance``)."""
    (_, r0, _), (_, r, _) = _fills(P6, d, T, ak.LENGTH_VAR_SCALE, 6)
    return r, r0


def test_the_length_rows_test_variance_is_the_single_intervals_for_a_heading_error_alone():
    """Issue 15 (helper h15split): the heading alone off, the length row's model error is 0
    for every heading (the lateral row's ``|b_perp|^2 / (2 d)`` and the track's ``d psi^2 /
    2`` cancel: the test above), so its single-interval variance is 0: the residual test's
    variance (``r[dof + 1]``) is the first-order row's to 1e-9 of ``d^2 s^4 / 2``, while the
    update's carries ``LENGTH_VAR_SCALE`` times the two parts' variances (their correlation
    left out) and the heading floor."""
    d, s = 7.0, np.radians(0.5)
    J = np.r_[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    r, r0 = _split_rows(s * s * np.outer(J, J), d)
    assert abs(r[4] - r0[1]) < 1e-9 * d * d * s ** 4 / 2
    assert r[1] - r0[1] > ak.LENGTH_VAR_SCALE * d * d * s ** 4 / 2
    assert r[3] == 0.0 and r[5] == 0.0                      # the other rows: as r
    np.testing.assert_array_equal(r[[0, 2]], r0[[0, 2]])


@pytest.mark.parametrize("s_deg", [0.5, 2.0])
def test_the_length_rows_test_variance_for_a_sins_turned_as_a_whole(s_deg):
    """A SINS turned as a whole by ``psi ~ N(0, s^2)``: the length row's model error is the
    first-order row's ``H x`` over the turn (Gauss-Hermite, as in the test above); the
    residual test's variance is the first-order row's plus that error's variance (not the
    heading floor, not ``LENGTH_VAR_SCALE``: one interval's marginal law), to the expansion's
    next order."""
    d, T = 7.0, 0.5
    s = np.radians(s_deg)
    v = np.array([0.0, d / T, 0.0])
    J = np.r_[[0.0, 0.0, 1.0], np.cross(v, [0.0, 0.0, 1.0])]
    r, r0 = _split_rows(s * s * np.outer(J, J), d, T)
    (_, _, H), _ = _second_order_rows(s * s * np.outer(J, J), d, T)
    w, psi, hx = _heading_quadrature(s, v, H)
    hx = hx[:, 1]
    var = w @ (hx - w @ hx) ** 2
    np.testing.assert_allclose(r[4] - r0[1], var, rtol=3.0 * s * s)
    e4 = w @ psi ** 4
    np.testing.assert_allclose(r[1] - r0[1], ak.LENGTH_VAR_SCALE * (var + e4 * d * d / 4),
                               rtol=3.0 * s * s)
