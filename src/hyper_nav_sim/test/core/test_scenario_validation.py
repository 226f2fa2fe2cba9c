"""Scenario validation (issue #6): typos are refused everywhere with the
nearest known name, ranges are checked, integers where numbers are expected
become floats (ROS double parameters), ``extends:`` resolves next to the
extending file and ``null`` removes an inherited key."""
import copy
import pathlib

import pytest
import yaml

from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, find_scenario, load_scenario, validate
from hyper_nav_workbench.graph import fusion_parameters


@pytest.fixture(scope="module")
def default():
    return load_scenario("default").data


def _refused(data, match):
    with pytest.raises(ScenarioError, match=match):
        validate(data, "x.yaml")


def _set(data, dotted, value):
    d = copy.deepcopy(data)
    cur = d
    parts = dotted.split(".")
    for p in parts[:-1]:
        cur = cur[int(p)] if isinstance(cur, list) else cur[p]
    cur[parts[-1]] = value
    return d


@pytest.mark.parametrize("dotted,expect", [
    ("graph.real_time_facter", r"graph.real_time_facter: unknown field; did you mean 'real_time_factor'\?"),
    ("gnss.rate_hzz", r"gnss.rate_hzz: unknown field; did you mean 'rate_hz'\?"),
    ("magnetoneter", r"x.yaml: magnetoneter: unknown field; did you mean 'magnetometer'\?"),
    ("maneuvers.0.dleta", r"maneuvers\[0\].dleta: unknown field; did you mean 'delta'\?"),
    ("imu.gyro_bias_deg_per_hour", r"imu.gyro_bias_deg_per_hour: unknown field; did you mean 'gyro_bias_deg_per_hr'\?"),
    ("filter.config.reprocess_windw_s", r"filter.config.reprocess_windw_s: unknown field; did you mean "
                                        r"'reprocess_window_s'\?"),
    ("filter.initial_error.pos_enu", r"filter.initial_error.pos_enu: unknown field; did you mean 'pos_enu_m'\?"),
    ("report.skip", r"report.skip: unknown field; did you mean 'skip_s'\?"),
    ("monitor.stream_timeout", r"monitor.stream_timeout: unknown field; did you mean 'stream_timeout_s'\?"),
    ("start.xyz", r"start.xyz: unknown field \(known: alt_m, angle_of_attack_deg"),
])
def test_unknown_keys_refused_with_suggestion(default, dotted, expect):
    _refused(_set(default, dotted, 1), expect)


def test_unknown_keys_in_model_blocks(default):
    seed004 = load_scenario("seed004").data
    _refused(_set(seed004, "gnss.raw.lock.doppler_limit", 1.0),
             r"gnss.raw.lock.doppler_limit: unknown field; did you mean 'doppler_limit_hz'\?")
    _refused(_set(seed004, "gnss.raw.elevation_mask", 5.0),
             r"gnss.raw.elevation_mask: unknown field; did you mean 'elevation_mask_deg'\?")
    _refused(_set(seed004, "flight.start.lat", 1.0), r"flight.start.lat: unknown field; did you mean 'lat_deg'\?")
    _refused(dict(default, barometer={"rate_hz": 10.0, "pressure_noise": 1.0}),
             r"barometer.pressure_noise: unknown field; did you mean 'pressure_noise_pa'\?")
    _refused(dict(default, radar={"sigma_alt": 1.0}), r"radar.sigma_alt: unknown field; did you mean 'sigma_alt_m'\?")


def test_set_overrides_are_checked_with_suggestion(tmp_path):
    sc = load_scenario("default")
    with pytest.raises(ScenarioError, match=r"--set graph.real_time_facter: unknown field 'graph.real_time_facter'; "
                                            r"did you mean 'graph.real_time_factor'\?"):
        apply_overrides(sc, {"graph.real_time_facter": 2.0}, tmp_path)
    with pytest.raises(ScenarioError, match=r"--set grpah.real_time_factor: unknown field 'grpah'; "
                                            r"did you mean 'graph'\?"):
        apply_overrides(sc, {"grpah.real_time_factor": 2.0}, tmp_path)
    assert apply_overrides(sc, {"graph.real_time_factor": 2}, tmp_path)["graph.real_time_factor"] == 2.0


