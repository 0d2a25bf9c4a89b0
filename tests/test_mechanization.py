"""SINS mechanization against theory: rest, Schuler, gyro drift, vertical channel, streaming.

Increments are built here for analytic motions (a stationary vehicle: ``dtheta = C_n^b
omega_ie_n dt``, ``dvel = -C_n^b g_n dt`` exactly; level drives from :mod:`analytic_drive`).
Hour-long runs use 10 Hz so that they take a fraction of a second.
"""
import numpy as np
import pytest

from analytic_drive import drive_increments, stop_and_go_hills
from inmotion.core import earth
from inmotion.core.bundle import BaroData, ImuData
from inmotion.core.mechanization import Strapdown, baro_gains, strapdown
from inmotion.core.rotations import (apply_misalignment, dcm_from_euler, misalignment,
                                     quat_from_dcm)
from inmotion.core.solution import NavState
from inmotion.errors import BadInput

ARCSEC = np.pi / 180 / 3600
DEG_H = np.pi / 180 / 3600


def stationary_imu(lat, h, euler, dt, duration, gyro_bias_b=(0, 0, 0)):
    """Exact increments of a vehicle at rest with attitude ``euler``; rows at 0, dt, ..."""
    n = int(round(duration / dt)) + 1
    t = np.arange(n) * dt
    C_nb = dcm_from_euler(np.asarray(euler, float))
    w_b = C_nb.T @ earth.omega_ie_n(lat) + np.asarray(gyro_bias_b, float)
    f_b = C_nb.T @ -earth.gravity_n(lat, h)
    return ImuData(t, np.tile(w_b * dt, (n, 1)), np.tile(f_b * dt, (n, 1)))


def run_at_rest(lat, h, euler, dt, duration, *, phi0=(0, 0, 0), dv0=(0, 0, 0), dh0=0.0,
                gyro_bias_b=(0, 0, 0), damping="none"):
    """Stationary run from truth perturbed by ``phi0`` [rad], ``dv0`` [m/s], ``dh0`` [m]."""
    imu = stationary_imu(lat, h, euler, dt, duration, gyro_bias_b)
    C_true = dcm_from_euler(np.asarray(euler, float))
    init = NavState(0.0, lat, 0.5, h + dh0, np.asarray(dv0, float),
                    quat_from_dcm(apply_misalignment(C_true, np.asarray(phi0, float))))
    baro = BaroData(imu.t, np.full(len(imu.t), h))
    sol = strapdown(imu, init, baro, damping=damping)
    d_north, d_east = earth.local_ne_offsets(sol.lat, sol.lon, lat, 0.5, h)
    phi = misalignment(sol.C_nb, C_true)
    return sol, d_north, d_east, phi


def test_kernel_helpers_agree_with_rotations():
    """The numba tuple helpers against :mod:`inmotion.core.rotations` (both sides of the
    0.01 rad series switch of the rotation-vector quaternion)."""
    from inmotion.core import _kernels as K
    from inmotion.core import rotations as R
    rng = np.random.default_rng(7)
    for angle in (0.0, 1e-9, 1e-5, 3e-3, 0.00999, 0.01001, 0.3, 3.0):
        axis = rng.normal(size=3)
        r = angle * axis / np.linalg.norm(axis)
        assert np.allclose(K.quat_from_rotvec(tuple(r)), R.quat_from_rotvec(r), rtol=0,
                           atol=3e-16)
    p, q = R.quat_normalize(rng.normal(size=4)), R.quat_normalize(rng.normal(size=4))
    v = rng.normal(size=3)
    assert np.allclose(K.qmul(tuple(p), tuple(q)), R.quat_multiply(p, q), atol=1e-15)
    assert np.allclose(K.qrotate(tuple(q), tuple(v)), R.dcm_from_quat(q) @ v, atol=1e-14)
    assert np.allclose(K.qrotate_inv(tuple(q), tuple(v)), R.dcm_from_quat(q).T @ v, atol=1e-14)
    assert np.allclose(K.cross(tuple(p[:3]), tuple(v)), np.cross(p[:3], v), atol=1e-15)
    lat, h, vel = 0.7, 300.0, np.array([10.0, -4.0, 0.3])
    assert np.allclose(K.omega_ie_n(lat), earth.omega_ie_n(lat), rtol=1e-15)
    assert np.allclose(K.omega_en_n(lat, h, tuple(vel)), earth.omega_en_n(lat, h, vel),
                       rtol=1e-15)
    assert K.gravity(lat, h) == earth.gravity(lat, h)
    assert K.radii(lat) == earth.radii(lat)


