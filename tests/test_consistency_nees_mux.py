"""Issue 15: ``fine-mux`` and ``adaptive`` (moving start: Strategy 2 = ``fine-mux``) cover
their final attitude error over a Monte Carlo of paper 003's drive cut to 85 s
(:mod:`consistency_mc`), and a coarse window too short for the heading says so.

The coarse stage's heading 1-sigma holds the window's own terms (mounting, scale factor,
lever arm, constraint violation, speed noise: ``multiplex.window_envelope``) besides the
IMU's; before, an 80 s window gave NEES 1.39 but 40 s 6.11 and 20 s 653 (6 runs), the coarse
heading far outside the fine prior."""
import numpy as np
import pytest
from consistency_mc import drive_003, drive_003_start, final_nees, parked_003

from inmotion.align import multiplex as mx
from inmotion.core import rotations
from inmotion.core.bundle import Bundle, ImuData
from inmotion.sim import simulate

PRIOR = (0.1, 0.1, 0.5)      # the start error drawn per run [deg]; fine-mux uses the position


@pytest.mark.parametrize("method,config", [
    ("fine-mux", {"coarse_window_s": 120.0}),
    ("adaptive", {"mux": {"coarse_window_s": 120.0}}),
])
def test_mux_nees_in_band(method, config):
    """A 120 s window on the 10-minute drive's first 194 s (coarse heading 1-sigma about 50
    arcmin, inside the fine filter's linear range, ``multiplex.LINEAR_HEADING_DEG``): the
    mean NEES of 6 runs in its 95 % band (measured 2.42; 2.54 since ``prior_cross``, issue
    15 session 12). Since session 17 on the truth drawn from the fine filter's priors
    (``consistency_mc.drawn_truth``: mounting, lever arms, scale spreads): 1.70 (band
    1.37-5.25); 20 runs 2.11 (band 2.02-4.16), the same for ``adaptive`` (its moving start is
    ``fine-mux``); 10 runs 1.83 against 1.98 on the same streams with nothing drawn."""
    mean, (lo, hi), per_run = final_nees(method, config, drive_003_start(), 6, PRIOR,
                                         prior_drawn=True)
    assert lo <= mean <= hi, (mean, (lo, hi), per_run)


def test_adaptive_parked_start_nees_in_band():
    """Strategy 1 (parked 120 s >= ``parked_coarse_s``: parked coarse, then ``parked-kf``;
    the window terms do not apply, nothing moves): NEES of 6 runs in its band (measured
    2.52; 2.56 over 20 runs, band 2.02-4.16)."""
    mean, (lo, hi), per_run = final_nees("adaptive", {}, parked_003(), 6, PRIOR)
    assert lo <= mean <= hi, (mean, (lo, hi), per_run)


@pytest.mark.parametrize("window_s", [40.0, 80.0])
def test_mux_short_window_warns_and_covers(window_s):
    """40 and 80 s windows on the 85 s drive: the mounting alone puts the coarse heading
    150-400 (40 s) or 40-240 (80 s) arcmin off, a coarse heading 1-sigma of about 10 and 3.7
    deg (the fine filter then ended 120-360 arcmin off with a 5-35 arcmin sigma at 40 s, NEES
    780): every run warns, names a longer window, and the reported sigma covers (NEES not
    above its band's top; measured 0.24 at 40 s, conservative)."""
    from inmotion import registry
    from inmotion.core.metrics import error_series
    from inmotion.core.solution import NavState
    from inmotion.estimation import chi2
    run, Config = registry.get("fine-mux").load()
    sc = drive_003()
    vals = []
    for k in range(4):
        rng = np.random.default_rng(100 + k)
        b = simulate(sc, rng)
        init = NavState.from_truth(b.truth, euler_error=np.zeros(3))
        sol = run(b, Config(coarse_window_s=window_s), init)
        w = [x for x in sol.info["warnings"] if "too short for the heading" in x]
        assert len(w) == 1 and "lengthen coarse_window_s to >=" in w[0], sol.info["warnings"]
        env = sol.info["coarse_envelope"]
        assert set(env["window"]["terms"]) == {"mount", "scale", "lever", "constraint",
                                               "speed_noise"}
        e = error_series(sol, b.truth)[["phi_E_arcmin", "phi_N_arcmin",
                                        "phi_U_arcmin"]].to_numpy()[-1]
        sig = np.degrees([sol.sigma[c][-1] for c in ("phi_E", "phi_N", "phi_U")]) * 60
        vals.append(float(np.sum((e / sig) ** 2)))
    assert np.mean(vals) <= chi2.isf(0.025, 3 * len(vals)) / len(vals), vals


def test_window_map_matches_turned_imu():
    """The linear map's heading error for a 30 arcmin yaw mounting against the real coarse
    stage run on the IMU increments turned by that angle (the body turned: the velocity it
    reads as ``s e_y`` is ``s R^T e_y``), mapped back: within 30 % (measured 436 against 560
    arcmin at 40 s, 205 against 218 at 80 s, 217 since the map takes the Earth-rate
    integral's share, issue 15; the map samples the vectors once a second)."""
    b = simulate(drive_003(), np.random.default_rng(100))
    mu = np.radians(0.5)
    R = rotations.rot_z(mu)
    turned = Bundle(ImuData(b.imu.t, b.imu.dtheta @ R.T, b.imu.dvel @ R.T), b.meta, b.radar,
                    b.ldv, b.odometer, b.baro, b.truth)
    cfg = mx.MuxConfig(coarse_window_s=80.0)
    t0 = mx.first_covered(b, float(b.imu.t[0]))
    t1 = mx.last_covered(b, t0 + 80.0)
    _, C0, emap = mx.coarse_fault_tolerant(b, cfg, None, t0, t1, error_map=True)
    _, C1 = mx.coarse_fault_tolerant(turned, cfg, None, t0, t1)
    fd = -rotations.vee(C1 @ R @ C0.T - np.eye(3))
    dv = emap["speed"][:, None] * (R.T @ [0.0, 1.0, 0.0] - [0.0, 1.0, 0.0])[None]
    lin = np.einsum("kij,kj->i", emap["H"], dv)
    assert abs(fd[2]) > np.radians(1.0)          # a real effect: degrees, not arcmin
    assert abs(lin[2] - fd[2]) <= 0.3 * abs(fd[2]), (np.degrees(fd) * 60, np.degrees(lin) * 60)
