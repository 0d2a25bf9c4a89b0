"""Dead reckoning (paper 002) against geometry: perfect sensors, scale factor, heading error,
mounting, lever arm, sensor on its own rate, streaming and feedback, bad input."""
import numpy as np
import pytest

from analytic_drive import drive_increments, stop_and_go_hills
from inmotion.core import earth
from inmotion.core.bundle import ImuData, SpeedData
from inmotion.core.deadreckoning import DeadReckoner, dead_reckon, speed_on_epochs
from inmotion.core.rotations import (apply_misalignment, dcm_from_euler, misalignment,
                                     quat_from_dcm, rot_x, rot_z)
from inmotion.core.solution import NavState
from inmotion.errors import BadInput

ARCSEC = np.pi / 180 / 3600
LAT0, LON0, H0 = np.radians(40.0), np.radians(-3.0), 650.0


def _init(d, k=0):
    return NavState.from_euler(d["t"][k], d["lat"][k], d["lon"][k], d["h"][k], d["vel_n"][k],
                               d["euler"][k])


@pytest.fixture(scope="module")
def north_line():
    """Straight along the meridian, 15 m/s, 1000 s, IMU at 10 Hz (15 km)."""
    t = np.arange(0.0, 1000.0 + 1e-9, 0.1)
    return drive_increments(t, LAT0, LON0, H0, psi=lambda t: 0.0 * t, dpsi=lambda t: 0.0 * t,
                            speed=lambda t: 15.0 + 0.0 * t, accel=lambda t: 0.0 * t)


@pytest.fixture(scope="module")
def circle():
    """Constant 6 deg/s right turn at 8 m/s (radius 76 m), 120 s, IMU at 50 Hz; a wheel sensor
    0.4 m right of, 1.8 m behind and 0.6 m below the IMU reads ``8 + [omega_eb_b x l_b]_y``
    (less: it is on the inside of the turn)."""
    t = np.arange(0.0, 120.0 + 1e-9, 0.02)
    rate = np.radians(6.0)
    d = drive_increments(t, LAT0, LON0, H0, psi=lambda t: 0.3 + rate * t,
                         dpsi=lambda t: rate + 0 * t, speed=lambda t: 8.0 + 0 * t,
                         accel=lambda t: 0.0 * t)
    d["lever"] = np.array([0.4, -1.8, -0.6])
    d["v_sensor"] = 8.0 + np.cross(d["omega_eb_b"], d["lever"])[:, 1]
    return d


def _offsets(sol, lat, lon):
    """North and east error [m] of the solution against truth."""
    return earth.local_ne_offsets(sol.lat, sol.lon, lat, lon, H0)


def test_perfect_sensors_reproduce_a_straight_drive(north_line):
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    sol = dead_reckon(imu, SpeedData(d["t"], v=np.full(len(d["t"]), 15.0)), _init(d))
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 1e-3
    assert np.abs(sol.vel_n - d["vel_n"]).max() < 1e-6
    assert np.abs(misalignment(sol.C_nb, dcm_from_euler(d["euler"]))).max() < 1e-3 * ARCSEC


def test_perfect_sensors_reproduce_turns_climbs_and_stops():
    """Turns, +-3 deg climbs and a stop, 900 s, IMU 20 Hz, odometer ``ds`` at 20 Hz."""
    t = np.arange(0.0, 900.0 + 1e-9, 0.05)
    d = stop_and_go_hills(t)
    imu = ImuData(t, d["dtheta"], d["dvel"])
    v = np.linalg.norm(d["vel_n"], axis=1)
    ds = np.concatenate([[0.0], 0.5 * (v[1:] + v[:-1]) * np.diff(t)])
    sol = dead_reckon(imu, SpeedData(t, ds=ds), _init(d))
    dn, de = earth.local_ne_offsets(sol.lat, sol.lon, d["lat"], d["lon"])
    # the trapezoid of the speed is the only approximation: O(dt^2) per unit distance
    assert np.hypot(dn, de).max() < 0.05
    assert np.abs(sol.h - d["h"]).max() < 0.05
    assert np.abs(sol.vel_n - d["vel_n"]).max() < 1e-4
    assert np.abs(misalignment(sol.C_nb, dcm_from_euler(d["euler"]))).max() < 0.01 * ARCSEC