@pytest.mark.parametrize("dotted,value,expect", [
    ("start.lat_deg", 95.0, r"start.lat_deg: must be within \(-90, 90\), got 95.0"),
    ("start.lat_deg", -90.0, r"start.lat_deg: must be within \(-90, 90\)"),
    ("start.lon_deg", 200.0, r"start.lon_deg: must be within \[-180, 180\], got 200.0"),
    ("imu.rate_hz", 0, r"imu.rate_hz: must be > 0, got 0.0"),
    ("gnss.rate_hz", -1.0, r"gnss.rate_hz: must be > 0"),
    ("gnss.pos_sigma_enu_m", [5.0, 0.0, 5.0], r"gnss.pos_sigma_enu_m: a standard deviation must be > 0"),
    ("filter.config.init_vel_sigma_mps", [0.2, 0.2, 0.0], r"filter.config.init_vel_sigma_mps: must be > 0, got 0"),
    ("filter.config.gyro_bias_sigma_deg_per_hr", -0.1, r"filter.config.gyro_bias_sigma_deg_per_hr: must be > 0"),
    ("report.skip_s", -1.0, r"report.skip_s: must be >= 0"),
    ("magnetometer.epoch_decimal_year", 2031.0, r"magnetometer.epoch_decimal_year: 2031.0 is outside every"),
    ("imu.rate_hz", "fifty", r"imu.rate_hz: expected a number, got 'fifty'"),
    ("filter.config.output_rate_hz", "fast", r"filter.config.output_rate_hz: expected a number, got 'fast'"),
    ("graph.qos_depth", 20.5, r"graph.qos_depth: expected an integer, got 20.5"),
])
def test_ranges_and_types(default, dotted, value, expect):
    _refused(_set(default, dotted, value), expect)


def test_integers_become_floats_for_ros_double_parameters(default, tmp_path):
    d = _set(_set(_set(default, "imu.rate_hz", 50), "filter.config.reprocess_window_s", 3),
             "filter.config.init_pos_sigma_m", [5, 5, 10])
    d = _set(d, "start.vel_enu_mps", [0, 1700, 0])
    v = validate(d, "x.yaml")
    assert type(v["imu"]["rate_hz"]) is float and type(v["filter"]["config"]["reprocess_window_s"]) is float
    assert all(type(x) is float for x in v["start"]["vel_enu_mps"] + v["filter"]["config"]["init_pos_sigma_m"])
    path = tmp_path / "ints.yaml"
    path.write_text(yaml.safe_dump(d))
    params = fusion_parameters(load_scenario(str(path)))
    assert type(params["filter.reprocess_window_s"]) is float
    assert all(type(x) is float for x in params["filter.init_pos_sigma_m"])


def test_extends_is_relative_to_the_extending_file(tmp_path, monkeypatch):
    base = yaml.safe_load(find_scenario("default").read_text())
    (tmp_path / "base_dir").mkdir()
    (tmp_path / "base_dir" / "mybase.yaml").write_text(yaml.safe_dump(dict(base, name="mybase", duration_s=42.0)))
    (tmp_path / "base_dir" / "child.yaml").write_text("extends: mybase\nname: child\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "grandchild.yaml").write_text("extends: ../base_dir/child.yaml\nname: grandchild\n"
                                                      "seed: 7\n")
    monkeypatch.chdir(tmp_path / "sub")            # neither file is relative to the working directory
    sc = load_scenario(str(tmp_path / "sub" / "grandchild.yaml"))
    assert (sc.name, sc["duration_s"], sc["seed"]) == ("grandchild", 42.0, 7)
    (tmp_path / "sub" / "bad.yaml").write_text("extends: nowhere\nname: bad\n")
    with pytest.raises(ScenarioError, match=r"bad.yaml: extends: scenario 'nowhere' not found"):
        load_scenario(str(tmp_path / "sub" / "bad.yaml"))


