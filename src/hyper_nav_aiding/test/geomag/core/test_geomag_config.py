"""The typed geomag parameters: Table 2 defaults, errors that name the
field, the flat ROS-parameter round trip, and the seed 003 scenario block."""
import pytest

from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig, GeomagConfigError


def test_defaults_are_table_2():
    c = GeomagConfig()
    assert (c.magcom.sequence_length, c.magcom.area_cells, c.magcom.rotation_max_deg, c.magcom.rotation_step_deg) \
        == (10, 25, 10.0, 1.0)
    assert (c.iccp.sequence_length, c.iccp.area_cells, c.iccp.max_iterations, c.iccp.critical_distance_m) \
        == (5, 300, 20, 200.0)
    assert c.siman.x0_m == (0.0, 0.0) and c.start_s == 420.0
    assert (c.map.grid_step_deg, c.map.refine_factor, c.map.lat_min_deg, c.map.lon_max_deg) == (0.01, 8, 40.0, 112.0)


@pytest.mark.parametrize("block, word", [
    ({"algorithm": "TERCOM"}, "geomag.algorithm: expected one of"),
    ({"magcom": {"sequence_length": 1}}, "geomag.magcom.sequence_length: expected an integer in"),
    ({"iccp": {"critical_distance_m": "far"}}, "geomag.iccp.critical_distance_m: expected a number"),
    ({"siman": {"p0_m2": [1.0]}}, "geomag.siman.p0_m2: expected a list of 2 numbers"),
    ({"map": {"alt_m": "high"}}, "geomag.map.alt_m: expected a number"),
    ({"magcom": {"length": 3}}, "geomag.magcom: unknown field"),
    ({"algoritm": "SIMAN"}, "geomag: unknown field"),
])
def test_errors_name_the_field(block, word):
    with pytest.raises(GeomagConfigError, match=word):
        GeomagConfig.from_dict(block)


def test_flat_parameters_round_trip_and_carry_descriptions():
    c = GeomagConfig.from_dict({"algorithm": "ICCP", "iccp": {"max_iterations": 7}, "map": {"alt_m": 26000}})
    flat = c.flat()
    assert flat["geomag.iccp.max_iterations"] == 7 and flat["geomag.map.alt_m"] == 26000.0
    assert isinstance(flat["geomag.map.alt_m"], float)      # a double parameter, not an integer
    assert GeomagConfig.from_flat(flat) == c
    d = GeomagConfig.describe()
    assert set(d) == set(flat)
    default, desc, lo, hi, _ = d["geomag.magcom.area_cells"]
    assert default == 25 and "Table 2" in desc and (lo, hi) == (3, 2001)


def test_seed003_scenario_block_is_valid():
    from hyper_nav_sim.core.scenario import load_scenario
    sc = load_scenario("seed003")
    c = GeomagConfig.from_dict(sc.data["geomag"])
    assert c.map.epoch_decimal_year == sc["magnetometer.epoch_decimal_year"]
    assert c.sensor_sigma_nT == sc["magnetometer.noise_nT"]
    assert c.ekf.map_error_corr_length_m == sc["magnetometer.map_error_corr_length_m"]
