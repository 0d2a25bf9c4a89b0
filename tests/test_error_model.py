"""The shared error model against the nonlinear system it linearizes.

* each measurement row against a central-difference derivative of the nonlinear measurement;
* eq. 25-27 of paper 000, as printed, are the derivative of the DESIGN Euler angles;
* the SINS/DR F: a small injected error propagated through the full nonlinear continuous
  SINS and DR equations (RK4, independent of the package's mechanization) against the linear
  prediction ``Phi x0`` over 30 s;
* the gyro drift does tilt the DR platform (``-C_b^n eps`` in the phi_D rows): the derived
  model follows the truth, paper 000's printed F does not;
* the SINS rows equal paper 000's printed F(1..9, .) entries.
"""
import numpy as np
import pytest

from inmotion.core import earth
from inmotion.core.rotations import (dcm_from_euler, dcm_from_rotvec, euler_from_dcm,
                                     misalignment, skew)
from inmotion.estimation import error_model as em
from inmotion.estimation.kalman import discretize
from inmotion.estimation.layout import Layout

LAY25 = Layout(["phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk"])


def _pt(euler=(0.05, -0.03, 0.6), speed=12.0, lat=0.6, mount=(0.0, 0.0, 0.0)):
    C = dcm_from_euler(np.array(euler))
    v_b = dcm_from_rotvec(np.array(mount)) @ np.array([0.0, speed, 0.0])
    return em.LinPoint(lat=lat, h=400.0, vel_n=C @ v_b, C_nb=C, f_n=np.array([0.3, -0.2, 9.8]),
                       omega_nb_b=np.array([0.01, -0.02, 0.05])), C, speed


def _numjac(fun, n, eps=1e-7):
    cols = []
    for i in range(n):
        e = np.zeros(n)
        e[i] = eps
        cols.append((fun(e) - fun(-e)) / (2 * eps))
    return np.stack(cols, axis=-1)


# -- measurement rows ---------------------------------------------------------------------

@pytest.mark.parametrize("euler", [(0.05, -0.03, 0.6), (-0.4, 0.7, 3.5), (0.2, -1.2, 5.9)])
def test_euler_rows_are_the_derivative_of_design_euler_angles(euler):
    """Paper 000 eq. 25-27 as printed hold under the DESIGN Euler and misalignment conventions."""
    C = dcm_from_euler(np.array(euler))

    def ypr(phi):
        e = euler_from_dcm(dcm_from_rotvec(-phi) @ C)     # C_computed = exp(-[phi x]) C
        d = e - np.array(euler)
        d = (d + np.pi) % (2 * np.pi) - np.pi
        return d[[2, 0, 1]]                                 # heading, pitch, roll (eq. 23)

    assert np.allclose(em.euler_rows(C), _numjac(ypr, 3), atol=1e-6)
    # eq. 25-27 printed term by term with T = C
    T = C
    h2 = T[0, 1] ** 2 + T[1, 1] ** 2
    printed = np.array([
        [-T[0, 1] * T[2, 1] / h2, -T[2, 1] * T[1, 1] / h2, 1.0],
        [-T[1, 1] / np.sqrt(1 - T[2, 1] ** 2), T[0, 1] / np.sqrt(1 - T[2, 1] ** 2), 0.0],
        [(T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0]) / (T[2, 0] ** 2 + T[2, 2] ** 2),
         (T[0, 2] * T[2, 0] - T[0, 0] * T[2, 2]) / (T[2, 0] ** 2 + T[2, 2] ** 2), 0.0]])
    assert np.allclose(printed, _numjac(ypr, 3), atol=1e-6)


def _split(x):
    return x[:3], x[3:6], x[6:9], x[9]          # phi-like, dv, mount, dk (test's own packing)


