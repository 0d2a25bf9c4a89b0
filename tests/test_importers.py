"""Importers end to end: small logs synthesized in each format from a known state (closed-form
increments, known attitude), the two real drives of ``../shared/data/real`` against their own
reference, the KF-GINS export round trip, the CLI, and every bad-input path."""
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import yaml
from click.testing import CliRunner

from inmotion.cli.import_cmds import export_cmd, import_cmd
from inmotion.core import earth, rotations
from inmotion.core.solution import Solution
from inmotion.errors import BadInput
from inmotion.io.importers import get_importer, import_log
from inmotion.io.importers.axes import (C_b_src, design_euler_from_ned_rpy,
                                        ned_rpy_from_design_euler)
from inmotion.io.importers.comma2k19 import import_comma2k19
from inmotion.io.importers.csv import import_csv
from inmotion.io.importers.ems import import_ems
from inmotion.io.importers.kf_gins import export_kf_gins, import_kf_gins, read_gnss, read_nav

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"
COMMA = REAL / "comma2k19_rav4_60s"
EMS = REAL / "ems_toronto_511s" / "ems_data_for_lc.mat"
D = np.pi / 180.0
LAT, LON, H = 30.5 * D, 114.3 * D, 25.0
G = 9.79

# a level vehicle at rest heading East: in FRD (forward = East, right = South, down = Down)
# the Earth rate [0, W cos L, W sin L] (ENU) reads [0, -W cos L, -W sin L] and the specific
# force [0, 0, -g]
W_FRD = np.array([0.0, -earth.OMEGA_IE * np.cos(LAT), -earth.OMEGA_IE * np.sin(LAT)])
F_FRD = np.array([0.0, 0.0, -G])


def earth_rate_in_b_heading_east():
    """``C_b^n(yaw = 90 deg)^T omega_ie^n``, from the DESIGN Euler convention alone."""
    C_nb = rotations.dcm_from_euler(np.array([0.0, 0.0, 90 * D]))
    return C_nb.T @ earth.omega_ie_n(LAT)


# ----------------------------------------------------------------------------- axes


def test_axes_declaration_to_rfu():
    np.testing.assert_array_equal(C_b_src(["forward", "right", "down"]) @ [1, 2, 3], [2, 1, -3])
    np.testing.assert_array_equal(C_b_src(["forward", "left", "up"]) @ [1, 2, 3], [-2, 1, 3])
    with pytest.raises(BadInput, match="right-handed"):
        C_b_src(["forward", "right", "up"])
    with pytest.raises(BadInput, match="unknown axis direction 'fwd'"):
        C_b_src(["fwd", "right", "down"])
    with pytest.raises(BadInput, match="3 directions"):
        C_b_src(["forward", "right"])


def test_ned_rpy_to_design_euler_by_axis_directions():
    """The FRD axes of an aerospace ZYX attitude, written independently in ENU, are the
    columns of the DESIGN C_b^n (forward = column y, right = column x)."""
    rng = np.random.default_rng(7)
    roll, pitch = rng.uniform(-40, 40, 50) * D, rng.uniform(-60, 60, 50) * D
    yaw = rng.uniform(0, 360, 50) * D
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), \
        np.cos(yaw), np.sin(yaw)
    forward_enu = np.column_stack([sy * cp, cy * cp, sp])
    right_enu = np.column_stack([sy * sp * sr + cy * cr, cy * sp * sr - sy * cr, -cp * sr])
    euler = design_euler_from_ned_rpy(roll, pitch, yaw)
    C_nb = rotations.dcm_from_euler(euler)
    np.testing.assert_allclose(C_nb[:, :, 1], forward_enu, atol=1e-12)
    np.testing.assert_allclose(C_nb[:, :, 0], right_enu, atol=1e-12)
    # same physical sequence (yaw, pitch about right, roll about forward): same numbers
    np.testing.assert_allclose(euler, np.column_stack([pitch, roll, yaw]), atol=1e-12)
    np.testing.assert_allclose(ned_rpy_from_design_euler(euler),
                               np.column_stack([roll, pitch, yaw]), atol=1e-12)


# ----------------------------------------------------------------------------- KF-GINS


def write_kf_gins(folder, n=200, dt=0.005, sow0=345600.0, odo_column=False):
    t = sow0 + dt * np.arange(1, n + 1)
    cols = [t, *(W_FRD[:, None] * dt * np.ones(n)), *(F_FRD[:, None] * dt * np.ones(n))]
    if odo_column:
        cols.append(np.full(n, 0.0))
    imu = folder / "imu.txt"
    np.savetxt(imu, np.column_stack(cols), fmt="%.12e")
    t_nav = sow0 + 0.1 * np.arange(11)
    nav = np.column_stack([np.full(11, 2200), t_nav, np.full(11, LAT / D), np.full(11, LON / D),
                           np.full(11, H), np.zeros(11), np.full(11, 10.0), np.zeros(11),
                           np.zeros(11), np.zeros(11), np.full(11, 90.0)])
    np.savetxt(folder / "truth.nav", nav, fmt="%.10f")
    gnss = np.column_stack([t_nav, np.full(11, LAT / D + 1e-5), np.full(11, LON / D),
                            np.full(11, H), np.full((11, 3), 0.02)])
    np.savetxt(folder / "gnss.txt", gnss, fmt="%.10f", delimiter=",")
    np.savetxt(folder / "odo.txt", np.column_stack([t_nav, np.full(11, 10.0)]), fmt="%.6f")
    return imu


