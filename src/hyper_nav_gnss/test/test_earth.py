"""Earth model against published WGS-84 values."""
import numpy as np
import pytest

from hyper_nav_gnss import earth


def test_normal_gravity_published_values():
    # WGS-84 normal gravity at the ellipsoid: equator 9.7803253359, pole 9.8321849379 m/s^2
    assert earth.gravity_n(0.0, 0.0)[2] == pytest.approx(-9.7803253359, abs=1e-9)
    assert earth.gravity_n(np.pi / 2, 0.0)[2] == pytest.approx(-9.8321849379, abs=1e-9)
    # free-air gradient about -3.086e-6 s^-2 near the ground
    dg = earth.gravity_n(0.7, 1000.0)[2] - earth.gravity_n(0.7, 0.0)[2]
    assert dg == pytest.approx(3.086e-3, rel=0.01)


def test_radii_of_curvature():
    r_m, r_n = earth.radii(0.0)
    assert r_n == pytest.approx(6378137.0, abs=1e-6)
    assert r_m == pytest.approx(6335439.327, abs=1e-3)
    r_m, r_n = earth.radii(np.pi / 2)
    assert r_m == pytest.approx(r_n, abs=1e-6)          # equal at the pole: a^2/b
    assert r_n == pytest.approx(6399593.626, abs=1e-3)


def test_ecef_roundtrip_and_known_point():
    # a point on the equator at the prime meridian, 0 m: (a, 0, 0)
    np.testing.assert_allclose(earth.geodetic_to_ecef(0.0, 0.0, 0.0), [6378137.0, 0.0, 0.0], atol=1e-9)
    lat, lon, alt = np.deg2rad(30.011), np.deg2rad(120.094), 30000.0
    r = earth.geodetic_to_ecef(lat, lon, alt)
    lat2, lon2, alt2 = earth.ecef_to_geodetic(r)
    assert lat2 == pytest.approx(lat, abs=1e-13)
    assert lon2 == pytest.approx(lon, abs=1e-13)
    assert alt2 == pytest.approx(alt, abs=1e-6)


def test_enu_frame_axes():
    # at lat 0, lon 0: east = +y_ecef, north = +z_ecef, up = +x_ecef
    np.testing.assert_allclose(earth.C_n_e(0.0, 0.0), [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15)
    # a point 1000 m north of the origin appears at (0, 1000, ~0) in ENU
    lat0, lon0 = np.deg2rad(30.0), np.deg2rad(120.0)
    r_m, _ = earth.radii(lat0)
    enu = earth.enu_offset_m(lat0, lon0, 0.0, lat0 + 1000.0 / r_m, lon0, 0.0)
    np.testing.assert_allclose(enu, [0.0, 1000.0, -0.078], atol=2e-3)


def test_earth_and_transport_rate():
    w = earth.omega_ie_n(np.deg2rad(30.0))
    assert np.linalg.norm(w) == pytest.approx(7.2921151467e-5, rel=1e-12)
    assert w[0] == 0.0 and w[2] == pytest.approx(7.2921151467e-5 * 0.5, rel=1e-12)
    # flying north at 1700 m/s: rotation about -east of v / (R_M + h)
    r_m, _ = earth.radii(0.5)
    np.testing.assert_allclose(earth.omega_en_n(0.5, 3e4, np.array([0.0, 1700.0, 0.0])),
                               [-1700.0 / (r_m + 3e4), 0.0, 0.0], rtol=1e-12)