def test_null_removes_inherited_keys_kinematic_becomes_flight(tmp_path):
    """``extends: default`` + ``maneuvers: null`` + ``start: null`` + a flight block
    gives a boost-glide scenario; with the inherited maneuvers kept it is refused."""
    flight = load_scenario("seed004").data["flight"]
    child = {"extends": str(find_scenario("default").resolve()), "name": "default_as_flight",
             "duration_s": 20.0, "maneuvers": None, "start": None, "flight": dict(flight, duration_s=20.0)}
    path = tmp_path / "flight.yaml"
    path.write_text(yaml.safe_dump(child))
    sc = load_scenario(str(path))
    assert "maneuvers" not in sc.data and "start" not in sc.data
    tr = sc.trajectory().truth([0.0, 10.0])
    assert tr.alt_m[1] > tr.alt_m[0] + 100.0               # the seed 004 boost climbs
    del child["maneuvers"]
    path.write_text(yaml.safe_dump(child))
    with pytest.raises(ScenarioError, match=r"give either 'flight' \(dynamic\) or 'maneuvers' \(kinematic\), not both "
                                            r"\(a file that extends a kinematic scenario removes them with "
                                            r"'maneuvers: null'\)"):
        load_scenario(str(path))
    child["maneuvers"], child["start"] = None, {"lat_deg": 30.0}
    path.write_text(yaml.safe_dump(child))
    with pytest.raises(ScenarioError, match=r"start: not used with a 'flight:' block"):
        load_scenario(str(path))


def test_set_null_removes_a_field(tmp_path):
    sc = apply_overrides(load_scenario("default"), {"report.max_pos_rms_m": None}, tmp_path)
    assert sc["report.max_pos_rms_m"] is None                # removed: back to its default (no limit)


def test_every_shipped_scenario_still_loads():
    for path in sorted(find_scenario("default").parent.glob("*.yaml")):
        load_scenario(str(path))


def test_a_load_sensor_rate_that_is_not_a_multiple_of_the_imu_rate_is_refused_at_load(tmp_path):
    """The structure-load triad samples each IMU interval a whole number of
    times: 400 Hz over a 500 Hz IMU is refused when the scenario loads,
    naming the field (it used to fail only when the IMU was simulated);
    400 Hz over 200 Hz loads."""
    sc = load_scenario("seed000_elastic")
    with pytest.raises(ScenarioError, match=r"lever_arm.load_sensor_rate_hz: must be a whole multiple of "
                                            r"imu.rate_hz \(500 Hz\), got 400"):
        apply_overrides(sc, {"imu.rate_hz": 500.0}, tmp_path)
    assert apply_overrides(sc, {"imu.rate_hz": 200.0}, tmp_path)["imu.rate_hz"] == 200.0
    assert apply_overrides(sc, {"imu.rate_hz": 500.0, "lever_arm.enabled": False}, tmp_path)["imu.rate_hz"] == 500.0


def test_every_scenario_field_is_declared_once_with_a_description():
    """The scenario's own fields are ParamSpecs (the one validation idiom, issue 34)."""
    from hyper_nav_sim.core.scenario import SCENARIO_PARAMS
    names = [s.name for s in SCENARIO_PARAMS]
    assert len(names) == len(set(names))
    assert all(s.description for s in SCENARIO_PARAMS)
    by = {s.name: s for s in SCENARIO_PARAMS}
    assert by["seed"].required and not by["graph.real_time_factor"].required
    assert by["gnss.pos_sigma_enu_m"].quantity == "a standard deviation"
