"""ROS parameters of the simulation, recording and monitoring nodes, declared
once (``hyper_nav_filter.core.params.ParamSpec``: type, range, description)
and declared on the node with descriptors by ``ros_util.declare_params``,
which checks and coerces every value (a bad one is an error naming it at
start, never a crash later). ``run_graph`` writes them from the scenario
(``graph.py``); defaults that come from the scenario (QoS depth, status
period, GNSS latency, real-time factor) are filled in by ``with_scenario``
once the node has loaded it."""
from __future__ import annotations

import dataclasses

from hyper_nav_filter.core.params import BOOL, FLOAT, FLOATS, INT, STR, STRS, ParamSpec

SCENARIO = ParamSpec("scenario", STR, "default", "scenario name (installed) or path of a scenario YAML file")
DIAG_PERIOD = ParamSpec("diagnostics_period_s", FLOAT, 1.0, "wall-clock period of the /diagnostics status (s)",
                        lo=0.0, lo_open=True)

# every clock-driven sensor node (sensor_base.ClockDrivenSensor); defaults from the scenario: with_scenario
SENSOR = (
    ParamSpec("min_subscribers", INT, 0, "matched subscriptions each publisher waits for before data flows",
              lo=0),
    ParamSpec("wait_topics", STRS, (), "topics whose publishers wait for their own count (wait_counts) "
              "instead of min_subscribers"),
    ParamSpec("qos.depth", INT, 2000, "publisher history depth (graph.qos_depth)", lo=1),
    ParamSpec("clock.lead_s", FLOAT, 0.5, "the simulated clock may run at most this far (sim s) ahead of the /clock "
              "this node has worked through (/graph/allowance, hyper_nav_filter.clock_gate)", lo=0.0, lo_open=True),
    DIAG_PERIOD,
)
SENSOR_FROM_SCENARIO = {"qos.depth": "graph.qos_depth", "diagnostics_period_s": "graph.diagnostics_period_s"}


def frame_id(default: str, what: str) -> ParamSpec:
    return ParamSpec("frame_id", STR, default, f"header.frame_id of the {what} messages")


GNSS = (
    frame_id("gnss_antenna", "GNSS fix"),
    ParamSpec("enu_frame_id", STR, "enu", "frame_id of gnss/vel (ENU velocity)"),
    ParamSpec("latency_s", FLOAT, 0.0, "release delay of each fix after its epoch (gnss.latency_s)", lo=0.0),
    ParamSpec("raw_min_subscribers", INT, -1, "subscriptions gnss/raw and gnss/ephemeris wait for "
              "(-1: min(1, min_subscribers))", lo=-1),
)
GNSS_FROM_SCENARIO = {"latency_s": "gnss.latency_s"}

TRUTH = (
    SCENARIO,
    ParamSpec("real_time_factor", FLOAT, 3.0, "sim seconds per wall second (graph.real_time_factor)",
              lo=0.0, lo_open=True),
    ParamSpec("clock_subscribers", INT, 0, "subscriptions /clock waits for before the flight starts", lo=0),
    ParamSpec("clock_nodes", STRS, (), "nodes whose /clock subscription is awaited, by name"),
    ParamSpec("min_subscribers", INT, 0, "subscriptions truth/state waits for", lo=0),
    ParamSpec("wait_topics", STRS, (), "user topics whose subscribers the time source waits for"),
    ParamSpec("allowance_nodes", STRS, (), "nodes whose /graph/allowance the clock waits for (by name; "
              "hyper_nav_filter.clock_gate): the simulation slows down instead of losing or delaying data"),
    ParamSpec("allowance_timeout_s", FLOAT, 10.0, "a waited-for node silent this long (wall s) is no longer "
              "waited for", lo=0.0, lo_open=True),
    ParamSpec("tail_s", FLOAT, 1.0, "sim time flown past duration_s so that late releases go out (s)", lo=0.0),
    ParamSpec("command_publishers", INT, 0, "guidance nodes in the loop: publishers of the command topic "
              "(remappable 'guidance/command', hyper_nav_msgs/GlideCommand) awaited before the clock starts; "
              "with a scenario guidance: block the flight then waits for every command due (issue 36)", lo=0),
    ParamSpec("frames.enu", STR, "enu", "frame_id of the ENU (map) frame"),
    ParamSpec("frames.body", STR, "base_link", "frame_id of the body frame"),
    DIAG_PERIOD,
)
TRUTH_FROM_SCENARIO = {"real_time_factor": "graph.real_time_factor",
                       "diagnostics_period_s": "graph.diagnostics_period_s"}

