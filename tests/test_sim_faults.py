"""Faults appear exactly in their windows, and nowhere else."""
import numpy as np
import pytest

from inmotion.sim import simulate

BASE = {"name": "f", "start": {"lat_deg": 30.0, "lon_deg": 110.0, "h_m": 100.0,
                               "heading_deg": 0.0, "speed_m_s": 10.0},
        "segments": [{"kind": "cruise", "duration_s": 40}]}


def _pair(sensor_spec, faults, seed=0):
    """The same drive with and without faults, same seed (noise-free sensors)."""
    clean = dict(BASE, sensors=sensor_spec)
    faulty = dict(clean, faults=faults)
    return simulate(clean, np.random.default_rng(seed)), simulate(faulty, np.random.default_rng(seed))


def _win(t, a, b):
    return (t >= a) & (t < b)


def test_offset_scale_stuck_dropout_on_radar():
    faults = [{"sensor": "radar", "kind": "offset", "start_s": 5, "end_s": 8, "offset_m_s": 0.7},
              {"sensor": "radar", "kind": "scale", "start_s": 10, "end_s": 12, "scale_ppm": 5e4},
              {"sensor": "radar", "kind": "stuck", "start_s": 15, "end_s": 17},
              {"sensor": "radar", "kind": "dropout", "start_s": 20, "end_s": 22.5}]
    c, f = _pair({"radar": {"rate_hz": 10}}, faults)
    keep = ~_win(c.radar.t, 20, 22.5)
    np.testing.assert_array_equal(f.radar.t, c.radar.t[keep])
    cv, fv, t = c.radar.v[keep], f.radar.v, f.radar.t
    w_off, w_sc, w_st = _win(t, 5, 8), _win(t, 10, 12), _win(t, 15, 17)
    np.testing.assert_allclose(fv[w_off] - cv[w_off], 0.7, atol=1e-12)
    np.testing.assert_allclose(fv[w_sc], cv[w_sc] * 1.05, rtol=1e-14)
    i0 = np.argmax(w_st)
    assert np.all(fv[w_st] == cv[i0 - 1])
    other = ~(w_off | w_sc | w_st)
    np.testing.assert_array_equal(fv[other], cv[other])
    assert w_off.sum() == 30 and w_sc.sum() == 20 and w_st.sum() == 20


def test_outliers_only_inside_their_window():
    faults = [{"sensor": "ldv", "kind": "outliers", "start_s": 10, "end_s": 20,
               "probability": 0.5, "magnitude_m_s": 3.0}]
    c, f = _pair({"ldv": {"rate_hz": 100}}, faults)
    d = f.ldv.v - c.ldv.v
    w = _win(c.ldv.t, 10, 20)
    assert np.all(d[~w] == 0.0)
    hit = d[w] != 0
    assert 0.4 < hit.mean() < 0.6 and np.abs(d[w]).max() <= 3.0 and np.abs(d[w]).max() > 2.0


def test_odometer_slip_and_idle_change_the_distance_in_their_windows():
    ppm = 1000.0
    faults = [{"sensor": "odometer", "kind": "slip", "start_s": 5, "end_s": 10, "slip_ratio": 0.2},
              {"sensor": "odometer", "kind": "idle", "start_s": 20, "end_s": 25,
               "idle_speed_m_s": 1.5}]
    c, f = _pair({"odometer": {"rate_hz": 10, "pulses_per_m": ppm}}, faults)
    t = c.odometer.t
    # samples ending in the window carry the fault (each ds covers the period ending at t)
    slip, idle = _win(t, 5, 10), _win(t, 20, 25)
    assert f.odometer.ds[slip].sum() == pytest.approx(1.2 * c.odometer.ds[slip].sum(), abs=2 / ppm)
    assert f.odometer.ds[idle].sum() == pytest.approx(c.odometer.ds[idle].sum() + 1.5 * 5,
                                                      abs=2 / ppm)
    other = ~(slip | idle)
    assert np.abs(f.odometer.ds[other] - c.odometer.ds[other]).max() <= 1 / ppm + 1e-12


def test_baro_offset_in_metres():
    faults = [{"sensor": "baro", "kind": "offset", "start_s": 3, "end_s": 4, "offset_m": -20.0}]
    c, f = _pair({"baro": {"rate_hz": 10}}, faults)
    d = f.baro.h - c.baro.h
    w = _win(c.baro.t, 3, 4)
    np.testing.assert_allclose(d[w], -20.0, atol=1e-9)
    assert np.all(d[~w] == 0.0)


def test_faults_listed_in_meta():
    faults = [{"sensor": "radar", "kind": "dropout", "start_s": 1, "end_s": 2}]
    _, f = _pair({"radar": {"rate_hz": 10}}, faults)
    assert f.meta["faults"] == [{"sensor": "radar", "kind": "dropout", "start_s": 1.0,
                                 "end_s": 2.0}]
