"""Scenario files: one YAML drives the simulation and every node's parameters.

``load_scenario(name_or_path)`` reads a file (a bare name is looked up in the
installed ``share/hyper_nav_sim/scenarios`` or the source tree), checks every
field against its declarations below (``SCENARIO_PARAMS``, one ``ParamSpec``
each) and raises ``ScenarioError`` naming the bad
field (``imu.rate_hz: expected a number, got 'fifty'``).

Validation rules (one place, applied to files and to ``--set`` overrides):

* every key of every block is known; an unknown one is refused with the
  nearest known name (``graph.real_time_facter: unknown field; did you mean
  'real_time_factor'?``);
* types: numbers are finite; an integer where a number (float) is expected
  is coerced to float at load, so ROS parameters declared as double accept
  it (``rate_hz: 50``); anything else is refused naming the field;
* ranges: ``start.lat_deg`` in (-90, 90), ``start.lon_deg`` in [-180, 180],
  rates, periods and timeouts > 0, every ``*sigma*`` field > 0, the
  magnetometer date inside a World Magnetic Model (``wmm.py``);
* ``extends: <name or path>`` starts from another file, resolved relative
  to the extending file first (then the installed scenarios); mappings merge
  key by key, lists and values replace, and ``key: null`` removes an
  inherited key (``maneuvers: null`` turns a kinematic scenario into a
  ``flight:`` one).
"""
from __future__ import annotations

import copy
import pathlib
from dataclasses import dataclass, fields

import numpy as np
import yaml

from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.sources import DEFAULT_TABLE, make_sources, parse_sources

from hyper_nav_filter import aiding_nodes
from hyper_nav_filter.core.params import (
    BOOL, FLOAT, FLOATS, INT, REQUIRED, STR, ParamSpec, nonneg, number, positive, suggestion, unknown_field,
)
from .. import sensors
from .trajectory import MANEUVER_KINDS, Maneuver, Start, Trajectory


class ScenarioError(ValueError):
    """Malformed scenario; the message names the field."""


def _unit_quaternion(q) -> str | None:
    norm = sum(v * v for v in q) ** 0.5
    if abs(norm - 1.0) > 1e-6:
        return f"must be a unit quaternion (x, y, z, w), got {list(q)!r} (norm {norm:.6g})"
    return None


def _f(name, default, description, **kw) -> ParamSpec:
    return ParamSpec(name, FLOAT, default, description, **kw)


def _v(name, n, default, description, **kw) -> ParamSpec:
    return ParamSpec(name, FLOATS, REQUIRED if default is REQUIRED else tuple(default), description, length=n,
                     broadcast=False, **kw)


def _sigma(name, description) -> ParamSpec:
    return _v(name, 3, REQUIRED, description, lo=0.0, lo_open=True, quantity="a standard deviation")