def test_dr_velocity_rows_match_the_nonlinear_dr_velocity():
    pt, C, V = _pt()

    def dv_D(x):
        phi_D, _, A, dk = _split(x)
        computed = dcm_from_rotvec(-phi_D) @ C @ np.array([0.0, (1 + dk) * V, 0.0])
        true = C @ dcm_from_rotvec(A) @ np.array([0.0, V, 0.0])
        return computed - true

    J = _numjac(dv_D, 10)
    D = em.dr_velocity_rows(LAY25, pt)
    assert np.allclose(D[:, LAY25["phi_D"]], J[:, 0:3], atol=1e-6)
    assert np.allclose(D[:, LAY25["mount"]], J[:, 6:9], atol=1e-6)
    assert np.allclose(D[:, LAY25["dk"]], J[:, 9:10], atol=1e-6)
    assert np.all(D[:, LAY25["phi"]] == 0)


@pytest.mark.parametrize("with_mount", [True, False])
def test_nhc_rows_match_the_nonlinear_projection(with_mount):
    """The one NHC measurement (:class:`inmotion.estimation.measurements.Nhc`) against the
    nonlinear projection, with the mounting columns; without them (paper 000's eq. 37 as
    printed) the mounting columns it misses are not zero."""
    from inmotion.core.rotations import quat_from_dcm
    from inmotion.estimation.measurements import AUX_SIZE, Nhc

    pt, C, V = _pt()

    def z(x):
        phi, dv, A, _ = _split(x)
        v_n = C @ dcm_from_rotvec(A) @ np.array([0.0, V, 0.0])    # vehicle moves along m's y
        C_hat = dcm_from_rotvec(-phi) @ C
        return (C_hat.T @ (v_n + dv))[[0, 2]]

    J = _numjac(z, 10)
    xs = np.r_[pt.lat, 0.0, pt.h, C @ np.array([0.0, V, 0.0]), quat_from_dcm(C)]
    H = Nhc(1.0, mount_terms=with_mount).rows((xs, xs, np.zeros(AUX_SIZE)), None, LAY25)[1]
    assert np.allclose(H[:, LAY25["phi"]], J[:, 0:3], atol=1e-6)
    assert np.allclose(H[:, LAY25["dv"]], J[:, 3:6], atol=1e-9)
    if with_mount:
        assert np.allclose(H[:, LAY25["mount"]], J[:, 6:9], atol=1e-6)
    else:      # the printed eq. 37 misses the mounting columns, which are not zero
        assert np.all(H[:, LAY25["mount"]] == 0)
        assert np.max(np.abs(J[:, 6:9])) > 0.5 * V


def test_nhc_rows_with_the_two_angle_mounting_match_the_nonlinear_projection():
    """Paper 003's sensor channels carry the mounting as two angles (pitch x, yaw z:
    ``aided_kf.SUB_LAYOUT``'s ``mount``); the NHC fallback of od-kf / ldv-kf / fkf takes their
    columns (``mount_axes="xz"``, issue 15, session 15): against the nonlinear projection with
    ``C_v^b = exp([A x])``, ``A = (a_x, 0, a_z)``, the same convention as the 3-angle block's."""
    from inmotion.align.aided_kf import SUB_LAYOUT
    from inmotion.core.rotations import quat_from_dcm
    from inmotion.estimation.measurements import AUX_SIZE, Nhc

    pt, C, V = _pt()

    def z(x):
        phi, dv, a = x[:3], x[3:6], x[6:8]
        A = np.array([a[0], 0.0, a[1]])
        v_n = C @ dcm_from_rotvec(A) @ np.array([0.0, V, 0.0])
        C_hat = dcm_from_rotvec(-phi) @ C
        return (C_hat.T @ (v_n + dv))[[0, 2]]

    J = _numjac(z, 8)
    xs = np.r_[pt.lat, 0.0, pt.h, C @ np.array([0.0, V, 0.0]), quat_from_dcm(C)]
    H = Nhc(1.0, mount_axes="xz").rows((xs, xs, np.zeros(AUX_SIZE)), None, SUB_LAYOUT)[1]
    assert np.allclose(H[:, SUB_LAYOUT["phi"]], J[:, 0:3], atol=1e-6)
    assert np.allclose(H[:, SUB_LAYOUT["mount"]], J[:, 6:8], atol=1e-6)
    assert np.max(np.abs(J[:, 6:8])) > 0.5 * V
    with pytest.raises(ValueError, match="2-angle 'mount' block"):
        Nhc(1.0, mount_axes="xz").check(LAY25)


