"""The RTS smoother (:mod:`inmotion.estimation.smoother`) against the batch least-squares
solution of a linear Gaussian system, with closed-loop resets in the forward pass; and the
engine's forward records smoothed on a simulated drive, against simulated truth."""
import gc
import os

import numpy as np
import pytest

from inmotion.estimation.smoother import ForwardRecord, rts_backward


def _linear_problem(rng, n=4, m=2, N=40):
    Phi = np.stack([np.eye(n) + 0.1 * rng.standard_normal((n, n)) for _ in range(N)])
    Q = np.stack([np.diag(rng.uniform(0.01, 0.1, n)) for _ in range(N)])
    H = np.stack([rng.standard_normal((m, n)) for _ in range(N)])
    R = np.stack([np.diag(rng.uniform(0.1, 1.0, m)) for _ in range(N)])
    m0, P0 = rng.standard_normal(n), np.diag(rng.uniform(0.5, 2.0, n))
    x = rng.multivariate_normal(m0, P0)
    z = []
    for k in range(N):
        if k:
            x = Phi[k] @ x + rng.multivariate_normal(np.zeros(n), Q[k])
        z.append(H[k] @ x + rng.multivariate_normal(np.zeros(m), R[k]))
    return Phi, Q, H, R, m0, P0, np.array(z)


def _forward(Phi, Q, H, R, m0, P0, z, reset_every):
    """A Kalman filter on the error relative to a nominal state that absorbs the estimate
    every ``reset_every`` epochs (closed loop), recording what the engine records."""
    N, n = len(z), len(m0)
    nom = m0.copy()                 # nominal; error estimate relative to it
    dx, P = np.zeros(n), P0.copy()
    rec = {k: [] for k in ("phi", "p_pred", "x", "p", "fb", "nom")}
    for k in range(N):
        if k:
            nom = Phi[k] @ nom
            dx = Phi[k] @ dx
            P = Phi[k] @ P @ Phi[k].T + Q[k]
        rec["phi"].append(Phi[k])
        rec["p_pred"].append(P.copy())
        S = H[k] @ P @ H[k].T + R[k]
        K = P @ H[k].T @ np.linalg.inv(S)
        dx = dx + K @ (z[k] - H[k] @ (nom + dx))
        IKH = np.eye(n) - K @ H[k]
        P = IKH @ P @ IKH.T + K @ R[k] @ K.T
        fb = dx.copy() if reset_every and k % reset_every == 0 else np.zeros(n)
        nom, dx = nom + fb, dx - fb
        for key, v in (("x", dx), ("p", P), ("fb", fb), ("nom", nom)):
            rec[key].append(np.array(v, dtype=float, copy=True))
    return {k: np.array(v) for k, v in rec.items()}


def _batch_least_squares(Phi, Q, H, R, m0, P0, z):
    """The MAP estimate of all states at once (normal equations) and its covariance."""
    N, n = len(z), len(m0)
    J = np.zeros((N * n, N * n))
    g = np.zeros(N * n)

    def add(rows, A, W, b):             # || A x - b ||^2_W over the state blocks in rows
        idx = np.concatenate([np.arange(r * n, (r + 1) * n) for r in rows])
        J[np.ix_(idx, idx)] += A.T @ W @ A
        g[idx] += A.T @ W @ b

    add([0], np.eye(n), np.linalg.inv(P0), m0)
    for k in range(1, N):
        add([k - 1, k], np.hstack([-Phi[k], np.eye(n)]), np.linalg.inv(Q[k]), np.zeros(n))
    for k in range(N):
        add([k], H[k], np.linalg.inv(R[k]), z[k])
    cov = np.linalg.inv(J)
    return np.linalg.solve(J, g).reshape(N, n), np.stack(
        [cov[k * n:(k + 1) * n, k * n:(k + 1) * n] for k in range(N)])


@pytest.mark.parametrize("reset_every", [0, 1, 3])
def test_rts_equals_batch_least_squares_on_a_linear_gaussian_system(reset_every):
    rng = np.random.default_rng(reset_every + 1)
    prob = _linear_problem(rng)
    rec = _forward(*prob, reset_every=reset_every)
    N, n = rec["x"].shape
    xs, Ps = np.empty((N, n)), np.empty((N, n, n))
    rts_backward(rec["x"], rec["p"], rec["phi"], rec["p_pred"], rec["fb"], xs, Ps)
    ref_x, ref_P = _batch_least_squares(*prob)
    np.testing.assert_allclose(rec["nom"] + xs, ref_x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Ps, ref_P, rtol=1e-8, atol=1e-10)
    # and the smoother is no worse than the filter anywhere
    Pf = rec["p"]
    assert np.all(np.trace(Ps, axis1=1, axis2=2) <= np.trace(Pf, axis1=1, axis2=2) + 1e-12)