# The scenario's own fields, declared once as every other parameter of the project is
# (hyper_nav_filter.core.params.ParamSpec: type, default or REQUIRED, range, description). The sensor
# and aiding nodes' blocks are declared by their descriptors, the model blocks by their parsers.
SCENARIO_PARAMS = (
    ParamSpec("name", STR, REQUIRED, "the scenario's name (bags, reports)"),
    ParamSpec("description", STR, "", "one line for people"),
    ParamSpec("seed", INT, REQUIRED, "seed of every random stream (per sensor: Scenario.rng)"),
    positive("duration_s", FLOAT, REQUIRED, "flight time simulated [s]"),
    _f("start.lat_deg", REQUIRED, "geodetic latitude at t = 0 [deg]",
       rule=lambda v: None if -90.0 < v < 90.0 else f"must be within (-90, 90), got {v!r}"),
    _f("start.lon_deg", REQUIRED, "longitude at t = 0 [deg]",
       rule=lambda v: None if -180.0 <= v <= 180.0 else f"must be within [-180, 180], got {v!r}"),
    _f("start.alt_m", REQUIRED, "ellipsoidal height at t = 0 [m]"),
    _v("start.vel_enu_mps", 3, REQUIRED, "velocity at t = 0, ENU [m/s]"),
    _f("start.angle_of_attack_deg", 0.0, "angle of attack of the kinematic flight [deg]"),
    _f("start.roll_deg", 0.0, "roll at t = 0 [deg]"),
    positive("imu.rate_hz", FLOAT, REQUIRED, "IMU sample rate [Hz]"),
    _v("imu.gyro_bias_deg_per_hr", 3, REQUIRED, "gyro bias per axis [deg/h]"),
    nonneg("imu.gyro_arw_deg_per_sqrt_hr", FLOAT, REQUIRED, "gyro angle random walk [deg/sqrt(h)]"),
    _v("imu.accel_bias_ug", 3, REQUIRED, "accelerometer bias per axis [ug]"),
    nonneg("imu.accel_vrw_ug_per_sqrt_hz", FLOAT, REQUIRED, "accelerometer velocity random walk [ug/sqrt(Hz)]"),
    # the IMU's own axes in base_link (FLU) as a unit quaternion (x, y, z, w): the mounting that
    # import_data applied at the edge (it prints this); its frame on /tf_static only, the filter
    # works in the body frame
    _v("imu.mounting_b_xyzw", 4, (0.0, 0.0, 0.0, 1.0), "IMU axes in base_link, quaternion (x, y, z, w)",
       rule=_unit_quaternion),
    positive("gnss.rate_hz", FLOAT, REQUIRED, "GNSS fix rate [Hz]"),
    _sigma("gnss.pos_sigma_enu_m", "fix position noise, ENU [m]"),
    _sigma("gnss.vel_sigma_enu_mps", "fix velocity noise, ENU [m/s]"),
    nonneg("gnss.latency_s", FLOAT, 0.0, "fix latency: stamp to release [s]"),
    _v("gnss.antenna_lever_arm_b_m", 3, (0.0, 0.0, 0.0), "antenna in base_link [m]"),
    positive("magnetometer.rate_hz", FLOAT, REQUIRED, "magnetometer sample rate [Hz]"),
    nonneg("magnetometer.noise_nT", FLOAT, REQUIRED, "magnetometer white noise per axis [nT]"),
    _f("magnetometer.epoch_decimal_year", REQUIRED, "date of the flight for the World Magnetic Model [year]"),
    _v("magnetometer.lever_arm_b_m", 3, (0.0, 0.0, 0.0), "magnetometer in base_link [m] (/tf_static only)"),
    positive("graph.real_time_factor", FLOAT, 3.0, "flight seconds per wall second"),
    positive("graph.clock_rate_hz", FLOAT, 50.0, "/clock messages per flight second"),
    # at most this many /clock messages per wall second: at high real-time factors the
    # sim-time step grows to real_time_factor / clock_max_wall_hz (every node takes
    # each /clock in Python; 1000 per second into 7 nodes is a core of 2)
    positive("graph.clock_max_wall_hz", FLOAT, 100.0, "at most this many /clock messages per wall second"),
    # the clock waits for the nodes' allowances (hyper_nav_filter.clock_gate): a loaded machine slows the
    # flight down instead of losing or delaying data; false = paced by the wall clock alone
    ParamSpec("graph.clock_gate", BOOL, True, "the clock waits for the nodes' allowances"),
    positive("graph.truth_rate_hz", FLOAT, 50.0, "truth messages per flight second"),
    ParamSpec("graph.qos_depth", INT, 2000, "history depth of every topic", lo=0, lo_open=True),
    # wall-clock period of every node's /diagnostics status (its heartbeat)
    positive("graph.diagnostics_period_s", FLOAT, 1.0, "wall period of every node's /diagnostics status [s]"),
    # liveness monitor (nodes/monitor.py): a node silent for heartbeat_timeout_s
    # (wall) is reported dead, one never heard of within startup_timeout_s (wall)
    # as not started; a stream that does not advance for stream_timeout_s of sim
    # time (at least 3 periods of its nominal rate) is reported missing
    positive("monitor.heartbeat_timeout_s", FLOAT, 5.0, "a node silent this long (wall) is reported dead [s]"),
    positive("monitor.startup_timeout_s", FLOAT, 60.0,
             "a node not heard of this long (wall) is reported not started [s]"),
    positive("monitor.stream_timeout_s", FLOAT, 3.0,
             "a stream that does not advance this long (flight) is missing [s]"),
    _v("filter.initial_error.pos_enu_m", 3, REQUIRED, "error of the filter's initial position, ENU [m]"),
    _v("filter.initial_error.vel_enu_mps", 3, REQUIRED, "error of the filter's initial velocity, ENU [m/s]"),
    _v("filter.initial_error.att_enu_arcmin", 3, REQUIRED, "error of the filter's initial attitude [arcmin]"),
    nonneg("report.skip_s", FLOAT, 30.0, "flight time left out of the report's RMS [s]"),
    positive("report.max_pos_rms_m", FLOAT, None, "verdict limit on the position RMS [m] (none: no limit)"),
    positive("report.max_vel_rms_mps", FLOAT, None, "verdict limit on the velocity RMS [m/s] (none: no limit)"),
    positive("report.max_att_rms_deg", FLOAT, None, "verdict limit on the attitude RMS [deg] (none: no limit)"),
    ParamSpec("report.reference_source", STR, "", "where the reference figures come from"),
    _f("report.reference_pos_m", None, "reference position RMS [m] (printed beside ours)"),
    _f("report.reference_vel_mps", None, "reference velocity RMS [m/s]"),
    _f("report.reference_att_deg", None, "reference attitude RMS [deg]"),
)
KINEMATIC_ONLY = ("start.", )          # fields not required when a `flight:` block is given
# (and the sensor and aiding nodes' blocks: hyper_nav_sim.sensors, hyper_nav_filter.aiding_nodes,
# read from the installed descriptors)
OPTIONAL_BLOCKS = ("flight", "trajectory_file", "lever_arm", "maneuvers", "tracker", "tracker_augmented",
                   "world", "guidance")