# -- the printed SINS F of paper 000 -----------------------------------------------------

def test_sins_rows_equal_paper_000_printed_entries():
    pt, C, _ = _pt()
    m = em.ErrorModel(LAY25, em.ProcessNoise(), gravity_gradient=False)
    F = m.F(pt)
    L, h = pt.lat, pt.h
    vE, vN, vU = pt.vel_n
    fE, fN, fU = pt.f_n
    r_m, r_n = earth.radii(L)
    RM, RN = r_m + h, r_n + h
    w = earth.OMEGA_IE
    s, c, t = np.sin(L), np.cos(L), np.tan(L)
    P = {(1, 2): w * s + vE / RN * t, (1, 3): -(w * c + vE / RN), (1, 5): -1 / RM,
         (1, 9): vN / RM ** 2, (2, 1): -w * s - vE * t / RN, (2, 3): -vN / RM, (2, 4): 1 / RN,
         (2, 7): -w * s, (2, 9): -vE / RN ** 2, (3, 1): w * c + vE / RN, (3, 2): vN / RM,
         (3, 4): t / RN, (3, 7): w * c + vE / c ** 2 / RN, (3, 9): -vE * t / RN ** 2,
         (4, 2): -fU, (4, 3): fN, (4, 4): (vN * t - vU) / RN, (4, 5): 2 * w * s + vE * t / RN,
         (4, 6): -2 * w * c - vE / RN,
         (4, 7): 2 * w * (vU * s + vN * c) + vE * vN / RN / c ** 2,
         (4, 9): (vE * vU - vE * vN * t) / RN ** 2, (5, 1): fU, (5, 3): -fE,
         (5, 4): -2 * w * s - 2 * vE * t / RN, (5, 5): -vU / RM, (5, 6): -vN / RM,
         (5, 7): -(vE ** 2 / c ** 2 / RN + 2 * vE * w * c),
         (5, 9): vN * vU / RM ** 2 + vE ** 2 * t / RN ** 2, (6, 1): -fN, (6, 2): fE,
         (6, 4): 2 * w * c + 2 * vE / RN, (6, 5): 2 * vN / RM, (6, 7): -2 * vE * w * s,
         (6, 9): -(vE ** 2 + vN ** 2) / RM ** 2, (7, 5): 1 / RM, (7, 9): -vN / RM ** 2,
         (8, 4): 1 / (c * RN), (8, 7): vE * t / c / RN, (8, 9): -vE / c / RN ** 2, (9, 6): 1.0}
    for (i, j), val in P.items():
        # F(6,9) mixes R_M and R_N in the paper; compare to 0.5 % (R_M vs R_N)
        assert F[i - 1, j - 1] == pytest.approx(val, rel=5e-3, abs=1e-12), (i, j)
    assert np.allclose(F[0:3, 9:12], -C) and np.allclose(F[3:6, 12:15], C)
    printed = np.zeros((9, 9))
    for (i, j), val in P.items():
        printed[i - 1, j - 1] = val
    # no SINS entry beyond the printed ones
    assert np.all((np.abs(F[:9, :9]) < 1e-15) | (printed != 0))


# -- the error model against the nonlinear SINS and DR -----------------------------------

G_VEC = None


def _rates(lat, h, v):
    r_m, r_n = earth.radii(lat)
    w_ie = earth.OMEGA_IE * np.array([0.0, np.cos(lat), np.sin(lat)])
    w_en = np.array([-v[1] / (r_m + h), v[0] / (r_n + h), v[0] * np.tan(lat) / (r_n + h)])
    pdot = np.array([v[1] / (r_m + h), v[0] / ((r_n + h) * np.cos(lat)), v[2]])
    return w_ie, w_en, pdot