def test_rest_stays_put_for_an_hour():
    lat, h = np.radians(45.0), 250.0
    sol, dn, de, phi = run_at_rest(lat, h, np.radians([3.0, -5.0, 130.0]), 0.1, 3600.0)
    assert np.hypot(dn, de).max() < 1e-3
    assert np.abs(sol.h - h).max() < 1e-3          # even the free vertical channel
    assert np.abs(sol.vel_n).max() < 1e-6
    assert np.abs(phi).max() < 1e-3 * ARCSEC


def _north_channel_at_equator(t, phi0, g, R):
    """Tilt ``phi_E(0) = phi0`` at the equator, at rest: the North channel with its Earth-rate
    coupling, paper 000 sec. 4.1 F (rows phi_E, phi_U, dvN, dL at L = 0, v = 0)::

        dvN'  = g phi_E                        (F(5,1) = f_U)
        phi_E' = -dvN / R - w_ie phi_U          (F(1,5), F(1,3))
        phi_U' = w_ie phi_E + w_ie dL           (F(3,1), F(3,7))
        dL'    = dvN / R

    The couplings through ``phi_U`` change the single-channel Schuler answer by about 2 % over
    an hour, so the reference is this linear system's exact solution (matrix exponential).
    Returns ``dvN`` [m/s] and the north position error ``R dL`` [m].
    """
    from scipy.linalg import expm
    w = earth.OMEGA_IE
    # state [dvN, phi_E, phi_U, dL]
    F = np.array([[0, g, 0, 0], [-1 / R, 0, -w, 0], [0, w, 0, w], [1 / R, 0, 0, 0]])
    x = np.array([expm(F * tk) @ [0.0, phi0, 0.0, 0.0] for tk in t])
    return x[:, 0], R * x[:, 3]


@pytest.mark.parametrize("axis", ["E", "N"])
def test_initial_tilt_gives_schuler_oscillation(axis):
    """Tilt phi0 at the equator, perfect baro: the Schuler loop.

    About North (east channel, no Earth-rate coupling at the equator): ``dvE' = -g phi_N``,
    ``phi_N' = dvE / (R_N + h)``, so ``dvE = -phi0 sqrt(g R) sin(w_s t)``,
    ``dE = -phi0 R (1 - cos(w_s t))``, ``w_s = sqrt(g / R)``, period 84.4 min.
    About East: ``dvN = +phi0 sqrt(g R) sin(w_s t)``, ``dN = +phi0 R (1 - cos)`` to first
    order, with the Earth-rate coupling of :func:`_north_channel_at_equator` on top.
    """
    lat, h, phi0 = 0.0, 100.0, 1e-4
    r_m, r_n = earth.radii(lat)
    g = earth.gravity(lat, h)
    R = r_n + h if axis == "N" else r_m + h
    w_s = np.sqrt(g / R)
    period = 2 * np.pi / w_s
    assert abs(period / 60 - 84.4) < 0.2
    phi_vec = np.array([phi0, 0, 0]) if axis == "E" else np.array([0, phi0, 0])
    sol, dn, de, _ = run_at_rest(lat, h, [0, 0, 0], 0.1, 1.3 * period, phi0=phi_vec,
                                 damping="baro")
    t = sol.t
    amp_v, amp_p = phi0 * np.sqrt(g * R), phi0 * R
    if axis == "N":
        v, p = sol.vel_n[:, 0], de
        v_theory = -amp_v * np.sin(w_s * t)
        p_theory = -amp_p * (1 - np.cos(w_s * t))
    else:
        v, p = sol.vel_n[:, 1], dn
        # single channel first, loosely: the coupling is a few per cent
        assert np.abs(v - amp_v * np.sin(w_s * t)).max() < 0.05 * amp_v
        v_theory, p_theory = _north_channel_at_equator(t[::50], phi0, g, R)
        v, p = v[::50], p[::50]
    assert np.abs(v - v_theory).max() < 0.005 * amp_v
    assert np.abs(p - p_theory).max() < 0.005 * 2 * amp_p
    # the period from the zero crossing of the velocity near one period
    tt = t if axis == "N" else t[::50]
    s = np.sign(v)
    k = np.flatnonzero((s[:-1] != s[1:]) & (tt[:-1] > 0.75 * period))[0]
    t_cross = tt[k] - v[k] * (tt[k + 1] - tt[k]) / (v[k + 1] - v[k])
    assert abs(t_cross - period) < 0.005 * period