MANEUVER_KEYS = ("type", "t_start_s", "duration_s", "delta")
# blocks whose nested content their own parser checks key by key (boost_glide_config,
# hyper_nav_filter.sources) or whose keys are data (gnss.raw.lock.sat_outages: satellite ids);
# the aiding nodes' blocks too (their descriptors' validators, see opaque_blocks)
OPAQUE_BLOCKS = {"flight", "trajectory_file", "gnss.raw.lock.sat_outages", "filter.sources",   # filter.sources: sources.parse_sources
                 "world",                          # core.world.WorldConfig
                 "guidance"}                       # core.guidance_config.GuidanceConfig


def opaque_blocks() -> set[str]:
    """``OPAQUE_BLOCKS`` and the installed aiding nodes' blocks."""
    return OPAQUE_BLOCKS | set(aiding_nodes.by_block())


def known_fields() -> dict[str, frozenset]:
    """Allowed keys of every block, by dotted block path ('' = top level):
    the SCENARIO_PARAMS above plus the fields each model block's parser takes."""
    from .gnss import receiver
    from .lever_arm import _DEFAULTS as LEVER_ARM_FIELDS
    from hyper_nav_filter.core.initial_state import INIT_PARAMS
    tree: dict[str, set] = {}
    for spec in SCENARIO_PARAMS:
        parts = spec.name.split(".")
        for i in range(len(parts)):
            tree.setdefault(".".join(parts[:i]), set()).add(parts[i])
    tree[""] |= set(OPTIONAL_BLOCKS) | set(aiding_nodes.by_block()) | set(sensors.blocks())
    for block, nodes in sensors.blocks().items():      # each sensor node's block: the keys its descriptor allows
        for node in nodes:
            if node.fields is not None:
                tree.setdefault(block, set()).update(node.fields())
    tree["gnss.raw"] = set(receiver._TOP_FIELDS)
    tree["gnss.raw.clock"] = set(receiver._CLOCK_FIELDS)
    tree["gnss.raw.lock"] = set(receiver._LOCK_FIELDS)
    tree["filter"] |= {"config", "sources", "initial_state"}
    tree["filter.initial_state"] = {p.name for p in INIT_PARAMS}              # hyper_nav_filter.core.initial_state
    tree["filter.config"] = {f.name for f in fields(FilterConfig) if f.init}   # the filter's declarations
    tree["lever_arm"] = set(LEVER_ARM_FIELDS)
    return {k: frozenset(v) for k, v in tree.items()}


def check_known_keys(data: dict, path: str = "", tree: dict | None = None) -> None:
    """ScenarioError (without the source) for the first unknown key anywhere in
    ``data``, with the nearest known name; maneuver entries too."""
    tree = known_fields() if tree is None else tree
    opaque = opaque_blocks()
    allowed = tree.get(path)
    for key, value in data.items():
        child = f"{path}.{key}" if path else str(key)
        if allowed is not None and key not in allowed:
            raise ScenarioError(unknown_field(f"{path}." if path else "", key, allowed))
        if child in opaque:
            continue
        if isinstance(value, dict) and child in tree:
            check_known_keys(value, child, tree)
        if child == "maneuvers" and isinstance(value, list):
            for i, m in enumerate(value):
                if isinstance(m, dict):
                    for k in m:
                        if k not in MANEUVER_KEYS:
                            raise ScenarioError(unknown_field(f"maneuvers[{i}].", k, MANEUVER_KEYS))


