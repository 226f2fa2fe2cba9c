"""The fusion node's converter of the relayed fixes (source type
``relay_fix``, declared through the entry-point group ``hyper_nav.sources``):
sensor_msgs/NavSatFix -> a GNSS antenna position measurement with the
message's ENU covariance. Duck-typed messages, no rclpy."""
from __future__ import annotations

from hyper_nav_filter import conversions
from hyper_nav_filter.sources.base import SourceType, navsatfix_check


class RelayFixSource(SourceType):
    TYPE = "relay_fix"
    MSG_TYPES = ("sensor_msgs/msg/NavSatFix",)
    DESCRIPTION = "antenna position fixes relayed by the fix_relay node (ENU covariance)"

    def convert(self, role, msg, engine):
        reason = navsatfix_check(msg)
        if reason is not None:
            return reason
        return self._queued(engine.add_measurement(conversions.gnss_position(msg)))