def test_kf_gins_level_vehicle_heading_east(tmp_path):
    imu = write_kf_gins(tmp_path)
    b = import_kf_gins(imu, nav=tmp_path / "truth.nav", odo=tmp_path / "odo.txt",
                       gnss=tmp_path / "gnss.txt")
    dt = 0.005
    np.testing.assert_allclose(b.imu.dtheta / dt, np.tile(earth_rate_in_b_heading_east(),
                                                          (200, 1)), atol=1e-15)
    np.testing.assert_allclose(b.imu.dvel / dt, np.tile([0, 0, G], (200, 1)), atol=1e-12)
    np.testing.assert_allclose(b.truth.euler[-1], [0, 0, 90 * D], atol=1e-12)
    np.testing.assert_allclose(b.truth.vel_n[-1], [10, 0, 0], atol=1e-12)
    assert b.truth.lat[0] == pytest.approx(LAT) and b.truth.h[0] == pytest.approx(H)
    np.testing.assert_allclose(b.odometer.v, 10.0)
    assert b.meta["initial_position"]["lat_deg"] == pytest.approx(LAT / D)
    assert b.meta["gnss"]["rows"] == 11 and "gaps" not in b.meta
    g = read_gnss(tmp_path / "gnss.txt")
    assert list(g.columns[:4]) == ["t", "lat_deg", "lon_deg", "h_m"]


def test_kf_gins_eighth_column_odometer_gnss_position_and_week_rollover(tmp_path):
    imu = write_kf_gins(tmp_path, sow0=604799.0, odo_column=True)
    b = import_kf_gins(imu, gnss=tmp_path / "gnss.txt")
    assert np.all(np.diff(b.imu.t) > 0) and b.imu.t[-1] == pytest.approx(604800.0 + 0.0)
    assert b.odometer is not None and np.all(b.odometer.v == 0.0)
    assert b.truth is None
    assert b.meta["initial_position"]["lat_deg"] == pytest.approx(LAT / D + 1e-5)


def test_kf_gins_comment_lines_and_commas(tmp_path):
    imu = write_kf_gins(tmp_path)
    rows = np.loadtxt(imu)
    text = "# sow, dtheta [rad], dvel [m/s]\n" + "\n".join(", ".join(f"{x:.12e}" for x in r)
                                                          for r in rows) + "\n"
    (tmp_path / "c.txt").write_text(text)
    np.testing.assert_array_equal(import_kf_gins(tmp_path / "c.txt").imu.dvel,
                                  import_kf_gins(imu).imu.dvel)


def test_kf_gins_binary_imu_file(tmp_path):
    imu = write_kf_gins(tmp_path)
    text = np.loadtxt(imu)
    text.astype("<f8").tofile(tmp_path / "imu.bin")
    b_txt, b_bin = import_kf_gins(imu), import_kf_gins(tmp_path / "imu.bin")
    np.testing.assert_array_equal(b_bin.imu.dtheta, b_txt.imu.dtheta)
    np.testing.assert_array_equal(b_bin.imu.t, b_txt.imu.t)
    np.zeros(10).tofile(tmp_path / "bad.bin")
    with pytest.raises(BadInput, match="not a multiple of 7"):
        import_kf_gins(tmp_path / "bad.bin")


def test_kf_gins_export_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    n = 20
    euler = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.5, 0.5, n),
                             rng.uniform(0, 2 * np.pi, n)])
    sol = Solution(np.arange(n) * 0.5 + 1000.0, np.full(n, LAT), np.full(n, LON),
                   np.full(n, H), rng.normal(0, 5, (n, 3)), euler)
    out = export_kf_gins(sol, tmp_path / "out" / "result.nav", gps_week=2200)
    back = read_nav(out)
    np.testing.assert_allclose(back.t, sol.t)
    np.testing.assert_allclose(back.lat, sol.lat, atol=1e-12)
    np.testing.assert_allclose(back.vel_n, sol.vel_n, atol=1e-5)
    np.testing.assert_allclose(rotations.misalignment(rotations.dcm_from_euler(back.euler),
                                                      sol.C_nb), 0, atol=1e-9)
    assert np.loadtxt(out)[0, 0] == 2200


