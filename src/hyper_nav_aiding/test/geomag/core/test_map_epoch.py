"""Map epoch against the flight's date (issue 27): the secular-variation
model against pygeomag, the issue's case refused with both fields and the
implied nT, a small offset reported (at start, along the track, per
stamp), a brought-forward map against a map built at the target date, and
the scenario validation."""
import copy
import dataclasses

import numpy as np
import pytest
from pygeomag import GeoMag

from hyper_nav_aiding.geomag.core import map_epoch as me
from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig, GeomagConfigError
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, MapSpec
from hyper_nav_aiding.geomag.core.matching import MagSample, NavPoint

# the issue's flight: seed 003's set-up moved to 33 S 143 E, 31 km (map at 32 km after the climb)
ISSUE_MAP = MapSpec(epoch_decimal_year=2025.5, alt_m=32000.0, lat_min_deg=-33.5, lat_max_deg=-25.5,
                    lon_min_deg=140.5, lon_max_deg=143.5, grid_step_deg=0.05, refine_factor=40)
# a 1 x 1 deg corner of it, for maps built in the test (21 x 21 nodes, ~0.2 s each)
SMALL = dataclasses.replace(ISSUE_MAP, lat_min_deg=-33.5, lat_max_deg=-32.5, lon_min_deg=142.5, lon_max_deg=143.5)


def _cfg(spec: MapSpec, **kw) -> GeomagConfig:
    return GeomagConfig.from_dict({"map": dataclasses.asdict(spec), **kw})


def _f(lat, lon, alt_m, year):
    gm = GeoMag(coefficients_file="wmm/WMM_2025.COF")
    return gm.calculate(glat=lat, glon=lon, alt=alt_m / 1000.0, time=year).f


def test_secular_variation_is_pygeomag_over_one_year():
    """Bdot from the release's SV coefficients = pygeomag's B(t + 1) - B(t)
    (the model is linear in t within a release) to 1e-9 nT/yr."""
    gm = GeoMag(coefficients_file="wmm/WMM_2025.COF")
    for lat, lon, alt_m in ((-33.0, 143.0, 31000.0), (44.0, 110.0, 26000.0), (80.0, -170.0, 0.0)):
        r0, r1 = (gm.calculate(glat=lat, glon=lon, alt=alt_m / 1000.0, time=t) for t in (2026.0, 2027.0))
        sv = me.secular_variation_enu_nT_per_yr(lat, lon, alt_m, 2026.0)
        assert np.allclose(sv, [r1.y - r0.y, r1.x - r0.x, r0.z - r1.z], atol=1e-9)


def test_issue_case_is_refused_naming_both_fields_and_the_nT():
    """2025.5 map, 2027.0 flight at 33 S 143 E: -16.4 nT mean over the map
    (the issue: -16 nT along the track), -17.42 nT at 33 S 143 E (= pygeomag's
    F difference to 1e-3 nT), far beyond the default 0.1 nT."""
    with pytest.raises(me.MapEpochError) as exc:
        me.check(_cfg(ISSUE_MAP), 2027.0)
    msg = str(exc.value)
    for s in ("geomag.map.epoch_decimal_year = 2025.5", "magnetometer.epoch_decimal_year = 2027",
              "1.500 years", "-16.4 nT", "geomag.map_epoch_tolerance_nT = 0.1 nT", "map_bring_forward"):
        assert s in msg, msg
    off = me.map_epoch_offset(ISSUE_MAP, 2027.0)
    assert -17.0 < off.bias_mean_nT < -16.0 and -19.0 < off.bias_min_nT < off.bias_max_nT < -14.0
    direct = _f(-33.0, 143.0, 32000.0, 2027.0) - _f(-33.0, 143.0, 32000.0, 2025.5)
    assert off.bias_nT(np.deg2rad(-33.0), np.deg2rad(143.0)) == pytest.approx(direct, abs=1e-3)
    assert direct == pytest.approx(-17.42, abs=0.01)


