"""Start the hyper-nav node graph from a scenario file (``ros2 launch`` is
not installable here; this is our launcher).

Command line::

    run_graph --scenario default --record bags/my_run --report

    run_graph --replay bags/my_run --record bags/my_replay --report   # the bag into a live fusion node

Python (a context manager, usable as a pytest fixture in a user's own ROS
test suite)::

    from hyper_nav_workbench.graph import Graph
    with Graph("default", overrides={"duration_s": 40.0},
               extra_subscribers={"nav/odom": 1}) as g:
        ...                      # subscribe to nav/odom from your test node
        g.wait_until_done()

Every node is its own process, found where ``ros2 run`` finds it
(``<prefix>/lib/<pkg>/<exe>`` through the ament index), with its ROS
parameters written from the scenario into a params file. Publishers wait for
their expected subscribers (the graph's own nodes, the recorder and
``extra_subscribers``) before data flows, and the time source (truth node or
player) waits for every ``extra_subscribers`` topic, so nothing is lost at
start-up. A ``monitor`` node reports dead nodes and missing streams on
``/diagnostics`` (``nodes/monitor.py``).

Faults: a node that dies (crash, kill -9) is reported with its exit status
and the time; the command line keeps the graph flying to the end of the
scenario (stopping at once if the time source or the recorder died, or a
node died before the clock started: the time source waits for it), then
stops every node, closes the bag and writes the report, which fails naming the
dead node. The Python API raises instead (``on_node_death="raise"``, the
default; ``"continue"`` behaves like the command line). SIGINT and SIGTERM
stop the graph the same way (recorder last, bag metadata written, report of
what was flown) with a one-line message and exit code 128 + signal; node
processes get SIGTERM if ``run_graph`` itself is killed (parent-death signal),
so none is left behind. Next to the bag: ``scenario.yaml`` (the scenario as
flown, overrides applied; ``report`` and ``replay_filter`` use it) and
``run_graph.json`` (node exits, how the run ended).
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml
from ament_index_python.packages import get_package_prefix


from hyper_nav_filter import aiding_nodes
from hyper_nav_filter.core.params import suggestion
from hyper_nav_sim import sensors
from hyper_nav_sim.core.scenario import (
    Scenario, ScenarioError, apply_overrides, bag_scenario, fusion_inputs, load_scenario,
)

# Neither the sensor nodes nor the aiding nodes are named here: each is declared by its package
# (hyper_nav_sim.sensors: executable, scenario block, topics and rates, parameters; hyper_nav_filter.aiding_nodes:
# executable, scenario block, inputs, outputs, parameters).
FUSION_OUTPUTS = ["nav/state", "nav/odom", "nav/fix"]
TRACKER_INPUT = "radar/track"                    # tracker_node (seed 002): starts when a sensor publishes its input
TRACKER_OUTPUTS = ["track/fix", "track/vel"]
CORE_EXECUTABLES = {"truth": ("hyper_nav_sim", "truth_node"),
                    "fusion": ("hyper_nav_filter", "fusion_node"), "recorder": ("hyper_nav_workbench", "recorder"),
                    "player": ("hyper_nav_workbench", "player"), "monitor": ("hyper_nav_workbench", "monitor"),
                    "tracker": ("hyper_nav_filter", "tracker_node"), "foxglove": ("hyper_nav_workbench", "foxglove_view"),
                    "guidance": ("hyper_nav_guidance", "guidance_node")}
# ROS node names where they differ from the graph's process names
CORE_ROS_NAMES = {"foxglove": "foxglove_view"}
_CLK_TCK = os.sysconf("SC_CLK_TCK")
CLOCK_SOURCES = ("truth", "player")          # publish /clock; their normal exit ends the run
# what a time source logs once every node it waits for is there and the clock starts
STARTED_LOG = {"truth": "subscribers matched; flying", "player": "replaying "}


class _NoAliasDumper(yaml.SafeDumper):
    """YAML without anchors: rcl's parameter-file parser refuses aliases ("Will
    not support aliasing"), which a list shared by two parameters produces."""

    def ignore_aliases(self, data):
        return True


CRITICAL_STREAMS = ("imu/data_raw", "nav/state")


