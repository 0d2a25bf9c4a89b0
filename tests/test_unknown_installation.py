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