def test_kf_gins_export_from_result_folder(tmp_path):
    from inmotion.io.result import write_result

    n = 5
    sol = Solution(np.arange(n, dtype=float), np.full(n, LAT), np.full(n, LON), np.full(n, H),
                   np.tile([10.0, 0, 0], (n, 1)), np.tile([0, 0, 90 * D], (n, 1)))
    write_result(sol, tmp_path / "res")
    out = export_kf_gins(tmp_path / "res", tmp_path / "r.nav")
    row = np.loadtxt(out)[-1]
    np.testing.assert_allclose(row[5:8], [0, 10, 0], atol=1e-9)       # NED velocity
    np.testing.assert_allclose(row[8:11], [0, 0, 90], atol=1e-6)      # roll, pitch, yaw


@pytest.mark.parametrize("content, match, row", [
    ("345600.0 1 2 3 4 5\n", "7 or 8 columns", 1),
    ("345600.0 0 0 0 0 0 0\n345600.005 0 0 x 0 0 0\n", "not a finite number", 2),
    ("345600.0 0 0 0 0 0 0\n345600.005 0 0 0 0 0\n", "6 columns, expected 7", 2),
    ("345600.0 0 0 0 0 0 0\n345599.0 0 0 0 0 0 0\n", "not strictly increasing", 2),
])
def test_kf_gins_bad_imu_file(tmp_path, content, match, row):
    p = tmp_path / "imu.txt"
    p.write_text(content)
    with pytest.raises(BadInput, match=match) as e:
        import_kf_gins(p)
    assert e.value.row == row and "imu.txt" in str(e.value)


def test_kf_gins_missing_files(tmp_path):
    with pytest.raises(BadInput, match="not found"):
        import_kf_gins(tmp_path / "nope.txt")
    imu = write_kf_gins(tmp_path)
    with pytest.raises(BadInput, match="nav file not found"):
        import_kf_gins(imu, nav=tmp_path / "missing.nav")
    (tmp_path / "bad.nav").write_text("0 1 2 3\n")
    with pytest.raises(BadInput, match="11 columns"):
        import_kf_gins(imu, nav=tmp_path / "bad.nav")
    with pytest.raises(BadInput, match="solution.csv"):
        export_kf_gins(tmp_path, tmp_path / "x.nav")


# ----------------------------------------------------------------------------- comma2k19


def save_npy(path, arr):
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:                  # no .npy suffix, as in comma2k19
        np.save(f, arr)


def write_comma_segment(root, rng, n=300):
    dt = 0.0096 * (1 + 0.2 * rng.uniform(-1, 1, n - 1))
    t = 500.0 + np.concatenate([[0], np.cumsum(dt)])
    w = np.tile([0.01, -0.02, 0.03], (n, 1))       # [forward, right, down] rad/s
    f = np.tile([0.5, 0.0, -9.8], (n, 1))
    for name, v in (("accelerometer", f), ("gyro", w)):
        save_npy(root / "processed_log/IMU" / name / "t", t)
        save_npy(root / "processed_log/IMU" / name / "value", v)
    t_can = 500.001 + 0.0112 * np.arange(200)
    save_npy(root / "processed_log/CAN/speed/t", t_can)
    save_npy(root / "processed_log/CAN/speed/value", np.full((200, 1), 10.0))
    t_ref = 499.99 + 0.05 * np.arange(60)
    C_en = earth.enu_from_ecef_matrix(LAT, LON).T
    C_nb = rotations.dcm_from_euler(np.array([0.0, 0.0, 90 * D]))
    C_b_cam = C_b_src(["forward", "right", "down"])
    q = rotations.quat_from_dcm(C_en @ C_nb @ C_b_cam)
    pose = root / "global_pose"
    save_npy(pose / "frame_times", t_ref)
    save_npy(pose / "frame_positions", np.tile(earth.lla_to_ecef(LAT, LON, H), (60, 1)))
    save_npy(pose / "frame_velocities", np.tile(C_en @ [10.0, 0, 0], (60, 1)))
    save_npy(pose / "frame_orientations", np.tile(q, (60, 1)))
    save_npy(pose / "frame_gps_times", np.tile([2012.0, 404106.4], (60, 1)))
    return t


def test_comma2k19_level_vehicle_heading_east(tmp_path):
    t = write_comma_segment(tmp_path / "seg", np.random.default_rng(5))
    b = import_comma2k19(tmp_path / "seg")
    np.testing.assert_array_equal(b.imu.t, t[1:])
    dt = np.diff(t)[:, None]
    np.testing.assert_allclose(b.imu.dtheta, [-0.02, 0.01, -0.03] * dt, atol=1e-16)
    np.testing.assert_allclose(b.imu.dvel, [0.0, 0.5, 9.8] * dt, atol=1e-15)
    np.testing.assert_allclose(b.truth.euler, np.tile([0, 0, 90 * D], (60, 1)), atol=1e-12)
    np.testing.assert_allclose(b.truth.vel_n, np.tile([10.0, 0, 0], (60, 1)), atol=1e-9)
    np.testing.assert_allclose(b.truth.lat, LAT, atol=1e-12)
    np.testing.assert_allclose(b.truth.h, H, atol=1e-6)
    np.testing.assert_allclose(b.odometer.v, 10.0)
    assert b.meta["truth"]["gps_week"] == 2012


