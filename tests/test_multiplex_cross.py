"""Issue 15: the fine prior's cross-covariance of the coarse attitude error with the sensor
states that caused it (``multiplex.window_cross_maps``, ``attitude_cross``, the fine
filters' ``init_attitude_cross``).

The maps are checked against the coarse stage itself run on a simulated drive with the error
injected (the difference of the two coarse answers, in the fine filter's ``phi``
convention, against the map times the injected error): the map is a linearisation sampled
once a second (the vectors' epochs), so it is held to 15 % of the injected effect's largest
component (measured: 0.2-10 %, ``attitude_determination.window_error_map``)."""
import numpy as np
import pytest
from consistency_mc import drive_003

from inmotion.align import aided_kf as ak
from inmotion.align import multiplex as mx
from inmotion.core import rotations
from inmotion.core.bundle import Bundle, ImuData, SpeedData
from inmotion.errors import BadInput
from inmotion.estimation.aiding_rows import SUB_LAYOUT
from inmotion.sim import simulate


def _coarse(window_s):
    b = simulate(drive_003(), np.random.default_rng(100))
    cfg = mx.MuxConfig(coarse_window_s=window_s)
    t0 = mx.first_covered(b, float(b.imu.t[0]))
    t1 = mx.last_covered(b, t0 + window_s)
    _, C0, emap = mx.coarse_fault_tolerant(b, cfg, None, t0, t1, error_map=True)

    def phi_change(bb, R=np.eye(3)):
        """The coarse attitude's change (fine ``phi`` convention, ``C_hat = (I - [phi x])
        C``) on ``bb`` (body ``b' = R b``) against the unperturbed run."""
        _, C1 = mx.coarse_fault_tolerant(bb, cfg, None, t0, t1)
        return -rotations.vee(C1 @ R @ C0.T - np.eye(3))
    return b, emap, phi_change


@pytest.fixture(scope="module")
def coarse80():
    return _coarse(80.0)


def _close(lin, fd):
    assert np.max(np.abs(lin - fd)) <= 0.15 * np.max(np.abs(fd)), \
        (np.degrees(lin) * 60, np.degrees(fd) * 60)


@pytest.mark.parametrize("axis", [0, 1])
def test_bias_map_matches_coarse_stage(coarse80, axis):
    """A 1e-3 m/s^2 (102 ug) accelerometer bias on b's x or y axis added to the increments:
    the coarse tilt moves by about bias / g (0.35 arcmin; x: 0.31 arcmin east, y: 0.33 west
    and 0.31 north after the 60 deg turn) and a forward bias turns the heading by 144 arcmin
    on this 80 s window (the map: 143.2; 140 before it followed the low-pass)."""
    b, emap, phi_change = coarse80
    nab = np.zeros(3)
    nab[axis] = 1e-3
    dt = np.diff(b.imu.t, prepend=b.imu.t[0] - float(np.median(np.diff(b.imu.t))))
    bb = Bundle(ImuData(b.imu.t, b.imu.dtheta, b.imu.dvel + dt[:, None] * nab), b.meta,
                b.radar, b.ldv, b.odometer, b.baro, b.truth)
    fd = phi_change(bb)
    lin = mx.window_cross_maps(emap)["nabla"] @ nab
    if axis == 0:                  # the level part (the heading's is second order here)
        fd, lin = fd[:2], lin[:2]
    assert np.max(np.abs(fd)) > np.radians(0.2 / 60)
    _close(lin, fd)


@pytest.mark.parametrize("rot,axis", [(rotations.rot_z, 2), (rotations.rot_x, 0)])
def test_mount_map_matches_coarse_stage(coarse80, rot, axis):
    """The IMU turned by 30 arcmin in the vehicle about z (a yaw mounting, the heading 205
    arcmin off; map 225, 217.8 before it followed the low-pass and the
    residuals) and about x (pitch; heading 5.6 arcmin off, map 5.6, 5.3 before): the fine
    filter's mounting state of that body, ``A = [alpha, gamma]`` with ``(I + [A x]) e_y``
    the vehicle's forward axis, times the map."""
    b, emap, phi_change = coarse80
    R = rot(np.radians(0.5))
    turned = Bundle(ImuData(b.imu.t, b.imu.dtheta @ R.T, b.imu.dvel @ R.T), b.meta, b.radar,
                    b.ldv, b.odometer, b.baro, b.truth)
    f = R @ [0.0, 1.0, 0.0]
    A = np.array([f[2], -f[0]])
    fd = phi_change(turned, R)
    lin = mx.window_cross_maps(emap)["mount"] @ A
    assert abs(fd[2]) > np.radians(5.0 / 60)
    _close(lin, fd)