def test_scale_factor_error_gives_proportional_along_track_error(north_line):
    """A sensor reading (1 + 1e-3) times the truth ends 1e-3 of the distance ahead;
    ``scale = 1 / (1 + 1e-3)`` removes it."""
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    speed = SpeedData(d["t"], v=np.full(len(d["t"]), 15.0 * 1.001))
    dist = 15.0 * 1000.0
    sol = dead_reckon(imu, speed, _init(d))
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert dn[-1] == pytest.approx(1e-3 * dist, rel=2e-3)
    assert abs(de[-1]) < 0.01
    fixed = dead_reckon(imu, speed, _init(d), scale=1 / 1.001)
    dn, de = _offsets(fixed, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 1e-3


@pytest.mark.parametrize("x_deg", [0.5, -2.0])
def test_heading_error_gives_cross_track_distance_sin_x(north_line, x_deg):
    """Initial yaw error x (yaw too large = heading east of the truth): the DR drives at
    heading x, cross-track ``d sin x`` (east), along-track ``-d (1 - cos x)``."""
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    init = _init(d)
    x = np.radians(x_deg)
    init.q_nb = quat_from_dcm(dcm_from_euler([0.0, 0.0, x]))
    sol = dead_reckon(imu, SpeedData(d["t"], v=np.full(len(d["t"]), 15.0)), init)
    dn, de = _offsets(sol, d["lat"], d["lon"])
    dist = 15.0 * 1000.0
    assert de[-1] == pytest.approx(dist * np.sin(x), rel=2e-3)
    along = dist * (1 - np.cos(x))
    assert dn[-1] == pytest.approx(-along, abs=0.02 + 2e-3 * along)


def test_tilt_error_follows_paper000_eq20(north_line):
    """A DR misalignment ``phi_DE`` on a northbound drive: paper 000 eq. 20,
    ``dh' = -v_N phi_DE + v_E phi_DN``, so the height error is ``-v_N phi_DE t``. The Earth rate
    turns the tilt into azimuth, ``phi_DU' = w_ie cos L phi_DE`` (the attitude error equation,
    F(3,1)), and eq. 12 ``dv_DE = v_N phi_DU`` gives the east error ``v_N w_ie cos L phi_DE t^2/2``."""
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    init = _init(d)
    phi = np.array([2e-4, 0.0, 0.0])
    init.q_nb = quat_from_dcm(apply_misalignment(init.C_nb, phi))
    sol = dead_reckon(imu, SpeedData(d["t"], v=np.full(len(d["t"]), 15.0)), init)
    dh = sol.h - d["h"]
    assert dh[-1] == pytest.approx(-15.0 * phi[0] * 1000.0, rel=5e-3)
    dn, de = _offsets(sol, d["lat"], d["lon"])
    t = 1000.0
    assert de[-1] == pytest.approx(15.0 * earth.OMEGA_IE * np.cos(LAT0) * phi[0] * t ** 2 / 2,
                                   rel=0.02)
    assert abs(dn[-1]) < 0.01


def test_mounting_matrix_turns_the_sensor_axis(north_line):
    """A sensor yawed by +delta (forward axis turned counter-clockwise, towards West) but run as
    if aligned goes off by ``-d sin delta`` to the East; given ``C_bm`` it is exact."""
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    speed = SpeedData(d["t"], v=np.full(len(d["t"]), 15.0))
    delta = np.radians(1.0)
    # the sensor's axis is body forward; saying it is turned by +delta moves the track west
    sol = dead_reckon(imu, speed, _init(d), C_bm=rot_z(delta))
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert de[-1] == pytest.approx(-15000.0 * np.sin(delta), rel=2e-3)
    # a sensor pitched up by eps (about body x) climbs d sin(eps)
    eps = np.radians(0.5)
    up = dead_reckon(imu, speed, _init(d), C_bm=rot_x(eps))
    assert up.vel_n[-1, 2] == pytest.approx(15.0 * np.sin(eps), rel=1e-3)
    assert up.h[-1] - H0 == pytest.approx(15000.0 * np.sin(eps), rel=2e-3)


def test_lever_arm_on_a_turning_vehicle(circle):
    """The IMU moves along the vehicle's forward axis; the sensor at the lever arm reads the
    forward part of ``omega x l`` on top (docs/ARCHITECTURE.md, vehicle frame). With the lever
    arm the DR gives the IMU's path; without it, the circle comes out 0.5 % small (0.8 m off
    across it)."""
    d = circle
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    speed = SpeedData(d["t"], v=d["v_sensor"])
    assert d["v_sensor"].max() < 7.96                    # the inner-wheel effect is there
    sol = dead_reckon(imu, speed, _init(d), lever_arm_b=d["lever"])
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 0.005
    assert np.abs(sol.vel_n[1:] - d["vel_n"][1:]).max() < 1e-4
    naive = dead_reckon(imu, speed, _init(d))
    dn, de = _offsets(naive, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() > 0.5


def test_distance_sensor_on_its_own_rate(circle):
    """An odometer giving ``ds`` at 7 Hz (IMU 50 Hz): its distance is interpolated to the IMU
    epochs; the positions agree with the truth to the interpolation error (cm)."""
    d = circle
    ts = np.arange(0.0, 120.0 + 1e-9, 1 / 7)
    v_s = np.interp(ts, d["t"], d["v_sensor"])           # constant in this turn
    odo = SpeedData(ts, ds=v_s / 7)
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    sol = dead_reckon(imu, odo, _init(d), lever_arm_b=d["lever"])
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert np.hypot(dn, de).max() < 0.01
    assert sol.info["rows_without_speed"] == 0


def test_chunked_batch_equals_one_chunk(circle, monkeypatch):
    """The batch run goes through the log in chunks, carrying the sensor's distance: small
    chunks give the same result as one (to rounding); gaps and coverage are counted alike."""
    import inmotion.core.deadreckoning as drm
    d = circle
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    ts = np.concatenate([np.arange(3.0, 50.0, 1 / 7), np.arange(60.0, 110.0, 1 / 7)])
    odo = SpeedData(ts, ds=np.full(len(ts), 8.0 / 7))
    init = _init(d)
    one = dead_reckon(imu, odo, init, lever_arm_b=d["lever"])
    monkeypatch.setattr(drm, "CHUNK_ROWS", 97)
    many = dead_reckon(imu, odo, init, lever_arm_b=d["lever"])
    assert one.info == many.info and one.info["rows_in_speed_gaps"] > 0
    assert np.abs(many.lat - one.lat).max() * earth.A < 1e-9
    assert np.abs(many.lon - one.lon).max() * earth.A < 1e-9


def test_memory_stays_flat_with_log_length():
    """Beyond its output, a run allocates the same whether the log is 1x or 3x as long."""
    import tracemalloc
    peaks = []
    for n in (1000, 200_000, 600_000):    # the first run warms up
        t = np.arange(n) * 0.01
        imu = ImuData(t, np.tile([0.0, 5e-7, 4e-7], (n, 1)), np.tile([0, 0, 0.098], (n, 1)))
        odo = SpeedData(t[::3], ds=np.full(len(t[::3]), 0.3))
        init = NavState.from_euler(0.0, LAT0, LON0, H0, [0, 10.0, 0], [0, 0, 0])
        tracemalloc.start()
        dead_reckon(imu, odo, init, out_stride=10_000)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[2] < 1.1 * peaks[1] + 2e5


def test_speed_is_never_extrapolated():
    """IMU epochs outside the sensor's span get no distance; gaps are interpolated across and
    counted; a ``v`` sensor is integrated by the trapezoid."""
    t_imu = np.arange(0.0, 10.0 + 1e-9, 0.1)
    sensor = SpeedData(np.array([2.0, 3.0, 4.0, 8.0, 9.0]), v=np.array([1.0, 3.0, 3.0, 5.0, 5.0]))
    ds, v, uncovered, in_gap = speed_on_epochs(sensor, t_imu, max_gap=2.0)
    inside = (t_imu[:-1] >= 2.0 - 1e-9) & (t_imu[1:] <= 9.0 + 1e-9)
    assert np.array_equal(~uncovered, inside)
    assert np.all(ds[uncovered] == 0) and np.all(v[uncovered] == 0)
    # trapezoid: 2 + 3 + 16 + 5 = 26 m from t=2 to t=9
    assert ds.sum() == pytest.approx(26.0, abs=1e-9)
    gap = (t_imu[1:] > 4.0 + 1e-9) & (t_imu[:-1] < 8.0 - 1e-9)
    assert np.array_equal(in_gap, gap)


def test_dead_reckon_holds_position_without_sensor(north_line):
    d = north_line
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    speed = SpeedData(d["t"][:5001], v=np.full(5001, 15.0))       # stops at t = 500 s
    sol = dead_reckon(imu, speed, _init(d))
    assert sol.info["rows_without_speed"] == len(d["t"]) - 5001
    assert np.all(sol.lat[5001:] == sol.lat[5000])
    dn, de = _offsets(sol, d["lat"], d["lon"])
    assert np.hypot(dn[:5001], de[:5001]).max() < 1e-3


def test_streaming_equals_batch_and_correct_removes_error(circle):
    d = circle
    imu = ImuData(d["t"], d["dtheta"], d["dvel"])
    speed = SpeedData(d["t"], v=d["v_sensor"])
    init = _init(d)
    batch = dead_reckon(imu, speed, init, lever_arm_b=d["lever"])
    ds, v, _, _ = speed_on_epochs(speed, d["t"])
    dr = DeadReckoner(init, lever_arm_b=d["lever"])
    lat = []
    edges = [1, 2, 50, 51, 3000, len(d["t"])]
    for a, b in zip(edges[:-1], edges[1:]):
        _, x = dr.run(d["dtheta"][a:b], d["t"][a:b], ds[a - 1:b - 1], v[a - 1:b - 1], out_stride=1)
        lat.append(x[:, 0])
    assert np.array_equal(np.concatenate(lat), batch.lat[1:])
    assert dr.state().lon == batch.lon[-1]
    assert np.allclose(dr.omega_ib_b, d["dtheta"][-1] / 0.02, rtol=1e-9)
    # inject an attitude and position error, then take it out with correct()
    ref = DeadReckoner(init, lever_arm_b=d["lever"])
    bad = init.copy()
    bad.q_nb = quat_from_dcm(apply_misalignment(init.C_nb, np.radians([0.2, 0.1, 1.5])))
    bad.lat += 2e-6
    nav = DeadReckoner(bad, lever_arm_b=d["lever"])
    half = len(d["t"]) // 2
    for s in (ref, nav):
        s.run(d["dtheta"][1:half], d["t"][1:half], ds[:half - 1], v[:half - 1])
    a, b = ref.state(), nav.state()
    nav.correct(phi=misalignment(b.C_nb, a.C_nb), dpos=[b.lat - a.lat, b.lon - a.lon, b.h - a.h])
    for s in (ref, nav):
        s.run(d["dtheta"][half:], d["t"][half:], ds[half - 1:], v[half - 1:])
    a, c = ref.state(), nav.state()
    dn, de = earth.local_ne_offsets(c.lat, c.lon, a.lat, a.lon)
    assert np.hypot(dn, de) < 1e-4
    assert np.linalg.norm(misalignment(c.C_nb, a.C_nb)) < 1e-3 * ARCSEC


def test_bad_input_messages(north_line):
    d = north_line
    imu = ImuData(d["t"][:20], d["dtheta"][:20], d["dvel"][:20])
    good = SpeedData(d["t"][:20], v=np.full(20, 15.0))
    t_bad = d["t"][:20].copy()
    t_bad[6] = t_bad[5]
    with pytest.raises(BadInput, match=r"radar, row 7, t=.*not strictly increasing"):
        speed_on_epochs(SpeedData(t_bad, v=np.full(20, 15.0)), d["t"][:20], what="radar")
    t_nan = d["t"][:20].copy()
    t_nan[9] = np.nan
    with pytest.raises(BadInput, match=r"odometer, row 10: t is not finite"):
        speed_on_epochs(SpeedData(t_nan, ds=np.full(20, 1.5)), d["t"][:20], what="odometer")
    v_bad = np.full(20, 15.0)
    v_bad[3] = np.nan
    with pytest.raises(BadInput, match=r"row 4, t=.*v is not a finite number"):
        dead_reckon(imu, SpeedData(d["t"][:20], v=v_bad), _init(d))
    with pytest.raises(BadInput, match="at least 2 samples"):
        dead_reckon(imu, SpeedData(d["t"][:1], v=[1.0]), _init(d))
    with pytest.raises(BadInput, match="not a rotation matrix"):
        dead_reckon(imu, good, _init(d), C_bm=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(BadInput, match="3x3"):
        dead_reckon(imu, good, _init(d), C_bm=np.eye(2))
    with pytest.raises(BadInput, match="lever_arm_b"):
        dead_reckon(imu, good, _init(d), lever_arm_b=[1.0, 2.0])
    with pytest.raises(BadInput, match="scale"):
        dead_reckon(imu, good, _init(d), scale=0.0)
    with pytest.raises(BadInput, match="out_stride"):
        dead_reckon(imu, good, _init(d), out_stride=0)
    dr = DeadReckoner(_init(d))
    with pytest.raises(BadInput, match="same number of rows"):
        dr.run(d["dtheta"][1:5], d["t"][1:5], np.zeros(3), np.zeros(4))
    with pytest.raises(BadInput, match=r"speed, row 2, t=0\.2 s: ds is not finite"):
        dr.run(d["dtheta"][1:5], d["t"][1:5], np.array([0.0, np.nan, 0.0, 0.0]), np.zeros(4))
    dth = d["dtheta"][:20].copy()
    dth[7, 2] = np.inf
    with pytest.raises(BadInput, match=r"imu, row 8, t=0\.7 s: dtheta is not finite"):
        dead_reckon(ImuData(d["t"][:20], dth, d["dvel"][:20]), good, _init(d))
