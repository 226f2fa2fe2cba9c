"""GNSS node: ``gnss/fix`` (sensor_msgs/NavSatFix) and ``gnss/vel``
(geometry_msgs/TwistWithCovarianceStamped, frame ``enu``: linear = ENU
velocity of the antenna w.r.t. Earth) at the scenario GNSS rate.

With a ``gnss.raw`` block the receiver is simulated from a broadcast-
ephemeris constellation (``core.gnss``): ``gnss/raw``
(hyper_nav_msgs/GnssMeasurements: pseudorange, rate, Doppler, C/N0, lock
flag per satellite), ``gnss/ephemeris`` (hyper_nav_msgs/GnssEphemeris, one
message per satellite, transient-local so late joiners get them), and the
fix/velocity come from the receiver's least-squares PVT over the locked
satellites (no fix is published while fewer than 4 are locked). Without it,
fixes are the antenna truth plus white noise.

Messages are released ``gnss.latency_s`` after their epoch (receiver
latency); header.stamp stays the measurement epoch.

On a commanded flight (issue 36) the fixes are those of the steered flight,
drawn epoch by epoch as the node's mirror of it is flown
(``core.flown_streams.FlownFixes``, none in ``gnss.outages_s``; with
``gnss.raw`` the receiver's epochs, ``FlownRaw``, each once the flight is
flown 0.05 s past it); the receiver's tracking option (and with it the
aiding loop) is refused there (ValueError at start).

Aiding loop (issue 23; ``gnss.raw.tracking.aiding_source: nav_state``, off by
default): the node subscribes ``nav/delayed/state`` (hyper_nav_msgs/NavState,
remappable), hands each message to ``core.gnss.aiding.AidingInput`` (refused
and counted when non-finite, its covariance not PSD or out of order) and
computes each receiver epoch when it is released, with the state it holds then
(real DDS latency); a state older than ``aiding_max_age_s`` at the epoch leaves
the receiver unaided. Fix and velocity of that epoch go out with it.
``/diagnostics`` carries ``aiding <count>`` per counter.
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import TwistWithCovarianceStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from hyper_nav_filter.ros_util import declare_params, latched_qos, run_node

from ..core import simulate
from ..core.commanded_flight import is_commanded
from ..core.flown_streams import FlownFixes, FlownRaw
from ..gnss_messages import fill_gnss_ephemeris
from .params import GNSS, GNSS_FROM_SCENARIO, with_scenario
from .sensor_base import ClockDrivenSensor


class GnssNode(ClockDrivenSensor):
    def __init__(self):
        super().__init__("gnss")
        sc = self.scenario
        p = declare_params(self, with_scenario(GNSS, sc, GNSS_FROM_SCENARIO))
        self.frame_id, self.enu_frame, self.latency_s = p["frame_id"], p["enu_frame_id"], p["latency_s"]
        self.pub_fix = self.create_publisher(NavSatFix, "gnss/fix", self.qos)
        self.pub_vel = self.create_publisher(TwistWithCovarianceStamped, "gnss/vel", self.qos)
        self.raw_mode = "raw" in sc.data["gnss"]
        # subscriptions gnss/raw must see before data flows (run_graph: the recorder,
        # plus the fusion node when it runs tightly coupled); -1: min(1, min_subscribers)
        raw_need = p["raw_min_subscribers"]
        self.raw_min_subscribers = min(1, self.min_subscribers) if raw_need < 0 else raw_need
        if is_commanded(sc):                 # issue 36: the epochs of the steered flight, one by one
            flight = self.follow_flight(self._on_flown).flight
            if self.raw_mode:
                self._raw_publishers()
                self.aiding = None
                self.flown = FlownRaw(sc, flight)                      # refuses the tracking option
            else:
                self.flown = FlownFixes(sc, flight)
            return
        if self.raw_mode:
            self._setup_raw(sc)
        else:
            self.fixes = simulate.gnss_stream(sc, sc.trajectory())
            n = len(self.fixes.t_s)
            self.pos_cov = [np.diag(self.fixes.pos_sigma_enu_m**2)] * n
            self.vel_cov = [np.diag(self.fixes.vel_sigma_enu_mps**2)] * n
            self.schedule(self.fixes.t_s, self.pub_fix, self._make_fix)
            self.schedule(self.fixes.t_s, self.pub_vel, self._make_vel)

    def _setup_raw(self, sc):
        from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements
        trk = simulate.gnss_receiver(sc).cfg.tracking
        if trk is not None and trk.aiding_source == "nav_state":
            return self._setup_aided(sc, trk, GnssEphemeris, GnssMeasurements)
        self.aiding = None
        self.epochs = simulate.gnss_raw_stream(sc, sc.trajectory())
        self._raw_publishers()
        with_fix = [i for i, e in enumerate(self.epochs) if e.fix is not None]
        self.fixes = _FixArrays([self.epochs[i] for i in with_fix])
        self.pos_cov = [self.epochs[i].fix.cov_pos_enu_m2 for i in with_fix]
        self.vel_cov = [self.epochs[i].fix.cov_vel_enu_m2ps2 for i in with_fix]
        self.schedule([e.t_s for e in self.epochs], self.pub_raw, self._make_raw)
        self.schedule(self.fixes.t_s, self.pub_fix, self._make_fix)
        self.schedule(self.fixes.t_s, self.pub_vel, self._make_vel)

    def _raw_publishers(self):
        from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements
        self.pub_raw = self.create_publisher(GnssMeasurements, "gnss/raw", self.qos)
        self.pub_eph = self.create_publisher(GnssEphemeris, "gnss/ephemeris", latched_qos(200))
        self._eph_cls, self._raw_cls = GnssEphemeris, GnssMeasurements
        self._published_eph = set()

    def _setup_aided(self, sc, trk, GnssEphemeris, GnssMeasurements):
        """Closed aiding loop: epochs computed at release with the held nav/state."""
        from hyper_nav_msgs.msg import NavState
        from hyper_nav_gnss.receiver.aiding import AidingInput
        from ..core.simulate import imu_epochs
        self.aiding = AidingInput(max_age_s=trk.aiding_max_age_s, accel_sigma_mps2=trk.aiding_accel_sigma_mps2)
        t = imu_epochs(sc["duration_s"], sc["gnss.rate_hz"])
        self.rx_run = simulate.gnss_receiver(sc).run(sc.trajectory(), t, sc.rng("gnss_raw"))
        self.epochs = {}
        self.pub_raw = self.create_publisher(GnssMeasurements, "gnss/raw", self.qos)
        self.pub_eph = self.create_publisher(GnssEphemeris, "gnss/ephemeris", latched_qos(200))
        self._eph_cls, self._raw_cls = GnssEphemeris, GnssMeasurements
        self._published_eph = set()
        self.fixes, self.pos_cov, self.vel_cov = None, [], []
        self.create_subscription(NavState, "nav/delayed/state", self._on_nav_state, self.qos)
        self.schedule(t, self.pub_raw, self._make_raw)
        self.scheduled["gnss/fix"] = self.scheduled["gnss/vel"] = 0
        self.published.setdefault("gnss/fix", 0)
        self.published.setdefault("gnss/vel", 0)

    def _on_nav_state(self, msg):
        from hyper_nav_gnss.receiver.aiding import AidingSample
        from hyper_nav_filter.conversions import stamp_to_s
        q = msg.q_b_enu
        n = int(msg.state_dim)
        cov = np.asarray(msg.covariance, float)
        self.aiding.offer(AidingSample(
            stamp_to_s(msg.header.stamp), msg.lat_rad, msg.lon_rad, msg.alt_m, np.asarray(msg.vel_enu_mps, float),
            np.array([q.x, q.y, q.z, q.w]), np.asarray(msg.accel_b_mps2, float), list(msg.state_blocks),
            cov.reshape(n, n) if cov.size == n * n else cov))

    def _epoch(self, i):
        """Epoch i: precomputed, or (aiding loop) computed now with the held state."""
        if self.aiding is None:
            return self.epochs[i]
        e = self.rx_run.epoch(i, self.aiding)
        self.epochs = {i: e}
        if e.fix is not None:          # the epoch's fix and velocity go out with it
            self.fixes = _FixArrays([e])
            self.pos_cov, self.vel_cov = [e.fix.cov_pos_enu_m2], [e.fix.cov_vel_enu_m2ps2]
            for pub, make, name in ((self.pub_fix, self._make_fix, "gnss/fix"),
                                    (self.pub_vel, self._make_vel, "gnss/vel")):
                pub.publish(make(0))
                self.published[name] += 1
                self.scheduled[name] += 1
                self.last_stamp[name] = e.t_s
        return e

    def publish_diagnostics(self):
        if getattr(self, "aiding", None) is not None:
            counts = dict(self.aiding.counts)
            trk = self.rx_run.trk
            counts.update(trk.counts)
            self._extra_diag = {f"aiding {k}": v for k, v in counts.items()}
            n = self.aiding.counts["aided_epochs"]
            self._extra_diag["aiding mean_age_s"] = f"{self.aiding.age_sum_s / n:.3f}" if n else "nan"
        super().publish_diagnostics()

    def publishers_to_match(self):
        pubs = [self.pub_fix, self.pub_vel]
        # loosely coupled fusion takes fix/vel, tightly coupled fusion gnss/raw (+ gnss/ephemeris,
        # transient local: no need to wait for it); the recorder takes all
        return pubs + [(self.pub_raw, self.raw_min_subscribers)] if self.raw_mode else pubs

    def _make_raw(self, i: int):
        return self._raw_msg(self._epoch(i))

    def _raw_msg(self, e):
        for eph in e.ephemeris_set:            # ephemerides before the first measurement using them
            key = (eph.system, eph.prn, eph.toe)
            if key not in self._published_eph:
                self._published_eph.add(key)
                self.pub_eph.publish(self._eph_msg(eph, e.t_s))
                self.published["gnss/ephemeris"] = self.published.get("gnss/ephemeris", 0) + 1
        m = self.stamp(self._raw_cls(), e.t_s, self.frame_id)
        m.gps_week = int(e.t_gpst_s // 604800)
        m.rx_time_of_week_s = float(e.t_tag_s - 604800 * m.gps_week)
        m.system = [1 if s == "G" else 3 for s in e.system]
        m.prn = [int(p) for p in e.prn]
        for name, arr in (("pseudorange_m", e.pseudorange_m), ("pseudorange_sigma_m", e.pr_sigma_m),
                          ("pseudorange_rate_mps", e.pseudorange_rate_mps),
                          ("pseudorange_rate_sigma_mps", e.rate_sigma_mps), ("doppler_hz", e.doppler_hz),
                          ("carrier_frequency_hz", e.carrier_hz), ("cn0_dbhz", e.cn0_dbhz),
                          ("elevation_rad", e.elevation_rad), ("azimuth_rad", e.azimuth_rad)):
            setattr(m, name, [float(x) for x in arr])
        m.locked = [bool(x) for x in e.locked]
        if e.lock_time_s is not None:          # tracking option: per-channel receiver outputs
            m.lock_time_s = [float(x) for x in e.lock_time_s]
            m.tracking_flags = [int(x) for x in e.tracking_flags]
        return m

    def _eph_msg(self, eph, t_s):
        return fill_gnss_ephemeris(self._eph_cls(), eph, t_s)

    def stream_complete(self) -> bool:
        return self.mirror is None or self.flown.done

    def _on_flown(self):
        for g in self.flown.until(float("inf")):
            if self.raw_mode:                # a receiver epoch: its measurements, then its fix if it has one
                self.schedule([g.t_s], self.pub_raw, lambda i, e=g: self._raw_msg(e))
                if g.fix is None:
                    continue
                pos_cov, vel_cov = g.fix.cov_pos_enu_m2, g.fix.cov_vel_enu_m2ps2
                g = _FixArrays([g])
            else:
                pos_cov, vel_cov = np.diag(g.pos_sigma_enu_m**2), np.diag(g.vel_sigma_enu_mps**2)
            self.schedule(g.t_s, self.pub_fix, lambda i, g=g, c=pos_cov: self._fix_msg(g, i, c))
            self.schedule(g.t_s, self.pub_vel, lambda i, g=g, c=vel_cov: self._vel_msg(g, i, c))

    def _make_fix(self, i: int) -> NavSatFix:
        return self._fix_msg(self.fixes, i, self.pos_cov[i])

    def _make_vel(self, i: int) -> TwistWithCovarianceStamped:
        return self._vel_msg(self.fixes, i, self.vel_cov[i])

    def _fix_msg(self, f, i: int, pos_cov) -> NavSatFix:
        m = self.stamp(NavSatFix(), f.t_s[i], self.frame_id)
        m.status.status = NavSatStatus.STATUS_FIX
        m.status.service = NavSatStatus.SERVICE_GPS
        m.latitude, m.longitude = float(np.rad2deg(f.lat_rad[i])), float(np.rad2deg(f.lon_rad[i]))
        m.altitude = float(f.alt_m[i])
        m.position_covariance = np.asarray(pos_cov, float).ravel().tolist()
        m.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
        return m

    def _vel_msg(self, f, i: int, vel_cov) -> TwistWithCovarianceStamped:
        m = self.stamp(TwistWithCovarianceStamped(), f.t_s[i], self.enu_frame)
        v = m.twist.twist.linear
        v.x, v.y, v.z = map(float, f.vel_enu_mps[i])
        vcov = np.zeros((6, 6))
        vcov[:3, :3] = vel_cov
        vcov[3:, 3:] = np.eye(3) * 1e6          # angular part unknown: huge variance
        m.twist.covariance = vcov.ravel().tolist()
        return m


class _FixArrays:
    """The receiver's fixes in the array layout of ``GnssFixes``."""

    def __init__(self, epochs):
        self.t_s = np.array([e.t_s for e in epochs])
        self.lat_rad = np.array([e.fix.lat_rad for e in epochs])
        self.lon_rad = np.array([e.fix.lon_rad for e in epochs])
        self.alt_m = np.array([e.fix.alt_m for e in epochs])
        self.vel_enu_mps = np.array([e.fix.vel_enu_mps for e in epochs]).reshape(-1, 3)


def main(args=None):
    run_node(GnssNode, args)


if __name__ == "__main__":
    main()
