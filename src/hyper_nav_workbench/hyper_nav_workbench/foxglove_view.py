"""Foxglove output of the live view (foxglove-sdk): the running graph, or a
recorded bag, served to the Foxglove app over WebSocket (localhost unless
told otherwise) or written to an MCAP file the app opens.

Channels (what to put in which panel):
  /map/truth, /map/fused, /map/gnss   foxglove.LocationFix   Map panel (black, blue, orange)
  /tf                                 foxglove.FrameTransforms  3D panel: map -> base_link -> sensors
  /vehicle                            foxglove.SceneUpdate   3D panel: a box at base_link
  /errors                             JSON (hyper_nav.Errors)  Plot panel: /errors.pos_err_enu_m[0] and
                                                               /errors.pos_sigma_enu_m[0] (x3 for 3 sigma), ...

``FoxgloveSink`` takes messages (rclpy or rosbags, duck-typed through
``core.live_view``); the ROS node (``nodes/foxglove_view.py``) and the bag
mode below feed it the same way.

    ros2run hyper_nav_workbench foxglove_view --bag bags/<run>                 # serve a recorded run, ws://127.0.0.1:8765
    ros2run hyper_nav_workbench foxglove_view --bag bags/<run> --out view.mcap # or write a Foxglove MCAP file
"""
from __future__ import annotations

import argparse
import sys
import time

from hyper_nav_workbench.core import live_view

# fused: the current-time stream (nav/state); delayed: the released record (nav/delayed/state)
COLORS = {"truth": (0.0, 0.0, 0.0), "fused": (0.12, 0.47, 0.71), "delayed": (0.17, 0.63, 0.17),
          "gnss": (1.0, 0.5, 0.05)}


class FoxgloveSink:
    def __init__(self, server: bool = True, host: str = "127.0.0.1", port: int = 8765, mcap_path=None,
                 map_rate_hz: float = 10.0, name: str = "hyper-nav"):
        import foxglove
        from foxglove.channels import FrameTransformsChannel, LocationFixChannel, SceneUpdateChannel
        self.fg = foxglove
        self.ctx = foxglove.Context()
        self.server = foxglove.start_server(name=name, host=host, port=port, context=self.ctx) if server else None
        self.mcap = foxglove.open_mcap(str(mcap_path), context=self.ctx) if mcap_path else None
        self.map = {k: LocationFixChannel(f"/map/{k}", context=self.ctx) for k in COLORS}
        self.tf = FrameTransformsChannel("/tf", context=self.ctx)
        self.vehicle = SceneUpdateChannel("/vehicle", context=self.ctx)
        self.errors = foxglove.Channel("/errors", schema=live_view.ERRORS_SCHEMA, context=self.ctx)
        self.tracker = live_view.ErrorTracker()
        self.errors_delayed = foxglove.Channel("/errors/delayed", schema=live_view.ERRORS_SCHEMA, context=self.ctx)
        self.tracker_delayed = live_view.ErrorTracker()
        self.min_dt_ns = int(1e9 / map_rate_hz) if map_rate_hz > 0 else 0
        self._last_map = {k: -10**19 for k in COLORS}
        self._vehicle_sent = False
        self.counts = {"map": 0, "tf": 0, "errors": 0, "errors_delayed": 0}

    @property
    def port(self) -> int | None:
        return self.server.port if self.server else None

    # ---- inputs -------------------------------------------------------------------
    def on_truth(self, m) -> None:
        self._log_errors(self.tracker.on_truth(m))
        self._log_errors(self.tracker_delayed.on_truth(m), self.errors_delayed)
        self._location("truth", live_view.navstate_point(m))

    def on_nav(self, m) -> None:
        self._location("fused", live_view.navstate_point(m))
        self._log_errors(self.tracker.on_nav(m))

    def on_nav_delayed(self, m) -> None:
        """The delayed record (nav/delayed/state): its own map track and errors (/errors/delayed)."""
        self._location("delayed", live_view.navstate_point(m))
        self._log_errors(self.tracker_delayed.on_nav(m), self.errors_delayed)

    def _log_errors(self, records, channel=None) -> None:
        for t_ns, rec in records:
            (channel or self.errors).log(rec, log_time=t_ns)
            self.counts["errors" if channel is None else "errors_delayed"] += 1

    def on_gnss(self, m) -> None:
        self._location("gnss", live_view.navsatfix_point(m))

    def on_tf(self, m) -> None:
        from foxglove.messages import FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3
        items = live_view.transforms(m)
        if not items:
            return
        out = [FrameTransform(timestamp=_ts(Timestamp, t["t_ns"]), parent_frame_id=t["parent"],
                              child_frame_id=t["child"], translation=Vector3(**dict(zip("xyz", t["translation"]))),
                              rotation=Quaternion(**dict(zip("xyzw", t["rotation_xyzw"])))) for t in items]
        self.tf.log(FrameTransforms(transforms=out), log_time=items[-1]["t_ns"])
        self.counts["tf"] += 1
        if not self._vehicle_sent and any(t["child"] == "base_link" for t in items):
            self._send_vehicle(items[-1]["t_ns"])

    # ---- outputs ------------------------------------------------------------------
    def _location(self, kind: str, p: dict) -> None:
        if p["t_ns"] - self._last_map[kind] < self.min_dt_ns:
            return
        self._last_map[kind] = p["t_ns"]
        from foxglove.messages import Color, LocationFix, LocationFixPositionCovarianceType, Timestamp
        r, g, b = COLORS[kind]
        self.map[kind].log(LocationFix(
            timestamp=_ts(Timestamp, p["t_ns"]), frame_id=kind, latitude=p["lat_deg"], longitude=p["lon_deg"],
            altitude=p["alt_m"], position_covariance=p["cov_enu"],
            position_covariance_type=LocationFixPositionCovarianceType.Known, color=Color(r=r, g=g, b=b, a=1.0)),
            log_time=p["t_ns"])
        self.counts["map"] += 1

    def _send_vehicle(self, t_ns: int) -> None:
        from foxglove.messages import (Color, CubePrimitive, Pose, Quaternion, SceneEntity, SceneUpdate, Timestamp,
                                       Vector3)
        cube = CubePrimitive(pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.0),
                                       orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
                             size=Vector3(x=6.0, y=1.5, z=1.0), color=Color(r=0.12, g=0.47, b=0.71, a=0.8))
        ent = SceneEntity(timestamp=_ts(Timestamp, t_ns), frame_id="base_link", id="vehicle", frame_locked=True,
                          cubes=[cube])
        self.vehicle.log(SceneUpdate(entities=[ent]), log_time=t_ns)
        self._vehicle_sent = True

    def close(self) -> None:
        if self.mcap is not None:
            self.mcap.close()
        if self.server is not None:
            self.server.stop()


