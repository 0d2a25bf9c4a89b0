"""Issue 15, session 19: an installation ``meta.yaml`` does not describe gets wide priors
(``meta_spec.unknown_installation_priors``), and a real road vehicle's assumed constraint
violation (``io.importers.vehicle``) sets the cross rows even without a sensor spec."""
import numpy as np

from inmotion.align import meta_spec
from inmotion.align.aided_kf import AidedKfConfig
from inmotion.align.aided_kf import config_with_spec as aided_with_spec
from inmotion.align.dr_kalman import DrKfConfig
from inmotion.align.dr_kalman import config_with_spec as dr_with_spec
from inmotion.io.importers.vehicle import ROAD_VEHICLE, road_vehicle

SIM_ODO = {"rate_hz": 100.0, "noise_m_s": 0.0, "pulses_per_m": 1000.0,
           "scale_factor_ppm": 0.0, "scale_factor_sigma_ppm": 500.0}


def test_no_mounting_and_no_scale_in_meta_give_the_unknown_priors():
    cfg, src = dr_with_spec(DrKfConfig(), {"name": "real"}, "odometer")
    assert cfg.mount_sigma_arcmin == meta_spec.UNKNOWN_MOUNTING_SIGMA_ARCMIN == 300.0
    assert cfg.dk_sigma_ppm == meta_spec.UNKNOWN_SCALE_SIGMA_PPM and np.isinf(cfg.dk_tau_s)
    assert src["mount_sigma_arcmin"] == "meta.yaml has no vehicle_mounting_arcmin"
    assert src["dk_sigma_ppm"] == src["dk_tau_s"] == "meta.sensors.odometer states no scale factor"
    cfg, src = aided_with_spec(AidedKfConfig(), {"name": "real"}, ("odometer",))
    assert cfg.mount_sigma_arcmin == 300.0 and cfg.od_scale_sigma_ppm == 10000.0
    assert cfg.ldv_scale_sigma_ppm == AidedKfConfig().ldv_scale_sigma_ppm   # not a sensor here
    from inmotion.navigate.sins_dr import SinsDrConfig
    from inmotion.navigate.sins_dr import config_with_spec as sins_dr_with_spec
    cfg, src = sins_dr_with_spec(SinsDrConfig(), {"name": "real"}, "odometer")
    assert cfg.dk_sigma_ppm == 10000.0 and np.isinf(cfg.dk_tau_s)
    assert src["dk_sigma_ppm"] == "meta.sensors.odometer states no scale factor"


def test_a_described_installation_keeps_the_defaults_and_the_config_wins():
    meta = {"vehicle_mounting_arcmin": [0.0, 0.0, 0.0], "sensors": {"odometer": SIM_ODO}}
    cfg, src = dr_with_spec(DrKfConfig(), meta, "odometer")
    assert cfg.mount_sigma_arcmin == DrKfConfig().mount_sigma_arcmin and \
        src["mount_sigma_arcmin"] == "default"
    assert cfg.dk_sigma_ppm == 500.0 and "unknown" not in src["dk_sigma_ppm"]
    cfg, src = dr_with_spec(DrKfConfig(mount_sigma_arcmin=45.0), {"name": "real"}, "odometer")
    assert cfg.mount_sigma_arcmin == 45.0 and src["mount_sigma_arcmin"] == "config"
    cfg, src = dr_with_spec(DrKfConfig(noise_preset="paper"), {"name": "real"}, "odometer")
    assert cfg.mount_sigma_arcmin == DrKfConfig().mount_sigma_arcmin     # paper: as configured
    assert "mount_sigma_arcmin" not in src