def test_gyro_drift_position_error_follows_schuler_response():
    """North gyro drift eps at the equator: ``phi_N' = dvE/R - eps``, ``dvE' = -g phi_N``, so
    ``dE = R eps (t - sin(w_s t)/w_s)`` (``g eps t^3 / 6`` at short times),
    ``phi_N = -eps sin(w_s t) / w_s``."""
    lat, h, eps = 0.0, 0.0, 0.01 * DEG_H
    sol, dn, de, phi = run_at_rest(lat, h, [0, 0, 0], 0.1, 3600.0,
                                   gyro_bias_b=(0, eps, 0), damping="baro")
    _, r_n = earth.radii(lat)
    R, g = r_n + h, earth.gravity(lat, h)
    w_s = np.sqrt(g / R)
    t = sol.t
    de_theory = R * eps * (t - np.sin(w_s * t) / w_s)
    assert np.abs(de - de_theory).max() < 0.01 * np.abs(de_theory).max()
    phi_n_theory = -eps * np.sin(w_s * t) / w_s
    assert np.abs(phi[:, 1] - phi_n_theory).max() < 0.01 * eps / w_s
    k = np.searchsorted(t, 300.0)
    assert de[k] == pytest.approx(g * eps * t[k] ** 3 / 6, rel=0.01)


def _paper000_F_at_rest(lat, h):
    """Paper 000 sec. 4.1 F, rows/columns phi_E, phi_N, phi_U, dvE, dvN, dL, dlambda, for a
    vehicle at rest (v = 0, f_n = [0, 0, g]); the vertical channel is held by the baro."""
    w, g = earth.OMEGA_IE, earth.gravity(lat, h)
    r_m, r_n = earth.radii(lat)
    rm, rn = r_m + h, r_n + h
    sl, cl = np.sin(lat), np.cos(lat)
    PE, PN, PU, VE, VN, DL, DLON = range(7)
    F = np.zeros((7, 7))
    F[PE, PN], F[PE, PU], F[PE, VN] = w * sl, -w * cl, -1 / rm            # F(1,2) F(1,3) F(1,5)
    F[PN, PE], F[PN, VE], F[PN, DL] = -w * sl, 1 / rn, -w * sl            # F(2,1) F(2,4) F(2,7)
    F[PU, PE], F[PU, VE], F[PU, DL] = w * cl, np.tan(lat) / rn, w * cl    # F(3,1) F(3,4) F(3,7)
    F[VE, PN], F[VE, VN] = -g, 2 * w * sl                                  # F(4,2) F(4,5)
    F[VN, PE], F[VN, VE] = g, -2 * w * sl                                  # F(5,1) F(5,4)
    F[DL, VN] = 1 / rm                                                     # F(7,5)
    F[DLON, VE] = 1 / (rn * cl)                                            # F(8,4)
    return F


def test_error_propagation_follows_paper000_error_model():
    """Tilt, azimuth and velocity errors at 45 deg, an hour at rest with perfect baro: the
    mechanization's errors follow ``x' = F x`` with paper 000's F (all couplings: Schuler,
    Earth rate, Foucault) to 0.5 % of each error's range (measured: 0.14 % at most)."""
    from scipy.linalg import expm
    lat, h = np.radians(45.0), 200.0
    phi0 = np.array([1e-4, -2e-4, 5e-4])
    dv0 = np.array([0.02, -0.01, 0.0])
    sol, *_ = run_at_rest(lat, h, np.radians([0.0, 0.0, 30.0]), 0.1, 3600.0, phi0=phi0,
                          dv0=dv0, damping="baro")
    C_true = dcm_from_euler(np.radians([0.0, 0.0, 30.0]))
    got = np.column_stack([misalignment(sol.C_nb, C_true), sol.vel_n[:, :2],
                           sol.lat - lat, sol.lon - 0.5])
    F = _paper000_F_at_rest(lat, h)
    x0 = np.concatenate([phi0, dv0[:2], [0.0, 0.0]])
    k = np.arange(0, len(sol.t), 600)
    want = np.array([expm(F * sol.t[i]) @ x0 for i in k])
    span = np.ptp(want, axis=0)
    assert np.all(np.abs(got[k] - want).max(axis=0) < 0.005 * span)


