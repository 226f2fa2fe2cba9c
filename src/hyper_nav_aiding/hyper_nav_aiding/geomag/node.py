"""Geomagnetic matching node (seed 003): magnetometer + navigation solution
in, horizontal position fixes out.

Subscribes ``imu/mag`` (sensor_msgs/MagneticField) and ``nav/delayed/state``
(hyper_nav_msgs/NavState); publishes ``geomag/fix`` (sensor_msgs/NavSatFix:
the fix, ENU covariance whose EN block is meaningful, vertical variance
1e12 m^2 = none) and ``geomag/quality`` (hyper_nav_msgs/MatchQuality, one
per match attempt, valid or not), and ``/diagnostics``. All math is in
``hyper_nav_aiding.core`` (``GeomagAiding``, the same engine the offline
reproduction runs).

Each magnetometer sample is paired with a solution for its stamp, chosen by
stamps alone (``core.nav_reference``: the newest solution stamped at least
``nav_reference_lag_s`` before it, carried forward; run_graph sets the lag to
the fusion node's ``output_delay_s`` + 1 s, so that solution is out when the
sample comes and the fix reaches the filter before it releases that epoch;
the pairing does not depend on which topic arrived first)
and queued to a worker thread, which matches and
publishes: MAGCOM's search (~0.1 s) or a map build (tens of seconds at
first start) never blocks the callbacks. The map is loaded (or built into
the cache) on that thread too.

Parameters: ``geomag.*`` (``GeomagConfig``, declared with descriptors,
written from the scenario's ``geomag:`` block by ``run_graph``),
``frame_id``, ``qos.depth``, ``min_subscribers`` (subscribe to the inputs
only when ``geomag/fix`` has that many subscribers), ``max_queue`` (samples
waiting for the worker; beyond, the oldest is dropped and counted),
``diagnostics_period_s``, ``map.build_if_missing``, and
``magnetometer.epoch_decimal_year``: the flight's date at stamp 0 (written by
``run_graph`` from the scenario), against which the map's epoch is checked at
start (``core.map_epoch``, issue 27): beyond ``geomag.map_epoch_tolerance_nT``
the node logs the error (both fields, the implied nT) and exits 2; within it
the implied bias is on ``/diagnostics`` (over the map at start, and along the
track) and in every ``geomag/quality`` (``map_epoch_bias_nt``, at the
solution and the sample's stamp). Without the date the node refuses to start.
"""
from __future__ import annotations

import collections
import queue
import threading

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from hyper_nav_msgs.msg import MatchQuality
from hyper_nav_msgs.msg import NavState as NavStateMsg
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.node import Node
from sensor_msgs.msg import MagneticField, NavSatFix

from hyper_nav_filter.clock_gate import ClockAllowance
from hyper_nav_filter.ros_util import (all_matched, assign_fields, diagnostic_array, publisher_qos, run_node,
                                      subscriber_qos)

from hyper_nav_aiding.geomag import conversions as conv
from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.mag_input import MagInputCheck
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.map_epoch import MEASUREMENT_EPOCH_FIELD, check as check_map_epoch
from hyper_nav_aiding.geomag.core.nav_reference import WAIT, NavReference


def _descriptor(name, default, desc, lo, hi, choices) -> ParameterDescriptor:
    d = ParameterDescriptor(name=name, description=desc + (f" (one of {list(choices)})" if choices else ""))
    if isinstance(default, bool):
        d.type = ParameterType.PARAMETER_BOOL
    elif isinstance(default, int):
        d.type = ParameterType.PARAMETER_INTEGER
        if lo is not None and hi is not None:
            d.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=0)]
    elif isinstance(default, float):
        # YAML writes 26000 for 26000.0: accept integers, GeomagConfig coerces and checks the range
        d.type, d.dynamic_typing = ParameterType.PARAMETER_DOUBLE, True
        if lo is not None and hi is not None:
            d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
    elif isinstance(default, list):
        d.type, d.dynamic_typing = ParameterType.PARAMETER_DOUBLE_ARRAY, True
    else:
        d.type = ParameterType.PARAMETER_STRING
    return d