def replay_topics() -> tuple:
    """Topics a replay feeds into the graph (the rest of a recorded run is its own output): the
    installed sensor nodes' and the truth."""
    return tuple(t for n in sensors.descriptors().values() for t in n.replay_topics) + ("truth/state",)


def default_nodes() -> tuple:
    """The graph without optional blocks: the truth, every sensor node started without a block of
    its own (the installed descriptors), the fusion node."""
    return ("truth",) + tuple(n.name for n in sensors.descriptors().values() if not n.optional) + ("fusion",)


def __getattr__(name: str):
    if name == "DEFAULT_NODES":                  # the former table, for importers (hyper_nav_guidance.pytest_plugin)
        return default_nodes()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def executables() -> dict[str, tuple[str, str]]:
    """Every node the graph can start: name -> (package, executable), the
    installed sensor and aiding nodes' included."""
    return {**CORE_EXECUTABLES, **{n.name: (n.package, n.executable) for n in sensors.descriptors().values()},
            **{n.name: (n.package, n.executable) for n in aiding_nodes.descriptors().values()}}


def ros_name(name: str) -> str:
    """The ROS node name of a graph process (what its /diagnostics carry as hardware_id)."""
    node = aiding_nodes.descriptors().get(name) or sensors.descriptors().get(name)
    return (node.ros_name if node else CORE_ROS_NAMES.get(name)) or name


def executable(name: str) -> str:
    """Path of a node executable as ``ros2 run`` resolves it."""
    known = executables()
    if name not in known:
        hint = suggestion(name, known)
        raise ScenarioError(f"unknown node '{name}'" + (f"; did you mean '{hint}'?" if hint else "") +
                            f" (nodes: {', '.join(sorted(known))})")
    pkg, exe = known[name]
    path = pathlib.Path(get_package_prefix(pkg)) / "lib" / pkg / exe
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: build the workspace (make setup)")
    return str(path)


def fusion_parameters(sc: Scenario) -> dict:
    """The fusion node's ROS parameters, all derived from the scenario."""
    from hyper_nav_filter.sources import spec_to_params
    start = sc.trajectory().truth([0.0])          # map frame origin: the true start point
    params = aiding_nodes.filter_parameters(sc)
    params.update(spec_to_params(sc.filter_source_specs()))
    params.update({f"init.{k}": v for k, v in sc.filter_initial_values().items()})
    params.update({
        "tf.magnetometer_position_b_m": [float(x) for x in sc["magnetometer.lever_arm_b_m"]],
        "tf.imu_rotation_b_xyzw": [float(x) for x in sc["imu.mounting_b_xyzw"]],
        "origin.lat_deg": float(np.rad2deg(start.lat_rad[0])), "origin.lon_deg": float(np.rad2deg(start.lon_rad[0])),
        "origin.alt_m": float(start.alt_m[0]), "qos.depth": int(sc["graph.qos_depth"]),
    })
    return params


def stream_rates_hz(sc: Scenario) -> dict:
    """Nominal rate of every periodic stream of a scenario (for the monitor's timeouts)."""
    rates = sensors.stream_rates_hz(sc)
    rates.update({"truth/state": sc["graph.truth_rate_hz"], "nav/state": float(sc.filter_config().output_rate_hz)})
    return rates


class NodeDied(RuntimeError):
    """A node of the graph exited before the end (Python API, on_node_death='raise')."""


def describe_exit(returncode: int) -> str:
    if returncode < 0:
        try:
            return f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"killed by signal {-returncode}"
    return f"exit code {returncode}"