def _vertical_rate(lat, h):
    """``k`` with ``k^2 = -dg/dh`` [1/s] (about ``sqrt(2 g / R)``), by a central difference."""
    dgdh = (earth.gravity(lat, h + 1.0) - earth.gravity(lat, h - 1.0)) / 2.0
    return np.sqrt(-dgdh)


@pytest.mark.parametrize("dh0, dv0", [(1.0, 0.0), (0.0, 0.01)])
def test_free_vertical_channel_diverges_as_theory(dh0, dv0):
    """``dh'' = k^2 dh``: ``dh = dh0 cosh(k t) + dv0 sinh(k t) / k``."""
    lat, h = np.radians(30.0), 500.0
    sol, *_ = run_at_rest(lat, h, np.radians([1.0, 2.0, 45.0]), 0.1, 3600.0,
                          dv0=(0, 0, dv0), dh0=dh0)
    k = _vertical_rate(lat, h)
    assert k == pytest.approx(np.sqrt(2 * earth.gravity(lat, h) / earth.A), rel=0.01)
    t = sol.t
    theory = dh0 * np.cosh(k * t) + dv0 * np.sinh(k * t) / k
    err = sol.h - h
    assert err[-1] > 100 * max(dh0, dv0 / k)        # it really diverges
    assert np.abs(err - theory).max() < 0.02 * np.abs(theory).max()


def test_baro_damping_bounds_vertical_channel():
    """Critically damped loop, double pole at -1/tau: ``dh = dh0 (1 - t/tau) exp(-t/tau)``."""
    lat, h, dh0 = np.radians(30.0), 500.0, 5.0
    sol, *_ = run_at_rest(lat, h, [0, 0, 0], 0.1, 3600.0, dh0=dh0, damping="baro")
    tau = 10.0
    t = sol.t
    theory = dh0 * (1 - t / tau) * np.exp(-t / tau)
    err = sol.h - h
    assert np.abs(err - theory).max() < 0.02 * dh0
    assert np.abs(err[t > 200]).max() < 1e-3
    assert np.abs(sol.vel_n[t > 200, 2]).max() < 1e-4


def test_baro_gains_place_double_pole():
    lat = np.radians(50.0)
    k_h, k_v = baro_gains(20.0, lat)
    k2 = _vertical_rate(lat, 0.0) ** 2
    poles = np.roots([1.0, k_h, k_v - k2])
    assert np.allclose(poles, -1 / 20.0, atol=2e-4)


# ---------------------------------------------------------------- a moving vehicle
@pytest.fixture(scope="module")
def drive():
    t = np.arange(0.0, 300.0 + 1e-9, 0.05)
    return drive_increments(t, np.radians(34.0), np.radians(108.0), 400.0,
                            psi=lambda t: np.radians(20) + np.radians(40) * np.sin(t / 30.0),
                            dpsi=lambda t: np.radians(40) / 30.0 * np.cos(t / 30.0),
                            speed=lambda t: 12 + 8 * np.sin(t / 40.0),
                            accel=lambda t: 0.2 * np.cos(t / 40.0))


def _init(d, k=0):
    return NavState.from_euler(d["t"][k], d["lat"][k], d["lon"][k], d["h"][k], d["vel_n"][k],
                               d["euler"][k])


def test_turning_accelerating_drive_reproduces_truth(drive):
    d = drive
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    sol = strapdown(imu, _init(d), BaroData(d["t"], d["h"]), damping="baro")
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 0.01
    assert np.abs(sol.vel_n - d["vel_n"]).max() < 1e-4
    assert np.abs(misalignment(sol.C_nb, dcm_from_euler(d["euler"]))).max() < 0.01 * ARCSEC


def test_stop_and_go_hills_reproduce_truth():
    """The issue's acceptance, scaled: turns, climbs and a stop, 900 s at 20 Hz, perfect baro.
    (The full hour at 100 Hz: ``benchmarks/bench_core.py --accuracy``.)"""
    t = np.arange(0.0, 900.0 + 1e-9, 0.05)
    d = stop_and_go_hills(t)
    imu = ImuData(t, d["dtheta"], d["dvel"])
    sol = strapdown(imu, _init(d), BaroData(t, d["h"]), damping="baro")
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 0.01
    assert np.abs(sol.h - d["h"]).max() < 1e-3
    assert np.abs(sol.vel_n - d["vel_n"]).max() < 1e-4
    assert np.abs(misalignment(sol.C_nb, dcm_from_euler(d["euler"]))).max() < 0.01 * ARCSEC


