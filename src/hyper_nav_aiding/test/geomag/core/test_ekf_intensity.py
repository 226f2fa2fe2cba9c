"""The EKF pseudo-fix is the scalar intensity update: applied as a 3-D
``PositionFix`` (degenerate covariance, the ``position_fix`` source) to the
fusion filter, in both mechanization frames, it gives the same correction
and covariance as the scalar measurement z = g . dr with variance sigma^2."""
from dataclasses import dataclass

import numpy as np
import pytest

from hyper_nav_aiding.geomag.core.ekf_intensity import EkfIntensity
from hyper_nav_aiding.geomag.core.geomag_config import EkfParams
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, MapSpec
from hyper_nav_aiding.geomag.core.matching import MagSample, NavPoint
from hyper_nav_aiding.geomag.conversions import fix_measurement
from hyper_nav_gnss import earth
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import make_filter
from hyper_nav_filter.core.measurements import Measurement, ModelContext
from hyper_nav_filter.core.nav_state import NavState

SPEC = MapSpec(lat_min_deg=44.0, lat_max_deg=44.5, lon_min_deg=110.0, lon_max_deg=110.5, grid_step_deg=0.05,
               alt_m=26000.0)


@dataclass(frozen=True)
class ScalarIntensity(Measurement):
    """The tightly coupled reference: z = F_map(r^) - m, H = grad F on pos."""
    t_s: float
    z_nT: float
    grad: np.ndarray
    var_nT2: float
    kind: str = "scalar"
    coupling = "aiding"

    def model(self, state, layout, ctx):
        H = np.zeros((1, layout.dim))
        H[0, layout.sl("pos")] = self.grad
        return np.array([self.z_nT]), H, np.array([[self.var_nT2]])


@pytest.fixture(scope="module")
def gmap():
    return GeomagMap.build(SPEC)


@pytest.mark.parametrize("frame", ["ENU", "LCI"])
def test_pseudo_fix_equals_the_scalar_update(gmap, frame):
    cfg = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "ba", "sg", "sa"), mechanization_frame=frame,
                       init_pos_sigma_m=(300.0, 300.0, 5.0), launch_azimuth_deg=10.0)
    lat, lon, alt = np.deg2rad(44.2), np.deg2rad(110.3), 25900.0
    C = np.eye(3)
    init = NavState(100.0, lat, lon, alt, np.array([100.0, 2000.0, 0.0]), C)
    sigma = 0.3
    # truth 200 m south-east of the solution, 2 m lower: the measured field there
    r_m, r_n = earth.radii(lat)
    t_lat, t_lon = lat - 150.0 / (r_m + alt), lon - 130.0 / ((r_n + alt) * np.cos(lat))
    m = float(gmap.total_nT(t_lat, t_lon, alt - 2.0))
    nav = NavPoint(100.0, lat, lon, alt, init.vel_enu_mps, np.diag([300.0**2] * 2), 25.0)
    res = EkfIntensity(gmap, EkfParams(across_sigma_m=1e5), sigma).step(MagSample(100.0, m), nav)
    f, g = gmap.total_and_gradient(lat, lon, alt)
    ctx = ModelContext(np.zeros(3), np.zeros(3), 0.0)
    kf_fix, kf_ref = make_filter(cfg, init), make_filter(cfg, init)
    r1 = kf_fix.update("position_fix", 100.0, *kf_fix.model(fix_measurement(res), ctx))
    r2 = kf_ref.update("scalar", 100.0, *kf_ref.model(ScalarIntensity(100.0, float(f) - m, g, sigma**2), ctx))
    assert r1.accepted and r2.accepted
    assert fix_measurement(res).kind == "position_fix"
    s1, s2 = kf_fix.state, kf_ref.state
    d = earth.position_error_enu_m(s1.lat_rad, s1.lon_rad, s1.alt_m, s2.lat_rad, s2.lon_rad, s2.alt_m)
    assert np.linalg.norm(d) < 0.05                              # the same correction to 5 cm (of ~40 m)
    moved = earth.position_error_enu_m(s1.lat_rad, s1.lon_rad, s1.alt_m, lat, lon, alt)
    assert np.linalg.norm(moved) > 30.0
    assert np.allclose(kf_fix.P, kf_ref.P, rtol=1e-4, atol=1e-9 * np.max(np.abs(kf_ref.P)))
