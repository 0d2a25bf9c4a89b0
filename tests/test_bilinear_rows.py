"""Issue 15, session 21: the body-frame velocity and displacement rows' bilinear term in the
attitude and velocity errors (``estimation.second_order``: its variance into the noise, its
value at the estimate out of the innovation), the rows with a mounting taken at its
estimate, and the DR restarted at the SINS as the speed comes back after a gap.

Checked against sampling of the Gaussian the moments assume, against the exact rotation the
term stands for (what is left is third order), and on the filters it is for: the simulated
phone drive with its odometer out for 35 s, whose final-attitude NEES was 7.8-14.8 over 20
runs against a band of 2.02-4.16."""
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.stats import chi2

from inmotion import registry
from inmotion.estimation import second_order as so
from inmotion.core.bundle import Bundle
from inmotion.core.metrics import error_series
from inmotion.core.rotations import skew
from inmotion.core.solution import NavState
from inmotion.sim.scenario import load_scenario
from inmotion.sim.simulate import simulate


def _gaussian(seed, mean):
    rng = np.random.default_rng(seed)
    L = rng.normal(size=(6, 6))
    P = L @ L.T * 0.1
    P[:3] *= 0.03                         # attitude [rad] against velocity [m/s]
    P[:, :3] *= 0.03
    return np.asarray(mean, float), P


@pytest.mark.parametrize("seed, mean", [(0, [0.0] * 6),
                                        (1, [0.01, -0.02, 0.005, 0.3, -0.2, 0.1])])
def test_bilinear_moments_match_sampling(seed, mean):
    m, P = _gaussian(seed, mean)
    h = np.array([0.1, 0.5, -0.2])
    got_mean, got_var = so.bilinear_moments(np.r_[m, P.ravel()], h)
    x = np.random.default_rng(100 + seed).multivariate_normal(m, P, size=400_000)
    q = np.cross(x[:, :3], x[:, 3:]) @ h
    # sampling error of the mean and variance of 400,000 draws (the variance's with the
    # product's heavier tails: 4 standard errors of a Gaussian's, times 2)
    se_mean = q.std() / np.sqrt(len(q))
    assert abs(got_mean - q.mean()) < 4.0 * se_mean
    assert got_var == pytest.approx(q.var(), rel=8.0 * np.sqrt(2.0 / len(q)))
    assert got_var > 0.0


def test_bilinear_term_is_the_rotation_s_second_order():
    """``C (I + [phi x]) (v + dv)`` is what the rows linearize; with the exact rotation
    ``exp([phi x])`` the rows' first order plus ``h . (phi x dv)`` leaves a third-order rest
    (and the ``[phi x]^2 v / 2`` the term does not describe, which is removed here)."""
    v = np.array([3.0, 14.0, 0.2])
    phi = np.radians([0.8, -1.1, 1.5])
    dv = np.array([4.0, -6.0, 0.5])
    exact = expm(skew(phi)) @ (v + dv)
    first = v + dv + np.cross(phi, v)
    quad = 0.5 * skew(phi) @ skew(phi) @ v
    a = np.linalg.norm(phi)
    third = a * a * (np.linalg.norm(dv) / 2.0 + a * np.linalg.norm(v) / 6.0)   # its bound
    means = []
    for i, h in enumerate(np.eye(3)):
        st = np.r_[phi, dv, np.zeros(36)]           # the mean alone: P = 0
        mean, var = so.bilinear_moments(st, h)
        assert var == 0.0
        rest = exact[i] - first[i] - quad[i] - mean
        assert abs(rest) < third, (i, rest, mean, third)
        means.append(abs(mean))
    assert max(means) > 20.0 * third      # the term is what matters at this size


def _gap_nees(seed, start=5.0, end=40.0, gap=True):
    from inmotion.io.importers.comma2k19 import PHONE_IMU_SPEC
    from inmotion.reproductions.real import comma_like_scenario
    b = simulate(load_scenario(comma_like_scenario()), np.random.default_rng(seed))
    b.meta = {**b.meta, "imu": {"rate_hz": 100.0, **PHONE_IMU_SPEC}}
    t0 = float(b.imu.t[0])
    odo = b.odometer.dropout(t0 + start, t0 + end) if gap else b.odometer
    cut = Bundle(b.imu, b.meta, odometer=odo, truth=b.truth)
    run, Config = registry.get("od-kf").load()
    sol = run(cut, Config(), NavState.from_truth(b.truth))
    last = error_series(sol, b.truth).iloc[-1]
    phi = np.radians([last[f"phi_{k}_arcmin"] / 60.0 for k in "ENU"])
    sig = np.array([sol.sigma[f"phi_{k}"][-1] for k in "ENU"])
    return float(np.sum((phi / sig) ** 2))


