"""Start the hyper-nav node graph from a scenario file (``ros2 launch`` is
not installable here; this is our launcher).

Command line::

    run_graph --scenario default --record bags/my_run --report

Python (a context manager, usable as a pytest fixture in a user's own ROS
test suite)::

    from hyper_nav_sim.graph import Graph
    with Graph("default", overrides={"duration_s": 40.0},
               extra_subscribers={"nav/odom": 1}) as g:
        ...                      # subscribe to nav/odom from your test node
        g.wait_until_done()

Every node is its own process, found where ``ros2 run`` finds it
(``<prefix>/lib/<pkg>/<exe>`` through the ament index), with its ROS
parameters written from the scenario into a params file. Publishers wait for
their expected subscribers (the graph's own nodes, the recorder and
``extra_subscribers``) before data flows, so nothing is lost at start-up.
"""
from __future__ import annotations

import argparse
import copy
import datetime
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml
from ament_index_python.packages import get_package_prefix

from hyper_nav_filter.core.attitude import C_to_quat_xyzw

from .core.scenario import Scenario, ScenarioError, load_scenario, validate

SENSOR_TOPICS = {"imu": ["imu/data_raw"], "gnss": ["gnss/fix", "gnss/vel"], "mag": ["imu/mag"],
                 "baro": ["baro/pressure"], "radar": ["radar/track"]}
OPTIONAL_SENSORS = {"baro": "barometer", "radar": "radar"}    # node: scenario block that enables it
FUSION_OUTPUTS = ["nav/state", "nav/odom", "nav/fix"]
# aiding nodes started when their scenario block is present: node -> (block, topics it subscribes);
# their ROS parameters are the filter configuration (filter.*) and the block's fields (dotted names)
OPTIONAL_AIDING = {"lever_arm": ("lever_arm_learning", ["imu/data_raw", "gnss/fix", "gnss/vel", "nav/state"])}
DEFAULT_NODES = ("truth", "imu", "gnss", "mag", "fusion")
EXECUTABLES = {"truth": ("hyper_nav_sim", "truth_node"), "imu": ("hyper_nav_sim", "imu_node"),
               "gnss": ("hyper_nav_sim", "gnss_node"), "mag": ("hyper_nav_sim", "mag_node"),
               "baro": ("hyper_nav_sim", "baro_node"), "radar": ("hyper_nav_sim", "radar_node"),
               "fusion": ("hyper_nav_filter", "fusion_node"), "recorder": ("hyper_nav_sim", "recorder"),
               "player": ("hyper_nav_sim", "player"), "lever_arm": ("hyper_nav_aiding", "lever_arm_node")}


def executable(name: str) -> str:
    """Path of a node executable as ``ros2 run`` resolves it."""
    pkg, exe = EXECUTABLES[name]
    path = pathlib.Path(get_package_prefix(pkg)) / "lib" / pkg / exe
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: build the workspace (make setup)")
    return str(path)


def apply_overrides(sc: Scenario, overrides: dict | None, workdir: pathlib.Path) -> Scenario:
    """A copy of the scenario with dotted-field overrides, validated and
    written to workdir so that every node reads the same file."""
    data = copy.deepcopy(sc.data)
    for dotted, value in (overrides or {}).items():
        cur = data
        parts = dotted.split(".")
        for part in parts[:-1]:
            cur = cur.setdefault(part, {})
        cur[parts[-1]] = value
    path = workdir / f"{data['name']}.yaml"
    data = validate(data, str(path))
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return Scenario(path, data)


def fusion_inputs(sc: Scenario) -> set[str]:
    """Topics the fusion node subscribes: those of the scenario's declared sources."""
    from hyper_nav_filter.sources import make_sources
    return {i.topic.lstrip("/") for src in make_sources(sc.filter_source_specs(), sc.filter_config())
            for i in src.inputs()}