def test_missing_or_uncovered_flight_date_is_refused():
    with pytest.raises(me.MapEpochError, match="magnetometer.epoch_decimal_year: expected the flight's date"):
        me.check(_cfg(SMALL), float("nan"))
    with pytest.raises(ValueError, match="magnetometer.epoch_decimal_year: 2031.0 is outside every World"):
        me.check(_cfg(SMALL), 2031.0)


def test_offset_within_tolerance_is_reported():
    """A flight 1.5 days after the map's epoch: b = -0.048 nT at 33 S 143 E,
    within 0.1 nT: returned, equal to pygeomag's F difference to 1e-5 nT;
    a sample stamped one day later adds dF/dt x 1 day (1e-5 nT)."""
    t_f = 2025.5 + 1.5 / 365.25
    off = me.check(_cfg(ISSUE_MAP), t_f)
    lat, lon = np.deg2rad(-33.0), np.deg2rad(143.0)
    direct = _f(-33.0, 143.0, 32000.0, t_f) - _f(-33.0, 143.0, 32000.0, 2025.5)
    assert off.bias_nT(lat, lon) == pytest.approx(direct, abs=1e-5)
    assert -0.06 < direct < -0.04
    later = _f(-33.0, 143.0, 32000.0, t_f + 1.0 / 365.25) - _f(-33.0, 143.0, 32000.0, 2025.5)
    assert off.bias_nT(lat, lon, t_s=86400.0) == pytest.approx(later, abs=1e-5)
    s = off.summary()
    assert s["map_epoch_decimal_year"] == 2025.5 and not s["map_brought_forward"]
    assert s["map_epoch_bias_min_nT"] <= s["map_epoch_bias_mean_nT"] <= s["map_epoch_bias_max_nT"] < 0.0
    # a larger stated tolerance lets the issue's map through, reported
    assert me.check(_cfg(ISSUE_MAP, map_epoch_tolerance_nT=20.0), 2027.0).bias_mean_nT < -16.0


def test_tolerance_is_a_validated_parameter():
    assert GeomagConfig().map_epoch_tolerance_nT == 0.1 and GeomagConfig().map_bring_forward is False
    with pytest.raises(GeomagConfigError, match="geomag.map_epoch_tolerance_nT: expected a number"):
        GeomagConfig.from_dict({"map_epoch_tolerance_nT": -1.0})
    with pytest.raises(GeomagConfigError, match="geomag.map_bring_forward: expected true or false"):
        GeomagConfig.from_dict({"map_bring_forward": "yes"})
    flat = GeomagConfig(map_bring_forward=True).flat()
    assert flat["geomag.map_epoch_tolerance_nT"] == 0.1 and flat["geomag.map_bring_forward"] is True


@pytest.fixture(scope="module")
def small_maps():
    return GeomagMap.build(SMALL), GeomagMap.build(dataclasses.replace(SMALL, epoch_decimal_year=2027.0))


def test_brought_forward_map_equals_a_map_built_at_the_target_date(small_maps):
    """2025.5 -> 2027.0 with WMM-2025's secular variation: every layer of
    the base grid within 1e-3 nT (F, components; measured 5e-5 nT) and
    1e-8 nT/m (dF/dh; measured 1e-10) of the map built at 2027.0, and F and
    its gradient at points 1 km off the map altitude likewise; the field
    itself changed by 17-18 nT."""
    m0, m1 = small_maps
    mb = me.bring_forward(m0, 2027.0)
    assert mb.spec == m1.spec and mb.provenance["brought_forward_from_epoch_decimal_year"] == 2025.5
    assert mb.provenance["secular_variation_model"] == "WMM-2025"
    d = np.abs(mb.layers - m1.layers).max(axis=(1, 2))
    assert np.all(d[:4] < 1e-3) and np.all(d[4:] < 1e-8), d
    assert 17.0 < np.abs(m1.layers[0] - m0.layers[0]).max() < 18.5
    rng = np.random.default_rng(2)
    la = np.deg2rad(rng.uniform(-33.45, -32.55, 50))
    lo = np.deg2rad(rng.uniform(142.55, 143.45, 50))
    h = 32000.0 + rng.uniform(-1000.0, 1000.0, 50)
    (f1, g1), (fb, gb) = m1.total_and_gradient(la, lo, h), mb.total_and_gradient(la, lo, h)
    assert np.max(np.abs(fb - f1)) < 1e-3 and np.max(np.abs(gb - g1)) < 1e-8
    # and the check of a brought-forward map finds nothing left (same release)
    off = me.check(_cfg(SMALL, map_bring_forward=True), 2027.0)
    assert off.brought_forward and abs(off.bias_worst_nT) < 1e-6


