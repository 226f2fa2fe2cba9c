"""What the Foxglove view shows, computed from messages (duck-typed: rclpy
messages live, rosbags messages from a bag). No rclpy, no foxglove here.

* map points: truth (``truth/state``), fused (``nav/state``), GNSS
  (``gnss/fix``) as (t, lat_deg, lon_deg, alt_m, ENU covariance);
* transforms: ``/tf`` and ``/tf_static`` entries as plain dicts;
* errors: at every ``nav/state`` epoch that has a ``truth/state`` of the same
  stamp (whichever arrives first), the estimate-minus-truth errors of
  position (ENU m), velocity (ENU m/s) and attitude (ENU deg)
  (``core.scoring``) with the filter's own 1-sigma from the covariance (the
  numbers of ``errors.png``, live).
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from hyper_nav_filter.conversions import stamp_to_s

from hyper_nav_workbench.core import scoring

_KEEP = 2000          # truth epochs kept for matching (the solution lags by output_delay_s)


def stamp_ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def navstate_point(m) -> dict:
    """A map point of a NavState (position covariance from its ``pos`` block, if any)."""
    cov = np.zeros(9)
    n = int(m.state_dim)
    if n:
        start = 0
        for entry in m.state_blocks:
            name, size = entry.split(":")
            if name == "pos":
                P = np.asarray(m.covariance, float).reshape(n, n)
                cov = P[start:start + 3, start:start + 3].ravel()
            start += int(size)
    return {"t_ns": stamp_ns(m.header.stamp), "lat_deg": float(np.rad2deg(m.lat_rad)),
            "lon_deg": float(np.rad2deg(m.lon_rad)), "alt_m": float(m.alt_m), "cov_enu": [float(x) for x in cov],
            "heading_rad": float(m.heading_rad), "vel_enu_mps": [float(x) for x in m.vel_enu_mps]}


def navsatfix_point(m) -> dict:
    return {"t_ns": stamp_ns(m.header.stamp), "lat_deg": float(m.latitude), "lon_deg": float(m.longitude),
            "alt_m": float(m.altitude), "cov_enu": [float(x) for x in m.position_covariance]}


def transforms(tf_msg) -> list[dict]:
    out = []
    for t in tf_msg.transforms:
        tr, q = t.transform.translation, t.transform.rotation
        out.append({"t_ns": stamp_ns(t.header.stamp), "parent": t.header.frame_id, "child": t.child_frame_id,
                    "translation": [tr.x, tr.y, tr.z], "rotation_xyzw": [q.x, q.y, q.z, q.w]})
    return out


def _sigmas(m) -> dict:
    n = int(m.state_dim)
    P = np.asarray(m.covariance, float).reshape(n, n)
    d = np.sqrt(np.maximum(np.diag(P), 0.0))
    out, start = {}, 0
    for entry in m.state_blocks:
        name, size = entry.split(":")
        out[name] = d[start:start + int(size)]
        start += int(size)
    return out


class ErrorTracker:
    """Pairs solutions with truth by stamp, whichever arrives first: each side
    waits (up to ``keep`` epochs) for the other, so every solution with a
    truth of the same stamp gets its error record, whatever the arrival
    order. ``on_truth`` and ``on_nav`` return the records completed by that
    message as (stamp in ns, record) pairs (usually zero or one)."""

    def __init__(self, keep: int = _KEEP):
        self.keep = keep
        self._truth: OrderedDict[int, object] = OrderedDict()
        self._nav: OrderedDict[int, object] = OrderedDict()   # solutions waiting for their truth
        self.unmatched = 0                                     # solutions dropped unpaired (memory bound)

    def on_truth(self, m) -> list[dict]:
        key = stamp_ns(m.header.stamp)
        self._truth[key] = m
        while len(self._truth) > self.keep:
            self._truth.popitem(last=False)
        nav = self._nav.pop(key, None)
        return [] if nav is None else [(key, self.record(nav, m))]

    def on_nav(self, m) -> list[dict]:
        key = stamp_ns(m.header.stamp)
        tr = self._truth.get(key)
        if tr is not None:
            return [(key, self.record(m, tr))]
        self._nav[key] = m
        while len(self._nav) > self.keep:
            self._nav.popitem(last=False)
            self.unmatched += 1
        return []

    @staticmethod
    def record(m, tr) -> dict:
        """The error record of a solution ``m`` against the truth ``tr`` of its stamp."""
        e = scoring.state_errors(scoring.states_from_msgs([m]), scoring.states_from_msgs([tr]))
        pos, vel, att = e["pos_enu_m"][0], e["vel_enu_mps"][0], e["att_enu_deg"][0]
        s = _sigmas(m)
        return {"t_s": stamp_to_s(m.header.stamp),
                "pos_err_enu_m": pos.tolist(), "pos_sigma_enu_m": s["pos"].tolist(),
                "vel_err_enu_mps": vel.tolist(), "vel_sigma_enu_mps": s["vel"].tolist(),
                "att_err_enu_deg": att.tolist(), "att_sigma_enu_deg": np.rad2deg(s["att"]).tolist(),
                "pos_err_3d_m": float(np.linalg.norm(pos)), "mode": int(m.mode),
                "last_nis": float(m.last_nis), "n_updates": int(m.n_updates)}


ERRORS_SCHEMA = {
    "type": "object", "title": "hyper_nav.Errors",
    "properties": {k: {"type": "array", "items": {"type": "number"}} for k in (
        "pos_err_enu_m", "pos_sigma_enu_m", "vel_err_enu_mps", "vel_sigma_enu_mps", "att_err_enu_deg",
        "att_sigma_enu_deg")} | {"t_s": {"type": "number"}, "pos_err_3d_m": {"type": "number"},
                                 "mode": {"type": "integer"}, "last_nis": {"type": "number"},
                                 "n_updates": {"type": "integer"}},
}
