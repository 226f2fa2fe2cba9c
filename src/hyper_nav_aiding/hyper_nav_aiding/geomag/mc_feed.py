"""The geomagnetic aiding node's logic in a Monte Carlo run
(``hyper_nav_workbench.core.mc_sources``; declared as ``GEOMAG.mc_feed`` in :mod:`.descriptor`), no
rclpy: what the graph's magnetometer node publishes and the geomag node
does with it, against the run's own filter in the loop.

* its configuration from the scenario as the launcher writes the node's
  ROS parameters (:func:`.parameters.geomag_parameters`: the fusion output
  delay + 1 s as the reference lag, the flight's date for the map-epoch
  check) and the map it loads (``GeomagAiding.from_config``, built into the
  cache on first use as the node does);
* the magnetometer samples of the run's own draw (``simulate.mag_stream``),
  each one taken at its stamp: checked as ``_on_mag`` checks it, paired with
  a solution chosen by stamps (``core.nav_reference``: the same choice the
  live node makes, whatever the arrival order), matched
  (``GeomagAiding.process``) and its fix published as the node publishes
  it (the NavSatFix fields of ``geomag_conversions.navsatfix_fields``) to
  the run's fusion sources on ``geomag/fix`` (``publish``: the declared
  source's own converter, as in the fusion node);
* the solutions the run releases, seen as the node sees ``nav/state``: the
  NavState message's fields (``hyper_nav_filter.output.navstate_fields``)
  read back by the node's own conversion (``geomag_conversions.nav_point``).

A sample whose solution has not been released yet waits (as in the node)
and is matched when it is; its fix is then late for the filter, which
re-processes from its epoch (the graph holds its clock for it instead:
the same numbers). ``counts`` are the node's diagnostics counters.
"""
from __future__ import annotations

import collections
from types import SimpleNamespace

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.output import OutputFrames, navstate_fields

from hyper_nav_aiding.geomag import conversions as conv
from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.mag_input import MagInputCheck
from hyper_nav_aiding.geomag.core.map_epoch import check as check_map_epoch
from hyper_nav_aiding.geomag.core.nav_reference import WAIT, NavReference
from hyper_nav_aiding.geomag.parameters import geomag_parameters

MEASUREMENT_EPOCH_FIELD = "magnetometer.epoch_decimal_year"
FIX_TOPIC = "geomag/fix"
FRAME_ID = "enu"                                   # the node's frame_id parameter default


def message(fields: dict) -> SimpleNamespace:
    """Flat message fields ({'header.stamp.sec': ..}) as a message-like
    object (``msg.header.stamp.sec``), what a duck-typed conversion reads."""
    root: dict = {}
    for path, value in fields.items():
        cur = root
        *parents, leaf = path.split(".")
        for p in parents:
            cur = cur.setdefault(p, {})
        cur[leaf] = value

    def build(d):
        return SimpleNamespace(**{k: build(v) if isinstance(v, dict) else v for k, v in d.items()})
    return build(root)


def node_config(sc) -> tuple[GeomagConfig, float]:
    """(GeomagConfig, flight epoch) as the node gets them from the launcher:
    every described parameter at its default, overridden by the scenario's."""
    params = geomag_parameters(sc)
    flat = {name: d[0] for name, d in GeomagConfig.describe().items()}
    flat.update({k: v for k, v in params.items() if k in flat})
    return GeomagConfig.from_flat(flat), float(params[MEASUREMENT_EPOCH_FIELD])


class GeomagFeed:
    """The geomag node of one Monte Carlo run (see the module docstring)."""

    def __init__(self, sc, traj, cfg, publish):
        from hyper_nav_sim.core import simulate
        self.cfg_filter = cfg
        self.publish = publish                          # publish(engine, topic, message)
        self.cfg, flight_epoch = node_config(sc)
        self.aiding = GeomagAiding.from_config(self.cfg, True, epoch=check_map_epoch(self.cfg, flight_epoch))
        if self.aiding.map is None:
            raise ValueError(f"geomag.map: refused, no fixes could be made: {self.aiding.map_problem}")
        self.nav = NavReference(self.cfg.max_nav_gap_s, self.cfg.max_nav_prediction_s, self.cfg.nav_reference_lag_s)
        self.frames = OutputFrames("map", "enu", "base_link", 0.0, 0.0, 0.0)     # nav_point reads no frame
        self.counts: collections.Counter = collections.Counter()
        self.results: list = []                         # every MatchResult, in order
        self._waiting: collections.deque = collections.deque()
        self._mag_check = MagInputCheck()
        t_s, field_T = simulate.mag_stream(sc, traj)
        self.mag_t_s = np.asarray(t_s, float)
        self.mag_field_T = np.asarray(field_T, float)

    def events(self) -> list[tuple[float, object]]:
        """(stamp, feed(engine)) of every magnetometer sample, taken when the run's IMU reaches its stamp."""
        return [(float(t), lambda eng, k=k: self.on_mag(eng, k)) for k, t in enumerate(self.mag_t_s)]

    def on_mag(self, eng, k: int) -> None:
        """A magnetometer sample (the MagneticField the node receives: tesla, body)."""
        self.counts["received imu/mag"] += 1
        f = self.mag_field_T[k]
        sec, nsec = s_to_stamp_fields(float(self.mag_t_s[k]))
        s = conv.mag_sample(message({"header.stamp.sec": sec, "header.stamp.nanosec": nsec,
                                     "magnetic_field.x": float(f[0]), "magnetic_field.y": float(f[1]),
                                     "magnetic_field.z": float(f[2])}))
        why = self._mag_check.reject(s)
        if why is not None:
            self.counts[why] += 1
            return
        self._waiting.append(s)
        self._pair(eng)

    def released(self, eng, solutions) -> None:
        """Solutions the engine released (the node's nav/state)."""
        lay = self.cfg_filter.layout
        frame = self.cfg_filter.mechanization_frame
        for sol in solutions:
            self.counts["received nav/state"] += 1
            n = conv.nav_point(message(navstate_fields(sol, lay, self.frames, frame)))
            if not self.nav.add(n):
                self.counts["rejected_nav_out_of_order"] += 1
        if solutions:
            self._pair(eng)

    def _pair(self, eng) -> None:
        while self._waiting:
            s = self._waiting[0]
            nav, why = self.nav.at(s.t_s)
            if why == WAIT:
                return
            self._waiting.popleft()
            if nav is None:
                self.counts[f"rejected_mag_nav_{why}"] += 1
                continue
            res = self.aiding.process(s, nav)
            if res is None:
                continue
            self.results.append(res)
            self.counts["published geomag/quality"] += 1
            if res.valid:
                self.counts["published geomag/fix"] += 1
                self.publish(eng, FIX_TOPIC, message(conv.navsatfix_fields(res, nav.alt_m, FRAME_ID)))


def mc_feed(sc, traj, cfg, publish) -> GeomagFeed:
    """``AidingNode.mc_feed`` of the geomag node."""
    return GeomagFeed(sc, traj, cfg, publish)