def test_the_vehicle_violation_sets_the_cross_rows_without_a_sensor_spec():
    """Before: no ``meta.sensors.odometer`` meant no cross-row figure at all, whatever the
    vehicle spec said. The value: the white equivalent of the Gauss-Markov violation at the
    interval, ``sqrt(2 sigma^2 tau / T)`` (``markov_white_equivalent_sigma``)."""
    meta = {"vehicle": road_vehicle()}
    cv = ROAD_VEHICLE["constraint_violation"]
    T = 0.5
    fwd, lat, origin = meta_spec.sensor_noise_from_meta(meta, "odometer", T, "displacement")
    want = np.sqrt(2 * cv["lateral_sigma_m_s"] ** 2 * cv["lateral_tau_s"] / T)
    assert fwd is None and np.allclose(lat, (want, want))
    assert origin == "meta.vehicle.constraint_violation"
    # the velocity form keeps the configured values, and nothing without a vehicle spec
    assert meta_spec.sensor_noise_from_meta(meta, "odometer", T, "velocity") == (None, None, "")
    assert meta_spec.sensor_noise_from_meta({}, "odometer", T, "displacement") == (None, None, "")


def test_road_vehicle_is_a_fresh_copy_marked_assumed():
    a = road_vehicle()
    a["constraint_violation"]["lateral_sigma_m_s"] = 1.0
    assert ROAD_VEHICLE["constraint_violation"]["lateral_sigma_m_s"] == 0.06
    assert a["source"] == "assumed"


def test_sins_dr_takes_the_vehicle_motion_and_the_accelerometer_level_from_meta():
    """Session 20: the DR takes the vehicle's lateral and vertical velocity as zero, so its
    position walks with the constraint violation, ``2 sigma^2 tau`` [m^2/s] (the larger of the
    two axes: the engine's DR walk is isotropic); and a start from an alignment of a phone's
    accelerometer (10000 ug) is level to ``b / g`` = 34.4 arcmin, not the navigation-grade 1
    arcmin. Neither applies with ``noise_preset: paper`` or when the user set the field."""
    from inmotion.navigate.sins_dr import SinsDrConfig
    from inmotion.navigate.sins_dr import config_with_spec as sins_dr_with_spec
    meta = {"vehicle": road_vehicle(), "imu": {"accel": {"bias_ug": 10000.0},
                                               "source": "assumed"}}
    cv = ROAD_VEHICLE["constraint_violation"]
    want = 2.0 * max(cv["lateral_sigma_m_s"] ** 2 * cv["lateral_tau_s"],
                     cv["vertical_sigma_m_s"] ** 2 * cv["vertical_tau_s"])
    cfg, src = sins_dr_with_spec(SinsDrConfig(), meta, "odometer")
    assert np.isclose(cfg.dr_violation_rw_m2_s, want) and np.isclose(want, 0.0144)
    assert src["dr_violation_rw_m2_s"] == "meta.vehicle.constraint_violation"
    assert cfg.accel_bias_ug == 10000.0
    assert np.isclose(cfg.init_tilt_sigma_arcmin, np.degrees(np.arctan(0.01)) * 60.0)
    assert src["init_tilt_sigma_arcmin"].startswith("accel_bias_ug / g")
    paper, _ = sins_dr_with_spec(SinsDrConfig(noise_preset="paper"), meta, "odometer")
    assert paper.dr_violation_rw_m2_s == 0.0 and paper.init_tilt_sigma_arcmin == 1.0
    own, src = sins_dr_with_spec(SinsDrConfig(init_tilt_sigma_arcmin=3.0), meta, "odometer")
    assert own.init_tilt_sigma_arcmin == 3.0 and src["init_tilt_sigma_arcmin"] == "config"
    fine, _ = sins_dr_with_spec(SinsDrConfig(), {"imu": {"accel": {"bias_ug": 100.0},
                                                         "source": "documented"}}, "odometer")
    assert fine.init_tilt_sigma_arcmin == 1.0          # 0.34 arcmin: the default stays