def test_bringing_forward_across_a_release_is_refused():
    """A WMM-2020 map of 2024.5 brought to 2025.5 with WMM-2020's secular
    variation differs from WMM-2025 at 2025.5 by tens of nT (-68 nT mean
    here): the releases' forecast, refused as such."""
    spec = dataclasses.replace(ISSUE_MAP, model="WMM-2020", epoch_decimal_year=2024.5)
    with pytest.raises(me.MapEpochError) as exc:
        me.check(_cfg(spec, map_bring_forward=True), 2025.5)
    assert "WMM-2020 map, WMM-2025 at the flight" in str(exc.value)
    assert me.map_epoch_offset(spec, 2025.5, True).bias_mean_nT < -30.0


def test_engine_reports_the_bias_per_sample(small_maps):
    """Within the tolerance the aiding engine puts b at the solution and
    stamp on every result (geomag/quality) and keeps the summary; beyond it
    a sample (a stamp far from stamp 0) is refused and counted."""
    m0, _ = small_maps
    t_f = 2025.5 + 1.0 / 365.25
    cfg = _cfg(SMALL, algorithm="EKF", start_s=0.0, ekf={"map_error_corr_length_m": 0.0})
    off = me.check(cfg, t_f)
    eng = GeomagAiding(cfg, m0, epoch=off)
    lat, lon = np.deg2rad(-33.0), np.deg2rad(143.0)
    nav = NavPoint(10.0, lat, lon, 32000.0, np.array([0.0, 2000.0, 0.0]), np.eye(2) * 100.0, 100.0)
    f = float(m0.total_nT(lat, lon, 32000.0))
    res = eng.process(MagSample(10.0, f + off.bias_nT(lat, lon, 10.0)), nav)
    assert res is not None and res.map_epoch_bias_nT == pytest.approx(off.bias_nT(lat, lon, 10.0), abs=1e-12)
    assert -0.04 < res.map_epoch_bias_nT < -0.025
    assert eng.epoch_report()["map_epoch_bias_track_nT"] == pytest.approx(res.map_epoch_bias_nT, abs=1e-4)
    late = 3.0 * 86400.0                                  # three days on: -0.1 nT more, beyond 0.1 nT
    nav_late = dataclasses.replace(nav, t_s=late)
    res = eng.process(MagSample(late, f), nav_late)
    assert not res.valid and res.code == "rejected_map_epoch" and eng.counters["rejected_map_epoch"] == 1
    assert "geomag.map_epoch_tolerance_nT" in res.reason


def test_scenario_validation_refuses_the_issue_case():
    from hyper_nav_sim.core.scenario import ScenarioError, load_scenario, validate
    data = copy.deepcopy(load_scenario("seed003").data)
    data["magnetometer"]["epoch_decimal_year"] = 2027.0
    with pytest.raises(ScenarioError) as exc:
        validate(data, "moved.yaml")
    msg = str(exc.value)
    assert msg.startswith("moved.yaml: geomag.map.epoch_decimal_year = 2025.5 and "
                          "magnetometer.epoch_decimal_year = 2027 are 1.500 years apart")
    assert "+48.7 nT" in msg                               # seed 003's own map region: +33 nT/yr
    data["geomag"]["map_bring_forward"] = True
    validate(data, "moved.yaml")                           # brought forward: accepted
