"""monitor: liveness of the node graph on ``/diagnostics``.

Subscribes ``/diagnostics`` (every node's status with its ``heartbeat`` and
message counters) and ``/clock``, and publishes, every
``diagnostics_period_s`` of wall time, one DiagnosticStatus per expected node
(``hyper_nav_sim: monitor: node <name>``: ERROR when dead or never started)
and per expected stream (``hyper_nav_sim: monitor: stream <topic>``: WARN,
ERROR for a critical stream, when it stopped), plus its own summary status
(``hyper_nav_sim: monitor``, the worst level, with its heartbeat). The
decisions are made by ``hyper_nav_workbench.core.liveness``.

Parameters (``run_graph`` fills them from the scenario's ``monitor`` block):
    nodes (str[])                   node names to watch (DiagnosticStatus.hardware_id)
    streams (str[])                 topics to watch
    stream_timeouts_s (double[])    sim seconds without progress, one per stream
    critical_streams (str[])        streams whose loss is an ERROR (default: none)
    heartbeat_timeout_s (5.0)       wall seconds without a status before a node is dead
    startup_timeout_s (60.0)        wall seconds to wait for a node's first status
    end_s (inf)                     sim time at which the streams end (scenario duration)
    diagnostics_period_s (1.0)      wall seconds between verdicts

Why a node and not part of ``run_graph``: the verdicts belong on
``/diagnostics`` where every ROS tool (and the recorder, hence the report)
sees them, for any graph, including one started by hand on a vehicle;
``run_graph`` stays a process supervisor (exit codes, clean stop) without a
DDS participant of its own.
"""
from __future__ import annotations

import math
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from hyper_nav_filter.clock_gate import InputDrain
from hyper_nav_filter.ros_util import declare_params, publisher_qos, run_node

from hyper_nav_workbench.core.liveness import ERROR, OK, STALE, WARN, LivenessConfig, LivenessMonitor, StreamSpec
from hyper_nav_sim.nodes.params import MONITOR

LEVEL = {OK: DiagnosticStatus.OK, WARN: DiagnosticStatus.WARN, ERROR: DiagnosticStatus.ERROR,
         STALE: DiagnosticStatus.STALE}
NAME = "hyper_nav_sim: monitor"


class MonitorNode(Node):
    def __init__(self):
        super().__init__("monitor")
        p = declare_params(self, MONITOR)
        topics = [t.lstrip("/") for t in p["streams"]]
        timeouts = list(p["stream_timeouts_s"])
        if len(timeouts) != len(topics) and topics:
            raise ValueError(f"stream_timeouts_s {timeouts} must give one timeout per stream {topics}")
        critical = {t.lstrip("/") for t in p["critical_streams"]}
        cfg = LivenessConfig(
            nodes=tuple(p["nodes"]),
            streams=tuple(StreamSpec(t, float(dt), t in critical) for t, dt in zip(topics, timeouts)),
            heartbeat_timeout_s=p["heartbeat_timeout_s"], startup_timeout_s=p["startup_timeout_s"],
            end_s=math.inf if math.isnan(p["end_s"]) else p["end_s"])
        self.core = LivenessMonitor(cfg, time.monotonic())
        self.beats = 0
        self.pub = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        subs = [self.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, publisher_qos(1000)),
                self.create_subscription(Clock, "/clock", self._on_clock, publisher_qos(1000))]
        # verdicts only on what has arrived: the executor runs a due timer before the messages queued beside
        # it, so a monitor that was frozen (SIGSTOP) or starved would call every node dead on resuming
        self.inputs = InputDrain(self, lambda: subs, lead_s=0.0)
        self.period_s = p["diagnostics_period_s"]
        self._last_wall = None
        self._quiet_until = 0.0          # no verdicts before (wall): the monitor itself did not run
        self.create_timer(self.period_s, self.publish)
        self._last_level = {}

    def _on_clock(self, msg: Clock) -> None:
        self.core.on_clock(msg.clock.sec + msg.clock.nanosec * 1e-9)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        for st in msg.status:
            if st.name.startswith(NAME) or not st.hardware_id:
                continue
            self.core.on_status(st.hardware_id, {kv.key: kv.value for kv in st.values}, now)

    def publish(self) -> None:
        now, last = time.monotonic(), self._last_wall
        self._last_wall = now
        if last is not None and now - last > 3.0 * self.period_s + 1.0:
            # this monitor did not run (frozen, starved): the silence was its own, and what the others sent
            # meanwhile may still be on its way in (its DDS threads stopped too): no verdicts for two periods
            # (an overdue timer fires again at once)
            self.get_logger().warning(f"monitor: not run for {now - last:.1f} s (wall); no verdicts for "
                                      f"{2.0 * self.period_s:g} s")
            self._quiet_until = now + 2.0 * self.period_s
        if now < self._quiet_until:
            self.inputs.drain()
            return
        self.inputs.drain()
        verdicts = self.core.evaluate(time.monotonic())
        self.beats += 1
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        sim = self.core.sim_s
        for v in verdicts:
            st = DiagnosticStatus(level=LEVEL[v.level], name=f"{NAME}: {v.name}", message=v.message,
                                  hardware_id=self.get_name())
            values = {"since_t_s": "" if v.since_s is None else f"{v.since_s:.3f}",
                      "sim_time_s": "" if sim is None else f"{sim:.3f}"}
            st.values = [KeyValue(key=k, value=val) for k, val in values.items()]
            arr.status.append(st)
            if self._last_level.get(v.name) != v.level and v.level in (WARN, ERROR):
                if v.level == ERROR:           # one severity per call site (rclpy)
                    self.get_logger().error(f"{v.name}: {v.message}")
                else:
                    self.get_logger().warning(f"{v.name}: {v.message}")
            self._last_level[v.name] = v.level
        worst = max((LEVEL[v.level] for v in verdicts if v.level != STALE), default=DiagnosticStatus.OK)
        faults = [f"{v.name}: {v.message}" for v in verdicts if v.level in (WARN, ERROR)]
        summary = DiagnosticStatus(level=worst, name=NAME, hardware_id=self.get_name(),
                                   message="; ".join(faults) if faults else "all nodes and streams alive")
        summary.values = [KeyValue(key="heartbeat", value=str(self.beats)),
                          KeyValue(key="sim_time_s", value="" if sim is None else f"{sim:.3f}")]
        arr.status.insert(0, summary)
        self.pub.publish(arr)


def main(args=None):
    run_node(MonitorNode, args)


if __name__ == "__main__":
    main()
