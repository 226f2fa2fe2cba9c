"""Fusion node: the ESKF engine on live messages from declared sources.

Inputs are the ``sources`` table (``hyper_nav_filter.sources``; ROS
parameters ``sources`` and ``sources.<id>.type|topic|qos|...``, written by
``run_graph`` from the scenario's ``filter.sources``): each source subscribes
its topic(s) with its QoS and converts messages to core measurements, IMU
samples or model updates. Two output streams (STYLE pattern 19):

* current time, for guidance, control and ``/tf`` users: at every accepted
  IMU sample (every ``output.current_decimation``-th), the state at that
  sample's stamp (``FusionEngine.current``: predicted over the fusion
  horizon): ``nav/state`` (hyper_nav_msgs/NavState with covariance),
  ``nav/odom`` (nav_msgs/Odometry), ``nav/fix`` (NavSatFix) and REP-105
  ``map -> base_link`` on ``/tf``, stamped with the IMU message's own
  stamp; published in the IMU message's callback, as soon as the engine has
  taken the sample and before the released solutions;
* delayed, for the record, replay and scoring: the released solutions,
  ``output_delay_s`` behind and independent of arrival order, on
  ``nav/delayed/state``, ``nav/delayed/odom``, ``nav/delayed/fix`` (aiding
  nodes that feed back into the filter subscribe these).

Also ``base_link -> imu_link / gnss_antenna / magnetometer`` once on
``/tf_static`` (transient local) and ``/diagnostics`` (counters per input
topic, gate statistics, mode and the sources it runs on, stream liveness,
heartbeat). Each output message is kept as its serialized bytes and
published as such (``cdr_template``: no rclpy message object per sample).
The initial state
(``init.*``, ``core.initial_state``) includes the IMU error values. All math is in
``hyper_nav_filter.core``; parameters are declared once with descriptors
(``core.params``).
"""
from __future__ import annotations

import importlib
import sys
import time

import numpy as np
import rclpy.clock
from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import LateInput
from hyper_nav_msgs.msg import NavState as NavStateMsg
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import NavSatFix
from tf2_msgs.msg import TFMessage

from ..core.config import ALL_PARAMS, FilterConfig
from ..core.warmup import warm_up
from ..core.fusion import MODE_NAMES, FusionEngine
from ..core.initial_state import INIT_PARAMS, initial_state
from ..core.params import BOOL, FLOAT, FLOATS, INT, STR, ConfigError, ParamSpec, positive
from ..cdr_template import CdrTemplate
from ..clock_gate import ClockAllowance, InputsIdle, InputsReady
from ..replay_order import LATE_INPUTS_TOPIC, LateInputTracker, stamp_ns
from ..realtime import REALTIME_PARAMS, apply as apply_realtime
from ..output import (OutputFrames, map_pose, navsatfix_fields, navstate_fields, odometry_fields,
                      static_transform_fields, transform_fields)
from ..ros_util import (EXECUTORS, all_matched, assign_fields, declare_params, diagnostic_array, latched_qos,
                       publisher_qos, run_node, subscriber_qos)
from ..sources import DEFAULT_TABLE, load_plugins, table_from_params
from ..sources.base import DELAY_PARAM
from ..sources.router import SourceRouter

