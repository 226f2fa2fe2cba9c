"""Messages -> the virtual GNSS core, shared by the node and the offline
replay (duck-typed messages, rclpy or rosbags; no rclpy here). Malformed
messages are counted in the core's counters and their reason returned,
never raised."""
from __future__ import annotations

import numpy as np

from hyper_nav_filter import conversions as fconv

from hyper_nav_aiding.virtual_gnss import conversions
from hyper_nav_aiding.virtual_gnss.core.virtual_gnss import VirtualGnss
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams


class VirtualGnssInput:
    """``on_*`` per input topic; those that can complete receiver epochs
    return the virtual epochs now ready, with their channels' elevation and
    azimuth: [(RawGnssEpoch, el, az)]."""

    def __init__(self, params: VirtualGnssNodeParams):
        self.params = params
        self.core = VirtualGnss(params.config, params.corrections, params.lever_arm_b_m, params.rate_hz,
                                np.random.default_rng([params.seed, 8, 0]))
        self.received: dict[str, int] = {}
        self._t_imu_prev = None

    def _count(self, topic):
        self.received[topic] = self.received.get(topic, 0) + 1

    def _ready(self):
        return [(e, *self.core.geometry.pop(e.t_s)) for e in self.core.ready()]

    def on_ephemeris(self, msg) -> str | None:
        self._count("gnss/ephemeris")
        try:
            return self.core.add_ephemeris(fconv.gnss_ephemeris(msg), fconv.stamp_to_s(msg.header.stamp))
        except (ValueError, TypeError) as exc:
            return self.core.reject("rejected_ephemeris_malformed", str(exc))

    def on_raw(self, msg):
        """(virtual epochs ready, rejection reason or None)."""
        self._count("gnss/raw")
        try:
            reason = self.core.add_raw(fconv.gnss_raw(msg))
        except (ValueError, TypeError) as exc:
            reason = self.core.reject("rejected_raw_malformed", str(exc))
        return self._ready(), reason

    def on_imu(self, msg):
        self._count("imu/data_raw")
        s = conversions.imu_sample(msg, self._t_imu_prev)
        t = fconv.stamp_to_s(msg.header.stamp)
        if self._t_imu_prev is None or t > self._t_imu_prev:
            self._t_imu_prev = t
        if s is None:
            return []
        self.core.add_imu(s)
        return self._ready()

    def on_state(self, msg):
        self._count("nav/state")
        self.core.add_state(*conversions.nav_state(msg))
        return self._ready()

    def on_fix(self, msg) -> None:
        self._count("gnss/fix")
        self.core.add_fix(*conversions.fix_ecef(msg))
