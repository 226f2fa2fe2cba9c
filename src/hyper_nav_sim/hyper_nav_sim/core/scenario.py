"""Scenario files: one YAML drives the simulation and every node's parameters.

``load_scenario(name_or_path)`` reads a file (a bare name is looked up in the
installed ``share/hyper_nav_sim/scenarios`` or the source tree), checks every
field against the schema below and raises ``ScenarioError`` naming the bad
field (``imu.rate_hz: expected a number, got 'fifty'``).
"""
from __future__ import annotations

import copy
import pathlib
from dataclasses import dataclass

import numpy as np
import yaml

from hyper_nav_filter.core.config import ConfigError, FilterConfig
from hyper_nav_filter.sources import DEFAULT_TABLE, make_sources, parse_sources

from .trajectory import MANEUVER_KINDS, Maneuver, Start, Trajectory


class ScenarioError(ValueError):
    """Malformed scenario; the message names the field."""


NUM, INT, STR, BOOL = "number", "integer", "string", "boolean"


def vec(n):
    return ("vector", n)


# field -> (type, required, default)
SCHEMA = {
    "name": (STR, True, None),
    "description": (STR, False, ""),
    "seed": (INT, True, None),
    "duration_s": (NUM, True, None),
    "start.lat_deg": (NUM, True, None),
    "start.lon_deg": (NUM, True, None),
    "start.alt_m": (NUM, True, None),
    "start.vel_enu_mps": (vec(3), True, None),
    "start.angle_of_attack_deg": (NUM, False, 0.0),
    "start.roll_deg": (NUM, False, 0.0),
    "imu.rate_hz": (NUM, True, None),
    "imu.gyro_bias_deg_per_hr": (vec(3), True, None),
    "imu.gyro_arw_deg_per_sqrt_hr": (NUM, True, None),
    "imu.accel_bias_ug": (vec(3), True, None),
    "imu.accel_vrw_ug_per_sqrt_hz": (NUM, True, None),
    "gnss.rate_hz": (NUM, True, None),
    "gnss.pos_sigma_enu_m": (vec(3), True, None),
    "gnss.vel_sigma_enu_mps": (vec(3), True, None),
    "gnss.latency_s": (NUM, False, 0.0),
    "gnss.antenna_lever_arm_b_m": (vec(3), False, [0.0, 0.0, 0.0]),
    "magnetometer.rate_hz": (NUM, True, None),
    "magnetometer.noise_nT": (NUM, True, None),
    "magnetometer.epoch_decimal_year": (NUM, True, None),
    "graph.real_time_factor": (NUM, False, 3.0),
    "graph.clock_rate_hz": (NUM, False, 50.0),
    "graph.truth_rate_hz": (NUM, False, 50.0),
    "graph.qos_depth": (INT, False, 2000),
    "filter.initial_error.pos_enu_m": (vec(3), True, None),
    "filter.initial_error.vel_enu_mps": (vec(3), True, None),
    "filter.initial_error.att_enu_arcmin": (vec(3), True, None),
    "report.skip_s": (NUM, False, 30.0),
    "report.max_pos_rms_m": (NUM, False, None),
    "report.max_vel_rms_mps": (NUM, False, None),
    "report.max_att_rms_deg": (NUM, False, None),
    "report.reference_source": (STR, False, ""),
    "report.reference_pos_m": (NUM, False, None),
    "report.reference_vel_mps": (NUM, False, None),
    "report.reference_att_deg": (NUM, False, None),
}
KINEMATIC_ONLY = ("start.", )          # fields not required when a `flight:` block is given
OPTIONAL_BLOCKS = ("flight", "lever_arm", "barometer", "radar")
POSITIVE = {"duration_s", "imu.rate_hz", "gnss.rate_hz", "magnetometer.rate_hz",
            "graph.real_time_factor", "graph.clock_rate_hz", "graph.truth_rate_hz", "graph.qos_depth"}


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


