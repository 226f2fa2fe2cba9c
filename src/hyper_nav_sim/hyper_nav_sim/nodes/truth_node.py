"""Truth node: sim-time source (``/clock``) and ``truth/state``.

Advances sim time in steps of 1 / graph.clock_rate_hz, paced at
graph.real_time_factor x wall time (steps of real_time_factor /
graph.clock_max_wall_hz when those are longer: at most clock_max_wall_hz
/clock messages per wall second; the sensor nodes release every sample due at
each step, stamped with its own epoch), once each node named in ``clock_nodes``
has a ``/clock`` subscription (by node name: a count would be fooled by a node
with two, e.g. a recorder on sim time) and ``/clock`` has ``clock_subscribers``
matched subscriptions and ``truth/state`` has ``min_subscribers``. Publishes
the exact truth (hyper_nav_msgs/NavState, mode TRUTH) at graph.truth_rate_hz,
and exits ``tail_s`` of sim time after the scenario ends.

The clock never passes what the nodes in ``allowance_nodes`` allow
(``hyper_nav_filter.clock_gate``: on a loaded machine the flight slows down
in wall time instead of losing or delaying data; ``clock_held_s`` on
/diagnostics says how long it waited).

Waiting for ``wait_topics`` as well: topics (e.g. ``nav/odom``) whose
subscriber count must reach ``wait_counts`` before the clock starts, so a
test's or user's own subscriber sees the first message (``Graph(...,
extra_subscribers=...)``). Its ``/diagnostics`` status carries ``sim_time_s``
and ``heartbeat`` every ``diagnostics_period_s`` of wall time, and a last one
with ``finished: true``.

Live commands (issue 36): with a scenario ``guidance:`` block and a
``flight:`` block, the flight is a ``core.commanded_flight.CommandedFlight``
stepped as the clock advances, with the bank and lift commands received on
``command_topic`` (``guidance.command_topic``, remappable;
``hyper_nav_msgs/GlideCommand``). A command stamped t_nav applies at the
declared step ceil((t_nav + guidance.apply_delay_s) / guidance.period_s),
and when a guidance is in the loop (``command_publishers`` > 0, or a
publisher present when the clock starts) the clock never passes a step
whose commands are not all in (``CommandLoop``): the same commands give the
same flight, live or offline, bit for bit. Without a publisher the
scheduled program flies. Refused commands (out of range, NaN, late) are
counted on /diagnostics by reason; a command awaited for
``guidance.command_timeout_s`` of wall time is given up (``commands missed``).
The truth stops at the flight's end (e.g. ``flight.end_alt_m``); the clock
runs on to duration_s. Every step flown goes out on ``flight/steps``
(hyper_nav_msgs/FlightStep: the step and the command that took effect at
it; transient local) before the /clock that passes it: the sensor nodes fly
a mirror of the same flight from them (``flight_mirror``), so their
measurements, and the navigation made from them, follow the steered flight.
"""
from __future__ import annotations

import math
import time

import numpy as np
import rclpy
from hyper_nav_msgs.msg import FlightStep, GlideCommand, NavState
from rclpy.duration import Duration
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from hyper_nav_filter.clock_gate import AllowanceGate
from hyper_nav_filter.conversions import s_to_stamp_fields, stamp_to_s
from hyper_nav_filter.core.attitude import C_to_quat_xyzw
from hyper_nav_filter.ros_util import all_matched, declare_params, publisher_qos, run_node

from ..core.commanded_flight import CommandLoop, flight_of_scenario
from ..core.imu_model import ImuErrors
from ..core.scenario import load_scenario
from .flight_mirror import FLIGHT_STEPS_TOPIC, steps_qos
from .params import TRUTH, TRUTH_FROM_SCENARIO, with_scenario
from .status import NodeStatus