NODE_PARAMS = (
    ParamSpec("frames.map", STR, "map", "REP-105 map frame (ENU tangent plane at the origin)"),
    ParamSpec("frames.enu", STR, "enu", "local-level frame of nav/state"),
    ParamSpec("frames.body", STR, "base_link", "body frame (FLU): the IMU's reference point and axes"),
    ParamSpec("frames.imu", STR, "imu_link", "IMU frame (child of base_link on /tf_static)"),
    ParamSpec("frames.gnss_antenna", STR, "gnss_antenna", "GNSS antenna frame, at filter.antenna_lever_arm_b_m"),
    ParamSpec("frames.magnetometer", STR, "magnetometer", "magnetometer frame"),
    ParamSpec("tf.publish", BOOL, True, "publish map -> base_link on /tf and the sensor frames on /tf_static"),
    ParamSpec("tf.min_subscribers", INT, 0, "with min_output_subscribers: wait for this many subscribers on /tf "
              "and /tf_static before subscribing to the inputs", lo=0, hi=100),
    ParamSpec("tf.imu_position_b_m", FLOATS, (0.0, 0.0, 0.0), "IMU position in base_link (FLU, m); the filter's "
              "body frame is the IMU's, so normally zero", length=3),
    ParamSpec("tf.imu_rotation_b_xyzw", FLOATS, (0.0, 0.0, 0.0, 1.0), "IMU axes in base_link, unit quaternion "
              "(x, y, z, w; scenario imu.mounting_b_xyzw: the mounting import_data applied)", length=4),
    ParamSpec("tf.magnetometer_position_b_m", FLOATS, (0.0, 0.0, 0.0), "magnetometer position in base_link "
              "(FLU, m; scenario magnetometer.lever_arm_b_m)", length=3),
    ParamSpec("origin.lat_deg", FLOAT, float("nan"), "map origin latitude (deg); NaN = the initial position",
              optional=True),
    ParamSpec("origin.lon_deg", FLOAT, float("nan"), "map origin longitude (deg)", optional=True),
    ParamSpec("origin.alt_m", FLOAT, float("nan"), "map origin height (m)", optional=True),
    ParamSpec("qos.depth", INT, 2000, "KEEP_LAST depth of reliable subscriptions and publishers", lo=1, hi=100000),
    ParamSpec("min_output_subscribers", INT, 0, "wait for this many subscribers on every output before "
              "subscribing to the inputs", lo=0, hi=100),
    positive("diagnostics_period_s", FLOAT, 1.0, "period of /diagnostics (wall s)"),
    positive("liveness.aiding_timeout_s", FLOAT, 5.0, "an aiding stream silent this long in sim time, while the "
             "IMU runs, is reported stale (WARN)"),
    positive("liveness.imu_timeout_s", FLOAT, 3.0, "no IMU message for this long (wall s) after the first is "
             "reported (WARN)"),
    ParamSpec("output.current_decimation", INT, 1, "publish the current-time state (nav/state, nav/odom, nav/fix, "
              "/tf) at every n-th IMU sample", lo=1, hi=100000),
    ParamSpec("executor", STR, "events", "the executor the node spins in: events (rclpy's EventsExecutor, "
              "experimental upstream: callbacks pushed by the middleware; at a 1 kHz IMU 45-48 % of a core and a "
              "p99 latency of 0.9-1.3 ms where single takes 76-80 % and 4.5-19 ms, benchmarks/current_latency.py) "
              "or single (rclpy's SingleThreadedExecutor, the upstream default)", choices=EXECUTORS),
    ParamSpec("publish_final_solutions", BOOL, True, "release and publish the last output_delay_s of solutions "
              "at shutdown"),
    positive("clock.lead_s", FLOAT, 0.5, "the simulated clock may run at most this far (sim s) ahead of the newest "
             "IMU epoch processed (/graph/allowance, hyper_nav_filter.clock_gate; waited for when the time source "
             "lists this node)"),
    positive("clock.imu_gap_s", FLOAT, 0.25, "when the /clock this node has taken is this far (sim s) past its newest "
             "IMU epoch (a gap in the IMU data, the end of a truncated bag, a dead IMU node), the allowance follows "
             "that /clock (+ clock.lead_s) instead: an empty IMU stream is not a node behind its queue. Below "
             "clock.lead_s, or the clock could never get there"),
)
_OUTPUTS = ("nav/state", "nav/odom", "nav/fix")                              # current time, IMU rate
DELAYED_OUTPUTS = ("nav/delayed/state", "nav/delayed/odom", "nav/delayed/fix")    # released, order-independent


class _Output:
    """A publisher and its message kept as CDR bytes (``cdr_template``: the
    numbers written in place, no rclpy message object per sample)."""

    def __init__(self, pub, template: CdrTemplate):
        self.pub, self.template = pub, template

    def send(self, fields: dict, stamp=None) -> None:
        """Publish ``fields``, stamped with ``stamp`` (a received Time) when given."""
        tpl = self.template
        tpl.fill(fields)
        if stamp is not None:
            tpl.set_stamp("header.stamp", stamp.sec, stamp.nanosec)
        self.pub.publish(tpl.bytes())


def tf_message(fields: dict) -> TFMessage:
    """A TFMessage of one TransformStamped from its flat fields (``output.transform_fields``)."""
    t = TransformStamped()
    assign_fields(t, fields)
    return TFMessage(transforms=[t])