def test_comma2k19_gyro_on_its_own_clock(tmp_path):
    """A gyro with its own (offset, slower) time stamps and a linear rate: interpolated to the
    accelerometer clock, the trapezoid increments are still the exact integrals."""
    root = tmp_path / "seg"
    t = write_comma_segment(root, np.random.default_rng(9))
    t_w = np.arange(t[0] - 0.05, t[-1] - 0.2, 0.013)
    w = np.column_stack([0.01 + 0.002 * (t_w - 500), -0.02 * np.ones_like(t_w), 0.03 + 0 * t_w])
    save_npy(root / "processed_log/IMU/gyro/t", t_w)
    save_npy(root / "processed_log/IMU/gyro/value", w)
    b = import_comma2k19(root)
    t_kept = t[t <= t_w[-1]]
    np.testing.assert_array_equal(b.imu.t, t_kept[1:])
    s = t_kept - 500
    exact_forward = np.diff(0.01 * s + 0.001 * s ** 2)       # integral of the forward rate
    np.testing.assert_allclose(b.imu.dtheta[:, 1], exact_forward, atol=1e-15)
    np.testing.assert_allclose(b.imu.dtheta[:, 0], -0.02 * np.diff(t_kept), atol=1e-16)
    assert b.meta["source"]["gyro_clock"].startswith("own clock")


def test_comma2k19_bad_layouts(tmp_path):
    with pytest.raises(BadInput, match="segment folder not found"):
        import_comma2k19(tmp_path / "none")
    root = tmp_path / "seg"
    write_comma_segment(root, np.random.default_rng(6))
    (root / "processed_log/CAN/speed/value").unlink()
    with pytest.raises(BadInput, match="file not found"):
        import_comma2k19(root)
    save_npy(root / "processed_log/CAN/speed/value", np.full((200, 1), 10.0))
    save_npy(root / "processed_log/IMU/gyro/t", np.load(root / "processed_log/IMU/gyro/t") + 1e3)
    with pytest.raises(BadInput, match="spans do not overlap"):
        import_comma2k19(root)
    root2 = tmp_path / "seg2"
    write_comma_segment(root2, np.random.default_rng(6))
    save_npy(root2 / "global_pose/frame_orientations", np.zeros((60, 3)))
    with pytest.raises(BadInput, match=r"expected \(60, 4\)"):
        import_comma2k19(root2)
    (root2 / "processed_log/IMU/gyro/value").write_text("not numpy")
    with pytest.raises(BadInput, match="not a NumPy"):
        import_comma2k19(root2)
    with pytest.raises(BadInput, match="gyro must be"):
        import_comma2k19(root, gyro="magnetometer")


# ----------------------------------------------------------------------------- EMS


def write_ems(path, n=100, **override):
    t = 0.05 * np.arange(n)
    s = {"time": t, "accel": np.tile(F_FRD, (n, 1)), "gyro": np.tile(W_FRD, (n, 1)),
         "roll": np.zeros(n), "pitch": np.zeros(n), "heading": np.full(n, 90 * D),
         "lat": np.full(n, LAT), "lon": np.full(n, LON), "h": np.uint8(100),
         "vel_N": np.tile([5.0, 0.0, 0.0], (n, 1))}
    s.update(override)
    scipy.io.savemat(path, {"ems_data": s})
    return path


def test_ems_level_vehicle_heading_east(tmp_path):
    b = import_ems(write_ems(tmp_path / "e.mat"))
    np.testing.assert_allclose(b.imu.dtheta / 0.05, np.tile(earth_rate_in_b_heading_east(),
                                                            (99, 1)), atol=1e-15)
    np.testing.assert_allclose(b.imu.dvel / 0.05, np.tile([0, 0, G], (99, 1)), atol=1e-12)
    np.testing.assert_allclose(b.truth.euler[-1], [0, 0, 90 * D], atol=1e-12)
    np.testing.assert_allclose(b.truth.h, 100.0)
    assert "placeholder" in b.meta["truth"]["h"]
    assert b.odometer is None


def test_ems_bad_files(tmp_path):
    with pytest.raises(BadInput, match="not found"):
        import_ems(tmp_path / "none.mat")
    (tmp_path / "junk.mat").write_text("junk")
    with pytest.raises(BadInput, match="not a readable MATLAB file"):
        import_ems(tmp_path / "junk.mat")
    scipy.io.savemat(tmp_path / "other.mat", {"x": np.ones(3)})
    with pytest.raises(BadInput, match="no variable 'ems_data'"):
        import_ems(tmp_path / "other.mat")
    with pytest.raises(BadInput, match=r"field 'gyro' has shape \(100, 2\)"):
        import_ems(write_ems(tmp_path / "g.mat", gyro=np.zeros((100, 2))))
    acc = np.tile(F_FRD, (100, 1))
    acc[40, 1] = np.nan
    with pytest.raises(BadInput, match="accel") as e:
        import_ems(write_ems(tmp_path / "a.mat", accel=acc))
    assert e.value.row == 41 and e.value.time == pytest.approx(2.0)


