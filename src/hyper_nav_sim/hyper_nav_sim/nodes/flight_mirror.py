"""A sensor node's mirror of the truth node's commanded flight (issue 36).

With a scenario ``guidance:`` and ``flight:`` block the truth node flies
the boost-glide equations live on the guidance's commands
(``core.commanded_flight``) and publishes every step it has flown on
``flight/steps`` (hyper_nav_msgs/FlightStep: the step index and the command
that took effect at it), before the /clock that passes it. A sensor node
cannot simulate that flight ahead of time; it flies its own copy instead:
the same construction (``flight_of_scenario``), the same command at the
same step, hence the same flight bit for bit, and after each step it draws
its samples of it (``core.flown_streams``) and queues them for release on
/clock like any other.

The topic is transient local, deep enough for every step of the flight,
so a node that subscribes late still gets them all, in order. Steps are
applied in index order only (one that arrives ahead waits for the ones
before it); a step whose command does not apply at that step under this
node's own configuration is a configuration mismatch between the nodes
and stops the node with that message rather than flying another flight.
"""
from __future__ import annotations

import math

from hyper_nav_msgs.msg import FlightStep

from hyper_nav_filter.ros_util import latched_qos

from ..core.commanded_flight import flight_of_scenario

FLIGHT_STEPS_TOPIC = "flight/steps"


def steps_qos(flight):
    """Reliable, transient local, deep enough for every step of the flight."""
    return latched_qos(int(math.ceil(flight.duration_s / flight.step_s)) + 2)


class FlightMirror:
    """Flies the truth node's commanded flight from ``flight/steps``;
    ``on_flown()`` is called after every step integrated."""

    def __init__(self, node, scenario, on_flown):
        self.cfg, self.flight = flight_of_scenario(scenario)
        self.on_flown = on_flown
        self.ahead: dict[int, FlightStep] = {}
        self.received = 0
        node.create_subscription(FlightStep, FLIGHT_STEPS_TOPIC, self._on_step, steps_qos(self.flight))

    def _on_step(self, msg: FlightStep) -> None:
        self.received += 1
        f = self.flight
        if int(msg.step) < f.next_step:
            return                                   # flown already (a repeat): nothing changes
        self.ahead[int(msg.step)] = msg
        while f.next_step in self.ahead and not f.finished:
            self.apply(self.ahead.pop(f.next_step))
            self.on_flown()

    def apply(self, msg: FlightStep) -> None:
        """Fly step ``msg.step`` (the next one) with the command that took effect at it."""
        f, k = self.flight, int(msg.step)
        if msg.command_applied:
            if f.apply_step(msg.t_nav_s) != k:
                raise RuntimeError(f"flight/steps: the command from t_nav {msg.t_nav_s:.3f} s took effect at step "
                                   f"{k} in the truth node, at step {f.apply_step(msg.t_nav_s)} here: the nodes' "
                                   f"guidance.period_s/apply_delay_s differ (one scenario for every node)")
            why = f.command(msg.t_nav_s, msg.bank_rad, msg.c_l)
            if why is not None:
                raise RuntimeError(f"flight/steps: the truth node flew a command this node refuses ({why}) at "
                                   f"step {k}: the nodes' flight or guidance blocks differ")
        f.advance((k + 1) * f.step_s)
