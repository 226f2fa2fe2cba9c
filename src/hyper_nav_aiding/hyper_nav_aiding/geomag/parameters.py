"""The geomagnetic matching node's ROS parameters from a scenario: what the launcher writes (its descriptor) and
what the Monte Carlo feed (:mod:`.mc_feed`) configures the node's logic with, one function for both."""
from __future__ import annotations

from hyper_nav_filter.aiding_nodes import flat_parameters, output_deadline_s


def geomag_parameters(sc) -> dict:
    """The node's parameters from a scenario (``geomag:`` block, the flight's date, the clock deadline)."""
    # the block's ``reproduction`` part configures the offline reproduction only
    p = {**flat_parameters(sc.data.get("geomag") or {}, "geomag", skip=("reproduction",)),
         "qos.depth": int(sc["graph.qos_depth"]),
         # the flight's date: the node checks its map's epoch against it (issue 27)
         "magnetometer.epoch_decimal_year": float(sc["magnetometer.epoch_decimal_year"]),
         "clock.deadline_s": output_deadline_s(sc)}
    # a sample is matched against a solution released a second before it is taken (by stamps, not by
    # arrival): the fix is made when the sample comes and reaches the filter before its release
    p.setdefault("geomag.nav_reference_lag_s", float(sc.filter_config().output_delay_s) + 1.0)
    return p