def _scaled(sd, k):
    """The speed sensor ``sd`` read with a scale factor ``k`` (``v_measured = (1 + k) v``)."""
    if sd is None:
        return None
    return SpeedData(sd.t, None if sd.v is None else sd.v * (1.0 + k),
                     None if sd.ds is None else sd.ds * (1.0 + k))


@pytest.mark.parametrize("k", [1e-3, -1e-3])
def test_scale_map_matches_coarse_stage(k):
    """Both speed sensors scaled by 1 + k (1000 ppm) on the 85 s drive, 40 s window (ending
    in the 60 deg turn): the coarse heading moves +89.5 arcmin (-86.4 for -1000 ppm; the
    level 0.1), the map's ``dk`` column +92.1. (The map before it followed the stage's
    low-pass, its sum over the window and the vectors' residuals: +147.8.)"""
    b, emap, phi_change = _coarse(40.0)
    bb = Bundle(b.imu, b.meta, b.radar, _scaled(b.ldv, k), _scaled(b.odometer, k), b.baro,
                b.truth)
    fd = phi_change(bb)
    lin = mx.window_cross_maps(emap)["dk"] * k
    assert abs(fd[2]) > np.radians(30.0 / 60)
    _close(lin, fd)


def test_map_lowpass_is_the_stage_filter():
    """``window_error_map``'s low-pass on the epochs (``attitude_determination._Lowpass``,
    first-order hold): a constant passes unchanged, a ramp comes out delayed by ``tau``
    once settled (the first-order low-pass of ``t`` is ``t - tau (1 - e^(-t / tau))``,
    exact for an input linear between epochs), and its adjoint satisfies ``sum a . L x =
    sum L^T a . x``."""
    from inmotion.align.attitude_determination import _Lowpass
    t = np.concatenate([[0.0], np.cumsum(np.random.default_rng(1).uniform(0.5, 1.5, 40))])
    L = _Lowpass(t, 2.0)
    np.testing.assert_allclose(L.apply(np.full((len(t), 3), 3.0)), 3.0, rtol=1e-12)
    y = L.apply(np.stack([t, t, t], 1))[:, 0]
    np.testing.assert_allclose(y, t - 2.0 * (1.0 - np.exp(-t / 2.0)), rtol=1e-12, atol=1e-12)
    rng = np.random.default_rng(2)
    x, a = rng.standard_normal((len(t), 3)), rng.standard_normal((len(t), 3, 3))
    lhs = np.einsum("kij,kj->i", a, L.apply(x))
    rhs = np.einsum("kij,kj->i", L.adjoint(a), x)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-12)


def test_fine_prior_carries_cross(coarse80):
    """``fine_config_from_coarse`` with ``cross``: ``init_attitude_cross`` is ``J P_s``
    (bias, and the mounting for each channel run), the attitude prior fits it; ``fkf``'s
    local filters hold it as given with the SINS block ``P15 / beta`` and the start
    velocity's rows ``[v x] X``; a cross larger than the sigmas allow, or a channel not
    run, is ``BadInput``."""
    b, emap, _ = coarse80
    cfg, env, _ = mx.fine_config_from_coarse(ak.FkfConfig, {}, b.meta, np.radians(32.0), 80.0,
                                             emap, "ldv", 10.0, ("odometer", "ldv"), True)
    X = cfg.init_attitude_cross
    assert set(X) == {"nabla", "odometer.mount", "ldv.mount", "ldv.dk"}
    J = mx.window_cross_maps(emap)
    s_m = cfg.mount_sigma_arcmin * ak.ARCMIN
    np.testing.assert_allclose(X["ldv.mount"], J["mount"] * s_m ** 2)
    np.testing.assert_allclose(X["ldv.dk"], J["dk"][:, None] * (cfg.ldv_scale_sigma_ppm * 1e-6) ** 2)
    vel = np.array([3.0, 9.0, 0.1])
    P15 = ak._sins_prior(cfg, np.radians(32.0), 0.0, vel)
    ak._check_prior(P15, "SINS")
    lf, _ = ak._channel(b, "ldv", cfg, 0.5, P15, P15 * 0, 1, np.eye(3), 0.0, 1, 0.0, vel)
    a, v, m = SUB_LAYOUT["phi"], SUB_LAYOUT["dv"], SUB_LAYOUT["mount"]
    np.testing.assert_allclose(lf.P0[a, m], X["ldv.mount"])
    np.testing.assert_allclose(lf.P0[v, m], rotations.skew(vel) @ np.asarray(X["ldv.mount"]))
    np.testing.assert_allclose(lf.P0[a, a], P15[a, a] / 0.5)
    assert np.linalg.eigvalsh(lf.P0)[0] > -1e-12 * np.max(np.diagonal(lf.P0))
    with pytest.raises(BadInput, match="positive semi-definite"):
        bad = cfg.model_copy(update={"init_tilt_sigma_deg": 1e-4, "init_heading_sigma_deg": 1e-4})
        ak._channel(b, "ldv", bad, 1.0, ak._sins_prior(bad, 0.5, 0.0), P15 * 0, 1, np.eye(3),
                    0.0, 1, 0.0)
    with pytest.raises(BadInput, match="runs no ldv"):
        ak._attitude_cross(cfg, ("odometer",))