def _check_type(field: str, typ, value):
    def is_num(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
    if typ == NUM and not is_num(value):
        raise ScenarioError(f"{field}: expected a number, got {value!r}")
    if typ == INT and not (isinstance(value, int) and not isinstance(value, bool)):
        raise ScenarioError(f"{field}: expected an integer, got {value!r}")
    if typ == STR and not isinstance(value, str):
        raise ScenarioError(f"{field}: expected a string, got {value!r}")
    if typ == BOOL and not isinstance(value, bool):
        raise ScenarioError(f"{field}: expected true or false, got {value!r}")
    if isinstance(typ, tuple):
        if not (isinstance(value, list) and len(value) == typ[1] and all(is_num(x) for x in value)):
            raise ScenarioError(f"{field}: expected a list of {typ[1]} numbers, got {value!r}")


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
            if "flight" in self.data:
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

    def filter_initial_state(self):
        """The filter's initial nominal state: truth at t = 0 plus the
        scenario's initial errors (what an alignment would hand over)."""
        from hyper_nav_filter.core import earth
        from hyper_nav_filter.core.attitude import rotvec_to_C
        from hyper_nav_filter.core.nav_state import NavState
        tr = self.trajectory().truth([0.0])
        d_pos = np.asarray(self["filter.initial_error.pos_enu_m"], float)
        r_m, r_n = earth.radii(tr.lat_rad[0])
        lat = tr.lat_rad[0] + d_pos[1] / (r_m + tr.alt_m[0])
        lon = tr.lon_rad[0] + d_pos[0] / ((r_n + tr.alt_m[0]) * np.cos(tr.lat_rad[0]))
        phi = np.deg2rad(np.asarray(self["filter.initial_error.att_enu_arcmin"], float) / 60.0)
        C = rotvec_to_C(-phi) @ tr.C_b_n[0]          # C_est = (I - [phi x]) C_true
        return NavState(0.0, lat, lon, tr.alt_m[0] + d_pos[2],
                        tr.vel_enu_mps[0] + np.asarray(self["filter.initial_error.vel_enu_mps"], float), C)

    def filter_config(self) -> FilterConfig:
        return FilterConfig.from_dict(self.data.get("filter", {}).get("config", {}))

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

    def rng(self, stream: str) -> np.random.Generator:
        """Independent, reproducible random stream per sensor."""
        return np.random.default_rng([self["seed"], sum(stream.encode())])


def validate(data, source: str = "<dict>") -> dict:
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: top level must be a mapping")
    data = copy.deepcopy(data)
    dynamic = "flight" in data
    for field, (typ, required, default) in SCHEMA.items():
        if dynamic and field.startswith(KINEMATIC_ONLY):
            continue
        try:
            value = _get(data, field)
        except KeyError:
            if required:
                raise ScenarioError(f"{source}: missing required field '{field}'") from None
            _set(data, field, default)
            continue
        if value is None and not required:
            continue
        try:
            _check_type(field, typ, value)
        except ScenarioError as exc:
            raise ScenarioError(f"{source}: {exc}") from None
        if field in POSITIVE and value <= 0:
            raise ScenarioError(f"{source}: {field}: must be > 0, got {value!r}")
    for i, m in enumerate(data.get("maneuvers", []) or []):
        where = f"maneuvers[{i}]"
        if not isinstance(m, dict):
            raise ScenarioError(f"{source}: {where}: expected a mapping")
        if m.get("type") not in MANEUVER_KINDS:
            raise ScenarioError(f"{source}: {where}.type: expected one of {sorted(MANEUVER_KINDS)}, got {m.get('type')!r}")
        for key in ("t_start_s", "duration_s", "delta"):
            if key not in m:
                raise ScenarioError(f"{source}: missing required field '{where}.{key}'")
            _check_type(f"{where}.{key}", NUM, m[key])
        if m["duration_s"] <= 0:
            raise ScenarioError(f"{source}: {where}.duration_s: must be > 0")
    try:
        cfg = FilterConfig.from_dict((data.get("filter") or {}).get("config", {}) or {})
    except (ConfigError, TypeError) as exc:
        raise ScenarioError(f"{source}: filter.config: {exc}") from None
    try:
        make_sources(parse_sources(filter_sources(data)), cfg)
    except ConfigError as exc:
        raise ScenarioError(f"{source}: {exc}") from None
    _validate_models(data, source)
    return data


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
    from .baro_model import BaroErrors
    from .boost_glide_config import parse_flight
    from .imu_model import ImuErrors
    from .lever_arm import LeverArmConfig
    from .mag_model import MagnetometerErrors
    checks = [("imu", lambda d: ImuErrors.from_config(d)),
              ("magnetometer", lambda d: MagnetometerErrors.from_config(d)),
              ("flight", lambda d: parse_flight(d)),
              ("lever_arm", lambda d: LeverArmConfig.from_config(d)),
              ("barometer", lambda d: BaroErrors.from_config(d, prefix="barometer"))]
    for key, check in checks:
        if key in data:
            try:
                check(data[key])
            except ValueError as exc:
                msg = str(exc)
                raise ScenarioError(f"{source}: {msg if msg.startswith(key) else key + '.' + msg}") from None
    raw = (data.get("gnss") or {}).get("raw")
    if raw is not None:
        from .gnss.receiver import GnssReceiverConfig
        try:
            GnssReceiverConfig.from_dict({k: v for k, v in raw.items()})
        except ValueError as exc:
            msg = str(exc)
            raise ScenarioError(f"{source}: {msg if msg.startswith('gnss') else 'gnss.raw.' + msg}") from None
    if "flight" in data and "maneuvers" in data:
        raise ScenarioError(f"{source}: give either 'flight' (dynamic) or 'maneuvers' (kinematic), not both")


def _read_yaml(path) -> dict:
    try:
        return yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{path}: not valid YAML: {exc}") from None


def _merge(base: dict, over: dict) -> dict:
    """``over`` on top of ``base``: mappings merge key by key, anything else
    (numbers, strings, lists) replaces."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else copy.deepcopy(v)
    return out


def _resolve_extends(raw, path, seen=()) -> dict:
    """A scenario file may start from another one: ``extends: <scenario name>``
    and only the fields that differ (merged by ``_merge``)."""
    if not isinstance(raw, dict) or "extends" not in raw:
        return raw
    base_name = raw["extends"]
    if not isinstance(base_name, str):
        raise ScenarioError(f"{path}: extends: expected a scenario name, got {base_name!r}")
    try:
        base_path = find_scenario(base_name)
    except ScenarioError as exc:
        raise ScenarioError(f"{path}: extends: {exc}") from None
    if base_path in seen:
        raise ScenarioError(f"{path}: extends: circular ({' -> '.join(str(p.name) for p in seen)} -> {base_path.name})")
    base = _resolve_extends(_read_yaml(base_path), base_path, seen + (path,))
    return _merge(base, {k: v for k, v in raw.items() if k != "extends"})


def load_scenario(name_or_path: str) -> Scenario:
    path = find_scenario(str(name_or_path))
    raw = _resolve_extends(_read_yaml(path), path)
    return Scenario(path, validate(raw, str(path)))