def test_streaming_equals_batch_bit_for_bit(drive):
    d = drive
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    baro = BaroData(d["t"], d["h"])
    batch = strapdown(imu, _init(d), baro, damping="baro")
    nav = Strapdown(_init(d))
    xs, ts = [], []
    edges = [1, 2, 9, 130, 131, 2000, len(d["t"])]
    for a, b in zip(edges[:-1], edges[1:]):
        t_out, x_out = nav.run(d["dtheta"][a:b], d["dvel"][a:b], d["t"][a:b],
                               h_baro=d["h"][a:b], out_stride=1)
        xs.append(x_out)
        ts.append(t_out)
    x = np.vstack(xs)
    assert np.array_equal(np.concatenate(ts), batch.t[1:])
    assert np.array_equal(x[:, 0], batch.lat[1:])
    assert np.array_equal(x[:, 1], batch.lon[1:])
    assert np.array_equal(x[:, 3:6], batch.vel_n[1:])
    st = nav.state()
    assert st.t == batch.t[-1] and st.lat == batch.lat[-1] and st.h == batch.h[-1]
    # decimated output is the same states, every 7th
    dec = strapdown(imu, _init(d), baro, damping="baro", out_stride=7)
    assert np.array_equal(dec.t, batch.t[::7])
    assert np.array_equal(dec.lat, batch.lat[::7])


def test_chunked_batch_is_bit_identical_and_memory_flat(drive, monkeypatch):
    import tracemalloc
    import inmotion.core.mechanization as mech
    d = drive
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    baro = BaroData(d["t"][::10], d["h"][::10])
    one = strapdown(imu, _init(d), baro, damping="baro")
    monkeypatch.setattr(mech, "CHUNK_ROWS", 101)
    many = strapdown(imu, _init(d), baro, damping="baro")
    assert np.array_equal(one.lat, many.lat) and np.array_equal(one.euler, many.euler)
    monkeypatch.undo()
    peaks = []
    for n in (1000, 200_000, 600_000):    # beyond the output, flat; the first run warms up
        imu = stationary_imu(0.5, 0.0, [0, 0, 0], 0.01, (n - 1) * 0.01)
        baro = BaroData(imu.t[::5], np.zeros(len(imu.t[::5])))
        init = NavState(0.0, 0.5, 0.0, 0.0, [0, 0, 0], [1, 0, 0, 0])
        tracemalloc.start()
        strapdown(imu, init, baro, damping="baro", out_stride=10_000)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[2] < 1.1 * peaks[1] + 2e5


def test_rates_for_filters_are_last_increments_over_dt(drive):
    d = drive
    nav = Strapdown(_init(d))
    assert np.array_equal(nav.omega_ib_b, np.zeros(3))
    nav.run(d["dtheta"][1:50], d["dvel"][1:50], d["t"][1:50])
    dt = d["t"][49] - d["t"][48]
    assert np.allclose(nav.omega_ib_b, d["dtheta"][49] / dt, rtol=1e-12)
    assert np.allclose(nav.f_b, d["dvel"][49] / dt, rtol=1e-12)


def test_correct_removes_an_injected_error(drive):
    d = drive
    ref = Strapdown(_init(d))
    bad_init = _init(d)
    phi = np.radians([0.5, -0.3, 2.0])
    bad_init.q_nb = quat_from_dcm(apply_misalignment(bad_init.C_nb, phi))
    bad_init.vel_n = bad_init.vel_n + [0.3, -0.2, 0.1]
    bad_init.lat += 1e-6
    bad_init.h += 3.0
    nav = Strapdown(bad_init)
    half = len(d["t"]) // 2
    for s in (ref, nav):
        s.run(d["dtheta"][1:half], d["dvel"][1:half], d["t"][1:half])
    a, b = ref.state(), nav.state()
    err_phi = misalignment(b.C_nb, a.C_nb)
    assert np.linalg.norm(err_phi) > 1e-3           # the error is there
    nav.correct(phi=err_phi, dvel_n=b.vel_n - a.vel_n,
                dpos=[b.lat - a.lat, b.lon - a.lon, b.h - a.h])
    c = nav.state()
    assert np.linalg.norm(misalignment(c.C_nb, a.C_nb)) < 1e-12
    assert np.allclose(c.vel_n, a.vel_n, atol=1e-12)
    assert abs(c.lat - a.lat) < 1e-15 and abs(c.lon - a.lon) < 1e-15 and abs(c.h - a.h) < 1e-9
    for s in (ref, nav):
        s.run(d["dtheta"][half:], d["dvel"][half:], d["t"][half:])
    a, c = ref.state(), nav.state()
    dn, de = earth.local_ne_offsets(c.lat, c.lon, a.lat, a.lon)
    assert np.hypot(dn, de) < 1e-3
    assert np.abs(c.vel_n - a.vel_n).max() < 1e-5
    assert np.linalg.norm(misalignment(c.C_nb, a.C_nb)) < 1e-3 * ARCSEC


