"""Raw receiver observations as every reader, the simulator and the filter exchange them: one receiver epoch
(:class:`RawGnssEpoch`, parallel arrays of channels, as in ``hyper_nav_msgs/GnssMeasurements``), its checks, and the
store of broadcast records a receiver has decoded (:class:`EphemerisStore`).

Readers (:mod:`hyper_nav_gnss.formats`) produce these epochs; single-point positioning
(:mod:`hyper_nav_gnss.positioning.spp`) and the filter's tightly coupled update
(``hyper_nav_filter.core.raw_to_pseudoranges``) consume them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import BroadcastEphemeris, NearestToe, select_ephemeris, system_time_s

SUPPORTED_SYSTEMS = ("G", "C")
EPHEMERIS_SYSTEMS = ("G", "E", "C", "J")          # records the store takes (receiver_model: real signals)


class MalformedGnssInput(ValueError):
    """A raw epoch or ephemeris record that cannot be used; the message says why."""


_EMPTY = np.zeros(0)


@dataclass(frozen=True)
class RawGnssEpoch:
    """One receiver epoch, parallel arrays of N channels (as in
    hyper_nav_msgs/GnssMeasurements). A channel is one tracked *signal*: a
    multi-frequency receiver reports a satellite once per signal.

    t_s: measurement epoch on the filter's time axis (header.stamp);
    t_rx_gpst_s: receiver time tag, continuous GPST seconds
    (gps_week * 604800 + rx_time_of_week_s; = true time + receiver clock / c);
    system: 'G' | 'E' | 'C' | 'J' ... per channel (anything the receiver
    models do not support is dropped and counted);
    locked: False -> the code is not valid (lost lock, u-blox prValid = 0).

    Per-signal receiver outputs, each empty (not reported) or of length N:
    ``signal`` RINEX 3 code ("1C", "5Q", ...; "" = the system's legacy
    signal, :mod:`.signals`), ``carrier_phase_cycles`` (NaN: none),
    ``doppler_hz``, ``cn0_dbhz``, ``lock_time_s``, ``tracking_flags``
    (GnssMeasurements.TRACK_*), ``carrier_frequency_hz``."""
    t_s: float
    t_rx_gpst_s: float
    system: tuple
    prn: np.ndarray
    pseudorange_m: np.ndarray
    pseudorange_sigma_m: np.ndarray
    rate_mps: np.ndarray
    rate_sigma_mps: np.ndarray
    locked: np.ndarray
    signal: tuple = ()
    carrier_phase_cycles: np.ndarray = field(default_factory=lambda: _EMPTY)
    doppler_hz: np.ndarray = field(default_factory=lambda: _EMPTY)
    cn0_dbhz: np.ndarray = field(default_factory=lambda: _EMPTY)
    lock_time_s: np.ndarray = field(default_factory=lambda: _EMPTY)
    tracking_flags: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    carrier_frequency_hz: np.ndarray = field(default_factory=lambda: _EMPTY)

    def __len__(self) -> int:
        return len(self.system)

    def signal_of(self, k: int) -> str:
        """RINEX code of channel k ('' when the epoch carries no codes)."""
        return self.signal[k] if self.signal else ""

    def subset(self, idx) -> "RawGnssEpoch":
        """The epoch with only the channels ``idx`` (optional arrays kept empty when empty)."""
        idx = np.asarray(idx, int)

        def pick(a):
            a = np.asarray(a)
            return a[idx] if len(a) else a
        return RawGnssEpoch(self.t_s, self.t_rx_gpst_s, tuple(self.system[k] for k in idx), pick(self.prn),
                            pick(self.pseudorange_m), pick(self.pseudorange_sigma_m), pick(self.rate_mps),
                            pick(self.rate_sigma_mps), pick(self.locked),
                            tuple(self.signal[k] for k in idx) if self.signal else (),
                            pick(self.carrier_phase_cycles), pick(self.doppler_hz), pick(self.cn0_dbhz),
                            pick(self.lock_time_s), pick(self.tracking_flags), pick(self.carrier_frequency_hz))


_ARRAYS = ("prn", "pseudorange_m", "pseudorange_sigma_m", "rate_mps", "rate_sigma_mps", "locked")
_OPTIONAL = ("signal", "carrier_phase_cycles", "doppler_hz", "cn0_dbhz", "lock_time_s", "tracking_flags",
             "carrier_frequency_hz")


def check_raw_epoch(raw: RawGnssEpoch) -> None:
    """Raise MalformedGnssInput if the epoch is unusable: non-finite times,
    arrays of different lengths, or a locked channel with a non-finite
    pseudorange/rate or a non-positive sigma."""
    if not (np.isfinite(raw.t_s) and np.isfinite(raw.t_rx_gpst_s)):
        raise MalformedGnssInput(f"gnss raw: non-finite epoch time (t_s={raw.t_s}, t_rx_gpst_s={raw.t_rx_gpst_s})")
    n = len(raw.system)
    lengths = {name: np.size(getattr(raw, name)) for name in _ARRAYS}
    lengths.update({name: len(getattr(raw, name)) for name in _OPTIONAL if len(getattr(raw, name))})
    if any(v != n for v in lengths.values()):
        raise MalformedGnssInput(f"gnss raw: array lengths differ: system {n}, "
                                 + ", ".join(f"{k} {v}" for k, v in lengths.items()))
    ok = np.asarray(raw.locked, bool)
    for name in ("pseudorange_m", "pseudorange_sigma_m", "rate_mps", "rate_sigma_mps"):
        v = np.asarray(getattr(raw, name), float)[ok]
        if not np.all(np.isfinite(v)):
            raise MalformedGnssInput(f"gnss raw: non-finite {name} on a locked channel at t = {raw.t_s:.3f} s")
        if name.endswith("sigma_m") or name.endswith("sigma_mps"):
            if np.any(v <= 0.0):
                raise MalformedGnssInput(f"gnss raw: {name} must be > 0 on locked channels, got {v.tolist()}")


def check_ephemeris(eph: BroadcastEphemeris) -> None:
    """Raise MalformedGnssInput for a record that cannot describe an orbit."""
    vals = [getattr(eph, f) for f in ("toe", "toc", "sqrtA", "e", "i0", "Omega0", "omega", "M0", "delta_n", "idot",
                                      "OmegaDot", "cuc", "cus", "crc", "crs", "cic", "cis", "af0", "af1", "af2",
                                      "tgd")]
    if not all(map(math.isfinite, vals)):          # math, not numpy: 7x less per record (6,922 in a day's file)
        raise MalformedGnssInput(f"gnss ephemeris {eph.sat_id}: non-finite field")
    if eph.system not in EPHEMERIS_SYSTEMS:
        raise MalformedGnssInput(f"gnss ephemeris: unsupported system {eph.system!r}")
    if not (eph.sqrtA > 0.0 and 0.0 <= eph.e < 1.0):
        raise MalformedGnssInput(f"gnss ephemeris {eph.sat_id}: sqrtA {eph.sqrtA} / e {eph.e} is not an orbit")


class EphemerisStore:
    """Broadcast records by (system, prn); :meth:`select` picks the one valid
    at an epoch (nearest toe, within 2 h GPS / 1 h BDS) among those received
    by then. A record's reception time (the stamp of the message that brought
    it; -inf when not known) keeps the choice a function of the stamps: a
    record a receiver got later cannot be used for an earlier epoch, whatever
    order the messages arrived in (issue 22)."""

    def __init__(self, records=()):
        self._by_sat: dict[tuple[str, int], list[BroadcastEphemeris]] = {}
        self._received: dict[tuple, float] = {}       # (system, prn, week, toe) -> reception time (s)
        self._select_cache: dict = {}           # receiver_model's per-minute record choice
        self._nearest: dict = {}                # (system, prn) -> NearestToe of its whole list
        for r in records:
            self.add(r)

    @classmethod
    def from_mapping(cls, mapping) -> "EphemerisStore":
        """From {(system, prn): record or list of records}."""
        store = cls()
        for recs in mapping.values():
            for r in (recs if isinstance(recs, (list, tuple)) else [recs]):
                store.add(r)
        return store

    def add(self, eph: BroadcastEphemeris, received_s: float = -math.inf) -> bool:
        """Store a record (validated) received at ``received_s``; False if the
        same (system, prn, week, toe) is already stored (it is then replaced;
        the earlier reception time is kept)."""
        check_ephemeris(eph)
        key = (eph.system, int(eph.prn), eph.week, eph.toe)
        known = key in self._received              # only then can a stored record have this week and toe
        self._received[key] = min(self._received.get(key, math.inf), float(received_s))
        self._select_cache.clear()
        self._nearest.pop((eph.system, int(eph.prn)), None)
        recs = self._by_sat.setdefault((eph.system, int(eph.prn)), [])
        if known:
            for i, r in enumerate(recs):
                if r.week == eph.week and r.toe == eph.toe:
                    recs[i] = eph
                    return False
        recs.append(eph)
        return True

    def records_of(self, system: str, prn: int, received_by_s: float = math.inf) -> list:
        """The records of a satellite received by ``received_by_s``."""
        recs = self._by_sat.get((system, int(prn)), [])
        if recs and received_by_s < math.inf:
            recs = [r for r in recs if self._received[(r.system, int(r.prn), r.week, r.toe)] <= received_by_s + 1e-9]
        return recs

    def choose(self, recs: list, t_sys_s: float, clock: int = 0):
        """``select_ephemeris(recs, ..., t_sys_s, clock=clock)``: the same
        record; by a satellite's ``NearestToe`` (kept until a record of it is
        added) when ``recs`` is its whole list (``records_of`` with every
        record received)."""
        key = (recs[0].system, int(recs[0].prn))
        if recs is not self._by_sat.get(key):
            return select_ephemeris(recs, recs[0].sat_id, t_sys_s, clock=clock)
        ix = self._nearest.get(key)
        if ix is None:
            ix = self._nearest[key] = NearestToe(recs)
        return ix.select(t_sys_s, clock=clock)

    def select(self, system: str, prn: int, t_gpst_s: float,
               received_by_s: float = math.inf) -> BroadcastEphemeris | None:
        """The record valid at ``t_gpst_s`` among those received by ``received_by_s``."""
        recs = self.records_of(system, prn, received_by_s)
        if not recs:
            return None
        return self.choose(recs, float(system_time_s(system, t_gpst_s)))

    def __contains__(self, key) -> bool:
        return (key[0], int(key[1])) in self._by_sat

    def __len__(self) -> int:
        return sum(len(v) for v in self._by_sat.values())