def check_override_key(dotted: str, tree: dict | None = None) -> None:
    """ScenarioError if a ``--set`` field names no known field (with a suggestion)."""
    tree = known_fields() if tree is None else tree
    opaque = opaque_blocks()
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        parent = ".".join(parts[:i])
        if parent in opaque or parent not in tree:
            return
        if part not in tree[parent]:
            hint = suggestion(part, tree[parent])
            what = f"--set {dotted}: unknown field '{'.'.join(parts[:i + 1])}'"
            if hint:
                raise ScenarioError(f"{what}; did you mean '{'.'.join(parts[:i] + [hint])}'?")
            raise ScenarioError(f"{what} (known in {parent or 'the top level'}: {', '.join(sorted(tree[parent]))})")


def scenario_dirs() -> list[pathlib.Path]:
    dirs = []
    try:
        from ament_index_python.packages import get_package_share_directory
        dirs.append(pathlib.Path(get_package_share_directory("hyper_nav_sim")) / "scenarios")
    except Exception:  # not installed: fall back to the source tree
        pass
    dirs.append(pathlib.Path(__file__).resolve().parents[2] / "scenarios")
    return dirs


def find_scenario(name_or_path: str) -> pathlib.Path:
    p = pathlib.Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.exists():
        return p
    for d in scenario_dirs():
        cand = d / f"{name_or_path}.yaml"
        if cand.exists():
            return cand
    raise ScenarioError(f"scenario '{name_or_path}' not found (looked in {[str(d) for d in scenario_dirs()]})")


def _get(d: dict, dotted: str):
    cur = d
    for part in dotted.split("."):
        if not isinstance(cur, dict) or part not in cur:
            raise KeyError(dotted)
        cur = cur[part]
    return cur


def _set(d: dict, dotted: str, value):
    parts = dotted.split(".")
    for part in parts[:-1]:
        d = d.setdefault(part, {})
    d[parts[-1]] = value


