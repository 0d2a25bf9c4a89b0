"""WGS-84 Earth model against published values and against its own geometry."""
import numpy as np
import pytest

from inmotion.core import earth

# published WGS-84 values (NIMA TR8350.2, 3rd ed., tables 3.1-3.3)
A = 6378137.0
E2 = 6.69437999014e-3
POLAR_RADIUS_OF_CURVATURE = 6399593.6258          # a^2 / b [m]
GAMMA_EQUATOR = 9.7803253359                      # [m/s^2]
GAMMA_POLE = 9.8321849378
SOMIGLIANA_K = 0.00193185265241


def test_constants():
    assert earth.A == A
    assert earth.E2 == pytest.approx(E2, rel=1e-11)
    assert earth.OMEGA_IE == 7.2921151467e-5
    # k from the defining constants (b from the rounded flattening): equal to 3e-9
    assert earth.K_SOM == pytest.approx(SOMIGLIANA_K, rel=1e-8)


@pytest.mark.parametrize("lat_deg, r_m, r_n", [
    (0.0, A * (1 - E2), A),
    (45.0, A * (1 - E2) / (1 - E2 / 2) ** 1.5, A / np.sqrt(1 - E2 / 2)),
    (90.0, POLAR_RADIUS_OF_CURVATURE, POLAR_RADIUS_OF_CURVATURE),
])
def test_radii_known_values(lat_deg, r_m, r_n):
    got_m, got_n = earth.radii(np.radians(lat_deg))
    assert got_m == pytest.approx(r_m, abs=1e-3)
    assert got_n == pytest.approx(r_n, abs=1e-3)


def test_radii_numbers():
    """The same, as plain numbers: 6335439.327 m / 6378137 m at the equator, 6367381.816 m /
    6388838.290 m at 45 deg."""
    assert earth.radii(0.0)[0] == pytest.approx(6335439.327, abs=1e-3)
    assert earth.radii(np.radians(45.0))[0] == pytest.approx(6367381.816, abs=1e-3)
    assert earth.radii(np.radians(45.0))[1] == pytest.approx(6388838.290, abs=1e-3)


@pytest.mark.parametrize("lat_deg, g", [(0.0, GAMMA_EQUATOR), (45.0, 9.8061977694),
                                        (90.0, GAMMA_POLE)])
def test_normal_gravity_known_values(lat_deg, g):
    """Somigliana with the published constants: at 45 deg
    ``9.7803253359 (1 + k/2) / sqrt(1 - e^2/2) = 9.8061977694`` m/s^2."""
    assert earth.gravity(np.radians(lat_deg), 0.0) == pytest.approx(g, abs=1e-9)


def test_free_air_gradient():
    """Normal gravity decreases by about 0.3086 mGal per metre (3.086e-6 1/s^2 at 45 deg)."""
    lat = np.radians(45.0)
    grad = (earth.gravity(lat, 10.0) - earth.gravity(lat, -10.0)) / 20.0
    assert grad == pytest.approx(-3.086e-6, rel=2e-3)


def test_vectorized():
    lat = np.radians(np.linspace(-80, 80, 7))
    r_m, r_n = earth.radii(lat)
    assert r_m.shape == (7,) and np.all(r_n >= r_m)
    assert earth.gravity_n(lat, 100.0).shape == (7, 3)


@pytest.mark.parametrize("lat_deg, lon_deg, h", [(0, 0, 0), (34.2, 108.9, 420.0),
                                                 (-63.0, -120.0, 3000.0), (89.9, 10.0, -50.0)])
def test_ecef_round_trip(lat_deg, lon_deg, h):
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    lat2, lon2, h2 = earth.ecef_to_lla(earth.lla_to_ecef(lat, lon, h))
    assert lat2 == pytest.approx(lat, abs=1e-12)
    assert np.cos(lon2 - lon) == pytest.approx(1.0, abs=1e-15)
    assert h2 == pytest.approx(h, abs=1e-6)


def test_enu_frame_and_earth_rate():
    lat, lon, h = np.radians(37.0), np.radians(-122.0), 100.0
    C_ne = earth.enu_from_ecef_matrix(lat, lon)
    assert np.allclose(C_ne @ C_ne.T, np.eye(3), atol=1e-15)
    # Up is the ellipsoid normal: d(ecef)/dh
    up = earth.lla_to_ecef(lat, lon, h + 1.0) - earth.lla_to_ecef(lat, lon, h)
    assert np.allclose(C_ne @ up, [0, 0, 1], atol=1e-9)
    assert np.allclose(C_ne @ [0, 0, earth.OMEGA_IE], earth.omega_ie_n(lat), atol=1e-18)


def test_position_rate_and_transport_rate_from_geometry():
    """Moving with ``vel_n`` for a short time: the ECEF displacement is ``C_n^e vel_n dt``,
    and the frame turns by ``omega_en_n dt`` (``dC_n^e/dt = C_n^e [omega_en x]``)."""
    lat, lon, h = np.radians(50.0), np.radians(8.0), 300.0
    vel = np.array([13.0, -7.0, 0.5])
    dt = 1e-2
    rate = earth.position_rate(lat, h, vel)
    lat1, lon1, h1 = np.array([lat, lon, h]) + rate * dt
    C_ne = earth.enu_from_ecef_matrix(lat, lon)
    disp = earth.lla_to_ecef(lat1, lon1, h1) - earth.lla_to_ecef(lat, lon, h)
    assert np.allclose(C_ne @ disp, vel * dt, atol=1e-7)
    C_en0 = C_ne.T
    C_en1 = earth.enu_from_ecef_matrix(lat1, lon1).T
    W = C_en0.T @ (C_en1 - C_en0) / dt                # ~ [omega_en x]
    w = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
    # omega_en is defined with the radii at (lat, h); the finite difference agrees to O(dt)
    assert np.allclose(w, earth.omega_en_n(lat, h, vel), atol=1e-10)


def test_local_offsets():
    lat0, lon0 = np.radians(40.0), np.radians(5.0)
    r_m, r_n = earth.radii(lat0)
    dn, de = earth.local_ne_offsets(lat0 + 100.0 / r_m, lon0 + 50.0 / (r_n * np.cos(lat0)),
                                    lat0, lon0)
    assert dn == pytest.approx(100.0) and de == pytest.approx(50.0)
