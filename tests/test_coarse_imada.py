"""IMADA family on error-free analytic drives: each variant recovers the true attitude to the
bound derived in ``inmotion.align.imada``; bad input raises BadInput."""
import numpy as np
import pytest

from coarse_truth import straight_drive
from inmotion.align import attitude_determination as ad
from inmotion.align import imada
from inmotion.align import obs_vectors as ov
from inmotion.core import earth, rotations
from inmotion.core.bundle import Bundle, SpeedData
from inmotion.errors import BadInput

LAT = np.radians(45.6778)


@pytest.fixture(scope="module")
def drives():
    return {v: straight_drive(speed=v, duration=120.0) for v in (20.0, 80.0)}


def _phi(sol, truth, which):
    """Misalignment [rad] of the start (C_b^n(0)) or end attitude."""
    if which == "start":
        e = np.radians([sol.info["attitude_start_deg"][k] for k in ("pitch", "roll", "yaw")])
        return rotations.misalignment(rotations.dcm_from_euler(e), truth.C_nb[0])
    return rotations.misalignment(sol.C_nb[-1], truth.C_nb[-1])


@pytest.mark.parametrize("model", [ov.MODEL_VN, ov.MODEL_DUAL, ov.MODEL_VB_EARTH])
@pytest.mark.parametrize("speed", [20.0, 80.0])
def test_exact_models_recover_attitude_when_vn_is_known(drives, model, speed):
    """With the true C_b^n(0) for v^n (the 'known V^n' premise of eq. 10 and 19), the models
    with no omitted term are exact up to the two-sample discretization (< 1e-7 rad)."""
    b = drives[speed]
    inp = ad.prepare(b, None, sensor=None, moving=True, min_window_s=10, v0_fit_s=0.0)
    lev = ad.run_level(inp, model, C_fixed=b.truth.C_nb[0])
    assert np.max(np.abs(rotations.misalignment(lev.C0, b.truth.C_nb[0]))) < 1e-7


@pytest.mark.parametrize("speed", [20.0, 80.0])
def test_imada_vb_error_is_its_omitted_term(drives, speed):
    """Tilt = omega_ie sin L |v| / g (the omitted omega_ie^b x V^b as a horizontal t-vector);
    heading <= 1.5 omega_ie sin L tan L |v| / g (the t^2 part of the rotated omitted term)."""
    b = drives[speed]
    sol = imada.run_imada_vb(b, imada.ImadaConfig())
    phi = _phi(sol, b.truth, "start")
    tilt = np.hypot(phi[0], phi[1])
    tilt_theory = earth.OMEGA_IE * np.sin(LAT) * speed / earth.gravity(LAT, 100.0)
    assert 0.9 * tilt_theory < tilt < 1.1 * tilt_theory
    assert abs(phi[2]) < 1.5 * tilt_theory * np.tan(LAT)
    # and it is really the omitted term: keeping it (oba) removes the tilt
    phi_oba = _phi(imada.run_oba(b, imada.ImadaConfig()), b.truth, "start")
    assert np.hypot(phi_oba[0], phi_oba[1]) < 0.1 * tilt_theory


@pytest.mark.parametrize("run", [imada.run_mimada, imada.run_mimada_dual])
@pytest.mark.parametrize("speed", [20.0, 80.0])
def test_multistage_contracts_the_first_level_error(drives, run, speed):
    """Level k's heading error <= G * level k-1's with G = |v| / (R omega_ie cos L) (the
    transport-rate error of the previous level's heading), plus 1e-7 rad; tilt < 1e-6 rad."""
    b = drives[speed]
    G = speed / (earth.A * earth.OMEGA_IE * np.cos(LAT))
    sol = run(b, imada.MimadaConfig(levels=3))
    lv = sol.info["levels"]
    psi_true = np.degrees(b.truth.euler[0, 2])
    errs = [abs(np.radians(l["attitude_start_deg"]["yaw"] - psi_true)) for l in lv]
    for k in range(1, len(errs)):
        assert errs[k] <= G * errs[k - 1] + 1e-7
    phi = _phi(sol, b.truth, "start")
    assert np.hypot(phi[0], phi[1]) < 1e-6
    phi_end = _phi(sol, b.truth, "end")
    assert np.max(np.abs(phi_end)) < 1e-5


@pytest.mark.parametrize("run", [imada.run_imada_dual, imada.run_oba])
def test_single_level_running_methods_converge(drives, run):
    """With the running answer for v^n the error is the calculation error (documented, larger
    for imada-dual); both stay below 0.1 deg at 20 m/s on an error-free drive."""
    b = drives[20.0]
    phi = _phi(run(b, imada.ImadaConfig()), b.truth, "end")
    assert np.max(np.abs(phi)) < np.radians(0.1)


def test_solution_series_and_info(drives):
    b = drives[20.0]
    sol = imada.run_mimada_dual(b, imada.MimadaConfig(output_interval_s=2.0))
    assert sol.t[0] == b.imu.t[0] and sol.t[-1] == b.imu.t[-1]
    assert np.allclose(np.diff(sol.t)[:-1], 2.0)
    assert {"attitude_start_deg", "attitude_end_deg", "quality", "levels"} <= set(sol.info)
    assert sol.info["quality"]["eigval_gap_rel"] > 0
    # dead-reckoned position with the aligned attitude follows the truth
    dn, de = earth.local_ne_offsets(sol.lat[-1], sol.lon[-1], b.truth.lat[-1], b.truth.lon[-1])
    assert np.hypot(dn, de) < 1.0


