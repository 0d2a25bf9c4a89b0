"""A measurement's own residual-test variances (issue 15, ``Measurement.test_variance``): the
gate statistic, the NIS log and the isolation decisions take ``nu^T (H P H^T + R_test)^-1
nu`` while the update takes ``R``; without a gate the filter is bit for bit the one whose
test takes ``R`` (only the statistic changes). Expected values from the Kalman algebra of a
scalar heading fix (``P r / (P + r)``, ``nu^2 / (P + r_test)``), and, for the engine's
kernels, from a numpy batch solve on a random problem.
"""
import numpy as np
import pytest

from inmotion.estimation import engine as eng
from inmotion.estimation import error_model as em
from inmotion.estimation import measurements as ms
from inmotion.estimation.kalman import sequential_joseph
from update_problems import random_rows_problem
from inmotion.estimation.layout import PHI, Layout
from inmotion.core.solution import NavState
from inmotion.sim import simulate
from inmotion.sim.scenario import find_scenario, load_scenario

ARCMIN = np.pi / 180 / 60
LAY = Layout(["phi", "dv", "dp", "eps", "nabla"])
D0 = np.r_[[ARCMIN * 30] * 2, [ARCMIN * 60], [0.1] * 3, [1e-7, 1e-7, 3.0], [1e-9] * 3,
           [1e-6] * 3]
P0 = D0[2] ** 2
#: the fix, 3 heading sigmas of the prior: c^2 / P0 = 3
C_FIX = np.sqrt(3.0 * P0)


@ms.fill_function
def _fill_heading_fix(xs, xd, aux, acc, data, p, offs, z, H, r):
    """A heading fix ``data[0]`` (the error state's heading: ``z = c``, ``H = e_psi``) with
    noise ``p[0]`` and, when ``p[1] > 0``, the test's variance ``p[1]`` at ``r[dof]``."""
    z[0] = data[0]
    H[0, offs[PHI] + 2] = 1.0
    r[0] = p[0]
    if p[1] > 0.0 and r.shape[0] >= 2:
        r[1] = p[1]
    return 1


class HeadingFix(ms.Measurement):
    name, dof, data_size = "heading_fix", 1, 1
    fill = staticmethod(_fill_heading_fix)

    def __init__(self, r, r_test=0.0, split=True, **kw):
        super().__init__(**kw)
        self.r, self.r_test = float(r), float(r_test)
        self.test_variance = bool(split)
        self.log_nis = True

    def params(self):
        return np.array([self.r, self.r_test])


@pytest.fixture(scope="module")
def rows():
    b = simulate(load_scenario(find_scenario("paper000_traj1")), np.random.default_rng(5))
    n = 6
    return NavState.from_truth(b.truth), b.imu.t[1:n], b.imu.dtheta[1:n], b.imu.dvel[1:n]


def _run(rows, meas, samples=1):
    init, t, dth, dv = rows
    f = eng.ErrorStateFilter(init, LAY, em.ErrorModel(LAY, em.ProcessNoise()),
                             np.diag(D0 ** 2), [meas], step_rows=1, max_nis=10,
                             feedback="open")
    for k in range(samples):
        f.add_measurement("heading_fix", t[k], [C_FIX])
        f.add_imu(t[k:k + 1], dth[k:k + 1], dv[k:k + 1])
    return f


def test_the_statistic_takes_the_test_variance_and_the_update_the_filters(rows):
    """r = P0, r_test = P0 / 4: the update halves the heading variance and moves the estimate
    by half the fix (as without the split: bit for bit), the statistic is ``c^2 / (P0 +
    P0 / 4) = 3 / 1.25 = 2.4`` against ``c^2 / (2 P0) = 1.5`` without."""
    split = _run(rows, HeadingFix(P0, P0 / 4))
    plain = _run(rows, HeadingFix(P0, P0 / 4, split=False))
    same = _run(rows, HeadingFix(P0))                  # test variance not written: r's
    for f in (split, plain, same):
        assert f.covariance()[2, 2] == pytest.approx(P0 / 2, rel=1e-6)
        assert f.x[2] == pytest.approx(C_FIX / 2, rel=1e-6)
    assert np.array_equal(split.x, plain.x) and np.array_equal(split.covariance(),
                                                               plain.covariance())
    assert split.nis_series()[0, 2] == pytest.approx(2.4, rel=1e-6)
    assert plain.nis_series()[0, 2] == pytest.approx(1.5, rel=1e-6)
    assert same.nis_series()[0, 2] == pytest.approx(1.5, rel=1e-6)
    assert split.counts()["heading_fix"]["used"] == 1


