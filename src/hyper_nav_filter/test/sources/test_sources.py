"""Declared fusion sources (hyper_nav_filter.sources): the table is
validated with errors that name the field, converters turn messages into the
core's measurements (duck-typed messages here: the same code takes rclpy and
rosbags messages), and the flat ROS-parameter form round-trips."""
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hyper_nav_filter.core.atmosphere import pressure_Pa, pressure_height_gradient_pa_per_m
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.params import ConfigError
from hyper_nav_filter.sources import DEFAULT_TABLE, make_sources, parse_sources, spec_to_params, table_from_params
from hyper_nav_filter.sources.router import SourceRouter

IMU = {"imu": {"type": "imu", "topic": "imu/data_raw"}}


def header(t):
    return NS(stamp=NS(sec=int(t), nanosec=int(round((t - int(t)) * 1e9))), frame_id="x")


def engine(cfg=None):
    return FusionEngine(cfg or FilterConfig(), NavState(0.0, 0.5, 2.0, 25000.0, np.zeros(3), np.eye(3)))


@pytest.mark.parametrize("table, match", [
    ({**IMU, "b": {"type": "barometer", "topic": "baro/pressure"}}, r"filter.sources.b.type: unknown source type "
                                                                    r"'barometer' \(did you mean 'baro_height'\?\)"),
    ({**IMU, "b": {"type": "baro_height"}}, r"filter.sources.b.topic: missing"),
    ({**IMU, "b": {"type": "baro_height", "topic": "p", "msg": "sensor_msgs/msg/NavSatFix"}},
     r"filter.sources.b.msg: source type 'baro_height' takes \['sensor_msgs/msg/FluidPressure'\]"),
    ({**IMU, "b": {"type": "baro_height", "topic": "p", "max_alt": 3.0}},
     r"filter.sources.b.max_alt: unknown field \(did you mean 'max_alt_m'\?\)"),
    ({**IMU, "b": {"type": "baro_height", "topic": "p", "max_alt_m": -3.0}}, r"filter.sources.b.max_alt_m: must be > 0"),
    ({**IMU, "b": {"type": "baro_height", "topic": "p", "qos": "fast"}}, r"filter.sources.b.qos: expected one of"),
    ({"g": {"type": "gnss_fix", "topic": "gnss/fix"}}, r"exactly one source of type 'imu'"),
    ({**IMU, "imu2": {"type": "imu", "topic": "imu2"}}, r"exactly one source of type 'imu'"),
    ([1, 2], r"filter.sources: expected a mapping"),
])
def test_bad_tables_name_the_field(table, match):
    with pytest.raises(ConfigError, match=match):
        parse_sources(table)


def test_flat_parameters_round_trip():
    table = {**IMU, "baro": {"type": "baro_height", "topic": "baro/pressure", "qos": "sensor_data",
                             "max_alt_m": 40000.0}}
    specs = parse_sources(table)
    params = spec_to_params(specs)
    assert params["sources"] == ["imu", "baro"] and params["sources.baro.qos"] == "sensor_data"
    back = parse_sources(table_from_params(lambda k, d: params.get(k, d)))
    assert back == specs


def test_baro_height_is_the_us76_pressure_altitude_with_its_variance():
    eng = engine()
    src = make_sources(parse_sources({**IMU, "b": {"type": "baro_height", "topic": "p"}}), eng.cfg)[1]
    p = float(pressure_Pa(25000.0))
    assert src.on_message("main", NS(header=header(1.0), fluid_pressure=p, variance=4.0), eng) is None
    (meas,) = [e[-1] for e in eng._events]
    assert meas.alt_m == pytest.approx(25000.0, abs=1e-6)
    assert np.sqrt(meas.var_m2) == pytest.approx(2.0 / abs(pressure_height_gradient_pa_per_m(25000.0)), rel=1e-9)
    assert src.on_message("main", NS(header=header(2.0), fluid_pressure=-1.0, variance=4.0), eng) == "bad_pressure"
    assert src.on_message("main", NS(header=header(2.0), fluid_pressure=p, variance=0.0), eng) == "no_variance"
    assert src.on_message("main", NS(header=header(2.0), fluid_pressure=float(pressure_Pa(70e3)), variance=1.0),
                          eng) == "above_max_alt"
    d = src.diagnostics()
    assert d["received p"] == 4 and d["processed p"] == 1 and d["rejected p"] == 3


def navsatfix(t, lat_deg, lon_deg, cov, status=0, cov_type=3):
    return NS(header=header(t), status=NS(status=status, service=1), latitude=lat_deg, longitude=lon_deg,
              altitude=25000.0, position_covariance=list(np.asarray(cov, float).ravel()),
              position_covariance_type=cov_type)


def test_horizontal_fix_takes_the_east_north_covariance():
    eng = engine()
    src = make_sources(parse_sources({**IMU, "m": {"type": "horizontal_fix", "topic": "geomag/fix"}}), eng.cfg)[1]
    cov = np.diag([100.0, 400.0, 1e6])
    cov[0, 1] = cov[1, 0] = 50.0
    assert src.on_message("main", navsatfix(1.0, 28.6, 114.6, cov), eng) is None
    meas = eng._events[-1][-1]
    np.testing.assert_allclose(meas.cov_en_m2, [[100.0, 50.0], [50.0, 400.0]])
    assert meas.lat_rad == pytest.approx(np.deg2rad(28.6)) and meas.kind == "horizontal_fix"
    assert src.on_message("main", navsatfix(2.0, 28.6, 114.6, cov, cov_type=0), eng) == "no_covariance"
    assert src.on_message("main", navsatfix(2.0, 28.6, 114.6, cov, status=-1), eng) == "no_fix"
    assert src.on_message("main", navsatfix(2.0, 28.6, 114.6, -cov), eng) == "bad_covariance"


def test_model_update_message_reaches_the_engine_and_a_bad_one_is_counted():
    cfg = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "gm", "ba", "lev"))
    eng = engine(cfg)
    src = make_sources(parse_sources({**IMU, "u": {"type": "model_update", "topic": "nav/model_update"}}), cfg)[1]
    msg = NS(header=header(1.0), model="lever_arm", names=["lever_arm_natural_freq_radps"] * 3,
             values=[20.0, 55.0, 113.0], sigmas=[], origin="test", note="")
    assert src.on_message("main", msg, eng) is None
    assert eng._events[-1][-1].fields == {"lever_arm_natural_freq_radps": (20.0, 55.0, 113.0)}
    bad = NS(**{**vars(msg), "names": ["gyro_bias_tau_s"], "values": [1.0]})
    assert src.on_message("main", bad, eng).startswith("invalid: model update: 'gyro_bias_tau_s' is not an updatable")


def test_router_feeds_imu_and_aiding_and_ignores_other_topics():
    eng = engine()
    router = SourceRouter(eng, DEFAULT_TABLE)
    assert set(router.topics()) == {"imu/data_raw", "gnss/fix", "gnss/vel"}
    imu = NS(header=header(0.02), angular_velocity=NS(x=0.0, y=0.0, z=0.0),
             linear_acceleration=NS(x=0.0, y=0.0, z=9.78))
    reason, sols = router.handle_topic("/imu/data_raw", imu)
    assert reason is None and eng.counters["imu_accepted"] == 1
    assert router.handle_topic("/some/other", imu) == (None, [])
    assert router.diagnostics()["received imu/data_raw"] == 1