class _World:
    """Truth by kinematics (body rate w.r.t. n and speed along the sensor axis), and the
    nonlinear continuous SINS and DR driven by the truth's sensors plus errors."""

    def __init__(self, A, eps, nabla, dk):
        self.C_mb = dcm_from_rotvec(A)
        self.eps, self.nabla, self.dk = eps, nabla, dk

    @staticmethod
    def w_nb(t):
        return np.array([0.02 * np.sin(0.3 * t), 0.01 * np.cos(0.2 * t), 0.04 * np.sin(0.1 * t)])

    @staticmethod
    def speed(t):
        return 10.0 + 2.0 * np.sin(0.2 * t), 0.4 * np.cos(0.2 * t)

    def truth_derivs(self, t, y):
        lat, lon, h = y[:3]
        C = y[3:12].reshape(3, 3)
        V, Vdot = self.speed(t)
        w_nb = self.w_nb(t)
        e = self.C_mb @ np.array([0.0, 1.0, 0.0])
        v = C @ e * V
        w_ie, w_en, pdot = _rates(lat, h, v)
        vdot = C @ np.cross(w_nb, e) * V + C @ e * Vdot
        g = np.array([0.0, 0.0, -earth.gravity(lat, h)])
        f_b = C.T @ (vdot + np.cross(2 * w_ie + w_en, v) - g)
        w_ib = w_nb + C.T @ (w_ie + w_en)
        dC = C @ skew(w_nb)
        return np.concatenate([pdot, dC.ravel()]), v, f_b, w_ib, V

    def derivs(self, t, y):
        dtruth, v, f_b, w_ib, V = self.truth_derivs(t, y[:12])
        w_m = w_ib + self.eps
        f_m = f_b + self.nabla
        # SINS: lat, lon, h, v, C
        s = y[12:27]
        lat, h, vs, Cs = s[0], s[2], s[3:6], s[6:15].reshape(3, 3)
        w_ie, w_en, pdot = _rates(lat, h, vs)
        g = np.array([0.0, 0.0, -earth.gravity(lat, h)])
        dvs = Cs @ f_m - np.cross(2 * w_ie + w_en, vs) + g
        dCs = Cs @ skew(w_m) - skew(w_ie + w_en) @ Cs
        # DR: lat, lon, h, C; velocity = C_D [0, (1 + dk) V, 0] (nominal mount I)
        d = y[27:39]
        latd, hd, Cd = d[0], d[2], d[3:12].reshape(3, 3)
        vd = Cd @ np.array([0.0, (1 + self.dk) * V, 0.0])
        w_ie_d, w_en_d, pdot_d = _rates(latd, hd, vd)
        dCd = Cd @ skew(w_m) - skew(w_ie_d + w_en_d) @ Cd
        return np.concatenate([dtruth, pdot, dvs, dCs.ravel(), pdot_d, dCd.ravel()])

    def linpoint(self, t, y):
        _, v, f_b, w_ib, _ = self.truth_derivs(t, y[:12])
        C = y[3:12].reshape(3, 3)
        return em.LinPoint(lat=y[0], h=y[2], vel_n=v, C_nb=C, f_n=C @ f_b)


def _errors(world, t, y, lay):
    x = np.zeros(lay.n)
    C = y[3:12].reshape(3, 3)
    _, v, *_ = world.truth_derivs(t, y[:12])
    x[lay["phi"]] = misalignment(y[18:27].reshape(3, 3), C)
    x[lay["dv"]] = y[15:18] - v
    x[lay["dp"]] = y[12:15] - y[0:3]
    x[lay["phi_D"]] = misalignment(y[30:39].reshape(3, 3), C)
    x[lay["dp_D"]] = y[27:30] - y[0:3]
    return x