def fusion_parameters(sc: Scenario) -> dict:
    """The fusion node's ROS parameters, all derived from the scenario."""
    from hyper_nav_filter.sources import spec_to_params
    init = sc.filter_initial_state()
    start = sc.trajectory().truth([0.0])          # map frame origin: the true start point
    params = {f"filter.{k}": v for k, v in sc.filter_config().as_dict().items()}
    params.update(spec_to_params(sc.filter_source_specs()))
    params.update({
        "init.t_s": float(init.t_s), "init.lat_deg": float(np.rad2deg(init.lat_rad)),
        "init.lon_deg": float(np.rad2deg(init.lon_rad)), "init.alt_m": float(init.alt_m),
        "init.vel_enu_mps": [float(x) for x in init.vel_enu_mps],
        "init.q_b_enu_xyzw": [float(x) for x in C_to_quat_xyzw(init.C_b_n)],
        "origin.lat_deg": float(np.rad2deg(start.lat_rad[0])), "origin.lon_deg": float(np.rad2deg(start.lon_rad[0])),
        "origin.alt_m": float(start.alt_m[0]), "qos.depth": int(sc["graph.qos_depth"]),
    })
    return params


def aiding_parameters(sc: Scenario, block: str) -> dict:
    """An aiding node's ROS parameters: the filter configuration it replays
    with (``filter.<field>``) and its scenario block flattened to dotted names."""
    def flat(d, prefix=""):
        out = {}
        for k, v in d.items():
            out.update(flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
        return out
    params = {f"filter.{k}": v for k, v in sc.filter_config().as_dict().items()}
    params.update(flat(sc.data[block]))
    return params


class Graph:
    def __init__(self, scenario: str | Scenario = "default", record: str | os.PathLike | None = None,
                 nodes=None, overrides: dict | None = None,
                 extra_subscribers: dict[str, int] | None = None, node_params: dict | None = None,
                 log_dir: str | os.PathLike | None = None, domain_id: int | None = None):
        base = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        self._tmp = tempfile.TemporaryDirectory(prefix="hyper_nav_graph_")
        self.workdir = pathlib.Path(self._tmp.name)
        self.scenario = apply_overrides(base, overrides, self.workdir)
        self.record = pathlib.Path(record) if record else None
        if nodes is None:
            nodes = DEFAULT_NODES[:-1] + tuple(n for n, block in OPTIONAL_SENSORS.items()
                                               if block in self.scenario.data) + ("fusion",) + \
                tuple(n for n, (block, _) in OPTIONAL_AIDING.items() if block in self.scenario.data)
        self.nodes = tuple(nodes)
        self.extra = dict(extra_subscribers or {})
        self.node_params = node_params or {}
        self.log_dir = pathlib.Path(log_dir) if log_dir else self.workdir / "logs"
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.domain_id = domain_id if domain_id is not None else int(os.environ.get("ROS_DOMAIN_ID", 0)) or \
            (os.getpid() % 100) + 1
        self.procs: dict[str, subprocess.Popen] = {}
        self._fusion_inputs = fusion_inputs(self.scenario)

    # ---- parameters ------------------------------------------------------------
    def _subscribers(self, topics, aiding: bool = True) -> int:
        """How many subscriptions the publishers of these topics must see
        (``aiding``: counting the aiding nodes that subscribe one of them)."""
        n = 1 if self.record else 0
        if "fusion" in self.nodes and self._fusion_inputs & set(topics):
            n += 1
        if aiding:
            n += sum(1 for a, (_, inputs) in OPTIONAL_AIDING.items() if a in self.nodes and set(inputs) & set(topics))
        return n + max((self.extra.get(t, 0) for t in topics), default=0)

    def _params(self, name: str) -> dict:
        sc_path = str(self.scenario.path)
        if name in SENSOR_TOPICS:
            p = {"scenario": sc_path, "min_subscribers": self._subscribers(SENSOR_TOPICS[name])}
            if name == "gnss":
                p["raw_min_subscribers"] = self._subscribers(["gnss/raw"])
        elif name == "truth":
            sensors = sum(1 for n in self.nodes if n in SENSOR_TOPICS)
            p = {"scenario": sc_path, "clock_subscribers": sensors + (1 if self.record else 0) + self.extra.get("/clock", 0),
                 "min_subscribers": self._subscribers(["truth/state"])}
        elif name == "fusion":
            p = fusion_parameters(self.scenario)
            # one count for all three outputs: the aiding nodes (nav/state only) are not waited for
            p["min_output_subscribers"] = self._subscribers(FUSION_OUTPUTS, aiding=False)
        elif name == "recorder":
            p = {"output": str(self.record), "qos_depth": int(self.scenario["graph.qos_depth"])}
        elif name in OPTIONAL_AIDING:
            p = aiding_parameters(self.scenario, OPTIONAL_AIDING[name][0])
        else:
            p = {}
        p.update(self.node_params.get(name, {}))
        return p

    def _params_file(self, name: str) -> pathlib.Path:
        path = self.workdir / f"{name}.params.yaml"
        path.write_text(yaml.safe_dump({"/**": {"ros__parameters": self._params(name)}}))
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
        self.procs[name] = subprocess.Popen(cmd, env=self.env(), stdout=log, stderr=subprocess.STDOUT,
                                            start_new_session=True)

    def start(self) -> "Graph":
        if self.record:
            self.record.parent.mkdir(parents=True, exist_ok=True)
            self._spawn("recorder")
        for name in self.nodes:
            self._spawn(name)
        return self

    def check_alive(self) -> None:
        for name, p in self.procs.items():
            if p.poll() not in (None, 0):
                raise RuntimeError(f"node '{name}' exited with code {p.returncode}; log:\n{self.log(name)[-3000:]}")

    def log(self, name: str) -> str:
        return (self.log_dir / f"{name}.log").read_text(errors="replace")

    def wait_until_done(self, timeout_s: float | None = None, drain_s: float = 2.0) -> None:
        """Wait for the truth node to finish the scenario, let messages drain,
        then stop every node (recorder last, so it closes a complete bag)."""
        if timeout_s is None:
            timeout_s = 120.0 + self.scenario["duration_s"] / self.scenario["graph.real_time_factor"] * 2.0
        deadline = time.monotonic() + timeout_s
        truth = self.procs.get("truth")
        while truth is not None and truth.poll() is None:
            self.check_alive()
            if time.monotonic() > deadline:
                raise TimeoutError(f"scenario did not finish within {timeout_s:.0f} s; truth log:\n{self.log('truth')[-2000:]}")
            time.sleep(0.2)
        self.check_alive()
        time.sleep(drain_s)
        self.stop()

    def stop(self) -> None:
        """SIGINT every node, the recorder last so it sees everything."""
        others = [n for n in self.procs if n != "recorder"]
        for name in others:
            self._interrupt(name)
        for name in others:
            self._reap(name)
        if "recorder" in self.procs and self.procs["recorder"].poll() is None:
            time.sleep(1.0)
            self._interrupt("recorder")
            self._reap("recorder")

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

    def __enter__(self) -> "Graph":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
        self._tmp.cleanup()


def main(argv=None) -> int:
    try:
        return _main(argv)
    except ScenarioError as exc:
        print(f"run_graph: error: {exc}", file=sys.stderr)
        return 2


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Start the hyper-nav node graph on a scenario.")
    ap.add_argument("--scenario", default="default", help="scenario name (installed) or YAML path")
    ap.add_argument("--record", help="bag directory to record every topic to (rosbag2, MCAP)")
    ap.add_argument("--report", action="store_true", help="print the accuracy report from the bag")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="override a scenario field, e.g. --set duration_s=60 (YAML value)")
    ap.add_argument("--nodes", default=None, help="comma-separated node names (default: every node the "
                    "scenario needs: truth, imu, gnss, mag, baro/radar when configured, fusion)")
    args = ap.parse_args(argv)
    overrides = {}
    for item in args.set:
        key, _, value = item.partition("=")
        overrides[key] = yaml.safe_load(value)
    record = args.record
    if record and pathlib.Path(record).exists():
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        record = f"{record}_{stamp}"
        print(f"[run_graph] {args.record} exists; recording to {record}")
    t0 = time.monotonic()
    with Graph(args.scenario, record=record, nodes=args.nodes.split(",") if args.nodes else None, overrides=overrides,
               log_dir=pathlib.Path(record).with_name(pathlib.Path(record).name + "_logs") if record else None) as g:
        print(f"[run_graph] scenario {g.scenario.name}: {g.scenario['duration_s']} s at "
              f"{g.scenario['graph.real_time_factor']}x real time; nodes: {', '.join(g.nodes)}")
        g.wait_until_done()
    print(f"[run_graph] graph finished in {time.monotonic() - t0:.1f} s wall")
    if record and args.report:
        from .report import main as report_main
        return report_main([record, "--scenario", str(args.scenario)] +
                           [f"--set={s}" for s in args.set])
    return 0


if __name__ == "__main__":
    sys.exit(main())