@dataclass
class Scenario:
    path: pathlib.Path
    data: dict
    _traj: object = None

    def __getitem__(self, dotted: str):
        return _get(self.data, dotted)

    @property
    def name(self) -> str:
        return self.data["name"]

    def start(self) -> Start:
        v = np.asarray(self["start.vel_enu_mps"], float)
        speed = float(np.linalg.norm(v))
        return Start(lat_rad=np.deg2rad(self["start.lat_deg"]), lon_rad=np.deg2rad(self["start.lon_deg"]),
                     alt_m=float(self["start.alt_m"]), speed_mps=speed,
                     gamma_rad=float(np.arcsin(v[2] / speed)), psi_rad=float(np.arctan2(v[0], v[1])),
                     alpha_rad=np.deg2rad(self["start.angle_of_attack_deg"]),
                     roll_rad=np.deg2rad(self["start.roll_deg"]))

    def maneuvers(self) -> list[Maneuver]:
        out = []
        for m in self.data.get("maneuvers", []):
            delta = m["delta"] if m["type"] == "accelerate" else np.deg2rad(m["delta"])
            out.append(Maneuver(m["type"], float(m["t_start_s"]), float(m["duration_s"]), float(delta)))
        return out

    def trajectory(self):
        """The truth: boost-glide dynamics when a ``flight:`` block is given
        (seed 002 eqs. 1-10, seed 004 eq. 12), else the kinematic maneuver
        profiles. Built once per Scenario object (it is deterministic)."""
        if self._traj is None:
            if "trajectory_file" in self.data:       # a user's trajectory (core.trajectory_file)
                from .trajectory_file import FileTrajectory
                self._traj = FileTrajectory.from_config(self.data["trajectory_file"], base_dir=self.path.parent)
                if self._traj.duration_s < self["duration_s"] - 1e-6:
                    raise ScenarioError(f"{self.path}: duration_s: the trajectory file ends at "
                                        f"{self._traj.duration_s:.1f} s, before duration_s = {self['duration_s']}")
            elif "flight" in self.data:
                from .boost_glide import DynamicTrajectory
                flight = dict(self.data["flight"])
                flight.setdefault("duration_s", self["duration_s"])
                self._traj = DynamicTrajectory.from_config(flight)
                if self._traj.duration_s < self["duration_s"] - 1e-6:
                    raise ScenarioError(f"{self.path}: duration_s: the flight ends at {self._traj.duration_s:.1f} s "
                                        f"(end_speed_mps/end_alt_m reached), before duration_s = {self['duration_s']}")
            else:
                self._traj = Trajectory(self.start(), self.maneuvers(), self["duration_s"])
        return self._traj

    def filter_initial_values(self) -> dict:
        """The filter's initial state as the fusion node's ``init.*``
        parameter values (degrees, quaternion, declared units;
        ``hyper_nav_filter.core.initial_state.state_values``): truth at t = 0
        plus the scenario's initial errors (what an alignment would hand
        over), with the fields of an optional ``filter.initial_state`` block
        over it (any of position, velocity, attitude, initial bias and
        scale-factor values)."""
        from hyper_nav_gnss import earth
        from hyper_nav_filter.core.attitude import rotvec_to_C
        from hyper_nav_filter.core.initial_state import state_values
        from hyper_nav_filter.core.nav_state import NavState
        tr = self.trajectory().truth([0.0])
        d_pos = np.asarray(self["filter.initial_error.pos_enu_m"], float)
        r_m, r_n = earth.radii(tr.lat_rad[0])
        lat = tr.lat_rad[0] + d_pos[1] / (r_m + tr.alt_m[0])
        lon = earth.wrap_lon_rad(float(tr.lon_rad[0] + d_pos[0] / ((r_n + tr.alt_m[0]) * np.cos(tr.lat_rad[0]))))
        phi = np.deg2rad(np.asarray(self["filter.initial_error.att_enu_arcmin"], float) / 60.0)
        C = rotvec_to_C(-phi) @ tr.C_b_n[0]          # C_est = (I - [phi x]) C_true
        nav = NavState(0.0, lat, lon, tr.alt_m[0] + d_pos[2],
                       tr.vel_enu_mps[0] + np.asarray(self["filter.initial_error.vel_enu_mps"], float), C)
        return state_values(initial_state_block(self.data, nav))

    def filter_initial_state(self):
        """The state the fusion node starts from: ``filter_initial_values``
        as the node turns its parameters into a NavState, so an offline run
        starts from the live node's state to the bit (the degree/radian and
        matrix/quaternion round trip moves the attitude by ~1e-16, which the
        covariance's cross terms amplify to ~1e-9 relative)."""
        from hyper_nav_filter.core.initial_state import initial_state
        return initial_state(self.filter_initial_values())

    def filter_config(self) -> FilterConfig:
        """``filter.config``; in the perfect-model world (``world.model:
        perfect``: the truth is the receiver's broadcast models, the only
        pseudorange error the receiver's white noise) ``range_errors``
        defaults to ``white``, everywhere else to the filter's own default
        (``states``: the range errors the corrections leave are correlated)."""
        cfg = dict(self.data.get("filter", {}).get("config", {}) or {})
        if not self.world_config().realistic:           # the world has no correlated range errors
            cfg.setdefault("range_errors", "white")
        return FilterConfig.from_dict(cfg)

    def filter_sources(self) -> dict:
        """The fusion node's declared sources (``filter.sources``; default: IMU
        and loosely coupled GNSS, ``hyper_nav_filter.sources.DEFAULT_TABLE``).
        A ``gnss_raw`` source that does not set its receiver models takes
        those of the ``gnss.raw`` block, with the Klobuchar set its satellites
        broadcast (the GnssEphemeris message does not carry it)."""
        return filter_sources(self.data)

    def filter_source_specs(self):
        """The validated table (``hyper_nav_filter.sources.SourceSpec`` list)."""
        return parse_sources(self.filter_sources())

    def world_config(self):
        """The ``world:`` block (:class:`.world.WorldConfig`; absent = realistic)."""
        from .world import WorldConfig
        return WorldConfig.from_config(self.data.get("world"))

    def world_seed(self) -> int:
        """Seed of this scenario's world realisation (ionosphere, meteorology,
        orbit/clock errors): a function of ``seed`` only."""
        return int(self.rng("world").integers(2 ** 31))

    def rng(self, stream: str) -> np.random.Generator:
        """Independent, reproducible random stream per sensor."""
        return np.random.default_rng([self["seed"], sum(stream.encode())])


def _check_filter_config(cfg: dict) -> dict:
    """``filter.config`` checked and coerced by the filter's own parameter
    declarations (``hyper_nav_filter.core.params``: types, ranges, every
    sigma > 0, an integer where a float is declared becomes a float); lists
    stay lists so the file can be written back."""
    from hyper_nav_filter.core.config import ALL_PARAMS
    from hyper_nav_filter.core.params import check_all
    try:
        coerced = check_all(ALL_PARAMS, cfg, "filter.config.")
    except ConfigError as exc:
        raise ScenarioError(str(exc)) from None
    return {k: list(v) if isinstance(v, tuple) else v for k, v in coerced.items() if k in cfg}


