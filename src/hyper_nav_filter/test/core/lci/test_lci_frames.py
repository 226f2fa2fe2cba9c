"""LCI frame definition and the ECEF / geodetic conversions (seed 001 section 2, 4.3)."""
import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import attitude_error_n_rad, euler_to_C_b_n
from hyper_nav_filter.core.lci.frames import LaunchFrame

FRAME = LaunchFrame.from_degrees(40.0, 100.0, 1200.0, 60.0, t0_s=5.0)


def test_origin_is_the_launch_point_at_launch_and_axes_follow_the_azimuth():
    f = FRAME
    r_a, v_a, C_b_a = f.geodetic_to_lci(f.lat_rad, f.lon_rad, f.alt_m, np.zeros(3), np.eye(3), f.t0_s)
    np.testing.assert_allclose(r_a, 0.0, atol=1e-6)
    # a point at rest on the Earth moves with omega_ie x R0 in the inertial frame
    np.testing.assert_allclose(v_a, np.cross(f.omega_ie_a_radps, f.R0_a_m), atol=1e-9)
    # x_a along azimuth 60 deg in the horizontal plane, y_a up, z_a = x cross y
    A, B = f.azimuth_rad, f.lat_rad
    np.testing.assert_allclose(C_b_a.T @ [1, 0, 0], [np.sin(A), np.cos(A), 0.0], atol=1e-12)   # ENU -> a
    np.testing.assert_allclose(C_b_a.T @ [0, 1, 0], [0.0, 0.0, 1.0], atol=1e-12)
    assert np.linalg.det(f.C_t_a) == pytest.approx(1.0, abs=1e-12)
    # eq. 5: Earth rate in LCI
    W = earth.OMEGA_IE_RADPS
    np.testing.assert_allclose(f.omega_ie_a_radps, W * np.array([np.cos(B) * np.cos(A), np.sin(B),
                                                                 -np.cos(B) * np.sin(A)]), atol=1e-18)
    # 1 km along the azimuth on the tangent plane is (1000, 0, 0) in LCI at t0
    d_n = 1000.0 * np.array([np.sin(A), np.cos(A), 0.0])
    r_e = f.r0_e_m + earth.C_n_e(f.lat_rad, f.lon_rad) @ d_n
    np.testing.assert_allclose(f.ecef_position_to_lci(r_e, f.t0_s), [1000.0, 0.0, 0.0], atol=1e-8)


def test_earth_fixed_point_rotates_about_the_spin_axis_in_lci():
    f = FRAME
    t = f.t0_s + 3600.0
    r_a = f.ecef_position_to_lci(f.r0_e_m, t)
    ang = earth.OMEGA_IE_RADPS * 3600.0
    # rotation of R0 about the spin axis by omega t
    from scipy.spatial.transform import Rotation
    expected = Rotation.from_rotvec(ang * f.spin_axis_a).apply(f.R0_a_m) - f.R0_a_m
    np.testing.assert_allclose(r_a, expected, atol=1e-6)


@pytest.mark.parametrize("t_s", [5.0, 100.0, 2000.0])
def test_geodetic_round_trips(t_s):
    rng = np.random.default_rng(1)
    n = 50
    lat = rng.uniform(-1.4, 1.4, n)
    lon = rng.uniform(-np.pi, np.pi, n)
    alt = rng.uniform(-100.0, 120e3, n)
    vel = rng.normal(0.0, 2000.0, (n, 3))
    C_b_n = np.stack([euler_to_C_b_n(*rng.uniform(-1.5, 1.5, 3)) for _ in range(n)])
    C_b_n[0] = euler_to_C_b_n(0.3, np.pi / 2, 1.0)                 # vertical
    tt = np.full(n, t_s)
    r_a, v_a, C_b_a = FRAME.geodetic_to_lci(lat, lon, alt, vel, C_b_n, tt)
    lat2, lon2, alt2, vel2, C2 = FRAME.lci_to_geodetic(r_a, v_a, C_b_a, tt)
    pos_err = earth.position_error_enu_m(lat2, lon2, alt2, lat, lon, alt)
    assert np.abs(pos_err).max() < 1e-6
    assert np.abs(vel2 - vel).max() < 1e-9
    att = max(np.linalg.norm(attitude_error_n_rad(C2[k], C_b_n[k])) for k in range(n))
    assert att < 1e-12
    # ECEF <-> LCI directly
    r_e = earth.geodetic_to_ecef(lat, lon, alt)
    v_e = rng.normal(0.0, 1000.0, (n, 3))
    r_e2, v_e2 = FRAME.lci_to_ecef(*FRAME.ecef_to_lci(r_e, v_e, tt), tt)
    assert np.abs(r_e2 - r_e).max() < 1e-6 and np.abs(v_e2 - v_e).max() < 1e-9
    # the scalar path agrees with the vectorised one
    r1, v1, C1 = FRAME.geodetic_to_lci(lat[3], lon[3], alt[3], vel[3], C_b_n[3], t_s)
    np.testing.assert_allclose(r1, r_a[3], atol=1e-7)
    np.testing.assert_allclose(C1, C_b_a[3], atol=1e-14)


def test_velocity_conversion_is_the_derivative_of_the_position_conversion():
    """v_a = d r_a / dt, including the omega_ie x r term (section 4.3)."""
    f = FRAME
    r_e0 = earth.geodetic_to_ecef(0.5, 1.9, 25e3)
    v_e = np.array([300.0, -1200.0, 400.0])
    t, h = 50.0, 1e-3
    r_p = f.ecef_position_to_lci(r_e0 + v_e * h, t + h)
    r_m = f.ecef_position_to_lci(r_e0 - v_e * h, t - h)
    _, v_a = f.ecef_to_lci(r_e0, v_e, t)
    np.testing.assert_allclose((r_p - r_m) / (2 * h), v_a, atol=1e-6)