def _propagate(x0_blocks, T=30.0, dt=0.05, dr_sees_gyro_drift=True):
    lay = LAY25
    A, eps, nabla, dk = (x0_blocks[k] for k in ("mount", "eps", "nabla", "dk"))
    world = _World(A, eps, nabla, dk)
    C0 = dcm_from_euler(np.array([0.02, -0.01, np.deg2rad(30.0)]))
    p0 = np.array([np.deg2rad(34.2), np.deg2rad(108.9), 380.0])
    truth0 = np.concatenate([p0, C0.ravel()])
    _, v0, *_ = world.truth_derivs(0.0, truth0)
    dpos = x0_blocks["dp"]
    sins0 = np.concatenate([p0 + dpos, v0 + x0_blocks["dv"],
                            (dcm_from_rotvec(-x0_blocks["phi"]) @ C0).ravel()])
    dr0 = np.concatenate([p0 + x0_blocks["dp_D"], (dcm_from_rotvec(-x0_blocks["phi_D"]) @ C0).ravel()])
    y = np.concatenate([truth0, sins0, dr0])
    x = _errors(world, 0.0, y, lay)
    for k in ("eps", "nabla", "mount", "dk"):
        x[lay[k]] = x0_blocks[k]
    model = em.ErrorModel(lay, em.ProcessNoise(dk_tau=np.inf),
                          dr_sees_gyro_drift=dr_sees_gyro_drift)
    t = 0.0
    for _ in range(int(round(T / dt))):
        # linear: F at the step's midpoint truth
        k1 = world.derivs(t, y)
        k2 = world.derivs(t + dt / 2, y + dt / 2 * k1)
        k3 = world.derivs(t + dt / 2, y + dt / 2 * k2)
        k4 = world.derivs(t + dt, y + dt * k3)
        ymid = y + dt / 2 * k2
        Phi, _ = discretize(model.F(world.linpoint(t + dt / 2, ymid)), np.zeros((lay.n, lay.n)), dt)
        x = Phi @ x
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t += dt
    nonlinear = _errors(world, t, y, lay)
    return x, nonlinear


_BASE = dict(phi=np.array([1e-3, -8e-4, 3e-3]), dv=np.array([0.05, -0.03, 0.02]),
             dp=np.array([2e-6, -1.5e-6, 3.0]), eps=np.zeros(3), nabla=np.zeros(3),
             phi_D=np.array([1e-3, -8e-4, 3e-3]), dp_D=np.array([2e-6, -1.5e-6, 3.0]),
             mount=np.deg2rad(np.array([3.0, 10.0, 5.0]) / 60), dk=2e-3)


def _compare(lin, nl, blocks):
    for b in blocks:
        s = LAY25[b]
        scale = np.max(np.abs(nl[s]))
        assert np.allclose(lin[s], nl[s], atol=0.03 * scale + 1e-12), (b, lin[s], nl[s])


def test_linear_model_follows_nonlinear_sins_and_dr():
    x0 = dict(_BASE, eps=np.deg2rad([5.0, -4.0, 8.0]) / 3600, nabla=np.array([2e-3, -1e-3, 1.5e-3]))
    lin, nl = _propagate(x0)
    _compare(lin, nl, ["phi", "dv", "dp", "phi_D", "dp_D"])


def test_gyro_drift_tilts_the_dr_platform_as_derived_not_as_printed():
    eps = np.deg2rad([20.0, -15.0, 30.0]) / 3600      # large, to make the term stand out
    x0 = dict(_BASE, phi=np.zeros(3), phi_D=np.zeros(3), dv=np.zeros(3), dp=np.zeros(3),
              dp_D=np.zeros(3), mount=np.zeros(3), dk=0.0, eps=eps)
    lin, nl = _propagate(x0, T=20.0)
    _compare(lin, nl, ["phi_D", "dp_D", "phi"])
    lin_printed, _ = _propagate(x0, T=20.0, dr_sees_gyro_drift=False)
    s = LAY25["phi_D"]
    # the printed F predicts almost no DR tilt; the truth has ~ |eps| T
    assert np.linalg.norm(lin_printed[s] - nl[s]) > 0.8 * np.linalg.norm(nl[s])