def test_forward_record_spills_to_disk_beyond_its_budget(tmp_path):
    rec = ForwardRecord(3, 10, memory_budget_bytes=2000, folder=tmp_path)
    chunk = {"t": np.arange(4.0), "phi": np.ones((4, 3, 3)), "p_pred": np.ones((4, 3, 3)),
             "x": np.ones((4, 3)), "p": np.ones((4, 3, 3)), "fb": np.zeros((4, 3)),
             "fed": np.zeros((4, 3)), "xs": np.zeros((4, 10)), "epoch": np.arange(4.0)}
    rec.append(chunk)                          # 4 x 8 x 48 bytes: within the budget
    assert not rec.on_disk and not list(tmp_path.iterdir())
    rec.append({**chunk, "t": np.arange(4.0, 8.0)})
    assert rec.on_disk
    assert rec.size == 8 and np.array_equal(rec["t"], np.arange(8.0))
    assert np.array_equal(rec["phi"], np.ones((8, 3, 3)))
    assert (tmp_path / "phi.f64").stat().st_size == 8 * 9 * 8
    assert np.array_equal(rec.block(3, 6)["t"], [3.0, 4.0, 5.0])
    with pytest.raises(ValueError, match="holds 10 epochs"):
        rec.append(chunk)
    rec.close()
    assert not list(tmp_path.iterdir())
    lost = ForwardRecord(3, 10, memory_budget_bytes=0)      # dropped unclosed (a failed run)
    lost.append(chunk)
    folder = os.path.dirname(lost.paths["t"])
    assert os.path.isdir(folder)
    del lost
    gc.collect()
    assert not os.path.exists(folder)
    mem = ForwardRecord(3, 10)
    mem.append(chunk)
    assert not mem.on_disk


