"""What a Monte Carlo run feeds the fusion core besides the IMU: the
scenario's declared sources (``filter.sources``), simulated as the nodes
publish them and converted as the fusion node converts them.

  * ``gnss_fix``, ``gnss_vel``: the loosely coupled fixes and velocities
    (``simulate.gnss_measurements``, as before);
  * ``gnss_raw`` (tightly coupled): the receiver's raw epochs and broadcast
    ephemerides through the source's own pseudorange core (the fusion
    node's ``gnss_raw`` source object), fed to the engine after each IMU
    sample as the node does;
  * a source on a sensor node's output (``baro_height`` on the barometer's
    ``baro/pressure``, or a user's sensor): the messages the node publishes,
    made by the node's own message code (``SensorNode.mc_feed``, declared by
    its package, e.g. ``hyper_nav_sim.nodes.baro_messages``), through the
    source's converter (for the barometer: US76 pressure altitude, sigma
    through dp/dh, floors and ceilings). A sensor node that declares no feed
    is refused, naming the source and the node.

  * a source on an aiding node's output (map matching: ``horizontal_fix``
    / ``position_fix`` on the geomag node's ``geomag/fix``): the node's own
    logic in the loop, declared by its package (``AidingNode.mc_feed``,
    e.g. ``hyper_nav_aiding.geomag.mc_feed``): it takes its inputs at their
    stamps and the run's released solutions as its ``nav/state``, and its
    outputs reach the run's sources through their own converters. An aiding
    node that declares no feed is refused, naming the source and the node.

No rclpy.
"""
from __future__ import annotations

LOOSE = {"gnss_fix": "gnss_pos", "gnss_vel": "gnss_vel"}


def _sensor_outputs(sc) -> dict:
    """{topic: SensorNode}: the topics the installed sensor nodes this scenario runs publish."""
    from hyper_nav_sim import sensors
    out = {}
    for node in sensors.descriptors().values():
        if node.wanted(sc.data):
            for topic in node.topics(sc):
                out[str(topic).lstrip("/")] = node
    return out


def _aiding_outputs(data: dict) -> dict:
    """{topic: AidingNode}: the outputs of the installed aiding nodes this scenario configures (has their block)."""
    from hyper_nav_filter import aiding_nodes
    out = {}
    for node in aiding_nodes.descriptors().values():
        if node.block not in data:
            continue
        for topic in node.outputs(data.get(node.block) or {}):
            out[str(topic).lstrip("/")] = node
    return out


class Feed:
    """The non-IMU inputs of one run, in time order: ``until(engine, t)``
    feeds everything stamped at or before ``t`` (after the IMU sample at
    ``t``), as the engine would receive it."""

    def __init__(self, sc, traj, cfg):
        from hyper_nav_filter.sources import make_sources

        from hyper_nav_sim.core import simulate
        self.events: list[tuple] = []          # (t_s, order, apply(engine))
        self.hooks = []
        self.aiding: list = []                  # the aiding nodes' feeds (AidingNode.mc_feed)
        self.routes: dict[str, list] = {}       # aiding output topic -> the fusion sources on it
        specs = sc.filter_source_specs()
        producers = _aiding_outputs(sc.data)
        sensor_topics = _sensor_outputs(sc)
        sensor_routes: dict[str, list] = {}     # sensor output topic -> the fusion sources on it
        kinds = {LOOSE[s.type] for s in specs if s.type in LOOSE}
        if kinds:
            for n, m in enumerate(m for m in simulate.gnss_measurements(sc, traj) if m.kind in kinds):
                self.events.append((m.t_s, 0, n, lambda eng, m=m: eng.add_measurement(m)))
        for src in make_sources(specs, cfg):
            typ = src.spec.type
            topic = src.spec.topic.lstrip("/")
            if topic in producers:
                node = producers[topic]
                if node.mc_feed is None:
                    raise ValueError(f"filter.sources.{src.spec.id}: its topic {topic!r} is aiding node "
                                     f"{node.name!r}'s output, which is not drawn in Monte Carlo campaigns "
                                     f"(the node declares no mc_feed)")
                self.routes.setdefault(topic, []).append(src)
                continue
            if typ in ("imu", *LOOSE):
                continue
            if typ == "gnss_raw":
                tight = src.tight
                for n, ep in enumerate(simulate.gnss_raw_stream(sc, traj)):
                    def raw(eng, ep=ep, tight=tight):
                        for eph in ep.ephemeris_set:
                            tight.add_ephemeris(eph)
                        tight.add_raw(ep.raw())
                    self.events.append((ep.t_s, 1, n, raw))
                self.hooks.append(lambda eng, tight=tight: tight.feed(eng))
            elif topic in sensor_topics:
                node = sensor_topics[topic]
                if node.mc_feed is None:
                    raise ValueError(f"filter.sources.{src.spec.id}: its topic {topic!r} is sensor node "
                                     f"{node.name!r}'s output, which is not drawn in Monte Carlo campaigns "
                                     f"(the node declares no mc_feed)")
                sensor_routes.setdefault(topic, []).append(src)
            else:
                raise ValueError(f"filter.sources.{src.spec.id}: type {typ!r} on {topic!r} is not drawn in Monte "
                                 "Carlo campaigns (not a simulated sensor's type, and no aiding node this scenario "
                                 "configures publishes that topic)")
        # each sensor node's messages, made by its own message code, to the sources on their topics (at equal
        # stamps after the GNSS fixes and raw epochs, before the aiding nodes' outputs)
        for k, node in enumerate({id(n): n for t, n in sensor_topics.items() if t in sensor_routes}.values()):
            for n, (t, topic, msg) in enumerate(node.mc_feed(sc, traj)):
                for j, src in enumerate(sensor_routes.get(str(topic).lstrip("/"), ())):
                    self.events.append((float(t), 2, (k, n, j),
                                        lambda eng, msg=msg, src=src: src.on_message("main", msg, eng)))
        for node in {id(n): n for t, n in producers.items() if t in self.routes}.values():
            feed = node.mc_feed(sc, traj, cfg, self._publish)
            self.aiding.append(feed)
            for n, (t, fn) in enumerate(feed.events()):
                self.events.append((t, 3 + len(self.aiding), n, fn))
        self.events.sort(key=lambda e: e[:3])
        self._j = 0

    def _publish(self, eng, topic: str, msg) -> None:
        """An aiding node's output to the fusion sources on its topic (their own converters)."""
        for src in self.routes.get(topic.lstrip("/"), ()):
            src.on_message("main", msg, eng)

    def released(self, eng, solutions) -> None:
        """The solutions the run released: the aiding nodes' nav/state."""
        for feed in self.aiding:
            feed.released(eng, solutions)

    def until(self, eng, t_s: float) -> None:
        ev = self.events
        while self._j < len(ev) and ev[self._j][0] <= t_s + 1e-9:
            ev[self._j][3](eng)
            self._j += 1
        for h in self.hooks:
            h(eng)