class TruthNode(Node):
    def __init__(self):
        super().__init__("truth")
        sc = self.scenario = load_scenario(declare_params(self, TRUTH[:1])["scenario"])
        p = declare_params(self, with_scenario(TRUTH[1:], sc, TRUTH_FROM_SCENARIO))
        self.rtf = p["real_time_factor"]
        self.clock_subscribers = p["clock_subscribers"]
        self.clock_nodes = set(p["clock_nodes"])
        self.min_subscribers = p["min_subscribers"]
        self.wait_topics = list(p["wait_topics"])
        self.declare_parameter("wait_counts", [0])
        self.wait_counts = list(self.get_parameter("wait_counts").value)
        if len(self.wait_counts) != len(self.wait_topics) and self.wait_topics:
            raise ValueError(f"wait_counts {self.wait_counts} must give one count per wait_topics entry "
                             f"{self.wait_topics}")
        self.tail_s = p["tail_s"]
        self.enu_frame, self.body_frame = p["frames.enu"], p["frames.body"]
        qos = publisher_qos(sc["graph.qos_depth"])
        self.pub_clock = self.create_publisher(Clock, "/clock", qos)
        self.pub_truth = self.create_publisher(NavState, "truth/state", qos)
        self.status = NodeStatus(self, "hyper_nav_sim: truth")
        self.create_timer(p["diagnostics_period_s"], self._diag)
        base_step_s = 1.0 / sc["graph.clock_rate_hz"]
        self.step_s = max(base_step_s, self.rtf / sc["graph.clock_max_wall_hz"])
        self.n_steps = int(np.ceil((sc["duration_s"] + self.tail_s) / self.step_s - 1e-9))
        # truth epochs on the graph.clock_rate_hz grid whatever the /clock step
        truth_every = max(1, int(round(sc["graph.clock_rate_hz"] / sc["graph.truth_rate_hz"])))
        steps = np.arange(0, int(np.floor(sc["duration_s"] / base_step_s + 1e-9)) + 1)
        t_truth = steps[steps % truth_every == 0] * base_step_s
        self._t_truth = t_truth
        self.loop = None
        self.counts = {"published /clock": 0, "published truth/state": 0}
        if "guidance" in sc.data and "flight" in sc.data:
            self._setup_commands(sc, p)
            self.truth = None
        else:
            self.truth = sc.trajectory().truth(t_truth)
        self._truth_idx = 0
        self.imu_errors = ImuErrors.from_scenario(sc)
        self.k = 0
        self.t_wall0 = None
        self.done = False
        self.gate = AllowanceGate(self, p["allowance_nodes"], p["allowance_timeout_s"])
        self.timer = self.create_timer(0.05, self._wait)

    def _wait(self):
        subscribed = {i.node_name for i in self.get_subscriptions_info_by_topic(self.pub_clock.topic_name)}
        if not (self.pub_clock.get_subscription_count() >= self.clock_subscribers and self.clock_nodes <= subscribed
                and all_matched([self.pub_truth], self.min_subscribers)
                and all(self.count_subscribers(t) >= n for t, n in zip(self.wait_topics, self.wait_counts))):
            return
        if self.loop is not None and self.count_publishers(self.sub_cmd.topic_name) < self.command_publishers:
            return
        self.timer.cancel()
        if self.loop is not None:
            self.loop.expect = self.count_publishers(self.sub_cmd.topic_name) > 0
            self.get_logger().info("flight commanded live on " + self.sub_cmd.topic_name if self.loop.expect
                                   else "no command publisher: the scenario's program flies")
        self.gate.restart()                    # the nodes' not-heard timeout counts from the start of the flight
        self.get_logger().info(f"subscribers matched; flying {self.scenario.name} at {self.rtf}x real time")
        self.t_wall0 = time.monotonic()
        self.timer = self.create_timer(min(0.01, self.step_s / self.rtf), self._tick)

    def _tick(self):
        # paced at real_time_factor, and never past what the slowest waited-for node allows
        paced = int((time.monotonic() - self.t_wall0) * self.rtf / self.step_s)
        limit = self.gate.limit_s()
        if self.k * self.step_s > self.scenario["duration_s"] + 1e-9:
            limit = float("inf")          # the tail: no sensor data any more, nothing to wait for
        allowed = paced if limit == float("inf") else int(np.floor(limit / self.step_s + 1e-9))
        if self.loop is not None:         # and never past the flight the commands due allow
            allowed = min(allowed, self._fly_to(min(self.n_steps, paced)))
        if allowed < paced:
            self.t_wall0 += self.timer.timer_period_ns * 1e-9          # held: the pace resumes from here
            self.gate.held_s += self.timer.timer_period_ns * 1e-9
        target = min(self.n_steps, paced, allowed)
        while self.k <= target and not self.done:
            t = self.k * self.step_s
            self._publish_truth_until(t)
            c = Clock()
            c.clock.sec, c.clock.nanosec = s_to_stamp_fields(t)
            self.pub_clock.publish(c)
            self.counts["published /clock"] += 1
            self.k += 1
            if self.k > self.n_steps:
                self.done = True
        if self.done:
            self.timer.cancel()
            self._diag()
            # reliable delivery: wait until every subscriber acknowledged
            for pub in (self.pub_clock, self.pub_truth, self.status.pub) + \
                    ((self.pub_steps,) if self.loop is not None else ()):
                pub.wait_for_all_acked(Duration(seconds=10.0))
            self.get_logger().info("scenario finished")
            rclpy.try_shutdown()

    # ---- live commands ------------------------------------------------------------
    def _setup_commands(self, sc, p):
        cfg, flight = flight_of_scenario(sc)
        self.guidance = cfg
        self.flight = flight
        # every flown step, to the sensor nodes' mirrors (transient local: a late joiner gets them all)
        self.pub_steps = self.create_publisher(FlightStep, FLIGHT_STEPS_TOPIC, steps_qos(flight))
        self._k_published, self._cmd_published = 0, 0
        self.counts["published flight/steps"] = 0
        self.loop = CommandLoop(flight, cfg.t_start_s, expect=False, t_end_s=sc["duration_s"])
        self.command_publishers = p["command_publishers"]
        self.sub_cmd = self.create_subscription(GlideCommand, cfg.command_topic, self._on_command,
                                                publisher_qos(sc["graph.qos_depth"]))
        self._wait_since = None
        self.counts.update({"commands received": 0, "commands accepted": 0, "commands missed": 0})

    def _on_command(self, msg):
        self.counts["commands received"] += 1
        t = stamp_to_s(msg.header.stamp)
        why = self.loop.receive(t, msg.bank_rad, msg.c_l)
        if why is None:
            self.counts["commands accepted"] += 1
        else:
            key = f"commands refused {why}"
            self.counts[key] = self.counts.get(key, 0) + 1
            self.get_logger().warning(f"command at {t:.3f} s refused ({why}): bank {msg.bank_rad!r} rad, "
                                      f"c_l {msg.c_l!r}")

    def _fly_to(self, target: int) -> int:
        """Integrate the flight as far as the commands allow toward clock step
        ``target``; returns the last clock step whose truth exists."""
        f = self.flight
        h = f.step_s
        t_goal = target * self.step_s
        self.loop.advance(math.ceil(t_goal / h - 1e-9) * h)
        self._publish_steps()
        if f.finished:
            return target
        k_ok = int(np.floor(f.flown_s / self.step_s + 1e-9))
        awaited = self.loop.waiting_for_s() if k_ok < target else None
        if awaited is not None:
            now = time.monotonic()
            if self._wait_since is None or self._wait_since[1] != awaited:
                self._wait_since = (now, awaited)          # the timeout counts per awaited command
            elif now - self._wait_since[0] > self.guidance.command_timeout_s:
                self.get_logger().warning(f"no command for the navigation stamp {self.loop.waiting_for_s():.3f} s "
                                          f"after {self.guidance.command_timeout_s:g} s (wall): flying on the last")
                self.loop.give_up()
                self.counts["commands missed"] = self.loop.missed
                self._wait_since = None
        else:
            self._wait_since = None
        return k_ok

    def _publish_steps(self):
        """One ``FlightStep`` per step flown since the last call (before the /clock that passes it)."""
        f = self.flight
        while self._k_published < f.next_step:
            k = self._k_published
            m = FlightStep()
            m.header.stamp.sec, m.header.stamp.nanosec = s_to_stamp_fields(k * f.step_s)
            m.header.frame_id = self.enu_frame
            m.step = k
            cmds = f.commands
            if self._cmd_published < len(cmds) and abs(cmds[self._cmd_published][0] - k * f.step_s) < 1e-9:
                _, m.t_nav_s, m.bank_rad, m.c_l = map(float, cmds[self._cmd_published])
                m.command_applied = True
                self._cmd_published += 1
            self.pub_steps.publish(m)
            self.counts["published flight/steps"] += 1
            self._k_published += 1

    def _publish_truth_until(self, t):
        if self.truth is None:
            self._publish_live_truth_until(t)
            return
        tr = self.truth
        while self._truth_idx < len(tr.t_s) and tr.t_s[self._truth_idx] <= t + 1e-9:
            self._publish_sample(tr, self._truth_idx)
            self._truth_idx += 1

    def _publish_live_truth_until(self, t):
        f, ts = self.flight, self._t_truth
        while (self._truth_idx < len(ts) and ts[self._truth_idx] <= t + 1e-9
               and ts[self._truth_idx] <= f.flown_s + 1e-9):
            i = self._truth_idx
            self._publish_sample(f.truth(ts[i:i + 1]), 0)     # one epoch at a time, as the offline loop
            self._truth_idx += 1

    def _publish_sample(self, tr, i):
        m = NavState()
        m.header.stamp.sec, m.header.stamp.nanosec = s_to_stamp_fields(tr.t_s[i])
        m.header.frame_id, m.child_frame_id = self.enu_frame, self.body_frame
        m.mode, m.mechanization_frame = NavState.MODE_TRUTH, "TRUTH"
        m.lat_rad, m.lon_rad, m.alt_m = float(tr.lat_rad[i]), float(tr.lon_rad[i]), float(tr.alt_m[i])
        m.vel_enu_mps = tr.vel_enu_mps[i].tolist()
        q = C_to_quat_xyzw(tr.C_b_n[i])
        m.q_b_enu.x, m.q_b_enu.y, m.q_b_enu.z, m.q_b_enu.w = map(float, q)
        m.roll_rad, m.pitch_rad, m.heading_rad = float(tr.roll_rad[i]), float(tr.pitch_rad[i]), float(tr.heading_rad[i])
        m.omega_ib_b_radps = tr.omega_ib_b_radps[i].tolist()
        m.accel_b_mps2 = tr.f_b_mps2[i].tolist()
        m.gyro_bias_b_radps = self.imu_errors.gyro_bias_b_radps.tolist()
        m.accel_bias_b_mps2 = self.imu_errors.accel_bias_b_mps2.tolist()
        self.pub_truth.publish(m)
        self.counts["published truth/state"] += 1

    def on_shutdown(self):
        """Final status on SIGINT/SIGTERM (ros_util.run_node): exact counts."""
        self._diag()

    def _diag(self):
        values = dict(self.counts, sim_time_s=f"{max(self.k - 1, 0) * self.step_s:.3f}",
                      clock_held_s=f"{self.gate.held_s:.2f}", clock_not_waited_for=",".join(sorted(self.gate.dropped)))
        self.status.publish("ok", "done" if self.done else ("running" if self.t_wall0 else "waiting for subscribers"),
                            values, finished=self.done)


def main(args=None):
    run_node(TruthNode, args)


if __name__ == "__main__":
    main()
