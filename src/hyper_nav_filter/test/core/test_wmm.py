"""The World Magnetic Model release is chosen by date (pygeomag ships
WMM-2010 .. WMM-2025); a date outside every release is refused clearly, at
scenario load."""
import numpy as np
import pytest
from pygeomag import GeoMag

from hyper_nav_sim.core import simulate
from hyper_nav_filter.core import wmm
from hyper_nav_sim.core.scenario import Scenario, ScenarioError, load_scenario, validate


@pytest.mark.parametrize("year,name", [(2012.3, "WMM-2010"), (2019.99, "WMM-2015v2"), (2022.5, "WMM-2020"),
                                       (2025.0, "WMM-2025"), (2029.9, "WMM-2025")])
def test_release_by_date(year, name):
    assert wmm.release_for(year).name == name


@pytest.mark.parametrize("year", [2009.99, 2030.0, 1990.0])
def test_date_outside_every_release_is_refused(year):
    with pytest.raises(wmm.WmmDateError, match=r"magnetometer.epoch_decimal_year: .* outside every World "
                                               r"Magnetic Model available \(WMM-2010 .. WMM-2025 cover 2010.0 to 2030.0"):
        wmm.release_for(year)


def test_field_in_2022_is_wmm2020_and_differs_from_wmm2025():
    """30N 120E 30 km, 2022.5: the WMM-2020 coefficients, to the nT."""
    lat, lon, alt = np.radians(30.0), np.radians(120.0), 30e3
    got = wmm.field_enu_nT(lat, lon, alt, 2022.5)
    r = GeoMag(coefficients_file="wmm/WMM_2020.COF").calculate(glat=30.0, glon=120.0, alt=30.0, time=2022.5)
    np.testing.assert_allclose(got, [r.y, r.x, -r.z], atol=1e-9)
    assert 40000 < np.linalg.norm(got) < 55000
    # the same date cannot be computed with WMM-2025 (before its epoch); 2025.0 with each release differs
    with pytest.raises(ValueError):
        GeoMag(coefficients_file="wmm/WMM_2025.COF").calculate(glat=30.0, glon=120.0, alt=30.0, time=2022.5)
    # longitude beyond 180 (a wrapped flight) is the same point
    np.testing.assert_allclose(wmm.field_enu_nT(lat, np.radians(-240.0), alt, 2022.5), got, atol=1e-9)


def _with_year(year):
    d = load_scenario("default").data
    return dict(d, duration_s=2.0, magnetometer=dict(d["magnetometer"], epoch_decimal_year=year))


def test_scenario_validation_refuses_a_date_without_model_and_simulates_2022():
    with pytest.raises(ScenarioError, match=r"x.yaml: magnetometer.epoch_decimal_year: 2031.0 is outside"):
        validate(_with_year(2031.0), "x.yaml")
    sc = Scenario(load_scenario("default").path, validate(_with_year(2022.5)))
    t, b_T = simulate.mag_stream(sc, sc.trajectory())
    assert len(t) == 20 and np.all(np.isfinite(b_T))
    norm_nT = np.linalg.norm(b_T, axis=1) * 1e9
    tr = sc.trajectory().truth(t)
    ref = np.linalg.norm(wmm.field_enu_nT(tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], 2022.5))
    assert np.all(np.abs(norm_nT - ref) < 50.0)         # 5 nT noise; the field barely changes in 2 s