def test_level_floor_only_where_unresolved():
    """``floor_attitude_sigma(level=False)`` (``prior_cross``): a resolved heading keeps the
    filter's own level sigma; an unresolved one, or ``level=True`` (the parked path), keeps
    it at least ``bias / g``."""
    from inmotion.core.solution import Solution
    n = 3
    sol = Solution(np.arange(n, dtype=float), np.zeros(n), np.zeros(n), np.zeros(n),
                   np.zeros((n, 3)), np.zeros((n, 3)),
                   sigma={k: np.full(n, 1e-6) for k in ("phi_E", "phi_N", "phi_U")})
    floor = 50e-6                      # 50 ug: bias / g [rad]
    for resolvable, level, want in ((True, False, 1e-6), (True, True, floor),
                                    (False, False, floor)):
        s = Solution(sol.t, sol.lat, sol.lon, sol.h, sol.vel_n, sol.euler,
                     sigma={k: v.copy() for k, v in sol.sigma.items()})
        mx.floor_attitude_sigma(s, {"accel_bias_ug": 50.0, "resolvable": resolvable}, level)
        np.testing.assert_allclose(s.sigma["phi_E"], want)
        np.testing.assert_allclose(s.sigma["phi_N"], want)


def test_sins_prior_velocity_rows_follow_the_cross():
    """With ``init_velocity_from_attitude`` the start velocity's error is ``[v x] phi + w``:
    its covariance with the bias is ``[v x] cov(phi, nabla)`` (the cross given), and the
    whole prior is ``E P E^T`` of the independent one (``E`` adding ``[v x]`` phi to dv)."""
    X = np.array([[1e-7, -2e-8, 0.0], [3e-8, 1e-7, 0.0], [0.0, 5e-8, 1e-8]])
    cfg = ak.FkfConfig(init_velocity_from_attitude=True, init_tilt_sigma_deg=0.05,
                       init_heading_sigma_deg=0.5, init_attitude_cross={"nabla": X.tolist()})
    vel = np.array([3.0, 9.0, 0.1])
    P = ak._sins_prior(cfg, 0.5, 0.0, vel)
    P0 = ak._sins_prior(cfg.model_copy(update={"init_velocity_from_attitude": False}), 0.5, 0.0)
    E = np.eye(P.shape[0])
    E[3:6, 0:3] = rotations.skew(vel)
    np.testing.assert_allclose(P, E @ P0 @ E.T, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(P0[0:3, 12:15], X)


@pytest.mark.parametrize("cross, message", [
    ({"gyro": [[0.0] * 3] * 3}, r"init_attitude_cross\.gyro: not a block it takes"),
    ({"ldv.scale": [[0.0]] * 3}, r"init_attitude_cross\.ldv\.scale: not a block it takes"),
    ({"nabla": [[0.0, 0.0]] * 3}, r"init_attitude_cross\.nabla: need a finite 3 x 3 matrix, "
                                  r"got shape \(3, 2\)"),
    ({"odometer.mount": [[0.0, float("nan")]] * 3},
     r"init_attitude_cross\.odometer\.mount: need a finite 3 x 2 matrix"),
])
def test_attitude_cross_bad_input(cross, message):
    """A key ``init_attitude_cross`` does not take, a block of the wrong shape or a NaN in
    it: one ``BadInput`` naming the key, before any run."""
    cfg = ak.FkfConfig(init_attitude_cross=cross)
    with pytest.raises(BadInput, match=message):
        ak._attitude_cross(cfg)