class Graph:
    def __init__(self, scenario: str | Scenario | None = None, record: str | os.PathLike | None = None,
                 nodes=None, overrides: dict | None = None,
                 extra_subscribers: dict[str, int] | None = None, node_params: dict | None = None,
                 log_dir: str | os.PathLike | None = None, domain_id: int | None = None,
                 replay: str | os.PathLike | None = None, monitor: bool = True,
                 on_node_death: str = "raise", foxglove: dict | None = None):
        """``scenario``: a name, path or Scenario (default: "default", or the
        replayed bag's ``scenario.yaml``). ``replay``: a bag to play into the
        graph instead of the simulator (nodes default to player + fusion).
        ``on_node_death``: "raise" (NodeDied from wait_until_done) or
        "continue" (keep flying, see ``exits``). ``foxglove``: start the Foxglove
        live view with these node parameters ({"port": 8765, "host": "127.0.0.1"};
        nodes/foxglove_view.py), None = off."""
        if on_node_death not in ("raise", "continue"):
            raise ValueError(f"on_node_death: 'raise' or 'continue', got {on_node_death!r}")
        self.replay = pathlib.Path(replay) if replay else None
        if scenario is None:
            scenario = bag_scenario(self.replay) if self.replay else "default"
        base = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        self._tmp = tempfile.TemporaryDirectory(prefix="hyper_nav_graph_")
        self.workdir = pathlib.Path(self._tmp.name)
        self.scenario = apply_overrides(base, overrides, self.workdir)
        self.record = pathlib.Path(record) if record else None
        self._fusion_inputs = fusion_inputs(self.scenario)
        if nodes is None:
            if self.replay:
                nodes = ("player", "fusion")
            else:
                sensor_nodes = [n for n in sensors.descriptors().values() if n.wanted(self.scenario.data)]
                nodes = ("truth",) + tuple(n.name for n in sensor_nodes) + ("fusion",)
                nodes += ("tracker",) if any(TRACKER_INPUT in n.topics(self.scenario) for n in sensor_nodes) else ()
                nodes += ("guidance",) if "guidance" in self.scenario.data else ()   # issue 36: the loop
            nodes += tuple(n.name for n in aiding_nodes.descriptors().values()
                           if n.wanted(self.scenario.data, self._fusion_inputs))
        self.nodes = tuple(nodes)
        for name in self.nodes:
            executable(name)                     # unknown names fail here, with a suggestion
        if self.replay and "player" not in self.nodes:
            raise ScenarioError("--replay needs the player node in --nodes")
        self.monitor = monitor
        self.on_node_death = on_node_death
        self.extra = dict(extra_subscribers or {})
        self.node_params = node_params or {}
        self.log_dir = pathlib.Path(log_dir) if log_dir else self.workdir / "logs"
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.domain_id = domain_id if domain_id is not None else int(os.environ.get("ROS_DOMAIN_ID", 0)) or \
            (os.getpid() % 100) + 1
        self.procs: dict[str, subprocess.Popen] = {}
        self.exits: list[dict] = []               # nodes that died: name, returncode, how, t_wall_s
        self.stopping = False
        self.stop_reason = None
        self.interrupted = None                   # signal name when stopped by SIGINT/SIGTERM
        self.t_start = None
        self._replay_topics = self._bag_topics() if self.replay else []
        if foxglove is not None:
            self.nodes += ("foxglove",)
            self.node_params = {**self.node_params, "foxglove": {"qos_depth": int(self.scenario["graph.qos_depth"]),
                                                                 **foxglove, **self.node_params.get("foxglove", {})}}

    # ---- parameters ------------------------------------------------------------
    def _recorded(self, topic: str) -> bool:
        """Whether the recorder takes this topic (all of them unless its ``topics`` parameter narrows it)."""
        wanted = self.node_params.get("recorder", {}).get("topics")
        return bool(self.record) and (not wanted or "/" + topic.lstrip("/") in {"/" + t.lstrip("/") for t in wanted})

    def _bag_topics(self) -> list[str]:
        from hyper_nav_workbench.core.bag import read_bag
        reader = read_bag(self.replay)
        known = replay_topics()
        topics = [t.lstrip("/") for t in reader.topics if t.lstrip("/") in known]
        if not topics:
            why = f" ({reader.error})" if reader.error else ""
            raise ScenarioError(f"{self.replay}: no replayable topics ({', '.join(known)}){why}")
        return topics

    def _subscribers(self, topics) -> int:
        """How many subscriptions the publishers of these topics must see."""
        n = 1 if any(self._recorded(t) for t in topics) else 0
        if "fusion" in self.nodes and self._fusion_inputs & set(topics):
            n += 1
        n += sum(1 for node in self._aiding()
                 if set(node.inputs(self.scenario.data.get(node.block) or {})) & set(topics))
        if "tracker" in self.nodes and TRACKER_INPUT in topics:
            n += 1
        if "guidance" in self.nodes and self._guidance_nav_topic() in topics:
            n += 1
        return n + max((self.extra.get(t, 0) for t in topics), default=0)

    def _guidance_nav_topic(self) -> str:
        """The navigation topic the guidance node flies on (its node parameter, else the scenario's)."""
        from hyper_nav_sim.core.guidance_config import GuidanceConfig
        given = self.node_params.get("guidance", {}).get("nav_topic")
        return (given or GuidanceConfig.from_config(self.scenario.data["guidance"]).nav_topic).lstrip("/")

    def _clock_gate(self) -> dict:
        """The time source waits for these nodes' allowances (hyper_nav_filter.clock_gate): on a
        loaded machine the flight slows down instead of losing or delaying data. Set
        graph.clock_gate: false in the scenario to pace by the wall clock alone."""
        if not self.scenario["graph.clock_gate"]:
            return {}
        names = ["fusion"] if "fusion" in self.nodes else []
        # the producers too: a starved or frozen sensor node holds the clock instead of bursting (issue 33)
        names += [ros_name(n) for n in self._sensor_nodes()]
        names += [node.ros_name or node.name for node in self._aiding() if node.gates_clock]
        names += ["guidance"] if "guidance" in self.nodes else []      # its input matched first (issue 36)
        if self.record:
            names.append("recorder")
        return {"allowance_nodes": names} if names else {}

    def _aiding(self) -> list:
        """The descriptors of the aiding nodes of this graph."""
        return [node for name, node in aiding_nodes.descriptors().items() if name in self.nodes]

    def _waits(self) -> dict:
        """The time source waits for these subscriber counts on the user's topics: the user's own
        subscribers on top of the graph's (the recorder's, the fusion node's, ...), as their publishers
        do; the user's count alone was already met by the recorder, and the user's first messages were
        lost (a guidance node in the fixture missed its first commands' states)."""
        return {t: self._subscribers([t]) for t, n in self.extra.items() if n > 0 and t != "/clock"}

    def _sensor_nodes(self):
        return [n for n in self.nodes if n in sensors.descriptors()]

    def _sensor_topics(self, name: str) -> dict:
        """{topic: nominal rate} of a sensor node of this graph."""
        return sensors.descriptors()[name].topics(self.scenario)

    def streams(self) -> list[str]:
        """Streams the monitor watches."""
        if self.replay:
            latched = {t for n in sensors.descriptors().values() for t in n.latched_topics}
            topics = [t for t in self._replay_topics if t not in latched]
        else:
            topics = [t for n in self._sensor_nodes() for t in self._sensor_topics(n)]
            if "truth" in self.nodes:
                topics.append("truth/state")
        if "fusion" in self.nodes:
            topics.append("nav/state")
        return topics

    def _params(self, name: str) -> dict:
        sc_path = str(self.scenario.path)
        diag = float(self.scenario["graph.diagnostics_period_s"])
        if name in sensors.descriptors():          # declared by its package
            # each topic waits for its own consumers (an aiding node may take one topic of a sensor)
            node = sensors.descriptors()[name]
            counts = {t: self._subscribers([t]) for t in node.waited_topics(self.scenario)}
            p = {"scenario": sc_path, "min_subscribers": max(counts.values(), default=0)}
            if len(set(counts.values())) > 1:
                p.update({"wait_topics": list(counts), "wait_counts": list(counts.values())})
            p.update(node.parameters(self.scenario, self._subscribers))
        elif name == "truth":
            n_sensors = len(self._sensor_nodes())
            p = {"scenario": sc_path, "clock_subscribers": n_sensors + (1 if self.record else 0) + self.extra.get("/clock", 0),
                 "min_subscribers": self._subscribers(["truth/state"])}
            clock_nodes = [ros_name(n) for n in self._sensor_nodes()] + (["recorder"] if self.record else [])
            if clock_nodes:
                p["clock_nodes"] = clock_nodes
            waits = self._waits()
            if waits:
                p.update({"wait_topics": list(waits), "wait_counts": list(waits.values())})
            p.update(self._clock_gate())
            if "guidance" in self.nodes:         # the flight waits for its commands (issue 36)
                p["command_publishers"] = 1
                nav = self._guidance_nav_topic()  # and for the guidance's subscription to its navigation
                if nav != "truth/state":
                    waits = dict(zip(p.get("wait_topics", []), p.get("wait_counts", [])))
                    waits[nav] = max(waits.get(nav, 0), self._subscribers([nav]))
                    p.update(wait_topics=list(waits), wait_counts=list(waits.values()))
        elif name == "fusion":
            p = fusion_parameters(self.scenario)
            # each output is published only once its subscribers exist; the user's own
            # subscribers (extra_subscribers) are waited for by the time source
            p["min_output_subscribers"] = min(self._subscribers([t]) for t in FUSION_OUTPUTS)
            p["diagnostics_period_s"] = diag
            p["tf.min_subscribers"] = self._subscribers(["/tf"])
        elif name == "tracker":
            from hyper_nav_sim.core.tracking_setup import tracker_parameters
            p = tracker_parameters(self.scenario)
            p["radar.rate_hz"] = float(stream_rates_hz(self.scenario)[TRACKER_INPUT])
            p["min_output_subscribers"] = min(self._subscribers([t]) for t in TRACKER_OUTPUTS)
        elif name in aiding_nodes.descriptors():            # declared by its package
            node = aiding_nodes.descriptors()[name]
            p = node.parameters(self.scenario)
            if node.output_wait_parameter:
                p[node.output_wait_parameter] = self._subscribers(node.outputs(self.scenario.data.get(node.block) or {}))
        elif name == "guidance":
            from hyper_nav_sim.core.guidance_config import GuidanceConfig
            cmd = GuidanceConfig.from_config(self.scenario.data["guidance"]).command_topic.lstrip("/")
            # its commands' subscribers: the truth node, then the recorder and the user's own
            p = {"scenario": sc_path, "diagnostics_period_s": diag,
                 "min_output_subscribers": 1 + self._subscribers([cmd])}
        elif name == "recorder":
            p = {"output": str(self.record), "qos_depth": int(self.scenario["graph.qos_depth"]),
                 "use_sim_time": True, "diagnostics_period_s": diag}
        elif name == "player":
            p = {"qos_depth": int(self.scenario["graph.qos_depth"]), "diagnostics_period_s": diag}
            if self.replay:
                waits = {t: self._subscribers([t]) for t in self._replay_topics}
                waits.update({t: max(waits.get(t, 0), n) for t, n in self._waits().items()})
                p.update({"bag": str(self.replay), "rate": float(self.scenario["graph.real_time_factor"]),
                          "topics": list(self._replay_topics), "wait_topics": list(waits),
                          "wait_counts": list(waits.values()), "wait_timeout_s": 60.0})
                p.update(self._clock_gate())
        elif name == "monitor":
            rates = stream_rates_hz(self.scenario)
            streams = self.streams()
            t_min = float(self.scenario["monitor.stream_timeout_s"])
            watched = (["recorder"] if self.record else []) + list(self.nodes)
            p = {"nodes": [ros_name(n) for n in watched],
                 "streams": streams,
                 "stream_timeouts_s": [max(t_min, 3.0 / rates.get(t, 1.0)) for t in streams],
                 "critical_streams": [t for t in streams if t in CRITICAL_STREAMS],
                 "heartbeat_timeout_s": float(self.scenario["monitor.heartbeat_timeout_s"]),
                 "startup_timeout_s": float(self.scenario["monitor.startup_timeout_s"]),
                 "end_s": float(self.scenario["duration_s"]), "diagnostics_period_s": diag}
            if not streams:
                p.pop("streams"), p.pop("stream_timeouts_s"), p.pop("critical_streams")
        else:
            p = {}
        p.update(self.node_params.get(name, {}))
        return p

    def _params_file(self, name: str) -> pathlib.Path:
        path = self.workdir / f"{name}.params.yaml"
        path.write_text(yaml.dump({"/**": {"ros__parameters": self._params(name)}}, Dumper=_NoAliasDumper))
        return path

    # ---- processes -------------------------------------------------------------
    def env(self) -> dict:
        env = dict(os.environ)
        env["ROS_DOMAIN_ID"] = str(self.domain_id)
        env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        env["PYTHONUNBUFFERED"] = "1"
        return env

    def _spawn(self, name: str) -> None:
        log = open(self.log_dir / f"{name}.log", "w")
        cmd = [executable(name), "--ros-args", "--params-file", str(self._params_file(name))]
        # the node gets SIGTERM if this process dies (kill -9 of run_graph leaves no orphans)
        setpriv = shutil.which("setpriv")
        if setpriv:
            cmd = [setpriv, "--pdeathsig", "TERM", "--"] + cmd
        self.procs[name] = subprocess.Popen(cmd, env=self.env(), stdout=log, stderr=subprocess.STDOUT,
                                            start_new_session=True)

    def start(self) -> "Graph":
        self.t_start = time.monotonic()
        if self.record:
            self.record.parent.mkdir(parents=True, exist_ok=True)
            self._spawn("recorder")
        for name in self.nodes:
            self._spawn(name)
        if self.monitor:
            self._spawn("monitor")
        return self

    def check_alive(self) -> None:
        for name, p in self.procs.items():
            if p.poll() not in (None, 0):
                raise RuntimeError(f"node '{name}' exited with code {p.returncode}; log:\n{self.log(name)[-3000:]}")

    def log(self, name: str) -> str:
        return (self.log_dir / f"{name}.log").read_text(errors="replace")

    def _last_error(self, name: str) -> str:
        """The last non-empty line of a node's log (a dead node's exception, usually)."""
        try:
            lines = [ln.strip() for ln in self.log(name).splitlines() if ln.strip()]
        except FileNotFoundError:
            return ""
        return lines[-1][:500] if lines else ""

    def _source_started(self) -> bool:
        """Whether the time source has started its clock (its log says so)."""
        for name in CLOCK_SOURCES:
            if name in self.procs:
                try:
                    return STARTED_LOG[name] in self.log(name)
                except FileNotFoundError:
                    return False
        return True

    def _poll_exits(self) -> list[dict]:
        """Nodes that exited since the last poll, other than a time source ending normally."""
        new = []
        seen = {e["node"] for e in self.exits}
        for name, p in self.procs.items():
            if name in seen or p.poll() is None or (name in CLOCK_SOURCES and p.returncode == 0):
                continue
            event = {"node": name, "ros_name": ros_name(name), "returncode": p.returncode,
                     "how": describe_exit(p.returncode), "t_wall_s": round(time.monotonic() - self.t_start, 2)}
            self.exits.append(event)
            new.append(event)
            print(f"[run_graph] node '{name}' died ({event['how']}) {event['t_wall_s']:.1f} s after the start; "
                  f"log: {self.log_dir / (name + '.log')}", flush=True)
            last = self._last_error(name)
            if last:
                event["last_log_line"] = last
                print(f"[run_graph]   {name}: {last}", flush=True)
            if self.on_node_death == "raise":
                raise NodeDied(f"node '{name}' {event['how']}; log:\n{self.log(name)[-3000:]}")
        return new

    def _cpu_s(self) -> dict[str, float]:
        """CPU time (user + system, s) of each running node process (/proc)."""
        out = {}
        for name, p in self.procs.items():
            try:
                fields = pathlib.Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()
                out[name] = (int(fields[11]) + int(fields[12])) / _CLK_TCK
            except (OSError, IndexError, ValueError):
                continue
        return out

    def wait_idle(self, min_s: float = 0.5, max_s: float = 60.0, window_s: float = 0.5,
                  busy_fraction: float = 0.15, quiet_windows: int = 2) -> float:
        """Let every node finish what is queued: wait until, over
        ``quiet_windows`` windows of ``window_s`` in a row, no node process used
        more than ``busy_fraction`` of a CPU (an idle node uses up to about 6 %
        with its wall-clock timers: the recorder's clock allowance at 20 Hz and
        topic discovery; a node working through a queue uses most of a core),
        at least ``min_s``, at most ``max_s``. A fixed drain is too short on a
        loaded machine (a fusion node still working through its input queue
        at SIGINT never sees the rest) and too long on an idle one. Returns
        the time waited (s)."""
        t0 = time.monotonic()
        time.sleep(min_s)
        prev, quiet = self._cpu_s(), 0
        while quiet < quiet_windows and time.monotonic() - t0 < max_s:
            time.sleep(window_s)
            cur = self._cpu_s()
            busy = [n for n in cur if n in prev and cur[n] - prev[n] > busy_fraction * window_s]
            quiet = 0 if busy else quiet + 1
            prev = cur
        return time.monotonic() - t0

    def wait_until_done(self, timeout_s: float | None = None, drain_s: float = 0.5) -> None:
        """Wait for the time source (truth node, or the player) to finish, let
        messages drain (at least ``drain_s``, then until every node is idle,
        ``wait_idle``), then stop every node (recorder last, so it closes a
        complete bag). A node that dies is recorded in ``exits`` (and raises
        NodeDied with on_node_death='raise'); if it was the time source or the
        recorder, the graph stops at once."""
        if timeout_s is None:
            timeout_s = 120.0 + self.scenario["duration_s"] / self.scenario["graph.real_time_factor"] * 2.0
        deadline = time.monotonic() + timeout_s
        source = next((self.procs[n] for n in CLOCK_SOURCES if n in self.procs), None)
        while source is not None and source.poll() is None:
            fatal = [e for e in self._poll_exits() if e["node"] in CLOCK_SOURCES + ("recorder",)]
            if fatal:
                self.stop_reason = f"node '{fatal[0]['node']}' died: nothing more can be flown or recorded"
                break
            if self.exits and not self._source_started():
                # the time source waits for every node before the clock starts: it would wait forever
                self.stop_reason = (f"node '{self.exits[0]['node']}' died before the flight started (the time "
                                    f"source waits for it): nothing can be flown")
                break
            if time.monotonic() > deadline:
                name = next(n for n in CLOCK_SOURCES if n in self.procs)
                raise TimeoutError(f"scenario did not finish within {timeout_s:.0f} s; {name} log:\n"
                                   f"{self.log(name)[-2000:]}")
            time.sleep(0.2)
        fatal = [e for e in self._poll_exits() + self.exits if e["node"] in CLOCK_SOURCES + ("recorder",)]
        if fatal and not self.stop_reason:
            self.stop_reason = f"node '{fatal[0]['node']}' died: nothing more can be flown or recorded"
        self.stop_reason = self.stop_reason or "end of the scenario"
        self.wait_idle(min_s=drain_s)
        self._poll_exits()
        self.stop()

    def stop(self) -> None:
        """SIGINT every node: the monitor first (a stopping graph is not a
        dying one), the recorder last so it sees everything."""
        if self.stopping:
            return
        self.stopping = True
        # the monitor first, in the same pass (it needs heartbeat_timeout_s of silence to call a node dead)
        others = [n for n in ("monitor",) if n in self.procs] + \
            [n for n in self.procs if n not in ("recorder", "monitor")]
        for name in others:
            self._interrupt(name)
        for name in others:
            self._reap(name)
        if "recorder" in self.procs and self.procs["recorder"].poll() is None:
            time.sleep(0.2)                       # the recorder then drains until quiet (drain_quiet_s)
            self._interrupt("recorder")
            self._reap("recorder")
        self._write_run_files()

    def _interrupt(self, name: str) -> None:
        if self.procs[name].poll() is None:
            self.procs[name].send_signal(signal.SIGINT)

    def _reap(self, name: str) -> None:
        p = self.procs[name]
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()

    def _write_run_files(self) -> None:
        """``scenario.yaml`` and ``run_graph.json`` beside the bag's MCAP file."""
        if not (self.record and self.record.is_dir()):
            return
        (self.record / "scenario.yaml").write_text(yaml.dump(self.scenario.data, Dumper=_NoAliasDumper, sort_keys=False))
        info = {"scenario": self.scenario.name, "nodes": list(self.nodes), "replay": str(self.replay or ""),
                "exits": self.exits, "stopped_by": self.stop_reason or "stopped", "interrupted": self.interrupted,
                "wall_s": round(time.monotonic() - self.t_start, 2) if self.t_start else None,
                "returncodes": {n: p.returncode for n, p in self.procs.items()}}
        (self.record / "run_graph.json").write_text(json.dumps(info, indent=2))

    def __enter__(self) -> "Graph":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
        self._tmp.cleanup()