def validate(data, source: str = "<dict>") -> dict:
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: top level must be a mapping")
    data = _drop_nulls(copy.deepcopy(data))
    try:
        from .sensor_catalogue import CATALOGUE, apply_grade     # imu: {grade: tactical, ...overrides}, gnss: ...
        for block in CATALOGUE:
            if isinstance(data.get(block), dict):
                data[block] = apply_grade(data[block], block)
    except ValueError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    try:
        check_known_keys(data)
    except ScenarioError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    dynamic = "flight" in data or "trajectory_file" in data      # the truth's own start
    if dynamic and "start" in data:
        raise ScenarioError(f"{source}: start: not used with a 'flight:' block (the flight starts at "
                            f"flight.start); remove it ('start: null' in a file that extends a kinematic scenario)")
    for spec in SCENARIO_PARAMS:
        if dynamic and spec.name.startswith(KINEMATIC_ONLY):
            continue
        try:
            value = _get(data, spec.name)
        except KeyError:
            if spec.required:
                raise ScenarioError(f"{source}: missing required field '{spec.name}'") from None
            _set(data, spec.name, list(spec.default) if isinstance(spec.default, tuple) else spec.default)
            continue
        try:
            value = spec.check(value)
        except ConfigError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
        # lists: the file can be written back
        _set(data, spec.name, list(value) if isinstance(value, tuple) else value)
    try:
        from hyper_nav_filter.core.wmm import WmmDateError, release_for
        release_for(data["magnetometer"]["epoch_decimal_year"])
    except WmmDateError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    for i, m in enumerate(data.get("maneuvers", []) or []):
        where = f"maneuvers[{i}]"
        if not isinstance(m, dict):
            raise ScenarioError(f"{source}: {where}: expected a mapping")
        if m.get("type") not in MANEUVER_KINDS:
            raise ScenarioError(f"{source}: {where}.type: expected one of {sorted(MANEUVER_KINDS)}, got {m.get('type')!r}")
        for key in ("t_start_s", "duration_s", "delta"):
            if key not in m:
                raise ScenarioError(f"{source}: missing required field '{where}.{key}'")
            m[key] = number(f"{source}: {where}.{key}", m[key], lo=0.0 if key == "duration_s" else None,
                            lo_open=True, error=ScenarioError)
    try:
        if "config" in data["filter"]:
            if not isinstance(data["filter"]["config"], dict):
                raise ScenarioError(f"filter.config: expected a mapping, got {data['filter']['config']!r}")
            data["filter"]["config"] = _check_filter_config(data["filter"]["config"])
    except ScenarioError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    try:
        cfg = FilterConfig.from_dict((data.get("filter") or {}).get("config", {}) or {})
    except (ConfigError, TypeError) as exc:
        raise ScenarioError(f"{source}: filter.config: {exc}") from None
    try:
        initial_state_block(data, None, check_only=True)
    except ConfigError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    try:
        make_sources(parse_sources(filter_sources(data)), cfg)
    except ConfigError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    _validate_models(data, source)
    return data


def initial_state_block(data: dict, base, check_only: bool = False):
    """``base`` with the fields of ``filter.initial_state`` over it (or, with
    check_only, just validate the block; errors name the field)."""
    from hyper_nav_filter.core.initial_state import INIT_PARAMS, from_block
    from hyper_nav_filter.core.params import check_all
    block = (data.get("filter") or {}).get("initial_state")
    if block is not None and not isinstance(block, dict):
        raise ConfigError(f"filter.initial_state: expected a mapping, got {block!r}")
    if check_only:
        check_all(INIT_PARAMS, block or {}, "filter.initial_state.")
        return None
    return base if not block else from_block(block, base, "filter.initial_state.")


def filter_sources(data: dict) -> dict:
    """See :meth:`Scenario.filter_sources`."""
    table = copy.deepcopy((data.get("filter") or {}).get("sources") or DEFAULT_TABLE)
    raw = (data.get("gnss") or {}).get("raw")
    if raw is not None and isinstance(table, dict):
        from .gnss.receiver import GnssReceiverConfig
        rx = GnssReceiverConfig.from_dict(raw)
        for entry in table.values():
            if isinstance(entry, dict) and entry.get("type") == "gnss_raw":
                entry.setdefault("ionosphere", rx.ionosphere)
                entry.setdefault("klobuchar_alpha", [float(x) for x in rx.klobuchar_alpha])
                entry.setdefault("klobuchar_beta", [float(x) for x in rx.klobuchar_beta])
                entry.setdefault("troposphere", rx.troposphere)
    return table


