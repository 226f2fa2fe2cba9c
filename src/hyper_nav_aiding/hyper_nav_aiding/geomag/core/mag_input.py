"""The geomagnetic node's checks of an incoming magnetometer sample, shared
by the node (``nodes/geomag_node.py``) and its Monte Carlo feed
(``mc_geomag.py``): a sample whose stamp or field magnitude is not a finite
positive number, or whose stamp is not after the previous accepted one, is
rejected with the name of the counter it goes to. No rclpy."""
from __future__ import annotations

import math

from hyper_nav_aiding.geomag.core.matching import MagSample


class MagInputCheck:
    def __init__(self):
        self.last_t_s = -math.inf

    def reject(self, s: MagSample) -> str | None:
        """The counter a rejected sample goes to, or None (accepted: its stamp is remembered)."""
        if not (math.isfinite(s.t_s) and math.isfinite(s.total_nT)) or s.total_nT <= 0.0:
            return "rejected_mag_nan"
        if s.t_s <= self.last_t_s:
            return "rejected_mag_out_of_order"
        self.last_t_s = s.t_s
        return None