def test_the_unknown_mounting_floor_turns_the_track_by_its_prior():
    """``floor_unknown_mounting``: a track run along the IMU's axis while the mounting is
    unknown to ``m`` turns by up to ``m``: north sigma ``>= m |d_E|``, east ``>= m |d_N|``,
    velocity likewise, height ``>= m`` times the path; a tighter filter sigma is raised, a
    wider one kept. Checked on a straight 1 km drive to the north-east at 10 m/s."""
    from inmotion.core import earth
    from inmotion.core.solution import Solution
    t = np.arange(0.0, 101.0)
    lat0, lon0 = np.radians(34.0), np.radians(108.0)
    r_m, r_n = earth.radii(lat0)
    v = 10.0 / np.sqrt(2.0)
    lat = lat0 + v * t / r_m
    lon = lon0 + v * t / (r_n * np.cos(lat0))
    vel = np.column_stack([np.full_like(t, v), np.full_like(t, v), np.zeros_like(t)])
    small, big = np.full_like(t, 0.1), np.full_like(t, 1e4)
    sol = Solution.from_arrays(t, np.column_stack([lat, lon, np.zeros_like(t)]), vel,
                               np.tile([1.0, 0, 0, 0], (len(t), 1)),
                               sigma={"north": small, "east": big, "vN": small, "h": small,
                                      "phi_U": np.full_like(t, 0.01)})
    meta_spec.floor_unknown_mounting(sol)
    m = np.radians(meta_spec.UNKNOWN_MOUNTING_SIGMA_ARCMIN / 60.0)
    assert np.isclose(sol.sigma["north"][-1], m * v * 100.0, rtol=1e-3)
    assert np.all(sol.sigma["east"] == 1e4)
    assert np.allclose(sol.sigma["vN"][1:], m * v)
    assert np.isclose(sol.sigma["h"][-1], m * 1000.0, rtol=1e-9)
    assert np.all(sol.sigma["phi_U"] == m)


def test_a_given_mounting_the_filter_estimates_from_zero_sets_the_prior():
    """dr-kf and od-velocity-kf estimate the whole mounting from zero (paper 000); where
    meta.yaml gives one beyond their 20 arcmin default (a phone pitched 228 arcmin in the
    car) the default prior covers its largest angle; within the default (paper 000's 3, 10,
    5 arcmin) nothing changes; a filter that takes the given mounting as its nominal
    (``mounting_from_meta``) keeps its default; the user's setting wins; a mounting that is
    not three numbers is bad input."""
    import pytest
    from inmotion.errors import BadInput
    cfg, src = dr_with_spec(DrKfConfig(), {"vehicle_mounting_arcmin": [228.0, 0.0, -48.0]},
                            "odometer")
    assert cfg.mount_sigma_arcmin == 228.0
    assert src["mount_sigma_arcmin"].startswith("covers meta.yaml vehicle_mounting_arcmin")
    cfg, src = dr_with_spec(DrKfConfig(), {"vehicle_mounting_arcmin": [3.0, 10.0, -5.0]},
                            "odometer")
    assert cfg.mount_sigma_arcmin == 20.0 and src["mount_sigma_arcmin"] == "default"
    meta = {"vehicle_mounting_arcmin": [228.0, 0.0, -48.0]}
    cfg, _ = aided_with_spec(AidedKfConfig(mounting_from_meta=True), meta, ("odometer",))
    assert cfg.mount_sigma_arcmin == AidedKfConfig().mount_sigma_arcmin
    cfg, _ = aided_with_spec(AidedKfConfig(), meta, ("odometer",))
    assert cfg.mount_sigma_arcmin == 228.0
    cfg, src = dr_with_spec(DrKfConfig(mount_sigma_arcmin=45.0), meta, "odometer")
    assert cfg.mount_sigma_arcmin == 45.0 and src["mount_sigma_arcmin"] == "config"
    with pytest.raises(BadInput, match="vehicle_mounting_arcmin: three numbers"):
        dr_with_spec(DrKfConfig(), {"vehicle_mounting_arcmin": [1.0, "x", 2.0]}, "odometer")
    with pytest.raises(BadInput, match="vehicle_mounting_arcmin: three numbers"):
        dr_with_spec(DrKfConfig(), {"vehicle_mounting_arcmin": [1.0, 2.0]}, "odometer")
    with pytest.raises(BadInput, match="vehicle_mounting_arcmin: not finite"):
        dr_with_spec(DrKfConfig(), {"vehicle_mounting_arcmin": [1.0, float("nan"), 2.0]},
                     "odometer")


