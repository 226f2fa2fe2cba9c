"""A node's own status on ``/diagnostics``, published every
``diagnostics_period_s`` of wall time: its counters plus a ``heartbeat``
counter that increases with every status, so a liveness monitor (``monitor``
node) tells a silent node from a quiet one. A node that ends by itself
publishes a last status with ``finished: true`` (no heartbeat is expected
after it).
"""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from hyper_nav_filter.ros_util import publisher_qos

LEVELS = {"ok": DiagnosticStatus.OK, "warn": DiagnosticStatus.WARN, "error": DiagnosticStatus.ERROR}


class NodeStatus:
    """Publishes one DiagnosticStatus named ``name`` (hardware_id = node name)."""

    def __init__(self, node, name: str):
        self.node = node
        self.name = name
        self.beats = 0
        self.pub = node.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))

    def publish(self, level: str, message: str, values: dict, finished: bool = False) -> None:
        self.beats += 1
        st = DiagnosticStatus(level=LEVELS[level], name=self.name, message=message,
                              hardware_id=self.node.get_name())
        vals = dict(values, heartbeat=self.beats)
        if finished:
            vals["finished"] = "true"
        st.values = [KeyValue(key=str(k), value=str(v)) for k, v in sorted(vals.items())]
        arr = DiagnosticArray(status=[st])
        arr.header.stamp = self.node.get_clock().now().to_msg()
        self.pub.publish(arr)