# ---------------------------------------------------------------- bad input
def test_bad_input_messages(drive):
    d = drive
    imu = ImuData(d["t"][:10], d["dtheta"][:10], d["dvel"][:10])
    with pytest.raises(BadInput, match="damping"):
        strapdown(imu, _init(d), damping="kalman")
    with pytest.raises(BadInput, match="needs barometer"):
        strapdown(imu, _init(d), damping="baro")
    with pytest.raises(BadInput, match="out_stride"):
        strapdown(imu, _init(d), out_stride=0)
    with pytest.raises(BadInput, match="time constant"):
        Strapdown(_init(d), baro_tau=0.0)
    nav = Strapdown(_init(d))
    t = d["t"][1:10].copy()
    t[4] = t[3]
    with pytest.raises(BadInput, match=r"imu, row 5, t=.*not strictly increasing"):
        nav.run(d["dtheta"][1:10], d["dvel"][1:10], t)
    with pytest.raises(BadInput, match="same number of rows"):
        nav.run(d["dtheta"][1:10], d["dvel"][1:9], d["t"][1:10])
    with pytest.raises(BadInput, match="h_baro has 3 rows"):
        nav.run(d["dtheta"][1:10], d["dvel"][1:10], d["t"][1:10], h_baro=np.zeros(3))


def test_bad_values_and_baro(drive):
    d = drive
    dth = d["dtheta"][:30].copy()
    dth[12, 1] = np.nan
    imu = ImuData(d["t"][:30], dth, d["dvel"][:30])
    with pytest.raises(BadInput, match=r"imu, row 13, t=0\.6 s: dtheta is not finite"):
        strapdown(imu, _init(d))
    imu = ImuData(d["t"][:30], d["dtheta"][:30], d["dvel"][:30])
    with pytest.raises(BadInput, match="baro: barometer damping needs at least 2 samples"):
        strapdown(imu, _init(d), BaroData([0.0], [400.0]), damping="baro")
    with pytest.raises(BadInput, match=r"baro, row 3, t=2 s: h is not finite"):
        strapdown(imu, _init(d), BaroData([0.0, 1.0, 2.0], [400.0, 400.0, np.inf]),
                  damping="baro")
    with pytest.raises(BadInput, match=r"baro, row 3, t=1 s: time not strictly increasing"):
        strapdown(imu, _init(d), BaroData([0.0, 1.0, 1.0], [400.0] * 3), damping="baro")


def test_baro_is_not_used_outside_its_span_or_in_gaps():
    """Baro from 10 s to 20 s and 60 s to 70 s (a 40 s gap), IMU at rest 0..100 s with a 2 m
    height error: damped only while the baro is there; never pulled towards an extrapolation."""
    lat, h = 0.3, 100.0
    imu = stationary_imu(lat, h, [0, 0, 0], 0.1, 100.0)
    tb = np.concatenate([np.arange(10.0, 20.01, 1.0), np.arange(60.0, 70.01, 1.0)])
    init = NavState(0.0, lat, 0.0, h + 2.0, [0, 0, 0], [1, 0, 0, 0])
    sol = strapdown(imu, init, BaroData(tb, np.full(len(tb), h)), damping="baro", baro_tau=2.0)
    err = sol.h - h
    free = run_at_rest(lat, h, [0, 0, 0], 0.1, 100.0, dh0=2.0)[0].h - h
    before = sol.t < 10.0
    assert np.array_equal(err[before], free[before])   # no baro yet: the free channel
    k20, k60 = np.searchsorted(sol.t, [20.0, 60.0])
    assert abs(err[k20]) < 0.2                          # pulled in while the baro was there
    gap = (sol.t > 20.05) & (sol.t < 60.0)
    slope = np.polyfit(sol.t[gap], err[gap], 1)[0]
    assert abs(slope - sol.vel_n[k20 + 1, 2]) < 1e-3    # in the gap: coasting, no damping