def _validate_models(data: dict, source: str) -> None:
    """The optional model blocks validate themselves; errors name the field."""
    from .boost_glide_config import parse_flight
    from .guidance_config import GuidanceConfig
    from .lever_arm import LeverArmConfig
    from .world import WorldConfig
    from .trajectory_file import check_config as check_trajectory_file
    checks = [("world", lambda d: WorldConfig.from_config(d)),
              ("trajectory_file", lambda d: check_trajectory_file(d)),
              ("flight", lambda d: parse_flight(d)),
              ("guidance", lambda d: GuidanceConfig.from_config(d)),
              ("lever_arm", lambda d: LeverArmConfig.from_config(d))]
    # each sensor node's block, by its descriptor's validator (hyper_nav_sim.sensors)
    checks += [(node.block, node.validate) for node in sensors.descriptors().values() if node.validate is not None]
    for key, check in checks:
        if key in data:
            try:
                check(data[key])
            except ValueError as exc:
                msg = str(exc)
                raise ScenarioError(f"{source}: {msg if msg.startswith(key) else key + '.' + msg}") from None
    _check_load_sensor_rate(data, source)
    for block, node in aiding_nodes.by_block().items():
        if block not in data:
            continue
        try:        # the node's package validates its own block (errors name the field)
            node.validate(data[block])
        except ValueError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
        if node.validate_scenario is not None:
            try:    # the block against the rest of the scenario (e.g. a map's epoch against the flight's date)
                node.validate_scenario(data)
            except ValueError as exc:
                raise ScenarioError(f"{source}: {exc}") from None
    if "tracker" in data:
        from hyper_nav_filter.core.target_tracking.config import TrackerConfig
        try:
            TrackerConfig.from_dict(data["tracker"])
        except ValueError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
        if "radar" not in data:
            raise ScenarioError(f"{source}: tracker: needs a radar block (the tracker's input)")
    raw = (data.get("gnss") or {}).get("raw")
    if raw is not None:
        from .gnss.receiver import GnssReceiverConfig
        try:
            GnssReceiverConfig.from_dict({k: v for k, v in raw.items()})
        except ValueError as exc:
            msg = str(exc)
            raise ScenarioError(f"{source}: {msg if msg.startswith('gnss') else 'gnss.raw.' + msg}") from None
    if "guidance" in data and "flight" not in data:
        raise ScenarioError(f"{source}: guidance: needs a 'flight' block (the boost-glide truth it steers)")
    if "flight" in data and "maneuvers" in data:
        raise ScenarioError(f"{source}: give either 'flight' (dynamic) or 'maneuvers' (kinematic), not both "
                            f"(a file that extends a kinematic scenario removes them with 'maneuvers: null')")


def _check_load_sensor_rate(data: dict, source: str) -> None:
    """The structure-load triad samples each IMU interval n times
    (``simulate._measured_load``): its rate must be a whole multiple of the
    IMU's, checked when the scenario loads rather than when it is flown."""
    from .lever_arm import LeverArmConfig
    if "lever_arm" not in data:
        return
    cfg = LeverArmConfig.from_config(data["lever_arm"])
    imu_hz = float((data.get("imu") or {}).get("rate_hz", 0.0) or 0.0)
    if not cfg.enabled or imu_hz <= 0.0:
        return
    n = cfg.load_sensor_rate_hz / imu_hz
    if round(n) < 1 or abs(n - round(n)) > 1e-6:
        raise ScenarioError(f"{source}: lever_arm.load_sensor_rate_hz: must be a whole multiple of imu.rate_hz "
                            f"({imu_hz:g} Hz), got {cfg.load_sensor_rate_hz:g}")


def _read_yaml(path) -> dict:
    try:
        return yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {exc}") from None