def test_smoothing_from_files_in_blocks_is_the_smoothing_in_memory(monkeypatch):
    """A record written to files and smoothed block by block (a budget of 40 records: the
    blocks of the backward pass meet at shared records) gives the smoothed solution of the
    record in memory bit for bit, and leaves no file behind."""
    import tempfile
    from pathlib import Path

    from inmotion.align import dr_kalman
    from inmotion.core.solution import NavState
    from inmotion.estimation import smoother
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    b = simulate(load_scenario(find_scenario("paper000_traj1")), np.random.default_rng(0))
    init = NavState.from_truth(b.truth, euler_error=np.radians([0.5, 0.5, 2.0]))
    cfg = {"smooth": True}
    ref = dr_kalman.run_dr_kf(b, cfg, init)
    before = set(Path(tempfile.gettempdir()).glob("inmotion-smoother-*"))
    seen = []
    real_close = smoother.ForwardRecord.close

    def close(rec):
        seen.append(rec.on_disk)
        real_close(rec)
    monkeypatch.setattr(smoother.ForwardRecord, "close", close)
    monkeypatch.setattr(smoother, "MEMORY_BUDGET_BYTES", 40 * 8 * 1700)
    got = dr_kalman.run_dr_kf(b, cfg, init)
    assert seen == [True]
    assert set(Path(tempfile.gettempdir()).glob("inmotion-smoother-*")) == before
    assert np.array_equal(got.t, ref.t)
    for name in ("lat", "lon", "h", "vel_n", "euler"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    for d in ("sigma", "states"):
        assert getattr(got, d).keys() == getattr(ref, d).keys()
        for key in getattr(ref, d):
            assert np.array_equal(getattr(got, d)[key], getattr(ref, d)[key]), (d, key)


def test_dr_kf_smoothed_against_truth_is_better_early_and_consistent():
    """``dr-kf`` with ``smooth=True`` over paper 000's trajectory 1 started 2 deg off in
    heading, 3 seeds: over the first 120 s (forward heading not yet converged) the smoothed
    heading error is far below the forward one, nowhere worse than the forward filter's
    final accuracy, and the smoothed attitude NEES (3 dof) stays in its band."""
    from inmotion.align import dr_kalman
    from inmotion.core import rotations
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    arcmin = np.pi / 180 / 60
    nees = []
    for seed in range(3):
        b = simulate(load_scenario(find_scenario("paper000_traj1")), np.random.default_rng(seed))
        init = NavState.from_truth(b.truth, euler_error=np.radians([0.5, 0.5, 2.0]))
        out = {}
        for smooth in (False, True):
            s = dr_kalman.run_dr_kf(b, {"smooth": smooth}, init)
            k = np.searchsorted(b.truth.t, s.t)
            phi = np.array([rotations.misalignment(a, c) for a, c in zip(
                rotations.dcm_from_euler(s.euler), rotations.dcm_from_euler(b.truth.euler[k]))])
            sig = np.column_stack([s.sigma[c] for c in ("phi_E", "phi_N", "phi_U")])
            out[smooth] = (s.t, phi, sig)
        t, pf, _ = out[False]
        _, ps, ss = out[True]
        early = t <= 120.0
        assert np.abs(ps[early, 2]).max() < 0.2 * np.abs(pf[early, 2]).max()
        assert np.abs(ps[:, 2]).max() < 3 * ss[-1, 2] + np.abs(pf[-1, 2])
        assert np.abs(ps[early, 2]).max() < 15 * arcmin
        nees.append(np.sum((ps / ss) ** 2, axis=1))
    m = np.mean(np.concatenate(nees))
    assert 1.0 < m < 6.0, m            # 3 dof; correlated over time, so a loose band


def test_nhc_kf_and_single_filter_od_kf_smooth():
    """``smooth`` on paper 003's filters: ``nhc-kf`` and ``od-kf`` without the NHC fallback
    are one local filter and smooth (the heading error over the first 60 s falls)."""
    from inmotion.align import aided_kf as ak
    from inmotion.core import rotations
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    b = simulate(load_scenario(find_scenario("paper003_drive")), np.random.default_rng(2))
    init = NavState.from_truth(b.truth, euler_error=np.radians([0.2, 0.2, 1.0]))
    for run, cfg in ((ak.run_od_kf, {"nhc_fallback": False, "init_heading_sigma_deg": 1.0}),
                     (ak.run_nhc_kf, {"init_heading_sigma_deg": 1.0})):
        err = {}
        for smooth in (False, True):
            s = run(b, {**cfg, "smooth": smooth}, init)
            assert s.info["smoothed"] is smooth
            k = np.searchsorted(b.truth.t, s.t)
            phi = np.array([rotations.misalignment(a, c) for a, c in zip(
                rotations.dcm_from_euler(s.euler), rotations.dcm_from_euler(b.truth.euler[k]))])
            early = s.t <= s.t[0] + 60.0
            err[smooth] = np.sqrt(np.mean(phi[early, 2] ** 2))
        assert err[True] < 0.5 * err[False], (run.__name__, err)


def test_bank_without_detection_smooths_to_the_single_filter():
    """``od-kf`` with its NHC fallback is a bank of two local filters; with no FDI detection
    the fallback never supplied the estimate, so the bank's smoothed result (the central
    filter over the accepted samples, aided_kf._smooth_bank) is the single filter's
    (``nhc_fallback=false``) smoothed result, to rounding."""
    from inmotion.align import aided_kf as ak
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    b = simulate(load_scenario(find_scenario("paper003_drive")), np.random.default_rng(2))
    init = NavState.from_truth(b.truth, euler_error=np.radians([0.2, 0.2, 1.0]))
    # detection off: calibrated at 1e-3 the residual test isolates a healthy channel about
    # once per 1200 tests (issue 15), and this check is about a bank with no isolation
    bank = ak.run_od_kf(b, {"smooth": True, "fdi": False}, init)
    single = ak.run_od_kf(b, {"smooth": True, "nhc_fallback": False, "fdi": False}, init)
    assert bank.info["smoothed"] and bank.info["events"] == []
    assert bank.info["smoothing"]["central_updates"]["nhc"] == 0
    np.testing.assert_allclose(bank.euler, single.euler, rtol=0, atol=1e-12)
    np.testing.assert_allclose(bank.lat, single.lat, rtol=0, atol=1e-14)
    for k in ("phi_U", "vE", "north"):
        np.testing.assert_allclose(bank.sigma[k], single.sigma[k], rtol=1e-10)
    np.testing.assert_allclose(bank.states["od_dk"], single.states["od_dk"], atol=1e-12)


def _velocity_errors(sol, truth):
    k = np.searchsorted(truth.t, sol.t)
    dv = sol.vel_n[:, :2] - truth.vel_n[k, :2]
    return dv, np.column_stack([sol.sigma["vE"], sol.sigma["vN"]])


#: fkf (issue 15): with the vehicle's constraint violation the smoothed velocity on seed 2 was
#: 6.7 mm/s off East at 6 s, 4.5 sigma; with the along-sensor row compared as a length
#: (``aided_kf._length_fill``) the largest |error| / sigma over the three seeds is 1.62, 2.71,
#: 1.31 (worst 2.4, 4.1, 4.0 mm/s)
@pytest.mark.parametrize("method", ["od-kf", "fkf"])
def test_bank_with_faults_smooths_without_the_isolated_sensor(method):
    """paper 003's injected OD / LDV faults (idling, slip, LDV offsets; three seeds): the
    bank's FDI isolates them, the smoothed result uses none of the isolated samples and
    keeps its velocity error small and inside 4 sigma against truth, where the smoother over
    every sample (FDI off) is pulled off by the faults; it is never worse than forward."""
    from inmotion.align import aided_kf as ak
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate
    from inmotion.sim.scenario import find_scenario, load_scenario

    run = {"od-kf": ak.run_od_kf, "fkf": ak.run_fkf}[method]
    for seed in (1, 2, 3):
        b = simulate(load_scenario(find_scenario("paper003_faults")),
                     np.random.default_rng(seed))
        init = NavState.from_truth(b.truth, euler_error=np.radians([0.2, 0.2, 1.0]))
        cfg = {"init_heading_sigma_deg": 1.0}
        fwd = run(b, cfg, init)
        sm = run(b, {**cfg, "smooth": True}, init)
        naive = run(b, {**cfg, "smooth": True, "fdi": False, "nhc_fallback": False}, init)
        iso = sm.info["smoothing"]["isolated_s"]
        faults = [(f["sensor"], f["start_s"]) for f in b.meta["faults"]
                  if f["sensor"] in iso]
        for sensor, start in faults:           # each fault isolated within 1 s of its start
            assert any(start <= a <= start + 1.0 for a, _ in iso[sensor]), (seed, iso)
        dv, sig = _velocity_errors(sm, b.truth)
        assert np.all(np.abs(dv[1:]) <= 4 * sig[1:]), seed
        dv_n, _ = _velocity_errors(naive, b.truth)
        dv_f, _ = _velocity_errors(fwd, b.truth)
        worst = np.abs(dv).max()
        assert worst < 0.03 and worst < 0.2 * np.abs(dv_n).max(), (seed, worst)
        assert worst <= np.abs(dv_f).max(), seed
        # the central filter applied no sample of an isolated interval
        n_iso = sum(len(sm.info["smoothing"]["isolated_s"][s]) for s in iso)
        assert n_iso >= len(faults)
        tests = sm.info["tests"]
        for s in iso:
            assert sm.info["smoothing"]["central_updates"][s] == tests[s]["updates"]


def test_smoother_gain_survives_an_eigh_that_does_not_converge():
    """LAPACK's ``dsyevd`` (``eigh``) fails to converge on some well-conditioned matrices; one
    (the correlation form of a 27-state P_k|k-1 of the central filter of paper 003's drive,
    eigenvalues 1.5e-4 .. 4.4) is stored. The backward pass then takes the SVD: its smoothed
    estimate equals the RTS formula with the inverse, to rounding."""
    from pathlib import Path
    Pp = np.load(Path(__file__).parent / "data" / "eigh_nonconvergent_27.npy")
    n = Pp.shape[0]
    rng = np.random.default_rng(0)
    M = rng.standard_normal((n, n))
    P0 = M @ M.T / n + np.eye(n)
    Phi = np.eye(n) + 0.01 * rng.standard_normal((n, n))
    x = rng.standard_normal((2, n))
    P = np.stack([P0, Pp])
    Phis = np.stack([np.eye(n), Phi])
    P_pred = np.stack([P0, Pp])
    fb = np.zeros((2, n))
    xs, Ps = np.empty((2, n)), np.empty((2, n, n))
    rts_backward(x, P, Phis, P_pred, fb, xs, Ps)
    A = P0 @ Phi.T @ np.linalg.inv(Pp)
    np.testing.assert_allclose(xs[0], x[0] + A @ (x[1] - Phi @ x[0]), rtol=1e-9, atol=1e-9)
    assert np.isfinite(Ps).all()