@pytest.mark.slow
def test_od_kf_across_a_speed_gap_is_consistent():
    """The phone drive (``reproductions.real.comma_like_scenario``, the importer's phone spec)
    with the odometer out from 5 to 40 s: after 35 s of coasting the velocity error is metres
    per second and the tilt a degree or two, and the first samples after the gap carry their
    product. Without the term: 10.65 over 20 runs (seeds 100-119; one run at 50), the second
    sample after the gap moving the tilt by an arc-degree the wrong way. With it (measured,
    seeds 100-119): 2.99. The phone spec's gyro wander (150 deg/h) is three times the
    simulated one (50), so od-kf is conservative on this drive: without the gap its NEES is
    0.73 (seeds 100-109), and 2.99 was in the band only by the gap's overconfidence on top.
    With the invariant velocity feedback (session 23, od-kf's default) the gap leaves it
    where it is: 0.87 against 0.75 without the gap (seeds 100-109 here). The test: not above
    the band, and the gap moves the mean by less than half."""
    runs = 10
    vals = [_gap_nees(100 + s) for s in range(runs)]
    ref = [_gap_nees(100 + s, gap=False) for s in range(runs)]
    hi = chi2.ppf(0.975, 3 * runs) / runs
    assert np.mean(vals) <= hi, (np.mean(vals), np.round(vals, 2))
    assert abs(np.mean(vals) / np.mean(ref) - 1.0) < 0.5, (np.mean(vals), np.mean(ref))


def _kernel_state(euler_deg, vel):
    from inmotion.core import rotations
    xs = np.zeros(10)
    xs[0], xs[2] = np.radians(37.0), 20.0
    xs[3:6] = vel
    xs[6:10] = rotations.quat_from_euler(np.radians(euler_deg))
    return xs


def _state_with_mount(a):
    from inmotion.estimation.measurements import ST_MOUNT, STATE_PARAMS
    st = np.zeros(STATE_PARAMS)
    st[ST_MOUNT:ST_MOUNT + 3] = a
    return st


def test_nhc_rows_are_taken_at_the_mounting_estimate():
    """The mounting estimate stays in the state (it is never fed back): the NHC rows are taken
    in the vehicle frame it gives, so the innovation the engine forms, ``z - H x``, is the
    exact prediction there, ``exp(-[a x]) C_vn v`` (rows x and z); at the nominal frame it
    differs by the second order (``v a^2 / 2``, here mm/s)."""
    from inmotion.core.rotations import dcm_from_euler
    from inmotion.estimation.layout import Layout
    from inmotion.estimation.measurements import Nhc
    lay = Layout(["phi", "dv", "mount"])
    xs = _kernel_state([130.0, 2.0, -1.0], [12.0, -9.0, 0.3])
    a = np.radians([3.8, 0.4, -0.8])
    x = np.zeros(lay.n)
    x[lay["mount"]] = a
    C_bn = dcm_from_euler(np.radians([130.0, 2.0, -1.0]))       # C_b^n
    exact = (expm(-skew(a)) @ C_bn.T @ xs[3:6])[[0, 2]]
    nav = (xs, xs.copy(), np.zeros(10))
    z, H, _ = Nhc(0.1).rows(nav, None, lay, state=_state_with_mount(a))
    np.testing.assert_allclose(z - H @ x, exact, atol=1e-12)
    z0, H0, _ = Nhc(0.1, second_order=False).rows(nav, None, lay)
    assert np.max(np.abs(z0 - H0 @ x - exact)) > 1e-3


def test_dr_velocity_rows_are_taken_at_the_mounting_estimate():
    """The SINS-minus-DR velocity rows likewise: the DR's velocity turned by the mounting
    estimate, ``z - H x = C_n^b_D (v_S - exp([(C_D a) x]) v_D)``."""
    from inmotion.core.rotations import dcm_from_euler
    from inmotion.estimation.layout import Layout
    from inmotion.estimation.measurements import SinsDrVelocity
    lay = Layout(["phi", "dv", "phi_D", "mount"])
    xs = _kernel_state([130.0, 2.0, -1.0], [12.0, -9.0, 0.3])
    xd = _kernel_state([130.2, 1.5, -1.1], [11.5, -9.4, 1.0])
    a = np.radians([3.8, 0.4, -0.8])
    x = np.zeros(lay.n)
    x[lay["mount"]] = a
    C_D = dcm_from_euler(np.radians([130.2, 1.5, -1.1]))
    exact = C_D.T @ (xs[3:6] - expm(skew(C_D @ a)) @ xd[3:6])
    z, H, _ = SinsDrVelocity(0.1).rows((xs, xd, np.zeros(10)), None, lay,
                                       state=_state_with_mount(a))
    np.testing.assert_allclose(z - H @ x, exact, atol=1e-12)