MONITOR = (
    ParamSpec("nodes", STRS, (), "nodes watched by their /diagnostics heartbeat (ROS names)"),
    ParamSpec("streams", STRS, (), "topics watched for progress in sim time"),
    ParamSpec("stream_timeouts_s", FLOATS, (3.0,), "sim time without a message before a stream is missing, "
              "one per stream (s)", lo=0.0, lo_open=True),
    ParamSpec("critical_streams", STRS, (), "streams whose loss is an ERROR (the others: WARN)"),
    ParamSpec("end_s", FLOAT, float("nan"), "sim time the flight ends (streams are not missing after it; "
              "NaN: never)", optional=True),
    ParamSpec("heartbeat_timeout_s", FLOAT, 5.0, "wall time without a status before a node is dead (s)",
              lo=0.0, lo_open=True),
    ParamSpec("startup_timeout_s", FLOAT, 60.0, "wall time for a node's first status (s)", lo=0.0, lo_open=True),
    DIAG_PERIOD,
)

RECORDER = (
    ParamSpec("output", STR, "", "bag directory (required)"),
    ParamSpec("clock.lead_s", FLOAT, 0.5, "the simulated clock may run at most this far (sim s) ahead of the node "
              "clock at which the recorder last found every recorded topic's queue empty (/graph/allowance, "
              "hyper_nav_filter.clock_gate.InputDrain)", lo=0.0, lo_open=True),
    ParamSpec("topics", STRS, (), "topics to record (empty: every topic)"),
    ParamSpec("discovery_period_s", FLOAT, 0.2, "wall period of the topic discovery (s)", lo=0.0, lo_open=True),
    ParamSpec("drain_quiet_s", FLOAT, 0.5, "at shutdown, stop once nothing arrived for this long (s)", lo=0.0),
    ParamSpec("drain_max_s", FLOAT, 10.0, "at shutdown, stop draining after this long in any case (s)", lo=0.0),
    ParamSpec("qos_depth", INT, 2000, "subscription history depth", lo=1),
    DIAG_PERIOD,
)

PLAYER = (
    ParamSpec("bag", STR, "", "bag directory or .mcap file to replay (required)"),
    ParamSpec("rate", FLOAT, 1.0, "replay speed (sim seconds per wall second)", lo=0.0, lo_open=True),
    ParamSpec("publish_clock", BOOL, True, "publish /clock from the bag's stamps"),
    ParamSpec("wait_for_subscribers", INT, 0, "subscriptions every replayed topic waits for", lo=0),
    ParamSpec("wait_topics", STRS, (), "topics with their own subscriber count (wait_counts)"),
    ParamSpec("wait_timeout_s", FLOAT, 30.0, "wall time to wait for the subscribers (s)", lo=0.0),
    ParamSpec("allowance_nodes", STRS, (), "nodes whose /graph/allowance the clock waits for (by name; "
              "hyper_nav_filter.clock_gate): the simulation slows down instead of losing or delaying data"),
    ParamSpec("allowance_timeout_s", FLOAT, 10.0, "a waited-for node silent this long (wall s) is no longer "
              "waited for", lo=0.0, lo_open=True),
    ParamSpec("topics", STRS, (), "topics to replay (empty: every readable topic)"),
    ParamSpec("qos_depth", INT, 2000, "publisher history depth", lo=1),
    DIAG_PERIOD,
)


def with_scenario(specs, sc, mapping: dict) -> tuple:
    """``specs`` with the defaults named in ``mapping`` ({param: scenario field}) from scenario ``sc``."""
    return tuple(dataclasses.replace(s, default=s.check(sc[mapping[s.name]], "scenario: "))
                 if s.name in mapping else s for s in specs)