def test_odometer_distance_increments_work_like_speed(drives):
    b = drives[20.0]
    t = b.radar.t
    ds = np.concatenate([[0.0], 0.5 * (b.radar.v[1:] + b.radar.v[:-1]) * np.diff(t)])
    bo = Bundle(b.imu, b.meta, odometer=SpeedData(t, ds=ds), truth=b.truth)
    phi = _phi(imada.run_mimada_dual(bo, imada.MimadaConfig()), b.truth, "start")
    assert np.max(np.abs(phi)) < 1e-5


def test_no_velocity_sensor_is_bad_input(drives):
    b = drives[20.0]
    with pytest.raises(BadInput, match="velocity sensor"):
        imada.run_imada_vb(Bundle(b.imu, b.meta, truth=b.truth), imada.ImadaConfig())


def test_short_window_is_bad_input(drives):
    b = drives[20.0].window(0.0, 5.0)
    with pytest.raises(BadInput, match="window is 5 s long"):
        imada.run_mimada(b, imada.MimadaConfig())


def test_sensor_not_covering_the_window_is_bad_input(drives):
    b = drives[20.0]
    short = SpeedData(b.radar.t[:6000], v=b.radar.v[:6000])
    with pytest.raises(BadInput, match="radar.*covers"):
        imada.run_imada_vb(Bundle(b.imu, b.meta, radar=short), imada.ImadaConfig())


def test_nan_speed_is_bad_input(drives):
    b = drives[20.0]
    v = b.radar.v.copy()
    v[100] = np.nan
    with pytest.raises(BadInput, match="row 101"):
        imada.run_imada_vb(Bundle(b.imu, b.meta, radar=SpeedData(b.radar.t, v=v)),
                           imada.ImadaConfig())


def test_no_position_is_bad_input(drives):
    b = drives[20.0]
    with pytest.raises(BadInput, match="no initial position"):
        imada.run_imada_vb(Bundle(b.imu, {}, radar=b.radar), imada.ImadaConfig())


def test_vector_pairs_are_exposed_and_satisfy_the_model(drives):
    """The engine's per-epoch alpha/beta (the API paper 001's filter builds on) satisfy
    C_b^n(0) alpha = beta on an error-free drive for the exact models (v^n known)."""
    b = drives[20.0]
    inp = ad.prepare(b, None, sensor=None, moving=True, min_window_s=10, v0_fit_s=0.0)
    C0 = b.truth.C_nb[0]
    for model in (ov.MODEL_DUAL, ov.MODEL_VB_EARTH, ov.MODEL_VN):
        run = ov.integrate_vectors(inp.t, inp.dtheta, inp.dvel, inp.speed, inp.speed0, inp.lat0,
                                   inp.lon0, inp.h0, model=model, C_fixed=C0, out_every=500)
        resid = run.beta - run.alpha @ C0.T
        assert np.max(np.abs(resid)) < 1e-6 * np.max(np.abs(run.beta))
        assert np.linalg.norm(run.beta[-1]) > 1000.0        # ~ g t at 120 s


def test_registered_methods_load_with_default_configs():
    from inmotion.registry import get
    for name in ("imada-vb", "imada-vn", "imada-dual", "mimada", "mimada-dual", "oba",
                 "coarse-inertial"):
        spec = get(name)
        run, Cfg = spec.load()
        assert spec.kind == "align" and not spec.needs_attitude and callable(run)
        Cfg()
    with pytest.raises(Exception):
        imada.ImadaConfig(initial_speed_fit_s=-1.0)
    with pytest.raises(Exception):
        imada.MimadaConfig(levels=1)


def test_error_free_drive_from_the_shared_simulator():
    """paper004_v80 with every sensor error switched off: imada-vb within its omitted-term
    bounds, the multistage methods within G times the first level's heading error."""
    from inmotion.sim.scenario import find_scenario, load_scenario
    from inmotion.sim.simulate import simulate
    sc = load_scenario(find_scenario("paper004_v80")).model_dump()
    sc["imu"]["gyro"].update(drift_deg_h=0.0, arw_deg_sqrt_h=0.0)
    sc["imu"]["accel"].update(bias_ug=0.0, vrw_ug_sqrt_hz=0.0)
    sc["sensors"]["radar"]["noise_m_s"] = 0.0
    b = simulate(sc, np.random.default_rng(0))
    v, lat = 80.0, b.truth.lat[0]
    tilt_theory = earth.OMEGA_IE * np.sin(lat) * v / earth.gravity(lat, 0.0)
    phi = _phi(imada.run_imada_vb(b, imada.ImadaConfig()), b.truth, "start")
    assert 0.9 * tilt_theory < np.hypot(phi[0], phi[1]) < 1.1 * tilt_theory
    assert abs(phi[2]) < 1.5 * tilt_theory * np.tan(lat)
    G = v / (earth.A * earth.OMEGA_IE * np.cos(lat))
    for run in (imada.run_mimada, imada.run_mimada_dual):
        phi2 = _phi(run(b, imada.MimadaConfig()), b.truth, "start")
        assert abs(phi2[2]) <= G * abs(phi[2]) + 1e-7
        assert np.hypot(phi2[0], phi2[1]) < 1e-6