def test_the_gate_and_the_isolation_judge_by_the_test_variance(rows):
    """Gate 2.0 between the two statistics (2.4 with the test variance, 1.5 without): the
    split sample is rejected (state untouched), the plain one applied; with ``isolate`` the
    split channel is declared faulty at its first sample."""
    gated = _run(rows, HeadingFix(P0, P0 / 4, gate=2.0))
    assert gated.counts()["heading_fix"]["rejected"] == 1
    assert gated.covariance()[2, 2] == pytest.approx(P0, rel=1e-6) and gated.x[2] == 0.0
    plain = _run(rows, HeadingFix(P0, P0 / 4, split=False, gate=2.0))
    assert plain.counts()["heading_fix"]["used"] == 1
    m = HeadingFix(P0, P0 / 4, gate=2.0)
    m.isolate = True
    iso = _run(rows, m)
    ev, _ = iso.events()
    assert len(ev) >= 1 and ev[0][2] == eng.EVENT_DETECTED and ev[0][3] == pytest.approx(2.4)


def test_the_gated_kernel_is_the_batch_statistic_and_the_plain_update():
    """On a random 3-row problem: ``_gated`` with the split returns the batch ``nu^T (H P H^T
    + diag(r_test))^-1 nu`` (numpy) and leaves ``x``, ``P`` as ``sequential_joseph`` with
    ``r`` makes them, bit for bit; over the gate it leaves them untouched."""
    n, m = 9, 3
    P, x, H, z, rl, rt = random_rows_problem(np.random.default_rng(3), n, m, 0.5)
    S = H[:m] @ P @ H[:m].T + np.diag(rt)
    nu = z[:m] - H[:m] @ x
    want = nu @ np.linalg.solve(S, nu)
    xw, Pw = np.empty(n), np.empty((n, n))
    xa, Pa = x.copy(), P.copy()
    ok, nis = eng._gated(xa, Pa, z, H, rl, rt, m, 0.0, xw, Pw, True, np.empty((0, 0)))
    assert ok and nis == pytest.approx(want, rel=1e-12)
    xb, Pb = x.copy(), P.copy()
    sequential_joseph(xb, Pb, z, H, rl, 0, m, 0.0, xw, Pw)
    assert np.array_equal(xa, xb) and np.array_equal(Pa, Pb)
    xc, Pc = x.copy(), P.copy()
    ok, nis = eng._gated(xc, Pc, z, H, rl, rt, m, 0.99 * want, xw, Pw, True, np.empty((0, 0)))
    assert not ok and nis == pytest.approx(want, rel=1e-12)
    assert np.array_equal(xc, x) and np.array_equal(Pc, P)
    # without the split: the sequential statistic with r (the batch one with r, to rounding)
    xd, Pd = x.copy(), P.copy()
    _, nis_r = eng._gated(xd, Pd, z, H, rl, rt, m, 0.0, xw, Pw, False, np.empty((0, 0)))
    Sr = H[:m] @ P @ H[:m].T + np.diag(rl)
    assert nis_r == pytest.approx(nu @ np.linalg.solve(Sr, nu), rel=1e-10)
    assert np.array_equal(xd, xb) and np.array_equal(Pd, Pb)


def test_fkf_with_the_detection_off_is_bit_for_bit_the_filter_whose_test_takes_r(monkeypatch):
    """fkf's default (the length row tested with its single-interval variance): with the
    detection off its solution is that of the same filter whose test takes the update's
    inflated variance, bit for bit; only the logged statistic differs (larger: a smaller
    variance in its test)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent))
    from consistency_mc import drive_003
    from inmotion.align import aided_kf as ak

    b = simulate(drive_003(), np.random.default_rng(500))
    init = NavState.from_truth(b.truth, euler_error=np.radians([0.05, -0.05, 0.3]))
    cfg = {"fdi": False, "keep_test_statistics": True}
    split = ak.run_fkf(b, cfg, init)
    monkeypatch.setattr(ak._LengthIncrement, "test_variance", False)
    plain = ak.run_fkf(b, cfg, init)
    for k in ("lat", "lon", "h", "vel_n", "euler"):
        assert np.array_equal(getattr(split, k), getattr(plain, k)), k
    for k in split.sigma:
        assert np.array_equal(split.sigma[k], plain.sigma[k]), k
    ls, lp = (s.info["test_statistics"]["lambda"] for s in (split, plain))
    ok = np.isfinite(ls) & np.isfinite(lp)
    assert np.all(ls[ok] >= lp[ok] * (1 - 1e-9)) and np.any(ls[ok] > lp[ok] * 1.01)