def test_an_imu_not_fixed_in_its_vehicle_gets_a_mounting_random_walk_from_meta():
    """Issue 15, session 22: ``meta.vehicle.mounting_rw_arcmin_sqrt_s`` (the PSINS MEMS
    platform rolls in its vehicle) becomes every mounting-state filter's
    ``mount_rw_arcmin_sqrt_s`` under ``noise_preset: matched``, with its origin; the
    configuration wins, the paper preset ignores it, a bad value is refused; and the value
    reaches the process noise of the mounting states (and only them)."""
    import pytest
    from inmotion.align import aided_kf
    from inmotion.align.dr_kalman import _process_noise
    from inmotion.errors import BadInput
    from inmotion.estimation import error_model as em
    from inmotion.estimation.layout import Layout
    from inmotion.navigate.sins_dr import SinsDrConfig
    from inmotion.navigate.sins_dr import config_with_spec as sins_dr_with_spec
    meta = {"name": "rolling", "vehicle": {"mounting_rw_arcmin_sqrt_s": 64.0}}
    origin = "meta.vehicle.mounting_rw_arcmin_sqrt_s"
    for cfg, src in (dr_with_spec(DrKfConfig(), meta, "odometer"),
                     aided_with_spec(AidedKfConfig(), meta, ("odometer",)),
                     sins_dr_with_spec(SinsDrConfig(), meta, "odometer")):
        assert cfg.mount_rw_arcmin_sqrt_s == 64.0 and src["mount_rw_arcmin_sqrt_s"] == origin
    cfg, src = dr_with_spec(DrKfConfig(mount_rw_arcmin_sqrt_s=1.0), meta, "odometer")
    assert cfg.mount_rw_arcmin_sqrt_s == 1.0 and src["mount_rw_arcmin_sqrt_s"] == "config"
    cfg, _ = dr_with_spec(DrKfConfig(noise_preset="paper"), meta, "odometer")
    assert cfg.mount_rw_arcmin_sqrt_s == 0.0
    cfg, src = dr_with_spec(DrKfConfig(), {"name": "fixed"}, "odometer")
    assert cfg.mount_rw_arcmin_sqrt_s == 0.0 and src["mount_rw_arcmin_sqrt_s"] == "default"
    for bad in (-1.0, "fast", float("nan"), True):
        with pytest.raises(BadInput, match="mounting_rw_arcmin_sqrt_s"):
            meta_spec.mounting_rw_from_meta({"vehicle": {"mounting_rw_arcmin_sqrt_s": bad}})
    # the density on the mounting block's diagonal, [rad^2/s], nothing else changed
    arcmin = np.pi / 180.0 / 60.0
    lay = Layout(["phi", "dv", "dp", "eps", "nabla", "mount", "dk"])
    Q0 = em.ErrorModel(lay, _process_noise(DrKfConfig())).Qc()
    Q1 = em.ErrorModel(lay, _process_noise(DrKfConfig(mount_rw_arcmin_sqrt_s=64.0))).Qc()
    m = lay["mount"]
    np.testing.assert_allclose(np.diag(Q1[m, m]), (64.0 * arcmin) ** 2, rtol=1e-12)
    D = Q1 - Q0
    D[m, m] = 0.0
    assert not D.any()
    # od-kf's channels carry their own 2-angle mounting block: the walk goes there
    Q = np.zeros((aided_kf.NSUB, aided_kf.NSUB))
    o = aided_kf.SUB_LAYOUT["mount"].start
    aided_kf._add_mount_walk(Q, o, AidedKfConfig(mount_rw_arcmin_sqrt_s=64.0))
    assert np.flatnonzero(np.diag(Q)).tolist() == [o, o + 1]
    assert Q[o, o] == pytest.approx((64.0 * arcmin) ** 2, rel=1e-12)