def test_linear_model_follows_the_package_mechanization_and_dead_reckoner():
    """Injected errors through the real Strapdown / DeadReckoner on a simulated drive with
    error-free sensors (turning and accelerating), against ``Phi x0`` over 40 s."""
    from inmotion.core.deadreckoning import DeadReckoner, speed_on_epochs
    from inmotion.core.mechanization import Strapdown
    from inmotion.core.solution import NavState
    from inmotion.sim import simulate

    sc = dict(name="em", start=dict(lat_deg=34.0, lon_deg=108.0, h_m=400.0, heading_deg=30.0,
                                    speed_m_s=10.0),
              segments=[dict(kind="accelerate", to_speed_m_s=14.0, accel_m_s2=0.5),
                        dict(kind="turn", angle_deg=60.0, rate_deg_s=3.0),
                        dict(kind="cruise", duration_s=20.0)],
              imu=dict(rate_hz=100), sensors=dict(radar=dict(rate_hz=100)))
    b = simulate(sc, np.random.default_rng(0))
    tr = b.truth
    lay = LAY25
    eps = np.deg2rad([2.0, -3.0, 4.0]) / 3600
    nabla = np.array([5e-4, -4e-4, 3e-4])
    dk = 1e-3
    phi0 = np.array([6e-4, -5e-4, 2e-3])
    dp0 = np.array([1.5e-6, -1e-6, 2.0])
    x = lay.zeros()
    x[lay["phi"]] = x[lay["phi_D"]] = phi0
    x[lay["dv"]] = [0.03, -0.02, 0.01]
    x[lay["dp"]] = x[lay["dp_D"]] = dp0
    x[lay["eps"]], x[lay["nabla"]], x[lay["dk"]] = eps, nabla, dk
    C0 = dcm_from_rotvec(-phi0) @ tr.C_nb[0]
    from inmotion.core.rotations import quat_from_dcm
    init = NavState(tr.t[0], tr.lat[0] + dp0[0], tr.lon[0] + dp0[1], tr.h[0] + dp0[2],
                    tr.vel_n[0] + x[lay["dv"]], quat_from_dcm(C0))
    sins, dr = Strapdown(init), DeadReckoner(init)
    ds, v, _, _ = speed_on_epochs(b.radar, tr.t)
    dt = 0.01
    model = em.ErrorModel(lay, em.ProcessNoise(dk_tau=np.inf))
    step, n = 10, 4000
    for a in range(1, n, step):
        rows = slice(a, a + step)
        dth = b.imu.dtheta[rows] + eps * dt
        dvl = b.imu.dvel[rows] + nabla * dt
        sins.run(dth, dvl, tr.t[rows])
        dr.run(dth, tr.t[rows], ds[a - 1:a - 1 + step] * (1 + dk), v[a - 1:a - 1 + step] * (1 + dk))
        k = a + step // 2
        f_n = tr.C_nb[k] @ (b.imu.dvel[k] / dt)
        pt = em.LinPoint(lat=tr.lat[k], h=tr.h[k], vel_n=tr.vel_n[k], C_nb=tr.C_nb[k], f_n=f_n)
        Phi, _ = discretize(model.F(pt), np.zeros((lay.n, lay.n)), step * dt)
        x = Phi @ x
    k = n - 1 + (step - (n - 1) % step) % step
    k = min(k, len(tr.t) - 1)
    s, d = sins.state(), dr.state()
    assert s.t == pytest.approx(tr.t[k])
    nl = lay.zeros()
    nl[lay["phi"]] = misalignment(s.C_nb, tr.C_nb[k])
    nl[lay["dv"]] = s.vel_n - tr.vel_n[k]
    nl[lay["dp"]] = [s.lat - tr.lat[k], s.lon - tr.lon[k], s.h - tr.h[k]]
    nl[lay["phi_D"]] = misalignment(d.C_nb, tr.C_nb[k])
    nl[lay["dp_D"]] = [d.lat - tr.lat[k], d.lon - tr.lon[k], d.h - tr.h[k]]
    for blk in ("phi", "dv", "dp", "phi_D", "dp_D"):
        sl = lay[blk]
        scale = np.max(np.abs(nl[sl]))
        assert np.allclose(x[sl], nl[sl], atol=0.05 * scale), (blk, x[sl], nl[sl])