def test_dr_reseed_cuts_precede_the_speed_s_return():
    """``velocity_aided._dr_reseeds``: the cut is the last filter epoch end at or before the
    first row with the speed back (so every sample that reads it comes after the reseed);
    none without a DR or without a return."""
    from inmotion.estimation.velocity_aided import _dr_reseeds
    blind = np.array([0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 0, 0], bool)
    ends = np.array([2, 4, 6, 8, 10, 12])
    assert _dr_reseeds(blind, ends, False, True) == ([4, 10], False)
    assert _dr_reseeds(blind, ends, False, False) == ([], False)
    assert _dr_reseeds(~blind, ends, True, True) == ([2, 8], True)
    assert _dr_reseeds(np.zeros(12, bool), ends, True, True) == ([0], False)  # back at row 0
    assert _dr_reseeds(np.ones(12, bool), ends, False, True) == ([], True)


def _gap_run(name, seed, start=5.0, end=40.0):
    from inmotion.io.importers.comma2k19 import PHONE_IMU_SPEC
    from inmotion.reproductions.real import comma_like_scenario
    b = simulate(load_scenario(comma_like_scenario()), np.random.default_rng(seed))
    b.meta = {**b.meta, "imu": {"rate_hz": 100.0, **PHONE_IMU_SPEC}}
    t0 = float(b.imu.t[0])
    cut = Bundle(b.imu, b.meta, odometer=b.odometer.dropout(t0 + start, t0 + end),
                 truth=b.truth)
    run, Config = registry.get(name).load()
    return run(cut, Config(), NavState.from_truth(b.truth)), b.truth


@pytest.mark.slow
@pytest.mark.parametrize("name", ["sins-dr", "dr-kf", "od-velocity-kf"])
def test_velocity_aided_filters_are_not_overconfident_across_a_speed_gap(name):
    """The same drive and gap with the filters of ``velocity_aided``. Before session 21 (20
    runs, seeds 100-119, band 2.02-4.16): sins-dr 7.82, dr-kf 14.75, od-velocity-kf 13.18.
    Now 0.75, 1.69, 1.66 (without a gap 0.66, 1.13, 0.96: the random-walk bias model and the
    rows' second-order variance make them conservative on this drive, not overconfident):
    sins-dr's DR restarts at the SINS as the speed comes back (``dr_reseeds``), the rows
    with the mounting are taken at its estimate and carry their bilinear term. What is
    asserted is the upper end of the band over seeds 100-109."""
    runs = 10
    vals = []
    for s in range(runs):
        sol, truth = _gap_run(name, 100 + s)
        last = error_series(sol, truth).iloc[-1]
        phi = np.radians([last[f"phi_{k}_arcmin"] / 60.0 for k in "ENU"])
        sig = np.array([sol.sigma[f"phi_{k}"][-1] for k in "ENU"])
        vals.append(float(np.sum((phi / sig) ** 2)))
        if name != "od-velocity-kf":          # the gap's end (and the first speed sample)
            assert sol.info["dr_reseeds"] >= 1
    hi = chi2.ppf(0.975, 3 * runs) / runs
    assert np.mean(vals) <= hi, (np.mean(vals), np.round(vals, 2))


