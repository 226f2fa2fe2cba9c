"""Longitude is wrapped to [-180, 180) deg at every boundary and every
longitude difference is wrapped (issue #6): a flight across 180 deg keeps
metre-level errors instead of 2 pi jumps."""
import math

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import Scenario, load_scenario, validate
from hyper_nav_sim.plot import ground_track_deg


@pytest.mark.parametrize("lon_deg,expect_deg", [(0.0, 0.0), (179.0, 179.0), (180.0, -180.0), (181.0, -179.0),
                                                (-180.0, -180.0), (-181.0, 179.0), (540.0, -180.0),
                                                (359.5, -0.5), (-720.25, -0.25)])
def test_wrap_scalar_and_array(lon_deg, expect_deg):
    got = earth.wrap_lon_rad(math.radians(lon_deg))
    assert isinstance(got, float) and math.degrees(got) == pytest.approx(expect_deg, abs=1e-9)
    arr = earth.wrap_lon_rad(np.radians([lon_deg, lon_deg]))
    np.testing.assert_allclose(np.degrees(arr), [expect_deg] * 2, atol=1e-9)
    assert -math.pi <= got < math.pi


def test_wrap_never_returns_plus_pi():
    """(x + pi) mod 2 pi may round up to 2 pi for x just below -pi: still -pi."""
    x = -math.pi - 1e-17
    assert earth.wrap_lon_rad(x) == -math.pi
    assert np.all(earth.wrap_lon_rad(np.array([x, math.pi, 3 * math.pi])) < math.pi)


def test_position_difference_across_180_is_metres_not_an_earth_circumference():
    lat = math.radians(30.0)
    east = earth.position_error_enu_m(lat, math.radians(-179.9999), 30e3, lat, math.radians(179.9999), 30e3)
    r_m, r_n = earth.radii(lat)
    expect = math.radians(0.0002) * (r_n + 30e3) * math.cos(lat)       # 19.3 m east
    assert east[0] == pytest.approx(expect, rel=1e-9) and abs(east[1]) < 1e-9
    # ECEF round trip on the far side gives -180 <= lon < 180
    lat2, lon2, _ = earth.ecef_to_geodetic(earth.geodetic_to_ecef(lat, math.pi, 1000.0))
    assert math.degrees(lon2) == pytest.approx(-180.0, abs=1e-9)


def _east_scenario(lon_deg=179.9, duration_s=20.0):
    """Default scenario flown due east from 179.9E: crosses 180 deg at ~5.7 s."""
    d = load_scenario("default").data
    d = dict(d, duration_s=duration_s, start=dict(d["start"], lon_deg=lon_deg, vel_enu_mps=[1700.0, 0.0, 0.0]))
    return Scenario(load_scenario("default").path, validate(d))


def test_truth_fixes_and_error_free_mechanization_across_180():
    from hyper_nav_filter.core import mechanization
    from hyper_nav_filter.core.nav_state import ImuSample
    sc = _east_scenario()
    traj = sc.trajectory()
    t = np.arange(0.0, 20.0 + 1e-9, 0.5)
    tr = traj.truth(t)
    lon_deg = np.degrees(tr.lon_rad)
    assert lon_deg[0] == pytest.approx(179.9) and lon_deg[-1] < -179.5        # crossed, wrapped
    assert np.all((lon_deg >= -180.0) & (lon_deg < 180.0))
    fixes = simulate.gnss_stream(sc, traj)
    assert np.all(np.abs(fixes.lon_rad) <= math.pi) and np.degrees(fixes.lon_rad).min() < -179.5
    err = earth.position_error_enu_m(fixes.lat_rad, fixes.lon_rad, fixes.alt_m,
                                     *(getattr(traj.truth(fixes.t_s), k) for k in ("lat_rad", "lon_rad", "alt_m")))
    assert np.sqrt(np.mean(err**2, axis=0)).max() < 7.0                       # the 5 m noise, no 4e7 m jumps
    # error-free IMU through the mechanization: stays on the truth through the crossing
    rate, dt = 50.0, 0.02
    te = np.arange(1, 1001) * dt
    dth, dv = traj.imu_increments(te, dt)
    s0 = traj.truth([0.0])
    st = NavState(0.0, s0.lat_rad[0], s0.lon_rad[0], s0.alt_m[0], s0.vel_enu_mps[0], s0.C_b_n[0])
    prev, v_prev = None, None
    worst = 0.0
    for k in range(len(te)):
        imu = ImuSample(te[k], dt, dth[k], dv[k])
        v_before = st.vel_enu_mps
        st = mechanization.propagate(st, imu, prev, v_prev)
        prev, v_prev = imu, v_before
        assert -math.pi <= st.lon_rad < math.pi
        if k % 50 == 49:
            ref = traj.truth([te[k]])
            e = earth.position_error_enu_m(st.lat_rad, st.lon_rad, st.alt_m, ref.lat_rad[0], ref.lon_rad[0],
                                           ref.alt_m[0])
            worst = max(worst, float(np.linalg.norm(e)))
    assert worst < 1e-3, worst                     # measured 5e-7 m over the 20 s


def test_initial_state_and_ground_track_plot_wrap():
    sc = _east_scenario(lon_deg=180.0)
    init = sc.filter_initial_state()
    assert -math.pi <= init.lon_rad < math.pi
    lon, lat = ground_track_deg(np.radians([179.0, 179.9, -179.9, -179.0]), np.radians([30.0] * 4))
    assert np.isnan(lon[2]) and np.isnan(lat[2]) and len(lon) == 5          # a break, not a line across the map
    np.testing.assert_allclose(lon[[0, 1, 3, 4]], [179.0, 179.9, -179.9, -179.0])