class Interrupted(Exception):
    """SIGINT or SIGTERM reached run_graph."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def main(argv=None) -> int:
    state = {"graph": None}

    def on_signal(signum, _frame):
        g = state["graph"]
        if g is not None and g.stopping:
            return                              # already stopping: let it finish cleanly
        if g is not None:
            g.interrupted = signal.Signals(signum).name
        raise Interrupted(signum)

    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _main(argv, state)
    except ScenarioError as exc:
        print(f"run_graph: error: {exc}", file=sys.stderr)
        return 2
    except Interrupted as exc:
        print(f"[run_graph] {exc}: stopped before the graph started", file=sys.stderr)
        return 128 + exc.signum
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _main(argv, state) -> int:
    ap = argparse.ArgumentParser(description="Start the hyper-nav node graph on a scenario.")
    ap.add_argument("--scenario", default=None, help="scenario name (installed) or YAML path (default: "
                    "'default', or the replayed bag's scenario.yaml)")
    ap.add_argument("--record", help="bag directory to record every topic to (rosbag2, MCAP)")
    ap.add_argument("--report", action="store_true", help="print the accuracy report from the bag "
                    "(exit code 1 when it fails)")
    ap.add_argument("--replay", metavar="BAG", help="play a recorded bag into the graph (player + fusion) "
                    "instead of simulating")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="override a scenario field, e.g. --set duration_s=60 (YAML value; null removes it)")
    ap.add_argument("--nodes", default=None, help="comma-separated node names (default: every node the "
                    "scenario needs: truth, the sensor nodes (the optional ones when their blocks are "
                    "configured), fusion, the aiding nodes)")
    ap.add_argument("--foxglove", nargs="?", const=8765, type=int, metavar="PORT",
                    help="serve the run live to the Foxglove app (ws://127.0.0.1:PORT, default 8765)")
    ap.add_argument("--foxglove-host", default="127.0.0.1", help="address the Foxglove server binds to")
    args = ap.parse_args(argv)
    overrides = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            raise ScenarioError(f"--set {item}: expected FIELD=VALUE")
        overrides[key] = yaml.safe_load(value)
    record = args.record
    if record and pathlib.Path(record).exists():
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        record = f"{record}_{stamp}"
        print(f"[run_graph] {args.record} exists; recording to {record}")
    t0 = time.monotonic()
    if args.report and not record:
        raise ScenarioError("--report needs --record (the report is computed from the recorded bag)")
    foxglove = None if args.foxglove is None else {"port": args.foxglove, "host": args.foxglove_host}
    g = Graph(args.scenario, record=record, nodes=args.nodes.split(",") if args.nodes else None, overrides=overrides,
              log_dir=pathlib.Path(record).with_name(pathlib.Path(record).name + "_logs") if record else None,
              replay=args.replay, on_node_death="continue", foxglove=foxglove)
    state["graph"] = g
    interrupted = None
    try:
        with g:
            if foxglove:
                print(f"[run_graph] Foxglove live view: ws://{args.foxglove_host}:{args.foxglove} "
                      "(Foxglove app: Open connection -> Foxglove WebSocket)", flush=True)
            what = f"replaying {args.replay}" if args.replay else f"{g.scenario['duration_s']} s"
            print(f"[run_graph] scenario {g.scenario.name}: {what} at "
                  f"{g.scenario['graph.real_time_factor']}x real time; nodes: {', '.join(g.nodes)}", flush=True)
            try:
                from hyper_nav_workbench.progress import ClockProgress
                with ClockProgress(g.domain_id, float(g.scenario["duration_s"])):
                    # no wall-time limit: on a loaded machine the clock gate slows the flight down instead of
                    # losing data (a frozen node holds it, a dead one is dropped after its timeout); SIGINT stops it
                    g.wait_until_done(timeout_s=float("inf"))
            except Interrupted as exc:
                interrupted = exc
                g.stop_reason = f"{exc} after {time.monotonic() - t0:.1f} s"
                print(f"[run_graph] {exc}: stopping the graph (recorder last)", flush=True)
                g.stop()
    except Interrupted as exc:                   # signal while starting: the with-block stopped the nodes
        interrupted = exc
    ended = f"stopped by {interrupted}" if interrupted else f"finished ({g.stop_reason})"
    print(f"[run_graph] graph {ended} in {time.monotonic() - t0:.1f} s wall", flush=True)
    for e in g.exits:
        print(f"[run_graph] node '{e['node']}' died ({e['how']}) {e['t_wall_s']:.1f} s after the start", flush=True)
    if record:
        print(f"[run_graph] bag: {record}", flush=True)
    code = 1 if g.exits else 0
    if record and args.report and pathlib.Path(record).is_dir():
        from hyper_nav_workbench.report import main as report_main
        code = report_main([record])
    if interrupted:
        return 128 + interrupted.signum
    return code


if __name__ == "__main__":
    sys.exit(main())