def message_class(type_name: str):
    """``pkg/msg/Name`` -> the rclpy message class."""
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


class FusionNode(Node):
    def __init__(self, **node_kw):
        """``node_kw``: rclpy Node arguments (e.g. ``context`` in tests)."""
        super().__init__("fusion", **node_kw)
        cfg = declare_params(self, ALL_PARAMS, "filter.", "filter.")
        self.cfg = FilterConfig(**cfg)
        self.p = declare_params(self, NODE_PARAMS + REALTIME_PARAMS)
        p = self.p
        for problem in apply_realtime({k: v for k, v in p.items() if k.startswith("realtime.")}):
            self.get_logger().warning(problem)
        self.executor_kind = p["executor"]          # read by ros_util.run_node
        self.table = self._declare_sources()
        self.init = declare_params(self, INIT_PARAMS, "init.")
        warm_up()                       # compiled kernels loaded (or compiled) before any message arrives
        self.engine = FusionEngine(self.cfg, initial_state(self.init))
        self.router = SourceRouter(self.engine, self.table)
        origin = [p["origin.lat_deg"], p["origin.lon_deg"], p["origin.alt_m"]]
        if not np.all(np.isfinite(origin)):
            origin = [self.init["lat_deg"], self.init["lon_deg"], self.init["alt_m"]]
        self.frames = OutputFrames(p["frames.map"], p["frames.enu"], p["frames.body"],
                                   np.deg2rad(origin[0]), np.deg2rad(origin[1]), origin[2])
        qos = publisher_qos(p["qos.depth"])
        types = (NavStateMsg, Odometry, NavSatFix)
        self.out_current = tuple(_Output(self.create_publisher(c, t, qos), CdrTemplate(c))
                                 for c, t in zip(types, _OUTPUTS))
        self.out_delayed = tuple(_Output(self.create_publisher(c, t, qos), CdrTemplate(c))
                                 for c, t in zip(types, DELAYED_OUTPUTS))
        self._n_imu = 0
        self.out_tf = self.pub_tf_static = None
        if p["tf.publish"]:
            self.out_tf = _Output(self.create_publisher(TFMessage, "/tf", qos),
                                  CdrTemplate(TFMessage, tf_message, prefix="transforms.0."))
            self.pub_tf_static = self.create_publisher(TFMessage, "/tf_static", latched_qos(10))
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        # inputs received behind the IMU (replay_order): transient local, so a late-joining recorder gets them
        self.pub_late = self.create_publisher(LateInput, LATE_INPUTS_TOPIC, latched_qos(p["qos.depth"]))
        self.late = LateInputTracker()
        q = np.asarray(p["tf.imu_rotation_b_xyzw"], float)
        if not (np.all(np.isfinite(q)) and abs(np.linalg.norm(q) - 1.0) <= 1e-6):
            raise ConfigError(f"tf.imu_rotation_b_xyzw: must be a unit quaternion (x, y, z, w), got {q.tolist()}")
        if not p["clock.imu_gap_s"] < p["clock.lead_s"]:
            raise ConfigError(f"clock.imu_gap_s ({p['clock.imu_gap_s']}) must be below clock.lead_s "
                              f"({p['clock.lead_s']}): the clock could never pass an IMU gap")
        # no allowance before the inputs are matched from this side (clock_gate: a time source that waits
        # for this node sends nothing this node's subscriptions would drop)
        self._input_subs = []
        imu_topics = [inp.topic for src in self.router.sources if src.drives_time for inp in src.inputs()
                      if inp.role == "main"]
        self.allowance = ClockAllowance(self, ready=InputsReady(self, lambda: self._input_subs, required=imu_topics))
        self._clock_s = -np.inf          # the newest /clock taken (in this executor, beside the inputs)
        # every declared input, whatever its rate (issue 33): the clock stays clock.lead_s ahead of the last
        # moment all input queues were empty (seen without taking: the executor keeps its order)
        # (checked as the IMU is processed, at most every 5 ms of wall time: a check costs 50-150 us; and on a
        # 20 ms wall timer, for a clock held with nothing arriving)
        self._idle = InputsIdle(self, lambda: self._input_subs, p["clock.lead_s"], lambda: self._clock_s)
        self._idle_wall = 0.0
        self.create_timer(0.02, self._check_idle, clock=rclpy.clock.Clock(clock_type=rclpy.clock.ClockType.STEADY_TIME))
        self._set_allowance()
        self.counts = {f"published {t}": 0 for t in _OUTPUTS + DELAYED_OUTPUTS}
        self.counts[f"published {LATE_INPUTS_TOPIC}"] = 0
        if self.out_tf is not None:
            self.counts.update({"published tf": 0, "published tf_static": 0})
        self._subs = []
        self._last_imu_wall = None
        self._last_msg_t = {}            # source id -> filter time of its last processed message
        self._heartbeat = 0
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(p["diagnostics_period_s"], self._publish_diagnostics)

    def _declare_sources(self) -> dict:
        """The sources table from the flat parameters (declared with descriptors)."""
        ids = self.declare_parameter("sources", list(DEFAULT_TABLE)).value
        values = {"sources": list(ids)}
        for sid in ids:
            dflt = DEFAULT_TABLE.get(sid, {})             # imu, gnss_fix, gnss_vel: loosely coupled by default
            base = [ParamSpec(f"sources.{sid}.{k}", STR, d, desc) for k, d, desc in (
                ("type", dflt.get("type", ""), "registered source type"),
                ("topic", dflt.get("topic", ""), "input topic"),
                ("qos", "reliable", "reliable or sensor_data"), ("msg", "", "ROS message type (default: the type's)"))]
            for s in base:
                values[s.name] = self.declare_parameter(s.name, s.default).value
            values[f"sources.{sid}.delay_s"] = declare_params(self, (DELAY_PARAM,), f"sources.{sid}.")["delay_s"]
            registry = load_plugins()                 # the built-in types and those other packages declare
            cls = registry.get(values[f"sources.{sid}.type"])
            if cls is None:
                raise ConfigError(f"sources.{sid}.type: unknown source type {values[f'sources.{sid}.type']!r} "
                                  f"(known: {sorted(registry)})")
            values.update({f"sources.{sid}.{k}": v for k, v in
                           declare_params(self, cls.PARAMS, f"sources.{sid}.").items()})
            if not values[f"sources.{sid}.msg"]:
                values[f"sources.{sid}.msg"] = None
        return table_from_params(lambda name, default: values.get(name, default))

    def _start_when_ready(self):
        """Subscribe to inputs only once every output has its subscribers, so
        nothing computed is published into the void."""
        if not all_matched([o.pub for o in self.out_current], self.p["min_output_subscribers"]):
            return
        if self.out_tf is not None:
            if not all_matched([self.out_tf.pub, self.pub_tf_static], self.p["tf.min_subscribers"]):
                return
            self._publish_static_transforms()
        self._wait_timer.cancel()
        depth = self.p["qos.depth"]
        self._subs.append(self.create_subscription(Clock, "/clock", self._on_clock, publisher_qos(1000)))
        # latched inputs (ephemerides) first: when both are ready, the executor takes them in creation order
        pairs = [(src, inp) for src in self.router.sources for inp in src.inputs()]
        for src, inp in sorted(pairs, key=lambda si: not si[1].latched):
            qos = latched_qos(max(depth, 500)) if inp.latched else \
                subscriber_qos(src.spec.qos == "reliable", depth)
            name = self.resolve_topic_name(inp.topic)         # after remapping: the topic the bag records
            cb = (lambda msg, s=src, r=inp.role, t=name: self._on_message(s, r, msg, t))
            self._input_subs.append(self.create_subscription(message_class(inp.msg_type), inp.topic, cb, qos))
        self._subs.extend(self._input_subs)
        self.get_logger().info("outputs matched; sources: " + ", ".join(
            f"{s.id} ({s.spec.type}) <- {', '.join(i.topic for i in s.inputs())}" for s in self.router.sources))

    def _on_message(self, src, role, msg, topic):
        imu = src.drives_time and role == "main"
        if imu:
            self._last_imu_wall = time.monotonic()
        t_ns = stamp_ns(msg)
        report, after_release = None, False
        if imu or not src.drives_time:
            # (the IMU source's other input, the structure load, pairs with its IMU samples whatever
            # the arrival order: not a late input)
            report, after_release = self.late.arrival(topic, t_ns, imu, self.engine.last_released_t_s)
        reason, sols = self.router.handle(src, role, msg)
        if imu and reason is None:
            self._n_imu += 1
            if self._n_imu % self.p["output.current_decimation"] == 0 and self.engine.current is not None:
                self._publish_current(self.engine.current, msg.header.stamp)
        if reason is None and not src.drives_time:
            self._last_msg_t[src.id] = self.engine.t_latest_s
        elif reason is not None:
            self.get_logger().warning(f"{src.id}: rejected {role} message: {reason}", throttle_duration_sec=5.0)
        if imu and reason is None:
            self.late.imu_accepted(t_ns)
        if src.drives_time and reason is None:
            self._set_allowance()
        if report is not None:
            self._publish_late(msg, report, reason or ("applied_after_release" if after_release else "applied"))
        self._publish(sols)

    def _on_clock(self, msg):
        self._clock_s = max(self._clock_s, msg.clock.sec + msg.clock.nanosec * 1e-9)
        self._set_allowance()

    def _set_allowance(self):
        """/graph/allowance (clock_gate): the newest IMU epoch + clock.lead_s;
        the /clock taken + clock.lead_s once that is clock.imu_gap_s past the
        newest IMU (no IMU data to wait for)."""
        t_imu, lead = self.engine.t_latest_s, self.p["clock.lead_s"]
        if (wall := time.monotonic()) - self._idle_wall >= 0.005:
            self._idle_wall = wall
            self._idle.check()
        # IMU samples held for their structure load (imu source's load_topic) are IMU data to wait
        # for: the clock stays at the engine's epoch + lead until they are in, so the load stream,
        # 8 messages per IMU sample through one subscription, catches up (a free clock let it fall
        # 1100 messages behind at real-time factor 2 on a loaded machine)
        held = sum(s.n_held_imu for s in self.router.sources)
        t = self._clock_s if self._clock_s > t_imu + self.p["clock.imu_gap_s"] and not held else t_imu
        self.allowance.set(min(t + lead, self._idle.allowance_s()))

    def _check_idle(self):
        self._idle_wall = 0.0                 # _set_allowance checks now
        self._set_allowance()

    def _publish_late(self, msg, report, outcome):
        """Report an input received behind the IMU (``nav/late_inputs``), so a
        replay can feed it where the node received it (``replay_order``)."""
        m = LateInput()
        m.header.stamp = msg.header.stamp
        m.header.frame_id = getattr(msg.header, "frame_id", "")
        m.topic, m.occurrence, m.outcome = "/" + report.topic, report.occurrence, outcome
        m.after_imu_stamp.sec, m.after_imu_stamp.nanosec = divmod(report.after_imu_ns, 1_000_000_000)
        self.pub_late.publish(m)
        self.counts[f"published {LATE_INPUTS_TOPIC}"] += 1

    def _publish_stream(self, sol, outs, names, stamp=None):
        """NavState, Odometry and NavSatFix of one solution; its map pose.
        ``stamp``: the header stamp as received (the IMU message's: float
        seconds of a wall-clock epoch keep 0.24 us, not the nanoseconds)."""
        # each message published as soon as it is built: NavState first (what guidance waits for)
        lay = self.cfg.layout
        outs[0].send(navstate_fields(sol, lay, self.frames, self.cfg.mechanization_frame), stamp)
        pose = map_pose(sol, self.frames)
        outs[1].send(odometry_fields(sol, lay, self.frames, pose), stamp)
        outs[2].send(navsatfix_fields(sol, lay, self.frames), stamp)
        for t in names:
            self.counts[f"published {t}"] += 1
        return pose

    def _publish_current(self, sol, stamp):
        """The current-time state (nav/state, nav/odom, nav/fix, /tf), stamped as its IMU sample."""
        pose = self._publish_stream(sol, self.out_current, _OUTPUTS, stamp)
        if self.out_tf is not None:
            self.out_tf.send(transform_fields(sol, self.frames, pose), stamp)
            self.counts["published tf"] += 1

    def _publish(self, solutions):
        """Released solutions (the delayed stream)."""
        for sol in solutions:
            self._publish_stream(sol, self.out_delayed, DELAYED_OUTPUTS)

    def _publish_static_transforms(self):
        """base_link -> imu_link / gnss_antenna / magnetometer (lever arms, body FLU; the IMU's mounting
        rotation), once, latched."""
        p = self.p
        identity = (0.0, 0.0, 0.0, 1.0)
        children = {p["frames.imu"]: (p["tf.imu_position_b_m"], p["tf.imu_rotation_b_xyzw"]),
                    p["frames.gnss_antenna"]: (self.cfg.antenna_lever_arm_b_m, identity),
                    p["frames.magnetometer"]: (p["tf.magnetometer_position_b_m"], identity)}
        msg = TFMessage()
        for child, (position, rotation) in children.items():
            t = TransformStamped()
            assign_fields(t, static_transform_fields(self.engine.t_latest_s, self.frames.body, child, position,
                                                     rotation))
            msg.transforms.append(t)
        self.pub_tf_static.publish(msg)
        self.counts["published tf_static"] += 1

    def on_shutdown(self):
        """At SIGINT/SIGTERM (ros_util.run_node): publish the solutions still
        held back by output_delay_s, then the final /diagnostics (its
        published counts are the node's last word, matched by the recorder)."""
        if self.p["publish_final_solutions"] and self._subs:
            self._publish(self.engine.release(final=True))
        self._publish_diagnostics()

    def _liveness(self) -> list[str]:
        """Problems with the input streams, for the diagnostics message."""
        problems = []
        now = time.monotonic()
        if self._last_imu_wall is not None and now - self._last_imu_wall > self.p["liveness.imu_timeout_s"]:
            problems.append(f"no IMU for {now - self._last_imu_wall:.1f} s")
        t = self.engine.t_latest_s
        for src in self.router.sources:
            if src.drives_time or src.id not in self._last_msg_t:
                continue
            silent = t - self._last_msg_t[src.id]
            if silent > self.p["liveness.aiding_timeout_s"]:
                problems.append(f"{src.id} ({src.spec.topic}) silent for {silent:.1f} s")
        return problems

    def _publish_diagnostics(self):
        self._heartbeat += 1
        eng, kf = self.engine, self.engine.kf
        c = dict(eng.counters)
        c.update(self.counts)
        c.update(self.router.diagnostics())
        mode, kinds = eng.mode_now()
        c.update({"heartbeat": self._heartbeat, "mode": MODE_NAMES[mode], "mode_sources": ",".join(kinds),
                  "n_updates": kf.n_updates, "n_rejected_gate": kf.n_rejected, "last_nis": f"{kf.last_nis:.3f}",
                  "filter_time_s": f"{eng.t_latest_s:.3f}", "sources": ",".join(s.id for s in self.router.sources)})
        problems = self._liveness()
        for kind, (acc, rej, nis_sum) in kf.stats.items():
            c[f"{kind}_accepted"] = acc
            c[f"{kind}_gated"] = rej
            c[f"{kind}_mean_nis_per_dof"] = f"{nis_sum / max(acc, 1):.3f}"
            w = kf.watch.get(kind)
            c[f"{kind}_far"] = w.far if w else 0
            c[f"{kind}_lockout_recoveries"] = w.recoveries if w else 0
            if w and w.recoveries:
                problems.append(f"{kind}: {w.recoveries} lock-out recoveries, last at t = {w.t_last_recovery_s:.2f} s")
        rejected = sum(v for k, v in c.items() if str(k).startswith("rejected_"))
        if eng.counters.get("imu_gaps"):
            problems.append(f"{eng.counters['imu_gaps']} IMU gap(s) bridged, last {eng.gaps[-1][0]:.2f}-"
                            f"{eng.gaps[-1][1]:.2f} s")
        arr = diagnostic_array(self, "hyper_nav_filter: fusion", rejected == 0 and not problems,
                               "; ".join(problems + [f"{rejected} input messages rejected",
                                                     f"mode: {MODE_NAMES[mode]}"]), c)
        self.pub_diag.publish(arr)



def main(args=None):
    # up to 5 s for every subscriber to acknowledge the final solutions (the last
    # output_delay_s of them go out at shutdown; at 0.3 s a loaded recorder missed
    # 11 of 100 while a second subscriber of nav/state was shutting down too)
    try:
        run_node(FusionNode, args, linger_s=5.0)
    except ConfigError as exc:                 # a wrong parameter: one line naming it, no traceback
        print(f"fusion_node: parameter error: {exc}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
