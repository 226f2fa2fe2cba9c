"""Tightly coupled GNSS input shared by the fusion node and the offline
replay: ``gnss/raw`` (hyper_nav_msgs/GnssMeasurements) and ``gnss/ephemeris``
(hyper_nav_msgs/GnssEphemeris) messages -> pseudorange updates of a
FusionEngine. Messages are duck-typed (rclpy or rosbags); no rclpy here.

Malformed messages (NaN pseudorange on a locked channel, arrays of different
lengths, an ephemeris that is no orbit) are rejected and counted in the
engine's counters (``rejected_gnss_raw_malformed``,
``rejected_gnss_ephemeris_malformed``), never raised.
"""
from __future__ import annotations

from . import conversions
from .core.fusion import FusionEngine
from .core.gnss.raw_to_pseudoranges import TightGnssInput


class TightGnssHandler:
    def __init__(self, engine: FusionEngine, tight: TightGnssInput):
        self.engine = engine
        self.tight = tight

    def on_raw(self, msg) -> str | None:
        """Queue a raw epoch and feed what is ready; the reason if rejected."""
        self.engine.counters["gnss_raw_msgs"] += 1
        try:
            self.tight.add_raw(conversions.gnss_raw(msg))
        except (ValueError, TypeError) as exc:
            self.engine.counters["rejected_gnss_raw_malformed"] += 1
            return str(exc)
        self.feed()
        return None

    def on_ephemeris(self, msg) -> str | None:
        """Store a broadcast record and feed the epochs it completes."""
        self.engine.counters["gnss_ephemeris_msgs"] += 1
        try:
            self.tight.add_ephemeris(conversions.gnss_ephemeris(msg))
        except (ValueError, TypeError) as exc:
            self.engine.counters["rejected_gnss_ephemeris_malformed"] += 1
            return str(exc)
        self.feed()
        return None

    def feed(self) -> None:
        """Pseudorange measurements of the ready epochs into the engine (call
        after every IMU sample too: held epochs become ready as the filter time
        advances)."""
        self.tight.feed(self.engine)

    def diagnostics(self) -> dict:
        """Channel/epoch counters of the input, prefixed ``gnss_``."""
        d = {f"gnss_{k}": v for k, v in self.tight.counters.items()}
        d["gnss_ephemerides"] = len(self.tight.ephemerides)
        return d