# ----------------------------------------------------------------------------- CSV


MAPPING = {
    "name": "csv-drive",
    "time": {"column": "time_ms", "unit": "ms"},
    "imu": {"kind": "rate", "axes": ["forward", "left", "up"],
            "gyro": {"columns": ["gx", "gy", "gz"], "unit": "deg/s"},
            "accel": {"columns": ["ax", "ay", "az"], "unit": "g"}},
    "odometer": {"column": "speed_kmh", "unit": "km/h"},
    "truth": {"file": "truth.csv", "time": {"column": "t_s", "unit": "s"},
              "lat": {"column": "lat", "unit": "deg"}, "lon": {"column": "lon", "unit": "deg"},
              "h": {"column": "alt", "unit": "m"},
              "velocity": {"columns": ["vn", "ve", "vd"], "frame": "ned"},
              "attitude": {"columns": ["roll", "pitch", "yaw"], "unit": "deg",
                           "convention": "ned-frd-zyx"}},
}


def write_csv_log(folder, n=50):
    t_ms = 1000.0 + 10.0 * np.arange(n) + np.r_[0, np.tile([0.5, -0.5], n // 2)][:n]
    lines = ["time_ms,gx,gy,gz,ax,ay,az,speed_kmh"]
    for k, tk in enumerate(t_ms):
        speed = "36.0" if k % 5 == 0 else ""       # odometer at a fifth of the IMU rate
        lines.append(f"{tk},1.0,2.0,3.0,0.0,0.0,1.0,{speed}")
    (folder / "log.csv").write_text("\n".join(lines) + "\n")
    (folder / "truth.csv").write_text(
        "t_s,lat,lon,alt,vn,ve,vd,roll,pitch,yaw\n"
        f"1.0,{LAT / D},{LON / D},{H},0,10,0,0,0,90\n1.2,{LAT / D},{LON / D},{H},0,10,0,0,0,90\n")
    (folder / "map.yaml").write_text(yaml.safe_dump(MAPPING))
    return t_ms / 1000.0


def test_csv_rates_axes_units_and_reference(tmp_path):
    t = write_csv_log(tmp_path)
    b = import_csv(tmp_path / "log.csv", mapping=tmp_path / "map.yaml")
    dt = np.diff(t)[:, None]
    np.testing.assert_allclose(b.imu.t, t[1:])
    np.testing.assert_allclose(b.imu.dtheta, np.array([-2.0, 1.0, 3.0]) * D * dt, atol=1e-16)
    np.testing.assert_allclose(b.imu.dvel, np.array([0, 0, 9.80665]) * dt, atol=1e-14)
    np.testing.assert_allclose(b.odometer.t, t[::5])
    np.testing.assert_allclose(b.odometer.v, 10.0)
    np.testing.assert_allclose(b.truth.euler[0], [0, 0, 90 * D], atol=1e-12)
    np.testing.assert_allclose(b.truth.vel_n[0], [10, 0, 0], atol=1e-12)
    assert b.name == "csv-drive"


def test_csv_increments_and_design_attitude(tmp_path):
    (tmp_path / "inc.csv").write_text("t;dx;dy;dz;vx;vy;vz;lat;lon;h;ve;vn;vu;p;r;y\n"
                                      f"0.1;1e-4;0;0;0;0;0.098;{LAT};{LON};5;1;0;0;0;0;1.5\n"
                                      f"0.2;1e-4;0;0;0;0;0.098;{LAT};{LON};5;1;0;0;0;0;1.5\n")
    m = {"delimiter": ";", "time": {"column": "t"},
         "imu": {"kind": "increment", "axes": ["right", "forward", "up"],
                 "gyro": {"columns": ["dx", "dy", "dz"], "unit": "rad"},
                 "accel": {"columns": ["vx", "vy", "vz"], "unit": "m/s"}},
         "truth": {"lat": {"column": "lat", "unit": "rad"}, "lon": {"column": "lon", "unit": "rad"},
                   "h": {"column": "h", "unit": "m"},
                   "velocity": {"columns": ["ve", "vn", "vu"], "frame": "enu"},
                   "attitude": {"columns": ["p", "r", "y"], "unit": "rad", "convention": "design"}}}
    b = import_csv(tmp_path / "inc.csv", mapping=m)
    np.testing.assert_allclose(b.imu.t, [0.1, 0.2])
    np.testing.assert_allclose(b.imu.dtheta[:, 0], 1e-4)
    np.testing.assert_allclose(b.truth.euler[:, 2], 1.5)


@pytest.mark.parametrize("change, match", [
    (lambda m: m["imu"]["gyro"].update(unit="furlong/s"), "unit 'furlong/s' not known"),
    (lambda m: m["imu"].update(axes=["forward", "right", "up"]), "right-handed"),
    (lambda m: m["imu"].update(kind="rates"), "imu.kind"),
    (lambda m: m.update(odometr={"column": "x"}), "odometr"),
    (lambda m: m["imu"]["gyro"].update(columns=["gx", "gy"]), "imu.gyro.columns"),
    (lambda m: m["odometer"].update(column="speed"), "no column 'speed'"),
])
def test_csv_bad_mapping(tmp_path, change, match):
    write_csv_log(tmp_path)
    m = yaml.safe_load(yaml.safe_dump(MAPPING))
    change(m)
    with pytest.raises(BadInput, match=match):
        import_csv(tmp_path / "log.csv", mapping=m)


def test_csv_bad_cells_and_files(tmp_path):
    write_csv_log(tmp_path)
    text = (tmp_path / "log.csv").read_text().splitlines()
    text[8] = text[8].replace(",2.0,", ",two,")
    (tmp_path / "log.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(BadInput, match="'two' is not a finite number") as e:
        import_csv(tmp_path / "log.csv", mapping=tmp_path / "map.yaml")
    assert e.value.row == 8 and e.value.time == pytest.approx(1.0705)
    text[8] = text[8].replace(",two,", ",,")
    (tmp_path / "log.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(BadInput, match="column 'gy': blank"):
        import_csv(tmp_path / "log.csv", mapping=tmp_path / "map.yaml")
    with pytest.raises(BadInput, match="mapping file not found"):
        import_csv(tmp_path / "log.csv", mapping=tmp_path / "none.yaml")
    (tmp_path / "bad.yaml").write_text("time: [unclosed\n")
    with pytest.raises(BadInput, match="not valid YAML"):
        import_csv(tmp_path / "log.csv", mapping=tmp_path / "bad.yaml")
    with pytest.raises(BadInput, match="needs a mapping"):
        import_csv(tmp_path / "log.csv", mapping=None)


# ----------------------------------------------------------------------------- registry, CLI


def test_unknown_format_is_bad_input():
    with pytest.raises(BadInput, match="unknown import format 'rosbag'"):
        get_importer("rosbag")
    assert get_importer("KF_GINS") is import_kf_gins


def test_cli_import_writes_a_readable_bundle(tmp_path):
    from inmotion.io.bundle import read_bundle

    write_csv_log(tmp_path)
    r = CliRunner().invoke(import_cmd, ["csv", str(tmp_path / "log.csv"), "-o",
                                        str(tmp_path / "bundle"), "--mapping",
                                        str(tmp_path / "map.yaml"), "--json"])
    assert r.exit_code == 0, r.output
    assert '"imu_rows": 49' in r.output
    b = read_bundle(tmp_path / "bundle")
    direct = import_csv(tmp_path / "log.csv", mapping=tmp_path / "map.yaml")
    np.testing.assert_allclose(b.imu.dtheta, direct.imu.dtheta, rtol=1e-15, atol=0)
    np.testing.assert_allclose(b.truth.euler, direct.truth.euler, atol=1e-12)


def test_cli_import_options_and_export(tmp_path):
    from inmotion.io.result import write_result

    imu = write_kf_gins(tmp_path)
    r = CliRunner().invoke(import_cmd, ["kf-gins", str(imu), "-o", str(tmp_path / "b"),
                                        "-O", f"nav={tmp_path / 'truth.nav'}"])
    assert r.exit_code == 0, r.output
    n = 3
    write_result(Solution(np.arange(n, dtype=float), np.full(n, LAT), np.full(n, LON),
                          np.full(n, H), np.zeros((n, 3)), np.zeros((n, 3))), tmp_path / "res")
    r = CliRunner().invoke(export_cmd, ["kf-gins", str(tmp_path / "res"), "-o",
                                        str(tmp_path / "out.nav")])
    assert r.exit_code == 0, r.output
    assert np.loadtxt(tmp_path / "out.nav").shape == (n, 11)


@pytest.mark.parametrize("args, match", [
    (["rosbag", "x", "-o", "b"], "unknown import format"),
    (["ems", "missing.mat", "-o", "b"], "not found"),
    (["ems", "missing.mat", "-o", "b", "-O", "colour=red"], "unknown option 'colour'"),
    (["ems", "missing.mat", "-o", "b", "-O", "order"], "must be key=value"),
    (["ems", "missing.mat", "-o", "b", "--mapping", "m.yaml"], "only for the csv format"),
])
def test_cli_import_bad_input(tmp_path, args, match):
    r = CliRunner().invoke(import_cmd, args)
    assert isinstance(r.exception, BadInput) and match in str(r.exception)


def test_cli_export_bad_input(tmp_path):
    r = CliRunner().invoke(export_cmd, ["gpx", str(tmp_path), "-o", str(tmp_path / "x")])
    assert isinstance(r.exception, BadInput) and "unknown export format" in str(r.exception)
    r = CliRunner().invoke(export_cmd, ["kf-gins", str(tmp_path / "no"), "-o",
                                        str(tmp_path / "x")])
    assert isinstance(r.exception, BadInput) and "solution.csv" in str(r.exception)


# ----------------------------------------------------------------------------- real drives

needs_real = pytest.mark.skipif(not REAL.is_dir(), reason=f"real data not found at {REAL}")


def course_minus_yaw_deg(truth, min_speed=3.0):
    speed = np.hypot(truth.vel_n[:, 0], truth.vel_n[:, 1])
    course = np.arctan2(truth.vel_n[:, 0], truth.vel_n[:, 1])
    return np.rad2deg(rotations.wrap_pi(course - truth.euler[:, 2]))[speed > min_speed]


def gyro_vs_reference_body_rates(bundle):
    """Mean body rates over each reference interval: from the IMU increments and from the
    reference attitude ``C_b^n`` (both in b, so the axes of both mappings are tested)."""
    imu, tr = bundle.imu, bundle.truth
    t_cum = np.concatenate([[imu.t[0] - imu.dt], imu.t])
    cum = np.vstack([np.zeros(3), np.cumsum(imu.dtheta, axis=0)])
    k = (tr.t > t_cum[0]) & (tr.t < t_cum[-1])
    tt = tr.t[k]
    theta = np.column_stack([np.interp(tt, t_cum, cum[:, j]) for j in range(3)])
    w_gyro = np.diff(theta, axis=0) / np.diff(tt)[:, None]
    C = tr.C_nb[k]
    w_ref = rotations.rotvec_from_dcm(np.einsum("kji,kjl->kil", C[:-1], C[1:])) \
        / np.diff(tt)[:, None]
    return w_gyro, w_ref


def check_specific_force_against_reference(bundle, t_end, atol):
    """Mean specific force in b up to ``t_end``: from the IMU increments and from the
    reference, ``f_b = C_n^b (dv_n/dt + [0, 0, g])`` (Coriolis and transport terms, below
    1e-3 m/s^2 here, neglected); the tolerance is the consumer accelerometers' bias."""
    imu, tr = bundle.imu, bundle.truth
    k = (imu.t > tr.t[0]) & (imu.t <= t_end)
    f_imu = imu.dvel[k].sum(axis=0) / (imu.t[k][-1] - imu.t[k][0] + imu.dt)
    a_n = np.gradient(tr.vel_n, tr.t, axis=0)
    g = earth.gravity(tr.lat, 0.0)
    f_ref_n = a_n + np.column_stack([0 * g, 0 * g, g])
    f_ref = np.einsum("kji,kj->ki", tr.C_nb, f_ref_n)
    m = (tr.t > imu.t[k][0]) & (tr.t <= t_end)
    np.testing.assert_allclose(f_imu, f_ref[m].mean(axis=0), atol=atol)


def check_axes_against_reference(bundle):
    w_gyro, w_ref = gyro_vs_reference_body_rates(bundle)
    for j in range(3):
        assert np.corrcoef(w_gyro[:, j], w_ref[:, j])[0, 1] > 0.9
        assert np.polyfit(w_ref[:, j], w_gyro[:, j], 1)[0] == pytest.approx(1.0, abs=0.15)


@needs_real
def test_real_comma2k19_imports_and_agrees_with_its_reference():
    b = import_log("comma2k19", COMMA)
    assert len(b.imu.t) == 6255 and len(b.truth.t) == 1200 and "gaps" not in b.meta
    d = course_minus_yaw_deg(b.truth)
    assert len(d) == len(b.truth.t)                     # moving all the time
    assert abs(np.median(d)) < 1.5 and np.abs(d).max() < 3.0   # mounting ~0.8 deg (README)
    check_specific_force_against_reference(b, b.truth.t[-1] - 1.0, atol=0.3)
    check_axes_against_reference(b)
    speed_ref = np.linalg.norm(b.truth.vel_n, axis=1)
    v_can = np.interp(b.truth.t, b.odometer.t, b.odometer.speed())
    # README: CAN reads "about 0.6 % low"; against the 3-D reference speed it is 0.86 % low
    assert np.median(v_can / speed_ref) == pytest.approx(0.994, abs=0.005)


@needs_real
@pytest.mark.parametrize("fmt, source", [("comma2k19", COMMA), ("ems", EMS)])
def test_real_bundles_survive_write_and_read(tmp_path, fmt, source):
    from inmotion.io.bundle import read_bundle, write_bundle

    b = import_log(fmt, source)
    back = read_bundle(write_bundle(b, tmp_path / fmt))
    np.testing.assert_array_equal(back.imu.dtheta, b.imu.dtheta)
    np.testing.assert_allclose(back.truth.euler, b.truth.euler, atol=1e-12)
    assert back.meta["imu_axes"]["source"] == ["forward", "right", "down"]


@needs_real
def test_real_ems_imports_and_agrees_with_its_reference():
    b = import_log("ems", EMS)
    assert len(b.imu.t) == 10218 and b.odometer is None
    d = course_minus_yaw_deg(b.truth)
    assert len(d) > 1000 and abs(np.median(d)) < 1.0
    assert np.percentile(np.abs(d), 90) < 2.5
    check_axes_against_reference(b)
    check_specific_force_against_reference(b, 60.0, atol=0.3)


# ----------------------------------------------------------------------------- remaining bad-input paths


def test_bad_paths_kinds(tmp_path):
    from inmotion.io.importers.tables import existing_dir, existing_file, read_text_table

    with pytest.raises(BadInput, match="is not a file"):
        existing_file(tmp_path, "IMU file")
    (tmp_path / "f").write_text("x")
    with pytest.raises(BadInput, match="is not a folder"):
        existing_dir(tmp_path / "f")
    (tmp_path / "empty.txt").write_text("# only a comment\n\n")
    with pytest.raises(BadInput, match="no data rows"):
        read_text_table(tmp_path / "empty.txt", 7, "IMU file")


def test_bad_result_solution_csv(tmp_path):
    (tmp_path / "solution.csv").write_text("t,lat,lon\n0,1,2\n")
    with pytest.raises(BadInput, match="missing column 'h'"):
        export_kf_gins(tmp_path, tmp_path / "x.nav")
    (tmp_path / "solution.csv").write_text("t,lat,lon,h,vE,vN,vU,pitch,roll,yaw\n"
                                           "0,1,2,3,0,0,0,0,0,0\n1,1,2,nan,0,0,0,0,0,0\n")
    with pytest.raises(BadInput, match="not a finite number") as e:
        export_kf_gins(tmp_path, tmp_path / "x.nav")
    assert e.value.row == 2


def test_comma2k19_value_rows_differ_from_times(tmp_path):
    root = tmp_path / "seg"
    write_comma_segment(root, np.random.default_rng(8))
    save_npy(root / "processed_log/CAN/speed/value", np.full((150, 1), 10.0))
    with pytest.raises(BadInput, match=r"value has shape \(150, 1\) for 200 times"):
        import_comma2k19(root)


def test_ems_missing_field_and_length(tmp_path):
    n = 100
    s = {"time": 0.05 * np.arange(n), "accel": np.zeros((n, 3)), "gyro": np.zeros((n, 3))}
    scipy.io.savemat(tmp_path / "m.mat", {"ems_data": s})
    with pytest.raises(BadInput, match="has no field 'vel_N'"):
        import_ems(tmp_path / "m.mat")
    with pytest.raises(BadInput, match="field 'roll' has 50 values for 100 times"):
        import_ems(write_ems(tmp_path / "r.mat", roll=np.zeros(50)))


def test_csv_more_bad_inputs(tmp_path):
    write_csv_log(tmp_path)
    m = yaml.safe_load(yaml.safe_dump(MAPPING))
    (tmp_path / "list.yaml").write_text("- a\n- b\n")
    with pytest.raises(BadInput, match="must be a YAML dictionary"):
        import_csv(tmp_path / "log.csv", mapping=tmp_path / "list.yaml")
    m2 = yaml.safe_load(yaml.safe_dump(MAPPING))
    m2["truth"]["velocity"]["columns"] = ["vn", "ve"]
    with pytest.raises(BadInput, match="truth.velocity.columns needs 3 columns"):
        import_csv(tmp_path / "log.csv", mapping=m2)
    (tmp_path / "truth.csv").write_text("t_s,lat,lon,alt,vn,ve,vd,roll,pitch,yaw\n"
                                        f"1.0,{LAT / D},{LON / D},{H},0,10,0,0,0,90\n"
                                        f"1.2,{LAT / D},,{H},0,10,0,0,0,90\n")
    with pytest.raises(BadInput, match="'lon' blank where latitude is given") as e:
        import_csv(tmp_path / "log.csv", mapping=m)
    assert e.value.time == pytest.approx(1.2)
    m3 = yaml.safe_load(yaml.safe_dump(MAPPING))
    del m3["truth"]
    text = (tmp_path / "log.csv").read_text().replace(",36.0\n", ",\n", 9)
    (tmp_path / "log.csv").write_text(text)
    with pytest.raises(BadInput, match="odometer: fewer than 2 samples"):
        import_csv(tmp_path / "log.csv", mapping=m3)
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x01garbage\x00\n")
    with pytest.raises(BadInput, match="not a readable CSV"):
        import_csv(tmp_path / "bin.csv", mapping=m3)
