"""Declared fusion sources (STYLE pattern 14, the navigation2 plugin list).

The fusion node's inputs are a table, ``filter.sources`` in the scenario:

    filter:
      sources:
        imu:      {type: imu,         topic: imu/data_raw}
        gnss_fix: {type: gnss_fix,    topic: gnss/fix}
        baro:     {type: baro_height, topic: baro/pressure, qos: sensor_data, max_alt_m: 40000.0}

Every entry may declare ``delay_s``: the source's known latency (a receiver
that emits its fix 0.2 s after its epoch; PX4's ``EKF2_*_DELAY``). The
largest declared delay sizes the engine's fusion horizon
(``FusionEngine.set_fusion_delay``): its measurements are then never late
and the current-time state is predicted over that horizon.

Each entry names a registered source *type*: a converter from one ROS
message type to core measurements (or IMU samples, or model updates), with
its own parameters (``PARAMS``, declared once, core.params). The fusion node,
the offline replay, the graph starter and the report all read this one
table; adding an aiding source is configuration plus, for a new kind of
message, one converter (here, or in the aiding node's own package, declared
through the entry-point group ``hyper_nav.sources``: ``"relay_fix =
my_pkg.converter:RelayFixSource"``) and one measurement model (core).
Messages are duck-typed: rclpy messages live, rosbags-deserialized ones
offline; no rclpy here.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from importlib.metadata import entry_points

from ..core.params import FLOAT, STR, ConfigError, ParamSpec, check_all, nonneg, suggest

QOS_CHOICES = ("reliable", "sensor_data")
COMMON_FIELDS = ("type", "topic", "qos", "msg", "delay_s")
DELAY_PARAM = nonneg("delay_s", FLOAT, 0.0, "the source's known latency (s) from its epoch to its delivery: "
                     "sizes the fusion horizon (the largest over the sources)")


@dataclass(frozen=True)
class SourceInput:
    """One subscription of a source: role (``main`` or an extra input such as
    ``ephemeris``), topic, ROS message type, and whether it is latched
    (reliable + transient local, e.g. broadcast ephemerides)."""
    role: str
    topic: str
    msg_type: str
    latched: bool = False


@dataclass(frozen=True)
class SourceSpec:
    """A validated table entry."""
    id: str
    type: str
    topic: str
    qos: str = "reliable"
    params: dict = field(default_factory=dict)
    delay_s: float = 0.0


class SourceType:
    """Base class of the converters. Subclasses set ``TYPE``, ``MSG_TYPES``
    (accepted ROS message types, the first is the default), ``PARAMS`` and
    ``EXTRA_INPUTS`` ({role: (param naming its topic, msg type, latched)}),
    and implement ``convert``."""
    TYPE = ""
    MSG_TYPES: tuple[str, ...] = ()
    DESCRIPTION = ""
    PARAMS: tuple[ParamSpec, ...] = ()
    EXTRA_INPUTS: dict = {}
    drives_time = False           # the IMU: advances the filter and releases solutions

    def __init__(self, spec: SourceSpec, cfg=None):
        self.spec = spec
        self.cfg = cfg
        self.p = spec.params
        self.counters: Counter = Counter()

    @property
    def id(self) -> str:
        return self.spec.id

    def inputs(self) -> list[SourceInput]:
        out = [SourceInput("main", self.spec.topic, self.spec.params.get("msg") or self.MSG_TYPES[0])]
        for role, (param, msg_type, latched) in self.EXTRA_INPUTS.items():
            out.append(SourceInput(role, self.p[param], msg_type, latched))
        return out

    def on_message(self, role: str, msg, engine) -> str | None:
        """Feed one message to the engine; returns the reason when it is
        rejected (counted, never raised)."""
        try:
            reason = self.convert(role, msg, engine)
        except (ValueError, TypeError, KeyError, AttributeError) as exc:
            reason = f"malformed: {exc}"
        return self._count(role, reason)

    def _count(self, role: str, reason: str | None) -> str | None:
        """One message of ``role`` received, processed (reason None) or rejected for ``reason``."""
        self.counters[f"received {role}"] += 1
        if reason is None:
            self.counters[f"processed {role}"] += 1
        else:
            self.counters[f"rejected {role}"] += 1
            self.counters[f"rejected {role}: {reason.split(':')[0]}"] += 1
        return reason

    def convert(self, role: str, msg, engine) -> str | None:
        raise NotImplementedError

    def prepare_rows(self, role: str, fields: dict, n: int) -> list | None:
        """Optional, for a recording read into arrays (``offline_arrays``):
        what ``convert`` would make of each of the n messages whose fields
        are ``fields`` ({dotted path: array}), converted column by column: a
        list of n items, each the core measurement ``convert`` would queue or
        the reason it would reject the message (str); ``on_prepared`` then
        feeds them one at a time. None (the default): this type converts
        message by message only."""
        return None

    def on_prepared(self, role: str, item, engine) -> str | None:
        """``on_message`` for an item of ``prepare_rows``: the same counters
        and the same engine call as the message would get."""
        return self._count(role, item if type(item) is str else self._queued(engine.add_measurement(item)))

    @staticmethod
    def _queued(result) -> str | None:
        ok, reason = result
        return None if ok else reason

    def check(self, cfg) -> None:
        """ConfigError when the filter configuration cannot take this source
        (e.g. pseudoranges need the clock block)."""

    @property
    def n_held_imu(self) -> int:
        """IMU samples this source holds back from the engine (waiting for a paired input)."""
        return 0

    def on_imu(self, engine) -> None:
        """Called after every IMU sample (sources holding data until the filter time passes it)."""

    def diagnostics(self) -> dict:
        """Counters keyed by topic: ``received <topic>``, ``processed <topic>``, ``rejected <topic>``."""
        out = {}
        topics = {i.role: i.topic for i in self.inputs()}
        for key, n in self.counters.items():
            what, _, role = key.partition(" ")
            role, _, detail = role.partition(": ")
            out[f"{what} {topics.get(role, role)}" + (f" ({detail})" if detail else "")] = n
        return out


def navsatfix_check(msg, allow_no_covariance: bool = False) -> str | None:
    """Why a sensor_msgs/NavSatFix cannot be used as a fix (None: usable):
    status below STATUS_FIX (no fix, or unknown), or no covariance."""
    if msg.status.status < 0:
        return "no_fix"
    if int(msg.position_covariance_type) == 0 and not allow_no_covariance:
        return "no_covariance"
    return None


REGISTRY: dict[str, type[SourceType]] = {}
PLUGIN_GROUP = "hyper_nav.sources"
_plugins = {"loaded": False}


def register(cls: type[SourceType]) -> type[SourceType]:
    REGISTRY[cls.TYPE] = cls
    return cls


def load_plugins() -> dict[str, type[SourceType]]:
    """Register the converters other packages declare (entry-point group
    ``hyper_nav.sources``, each a ``SourceType`` subclass), once; the registry."""
    if not _plugins["loaded"]:
        _plugins["loaded"] = True
        for ep in sorted(entry_points(group=PLUGIN_GROUP), key=lambda e: e.name):
            cls = ep.load()
            if not (isinstance(cls, type) and issubclass(cls, SourceType) and cls.TYPE):
                raise ConfigError(f"entry point {PLUGIN_GROUP}:{ep.name} ({ep.value}): not a SourceType with a TYPE")
            if REGISTRY.get(cls.TYPE, cls) is not cls:
                raise ConfigError(f"entry point {PLUGIN_GROUP}:{ep.name}: source type {cls.TYPE!r} is already registered")
            register(cls)
    return REGISTRY


def parse_sources(table, where: str = "filter.sources") -> list[SourceSpec]:
    """Validate a sources table ({id: {type, topic, qos, <params>}}); errors
    name the field. Exactly one source drives time (type ``imu``)."""
    if not isinstance(table, dict) or not table:
        raise ConfigError(f"{where}: expected a mapping of source ids to {{type, topic, ...}}, got {table!r}")
    load_plugins()
    specs = []
    for sid, entry in table.items():
        at = f"{where}.{sid}"
        if not isinstance(sid, str) or not sid.replace("_", "").isalnum():
            raise ConfigError(f"{at}: source ids are names of letters, digits and '_'")
        if not isinstance(entry, dict):
            raise ConfigError(f"{at}: expected a mapping {{type, topic, ...}}, got {entry!r}")
        typ = entry.get("type")
        if typ is None:
            raise ConfigError(f"{at}.type: missing (known types: {', '.join(sorted(REGISTRY))})")
        if typ not in REGISTRY:
            raise ConfigError(f"{at}.type: unknown source type {typ!r}{suggest(str(typ), REGISTRY)}")
        cls = REGISTRY[typ]
        topic = entry.get("topic")
        if not isinstance(topic, str) or not topic.strip():
            raise ConfigError(f"{at}.topic: missing or not a topic name (got {topic!r})")
        qos = ParamSpec("qos", STR, "reliable", "", choices=QOS_CHOICES).check(entry.get("qos", "reliable"), f"{at}.")
        msg = entry.get("msg", cls.MSG_TYPES[0])
        if msg not in cls.MSG_TYPES:
            raise ConfigError(f"{at}.msg: source type {typ!r} takes {list(cls.MSG_TYPES)}, not {msg!r}")
        params = {k: v for k, v in entry.items() if k not in COMMON_FIELDS}
        params = check_all(cls.PARAMS, params, f"{at}.")
        params["msg"] = msg
        delay = DELAY_PARAM.check(entry.get("delay_s", 0.0), f"{at}.")
        specs.append(SourceSpec(sid, typ, topic, qos, params, delay))
    timed = [s.id for s in specs if REGISTRY[s.type].drives_time]
    if len(timed) != 1:
        raise ConfigError(f"{where}: exactly one source of type 'imu' is needed, got {timed or 'none'}")
    return specs


def make_sources(specs: list[SourceSpec], cfg) -> list[SourceType]:
    """The converter objects of a validated table (checked against the filter configuration)."""
    out = []
    for s in specs:
        src = REGISTRY[s.type](s, cfg)
        src.check(cfg)
        out.append(src)
    return out


def spec_to_params(specs: list[SourceSpec]) -> dict:
    """Flat ROS parameters of a table: ``sources`` (ids) and
    ``sources.<id>.type|topic|qos|msg|<param>``."""
    out = {"sources": [s.id for s in specs]}
    for s in specs:
        out[f"sources.{s.id}.type"] = s.type
        out[f"sources.{s.id}.topic"] = s.topic
        out[f"sources.{s.id}.qos"] = s.qos
        out[f"sources.{s.id}.delay_s"] = float(s.delay_s)
        for k, v in s.params.items():
            out[f"sources.{s.id}.{k}"] = list(v) if isinstance(v, tuple) else v
    return out


def table_from_params(get) -> dict:
    """Rebuild the table from flat parameters; ``get(name, default)`` reads one."""
    load_plugins()
    table = {}
    for sid in get("sources", []):
        typ = get(f"sources.{sid}.type", None)
        entry = {"type": typ, "topic": get(f"sources.{sid}.topic", None), "qos": get(f"sources.{sid}.qos", "reliable"),
                 "msg": get(f"sources.{sid}.msg", None), "delay_s": get(f"sources.{sid}.delay_s", 0.0)}
        cls = REGISTRY.get(typ)
        if cls is not None:
            for p in cls.PARAMS:
                entry[p.name] = get(f"sources.{sid}.{p.name}", p.default)
        if entry["msg"] is None:
            entry.pop("msg")
        table[sid] = entry
    return table