def _merge(base: dict, over: dict) -> dict:
    """``over`` on top of ``base``: mappings merge key by key, anything else
    (numbers, strings, lists) replaces; ``None`` (YAML null) removes the key."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if v is None:
            out.pop(k, None)
        elif isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _drop_nulls(d):
    """A mapping without its null-valued keys (null = not given), recursively."""
    if not isinstance(d, dict):
        return d
    return {k: _drop_nulls(v) for k, v in d.items() if v is not None}


def _find_base(base_name: str, path: pathlib.Path) -> pathlib.Path:
    """``extends:`` target: a path or name relative to the extending file's
    directory first, then an installed scenario name."""
    here = pathlib.Path(path).resolve().parent
    cands = [here / base_name]
    if pathlib.Path(base_name).suffix not in (".yaml", ".yml"):
        cands.append(here / f"{base_name}.yaml")
    for cand in cands:
        if cand.is_file():
            return cand
    return find_scenario(base_name)


def _resolve_extends(raw, path, seen=()) -> dict:
    """A scenario file may start from another one: ``extends: <scenario name
    or path>`` (relative to this file's directory, then installed names) and
    only the fields that differ (merged by ``_merge``; null removes)."""
    if not isinstance(raw, dict) or "extends" not in raw:
        return raw
    base_name = raw["extends"]
    if not isinstance(base_name, str):
        raise ScenarioError(f"{path}: extends: expected a scenario name, got {base_name!r}")
    try:
        base_path = _find_base(base_name, path).resolve()
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: extends: {exc}") from None
    if base_path in seen:
        raise ScenarioError(f"{path}: extends: circular ({' -> '.join(str(p.name) for p in seen)} -> {base_path.name})")
    base = _resolve_extends(_read_yaml(base_path), base_path, seen + (path,))
    return _merge(base, {k: v for k, v in raw.items() if k != "extends"})


def load_scenario(name_or_path: str) -> Scenario:
    path = find_scenario(str(name_or_path))
    raw = _resolve_extends(_read_yaml(path), pathlib.Path(path).resolve())
    tf = raw.get("trajectory_file") if isinstance(raw, dict) else None
    for key in ("path", "bag"):
        if isinstance(tf, dict) and isinstance(tf.get(key), str) and not pathlib.Path(tf[key]).is_absolute():
            # absolute from here on: the copies beside a bag or in an override's work dir still find the file
            tf[key] = str(pathlib.Path(path).resolve().parent / tf[key])
    return Scenario(path, validate(raw, str(path)))


# ---- scenarios of runs: overrides, the scenario a bag was recorded with, the fusion node's inputs ----
def set_fields(data: dict, values: dict) -> dict:
    """``data`` with the dotted fields of ``values`` set in place
    ({"imu.rate_hz": 100.0}); a value None removes the field (``--set
    maneuvers=null``). Returns ``data``."""
    for dotted, value in values.items():
        parts = dotted.split(".")
        cur = data
        for part in parts[:-1]:
            cur = cur.setdefault(part, {})
        if value is None:
            cur.pop(parts[-1], None)
        else:
            cur[parts[-1]] = value
    return data


def apply_overrides(sc: Scenario, overrides: dict | None, workdir: pathlib.Path) -> Scenario:
    """A copy of the scenario with dotted-field overrides, validated and
    written to workdir so that every node reads the same file."""
    tree = known_fields()
    for dotted in overrides or {}:
        check_override_key(dotted, tree)
    data = set_fields(copy.deepcopy(sc.data), overrides or {})
    path = pathlib.Path(workdir) / f"{data['name']}.yaml"
    data = validate(data, str(path))
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return Scenario(path, data)


def bag_scenario(bag) -> str:
    """The scenario a bag was recorded with (``scenario.yaml`` beside it, as
    ``run_graph`` writes it), else the default scenario."""
    path = pathlib.Path(bag) / "scenario.yaml"
    return str(path) if path.is_file() else "default"


def load_with_settings(name_or_path: str, settings=()) -> Scenario:
    """``load_scenario`` with ``settings`` applied ("FIELD=VALUE" strings,
    YAML values, as a command's ``--set`` gives them)."""
    import tempfile
    sc = load_scenario(name_or_path)
    overrides = {k: yaml.safe_load(v) for k, _, v in (str(s).partition("=") for s in settings)}
    if overrides:
        sc = apply_overrides(sc, overrides, pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_scenario_")))
    return sc


def scenario_of_run(bag, scenario: str | None = None, settings=()) -> Scenario:
    """The scenario to score or replay a recorded run with: ``scenario`` (a
    name or path), else the bag's own (``bag_scenario``), with ``settings``."""
    return load_with_settings(scenario or bag_scenario(bag), settings)


def fusion_inputs(sc: Scenario) -> set[str]:
    """Topics the fusion node subscribes: those of the scenario's declared sources."""
    return {i.topic.lstrip("/") for src in make_sources(sc.filter_source_specs(), sc.filter_config())
            for i in src.inputs()}