def _ts(Timestamp, t_ns: int):
    return Timestamp(sec=int(t_ns // 1_000_000_000), nsec=int(t_ns % 1_000_000_000))


HANDLERS = {"truth/state": "on_truth", "nav/state": "on_nav", "nav/delayed/state": "on_nav_delayed",
            "gnss/fix": "on_gnss", "tf": "on_tf",
            "tf_static": "on_tf"}


def feed_bag(sink: FoxgloveSink, bag, rate: float = 0.0, reorder_s: float = 10.0) -> int:
    """Every message of the bag the view uses, in stamp order (a reorder
    buffer of ``reorder_s``: the bag's log order is its recorder's arrival
    order, and the view must not depend on it); ``rate`` > 0 paces it at that
    multiple of real time (a live-looking replay), 0 = as fast as possible.
    Messages more than ``reorder_s`` out of order are fed as they come and
    counted in ``sink.counts["late"]``."""
    from hyper_nav_filter.core.reorder import StampReorder

    from hyper_nav_workbench.core.bag import deserialize, read_bag
    reader = read_bag(bag)
    buf = StampReorder(reorder_s)
    n, t_first, w0 = 0, None, time.monotonic()

    def emit(items):
        nonlocal n, t_first
        for t_ns, h, m in items:
            if rate > 0:
                t_first = t_ns if t_first is None else t_first
                wait = (t_ns - t_first) * 1e-9 / rate - (time.monotonic() - w0)
                if wait > 0:
                    time.sleep(wait)
            getattr(sink, h)(m)
            n += 1
    for r in reader:
        h = HANDLERS.get(r.topic.lstrip("/"))
        if h is None:
            continue
        m = deserialize(r.raw, r.msgtype)
        t_ns = _stamp_ns(m, r.t_ns)
        emit(buf.push(t_ns, r.topic, (t_ns, h, m)))
    emit(buf.flush())
    sink.counts["late"] = buf.late
    return n


def _stamp_ns(m, default: int) -> int:
    """header.stamp in ns (TFMessage: its first transform's), else the log time."""
    h = getattr(m, "header", None)
    if h is None and getattr(m, "transforms", None):
        h = m.transforms[0].header
    return default if h is None else live_view.stamp_ns(h.stamp)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="foxglove_view", description="A recorded run in Foxglove: served over "
                                 "WebSocket or written to a Foxglove MCAP file (live runs: run_graph --foxglove).")
    ap.add_argument("--bag", required=True, help="recorded run (rosbag2/MCAP directory)")
    ap.add_argument("--out", help="write a Foxglove MCAP file instead of serving")
    ap.add_argument("--host", default="127.0.0.1", help="address to bind (default localhost only)")
    ap.add_argument("--port", type=int, default=8765)
    ap.add_argument("--rate", type=float, default=1.0, help="replay speed when serving (x real time)")
    ap.add_argument("--wait-client-s", type=float, default=30.0,
                    help="when serving: wait this long for the app to connect before replaying")
    args = ap.parse_args(argv)
    sink = FoxgloveSink(server=args.out is None, host=args.host, port=args.port, mcap_path=args.out)
    try:
        if args.out is None:
            print(f"[foxglove_view] serving ws://{args.host}:{sink.port} (Foxglove: Open connection -> "
                  f"Foxglove WebSocket); replay starts when a client connects or after {args.wait_client_s:g} s",
                  flush=True)
            t_end = time.monotonic() + args.wait_client_s
            while time.monotonic() < t_end and not sink.map["truth"].has_sinks():
                time.sleep(0.2)
        n = feed_bag(sink, args.bag, rate=args.rate if args.out is None else 0.0)
        print(f"[foxglove_view] {n} messages from {args.bag}; {sink.counts}", flush=True)
    finally:
        sink.close()
    if args.out:
        print(f"[foxglove_view] wrote {args.out} (open it in Foxglove)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
