"""ParamSpec, the one field-validation idiom (issue 34): the scenario's own
fields are declared with it too (hyper_nav_sim.core.scenario.SCENARIO_PARAMS), so the forms they need are proven here
(required fields, interval wording, a named quantity, a whole-value rule,
the value in the error as it was coerced)."""
import math

import pytest

from hyper_nav_filter.core.params import (
    BOOL, FLOAT, FLOATS, INT, REQUIRED, ConfigError, ParamSpec, checked, number,
)


def test_bound_crossed_is_named_and_the_value_is_shown_as_coerced():
    rate = ParamSpec("imu.rate_hz", FLOAT, 100.0, "", lo=0.0, lo_open=True)
    with pytest.raises(ConfigError, match=r"^imu.rate_hz: must be > 0, got 0.0$"):
        rate.check(0)                                   # an integer, coerced to float, shown as such
    depth = ParamSpec("graph.qos_depth", INT, 10, "", lo=0, lo_open=True)
    with pytest.raises(ConfigError, match=r"^graph.qos_depth: must be > 0, got 0$"):
        depth.check(0)
    assert rate.check(50) == 50.0 and type(rate.check(50)) is float


def test_interval_wording_follows_the_openness_of_each_bound():
    lat = ParamSpec("lat_deg", FLOAT, 0.0, "", lo=-90.0, hi=90.0, lo_open=True, hi_open=True, interval=True)
    lon = ParamSpec("lon_deg", FLOAT, 0.0, "", lo=-180.0, hi=180.0, interval=True)
    with pytest.raises(ConfigError, match=r"^lat_deg: expected a number in \(-90, 90\), got 90.0$"):
        lat.check(90.0)
    with pytest.raises(ConfigError, match=r"^lon_deg: expected a number in \[-180, 180\], got -180.5$"):
        lon.check(-180.5)
    n = ParamSpec("sequence_length", INT, 10, "", lo=2, hi=1000, interval=True)
    with pytest.raises(ConfigError, match=r"^sequence_length: expected an integer in \[2, 1000\], got 1$"):
        n.check(1)
    assert lon.check(180) == 180.0 and lat.check(-89.9) == -89.9
    plain = ParamSpec("lat_deg", FLOAT, 0.0, "", lo=-90.0, hi=90.0)      # without: the bound crossed
    with pytest.raises(ConfigError, match=r"^lat_deg: must be <= 90, got 91.0$"):
        plain.check(91.0)


def test_quantity_and_rule():
    sigma = ParamSpec("pos_sigma_m", FLOATS, (1.0, 1.0, 1.0), "", length=3, lo=0.0, lo_open=True,
                      quantity="a standard deviation")
    with pytest.raises(ConfigError, match=r"^pos_sigma_m: a standard deviation must be > 0, got 0.0$"):
        sigma.check([1.0, 0.0, 1.0])
    assert sigma.check(2) == (2.0, 2.0, 2.0)           # one number for every axis
    unit = ParamSpec("q", FLOATS, (0.0, 0.0, 0.0, 1.0), "", length=4,
                     rule=lambda q: None if abs(math.hypot(*q) - 1.0) < 1e-9 else "must be a unit quaternion")
    with pytest.raises(ConfigError, match=r"^q: must be a unit quaternion$"):
        unit.check([0.0, 0.0, 0.0, 2.0])
    assert unit.check([0, 0, 1, 0]) == (0.0, 0.0, 1.0, 0.0)
    listed = ParamSpec("vel_enu_mps", FLOATS, (0.0, 0.0, 0.0), "", length=3, broadcast=False)
    with pytest.raises(ConfigError, match=r"^vel_enu_mps: expected a list of 3 numbers, got 5$"):
        listed.check(5)
    with pytest.raises(ConfigError, match=r"^vel_enu_mps: expected a list of 3 numbers, got \[1.0, 2.0\]$"):
        listed.check([1.0, 2.0])
    with pytest.raises(ConfigError, match=r"^pos_sigma_m: expected 3 numbers, got \[1.0, 2.0\]$"):
        sigma.check([1.0, 2.0])


def test_required_and_the_number_rule_of_parsers():
    assert ParamSpec("seed", INT, REQUIRED, "").required and not ParamSpec("seed", INT, 0, "").required
    assert repr(REQUIRED) == "REQUIRED"
    with pytest.raises(ValueError, match=r"^flight.x: expected a finite number, got inf$"):
        number("flight.x", float("inf"), error=ValueError)
    with pytest.raises(ValueError, match=r"^tracker.imm_p_stay: expected a number in \(0, 1\), got 1.0$"):
        number("tracker.imm_p_stay", 1, 0.0, 1.0, lo_open=True, hi_open=True, interval=True, error=ValueError)


def test_checked_is_one_declared_field_of_a_parser():
    """``checked``: a block read key by key (the world, the lever arm, the magnetometer, the virtual receiver,
    the geomagnetic map) checks each value as a ParamSpec of one field, raising the parser's own error."""
    class BlockError(ValueError):
        pass
    with pytest.raises(BlockError, match=r"^world.x.enabled: expected true or false, got 'yes'$"):
        checked("world.x.enabled", "yes", BOOL, error=BlockError)
    with pytest.raises(BlockError, match=r"^map.refine_factor: must be >= 1, got 0$"):
        checked("map.refine_factor", 0, INT, lo=1, error=BlockError)
    with pytest.raises(BlockError, match=r"^lever_arm.axis: expected a list of 3 numbers, got 2.0$"):
        checked("lever_arm.axis", 2.0, FLOATS, length=3, broadcast=False, error=BlockError)
    assert checked("map.alt_m", 26000, FLOAT) == 26000.0