class GeomagNode(Node):
    def __init__(self):
        super().__init__("geomag")
        values = {}
        for name, (default, desc, lo, hi, choices) in GeomagConfig.describe().items():
            d = _descriptor(name, default, desc, lo, hi, choices)
            values[name] = self.declare_parameter(name, default, d).value
        self.cfg = GeomagConfig.from_flat(values)          # raises naming the field
        flight_epoch = self.declare_parameter(MEASUREMENT_EPOCH_FIELD, float("nan"), ParameterDescriptor(
            name=MEASUREMENT_EPOCH_FIELD, type=ParameterType.PARAMETER_DOUBLE, dynamic_typing=True,
            description="the flight's date (decimal year) at stamp 0, from the scenario: the map's epoch "
                        "is checked against it")).value
        try:
            self.epoch = check_map_epoch(self.cfg, flight_epoch)
        except ValueError as exc:                          # MapEpochError, WmmDateError: name the fields
            self.get_logger().fatal(f"geomagnetic map refused at start: {exc}")
            raise SystemExit(2) from None
        self.get_logger().info(f"map epoch: {self.epoch.describe()}")
        p = {name: self.declare_parameter(name, default, ParameterDescriptor(description=desc)).value
             for name, default, desc in [
                 ("frame_id", "enu", "frame_id of geomag/fix and geomag/quality"),
                 ("qos.depth", 2000, "publisher/subscriber queue depth"),
                 ("qos.reliable_subscriptions", True, "reliable (true) or sensor-data QoS inputs"),
                 ("min_subscribers", 0, "subscribe to the inputs once geomag/fix has this many subscribers"),
                 ("max_queue", 30, "samples waiting for the matcher before the oldest is dropped"),
                 ("diagnostics_period_s", 1.0, "period of /diagnostics"),
                 ("map.build_if_missing", True, "build the configured map into the cache when missing"),
                 ("clock.deadline_s", float("inf"), "while a sample stamped t waits for its fix, the simulated "
                  "clock may not pass t + this (sim s; /graph/allowance, hyper_nav_filter.clock_gate): run_graph "
                  "sets the fusion output delay minus 0.2 s, so every fix reaches the filter before its epoch is "
                  "released; inf = never hold the clock")]}
        self.p = p
        qos = publisher_qos(p["qos.depth"])
        self.pub_fix = self.create_publisher(NavSatFix, "geomag/fix", qos)
        self.pub_quality = self.create_publisher(MatchQuality, "geomag/quality", qos)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self.aiding: GeomagAiding | None = None
        self.counts = collections.Counter()
        self._lock = threading.Lock()
        self._mag = collections.deque()             # MagSample waiting for its nav/state
        self._inflight: dict[float, int] = {}       # stamps of samples not yet matched or dropped
        self.allowance = ClockAllowance(self, source=self._allowance)
        self._nav = NavReference(self.cfg.max_nav_gap_s, self.cfg.max_nav_prediction_s, self.cfg.nav_reference_lag_s)
        self._mag_check = MagInputCheck()
        self._jobs: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._work, name="geomag_matcher", daemon=True)
        self._worker.start()
        self._subs = []
        self._wait_timer = self.create_timer(0.05, self._start_when_ready)
        self.create_timer(p["diagnostics_period_s"], self._publish_diagnostics)

    # ---- start-up ---------------------------------------------------------------------
    def _start_when_ready(self):
        if not all_matched([self.pub_fix], self.p["min_subscribers"]):
            return
        self._wait_timer.cancel()
        qos = subscriber_qos(self.p["qos.reliable_subscriptions"], self.p["qos.depth"])
        self._subs = [self.create_subscription(MagneticField, "imu/mag", self._on_mag, qos),
                      self.create_subscription(NavStateMsg, "nav/delayed/state", self._on_nav, qos)]
        self.get_logger().info(f"{self.cfg.algorithm}: subscribed to imu/mag and nav/delayed/state")

    def _load_map(self):
        log = self.get_logger()
        aiding = GeomagAiding.from_config(self.cfg, self.p["map.build_if_missing"], log=log.info, epoch=self.epoch)
        if aiding.map is None:
            log.error(f"geomagnetic map refused, no fixes: {aiding.map_problem}")
        else:
            s = aiding.map.spec
            log.info(f"map {s.model} epoch {s.epoch_decimal_year} at {s.alt_m:.0f} m, "
                     f"{s.lat_min_deg}-{s.lat_max_deg} N {s.lon_min_deg}-{s.lon_max_deg} E, "
                     f"step {s.grid_step_deg} deg / {s.refine_factor}"
                     + (" (brought forward)" if self.epoch.brought_forward else ""))
        self.aiding = aiding

    # ---- callbacks (short: validate, pair, queue) ---------------------------------------
    def _on_mag(self, msg):
        self.counts["received imu/mag"] += 1
        s = conv.mag_sample(msg)
        why = self._mag_check.reject(s)
        if why is not None:
            self.counts[why] += 1
            return
        with self._lock:
            self._inflight[s.t_s] = self._inflight.get(s.t_s, 0) + 1
        self._mag.append(s)
        self._pair()

    def _done(self, t_s: float) -> None:
        """A sample is matched (or dropped): it no longer holds the clock."""
        with self._lock:
            n = self._inflight.get(t_s, 0) - 1
            if n > 0:
                self._inflight[t_s] = n
            else:
                self._inflight.pop(t_s, None)

    def _allowance(self) -> float:
        with self._lock:
            oldest = min(self._inflight, default=None)
        return float("inf") if oldest is None else oldest + self.p["clock.deadline_s"]

    def _on_nav(self, msg):
        self.counts["received nav/state"] += 1
        n = conv.nav_point(msg)
        if not (np.isfinite(n.t_s) and np.isfinite(n.lat_rad) and np.isfinite(n.lon_rad) and np.isfinite(n.alt_m)
                and np.all(np.isfinite(n.vel_enu_mps))):
            self.counts["rejected_nav_nan"] += 1
            return
        if not self._nav.add(n):
            self.counts["rejected_nav_out_of_order"] += 1
            return
        self._pair()

    def _pair(self):
        """Pair each waiting magnetometer sample with a solution for its stamp."""
        while self._mag:
            s = self._mag[0]
            nav, why = self._nav.at(s.t_s)
            if why == WAIT:
                return                                   # its solution has not come yet
            self._mag.popleft()
            if nav is None:
                self.counts[f"rejected_mag_nav_{why}"] += 1
                self._done(s.t_s)
                continue
            if self._jobs.qsize() >= self.p["max_queue"]:
                try:
                    old, _ = self._jobs.get_nowait()
                    self.counts["dropped_backlog"] += 1
                    self._done(old.t_s)
                except queue.Empty:
                    pass
            self._jobs.put((s, nav))

    # ---- worker thread: match and publish --------------------------------------------
    def _work(self):
        self._load_map()
        while not self._stop.is_set():
            try:
                s, nav = self._jobs.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                res = self.aiding.process(s, nav)
            except Exception as exc:  # noqa: BLE001 - a matcher bug must not kill the node
                self.counts["matcher_exceptions"] += 1
                self.get_logger().error(f"matcher failed at t = {s.t_s:.3f}: {exc}", throttle_duration_sec=5.0)
                self._done(s.t_s)
                continue
            if res is not None:
                with self._lock:
                    self._publish(res, nav)
            self._done(s.t_s)

    def _publish(self, res, nav):
        q = MatchQuality()
        assign_fields(q, conv.match_quality_fields(res, self.p["frame_id"]))
        self.pub_quality.publish(q)
        self.counts["published geomag/quality"] += 1
        if res.valid:
            f = NavSatFix()
            assign_fields(f, conv.navsatfix_fields(res, nav.alt_m, self.p["frame_id"]))
            self.pub_fix.publish(f)
            self.counts["published geomag/fix"] += 1
        elif res.reason:
            self.get_logger().warning(f"no fix at t = {res.t_s:.1f}: {res.reason}", throttle_duration_sec=5.0)

    # ---- diagnostics -------------------------------------------------------------------
    def on_shutdown(self):
        self._stop.set()
        self._worker.join(timeout=2.0)
        self._publish_diagnostics()

    def _publish_diagnostics(self):
        c = dict(self.counts)
        c["algorithm"] = self.cfg.algorithm
        c["queue"] = self._jobs.qsize()
        c.update(self.epoch.summary())
        a = self.aiding
        if a is None:
            c["map"] = "loading"
        else:
            c.update(a.counters)
            c.update(a.epoch_report())
            c["map"] = "ok" if a.map is not None else f"refused: {a.map_problem}"
            c["compute_time_s"] = f"{a.compute_time_s:.3f}"
        bad = sum(v for k, v in c.items() if str(k).startswith(("rejected_", "dropped_", "no_map", "off_map",
                                                                 "matcher_exceptions")) and isinstance(v, int))
        ok = a is not None and a.map is not None and bad == 0
        msg = c["map"] if a is None or a.map is None else f"{bad} inputs without fix"
        with self._lock:
            self.pub_diag.publish(diagnostic_array(self, "hyper_nav_aiding: geomag", ok, msg, c))



def main(args=None):
    run_node(GeomagNode, args)


if __name__ == "__main__":
    main()