def test_reseed_dr_position_is_the_copy_transform():
    """``ErrorStateFilter.reseed_dr_position``: the DR's position becomes the SINS's and its
    position error the SINS's, ``x' = T x``, ``P' = T P T^T`` with ``T`` the identity whose
    ``dp_D`` rows copy ``dp``'s (closed form here); a filter without a DR refuses."""
    from inmotion.estimation import error_model as em
    from inmotion.estimation.engine import ErrorStateFilter
    from inmotion.estimation.layout import Layout
    lay = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D"])
    init = NavState(0.0, np.radians(37.0), np.radians(-122.0), 20.0,
                    np.array([10.0, 5.0, 0.0]), np.array([1.0, 0.0, 0.0, 0.0]))
    rng = np.random.default_rng(0)
    L = rng.normal(size=(lay.n, lay.n))
    P0 = L @ L.T * 1e-6 + np.eye(lay.n) * 1e-8
    f = ErrorStateFilter(init, lay, em.ErrorModel(lay, em.ProcessNoise()), P0, [])
    S = f._S
    S.xd[0:3] += [1e-5, -2e-5, 3.0]                 # the DR off the SINS
    S.X[0] = rng.normal(size=lay.n)
    x0 = S.X[0].copy()
    T = np.eye(lay.n)
    o, od = lay["dp"], lay["dp_D"]
    T[od] = 0.0
    T[od, o] = np.eye(3)
    f.reseed_dr_position()
    np.testing.assert_array_equal(S.xd[0:3], S.xs[0:3])
    np.testing.assert_allclose(S.X[0], T @ x0, atol=0)
    np.testing.assert_allclose(S.P[0], T @ P0 @ T.T, atol=1e-20)
    no_dr = Layout(["phi", "dv", "dp", "eps", "nabla"])
    g = ErrorStateFilter(init, no_dr, em.ErrorModel(no_dr, em.ProcessNoise()),
                         np.eye(no_dr.n) * 1e-6, [])
    with pytest.raises(ValueError, match="needs a filter with a DR"):
        g.reseed_dr_position()


def test_rows_refuse_a_state_of_the_wrong_size():
    """``Measurement.rows(state=...)``: the values the engine would hand a measurement that
    wants its filter's state must be :data:`STATE_PARAMS` long; anything else is named."""
    from inmotion.estimation.layout import Layout
    from inmotion.estimation.measurements import STATE_PARAMS, Nhc
    lay = Layout(["phi", "dv", "mount"])
    xs = _kernel_state([10.0, 0.0, 0.0], [5.0, 5.0, 0.0])
    with pytest.raises(ValueError, match=f"nhc: state holds {STATE_PARAMS} values, got shape "
                                         r"\(42,\)"):
        Nhc(0.1).rows((xs, xs.copy(), np.zeros(10)), None, lay, state=np.zeros(42))


def test_the_mount_spread_blocks_are_the_linear_transform_of_the_covariance():
    """``measurements._with_mount_spread`` (scalar code on tuples since session 22, no
    allocation) against its closed form: ``psi = phi - C_vn^T a`` is ``T [phi, dv, mount]``
    with ``T = [I, 0, -C_vn^T]``, so ``Cov(psi) = (T P T^T)`` and ``Cov(dv, psi) =
    P_v,: T^T``; and ``bilinear_rows_blocks`` with ``st``'s own blocks is ``bilinear_rows``
    bit for bit."""
    from inmotion.estimation import measurements as ms_mod
    rng = np.random.default_rng(7)
    G = rng.normal(size=(9, 9))
    P = G @ G.T * 1e-4 + np.eye(9) * 1e-6          # [phi, dv, mount]
    C = expm(skew(rng.normal(size=3)))             # C_vn
    st = np.zeros(ms_mod.STATE_PARAMS)
    st[:6] = rng.normal(size=6) * 1e-2
    st[6:42] = P[:6, :6].ravel()
    st[ms_mod.ST_MOUNT_COV:ms_mod.ST_MOUNT_COV + 27] = P[6:9, :].ravel()
    Ppsi, Pvpsi = ms_mod._with_mount_spread(st, tuple(C[0]), tuple(C[1]), tuple(C[2]))
    T = np.hstack([np.eye(3), np.zeros((3, 3)), -C.T])
    np.testing.assert_allclose(np.reshape(Ppsi, (3, 3)), T @ P @ T.T, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(np.reshape(Pvpsi, (3, 3)), P[3:6, :] @ T.T, rtol=1e-12,
                               atol=1e-18)
    H = rng.normal(size=(3, 12))
    z1, r1 = np.zeros(3), np.full(3, 1e-2)
    z2, r2 = z1.copy(), r1.copy()
    so.bilinear_rows(z1, H, r1, st, 3, 0, 3)
    so.bilinear_rows_blocks(z2, H, r2, tuple(st[:3]), tuple(st[3:6]), so.cov_block(st, 0, 0),
                            so.cov_block(st, 3, 3), so.cov_block(st, 3, 0), 3, 0, 3)
    assert np.array_equal(z1, z2) and np.array_equal(r1, r2) and (r1 > 1e-2).all()
