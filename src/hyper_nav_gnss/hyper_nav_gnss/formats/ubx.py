"""u-blox UBX raw logs -> raw measurement epochs and broadcast ephemerides.

Framing and checksums: ``pyubx2`` (``UBXReader`` in raw mode, then
``isvalid_checksum``); payloads of the two messages used are decoded here
from the u-blox interface description (F9 HPG 1.32 / X20 HPG 2.00, "UBX-RXM"):

* ``UBX-RXM-RAWX`` (0x02 0x15): rcvTow R8, week U2, leapS I1, numMeas U1,
  recStat X1 (bit 0 leapSec, bit 1 clkReset), version U1, then per
  measurement 32 bytes: prMes R8 [m], cpMes R8 [cycles], doMes R4 [Hz],
  gnssId, svId, sigId, freqId U1, locktime U2 [ms], cno U1 [dB-Hz],
  prStdev (0.01 x 2^n m), cpStdev (0.004 x n cycles), doStdev (0.002 x 2^n
  Hz), trkStat X1 (bit 0 prValid, 1 cpValid, 2 halfCyc, 3 subHalfCyc).
  Decoded with one numpy structured array per message (the same fields as
  pyubx2's full parse, which the tests compare with) into one
  :class:`~hyper_nav_gnss.observations.RawGnssEpoch` per message, one channel per
  signal: ``locked`` = prValid; ``tracking_flags`` = PR_VALID (prValid),
  CP_VALID (cpValid), HALF_CYCLE (halfCyc), DOPPLER_VALID (a measurement was
  output); carrier phase NaN unless cpValid; rate = -Doppler x wavelength.
  subHalfCyc (a half cycle already subtracted from the phase) has no
  GnssMeasurements flag: it is counted (``rawx_sub_half_cycle``), not carried.
* ``UBX-RXM-SFRBX`` (0x02 0x13): gnssId, svId, sigId, freqId, numWords, chn,
  version, reserved, numWords x U4 -> :mod:`.navmsg` (GPS/QZSS LNAV from L1
  C/A, Galileo I/NAV from E1-B, BeiDou D1 from B1I/B2I/B3I); other
  navigation messages (CNAV, B-CNAV1/2, F/NAV, HAS, SBAS, GLONASS) are
  counted as not decoded.

Every other frame (NAV-PVT, NMEA, ...) is counted by its identity. A frame
with a bad checksum, a payload whose length does not match its content and a
frame cut at the end of the file are skipped, named (the first 20 in
``errors``) and counted; the rest of the file is read.

Time: ``t_s`` of each epoch is the receiver time tag as continuous GPST
seconds (week x 604800 + rcvTow); importers map it to a bag's time axis.
"""
from __future__ import annotations

import io
import pathlib
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from pyubx2 import UBX_PROTOCOL, UBXReader, isvalid_checksum
from pyubx2.exceptions import UBXStreamError

from hyper_nav_gnss.orbits.ephemeris import SECONDS_PER_WEEK, BroadcastEphemeris
from hyper_nav_gnss.formats.navmsg import bds_d1, gal_inav, gps_lnav
from hyper_nav_gnss.observations import RawGnssEpoch
from hyper_nav_gnss.signals import C_MPS, UBX_GNSS, UBX_SIGNALS, has_frequency, frequency_hz

RAWX_ID = b"\x02\x15"
SFRBX_ID = b"\x02\x13"
TRACK_PR_VALID, TRACK_CP_VALID, TRACK_HALF_CYCLE, TRACK_DOPPLER_VALID = 1, 2, 4, 8
MAX_ERRORS = 20

RAWX_MEAS = np.dtype([("prMes", "<f8"), ("cpMes", "<f8"), ("doMes", "<f4"), ("gnssId", "u1"), ("svId", "u1"),
                      ("sigId", "u1"), ("freqId", "u1"), ("locktime", "<u2"), ("cno", "u1"), ("prStdev", "u1"),
                      ("cpStdev", "u1"), ("doStdev", "u1"), ("trkStat", "u1"), ("reserved", "u1")])
assert RAWX_MEAS.itemsize == 32
RAWX_HEAD = np.dtype([("rcvTow", "<f8"), ("week", "<u2"), ("leapS", "i1"), ("numMeas", "u1"), ("recStat", "u1"),
                      ("version", "u1"), ("reserved", "<u2")])

_GLO_F1_HZ, _GLO_DF1_HZ, _GLO_F2_HZ, _GLO_DF2_HZ = 1602.0e6, 0.5625e6, 1246.0e6, 0.4375e6


@dataclass
class UbxLog:
    """What a UBX log holds: ``epochs`` (RXM-RAWX, in file order),
    ``ephemerides`` [(t_gpst_s when the set was complete, record)] in
    decoding order, ``iono`` {system: (alpha[4], beta[4])} (the latest
    Klobuchar set of GPS LNAV page 18 / BDS D1 subframe 1), ``counts`` and
    ``errors`` (the first MAX_ERRORS problems, named)."""
    epochs: list = field(default_factory=list)
    ephemerides: list = field(default_factory=list)
    iono: dict = field(default_factory=dict)
    counts: Counter = field(default_factory=Counter)
    errors: list = field(default_factory=list)

    def records(self) -> list[BroadcastEphemeris]:
        return [e for _, e in self.ephemerides]

    def error(self, text: str) -> None:
        if len(self.errors) < MAX_ERRORS:
            self.errors.append(text)


def _frames(data: bytes, log: UbxLog):
    """(offset, raw frame) of every UBX frame in ``data`` (pyubx2 framing)."""
    stream = io.BytesIO(data)
    reader = UBXReader(stream, protfilter=UBX_PROTOCOL, parsing=0, validate=0, quitonerror=2)
    while True:
        start = stream.tell()
        try:
            raw, _ = reader.read()
        except UBXStreamError as exc:          # a frame cut by the end of the data
            log.counts["truncated_frame"] += 1
            log.error(f"frame after byte {start}: {exc}")
            return
        except Exception as exc:               # noqa: BLE001 -- any framing error of the library: counted, reading stops
            log.counts["framing_error"] += 1
            log.error(f"frame after byte {start}: {type(exc).__name__}: {exc}")
            return
        if raw is None:
            return
        yield stream.tell() - len(raw), raw


def _glonass_hz(code: str, freq_id: int) -> float:
    k = int(freq_id) - 7
    return _GLO_F1_HZ + k * _GLO_DF1_HZ if code.startswith("1") else _GLO_F2_HZ + k * _GLO_DF2_HZ


def decode_rawx(payload: bytes, offset: int, log: UbxLog) -> RawGnssEpoch | None:
    """One RXM-RAWX payload -> RawGnssEpoch (t_s = receiver time, GPST s)."""
    if len(payload) < 16:
        log.counts["rawx_short"] += 1
        log.error(f"RXM-RAWX at byte {offset}: payload {len(payload)} bytes, header needs 16")
        return None
    head = np.frombuffer(payload, RAWX_HEAD, 1)[0]
    n = int(head["numMeas"])
    if len(payload) != 16 + 32 * n:
        log.counts["rawx_bad_length"] += 1
        log.error(f"RXM-RAWX at byte {offset}: numMeas {n} needs {16 + 32 * n} bytes, payload has {len(payload)}")
        return None
    if int(head["recStat"]) & 2:
        log.counts["rawx_clock_reset"] += 1
    m = np.frombuffer(payload, RAWX_MEAS, n, 16)
    systems, codes, keep = [], [], []
    freq = np.full(n, np.nan)
    for k in range(n):
        g, sig = int(m["gnssId"][k]), int(m["sigId"][k])
        sysc = UBX_GNSS.get(g)
        code = UBX_SIGNALS.get((g, sig))
        if sysc is None or code is None:
            log.counts["rawx_unknown_signal"] += 1
            log.error(f"RXM-RAWX at byte {offset}: unknown gnssId {g} sigId {sig}")
            continue
        if sysc == "R":
            freq[k] = _glonass_hz(code, int(m["freqId"][k]))
        elif has_frequency(sysc, code):
            freq[k] = frequency_hz(sysc, code)
        systems.append(sysc)
        codes.append(code)
        keep.append(k)
    m = m[keep]
    freq = freq[keep]
    trk = m["trkStat"].astype(np.uint8)
    pr_valid = (trk & 1).astype(bool)
    cp_valid = (trk & 2).astype(bool)
    log.counts["rawx_sub_half_cycle"] += int(np.count_nonzero(trk & 8))
    flags = ((trk & 1) * TRACK_PR_VALID | ((trk >> 1) & 1) * TRACK_CP_VALID | ((trk >> 2) & 1) * TRACK_HALF_CYCLE
             | TRACK_DOPPLER_VALID).astype(np.uint8)
    lam = C_MPS / freq
    dop = m["doMes"].astype(float)
    t_rx = float(head["week"]) * SECONDS_PER_WEEK + float(head["rcvTow"])
    log.counts["rawx_epochs"] += 1
    log.counts["rawx_signals"] += len(keep)
    return RawGnssEpoch(
        t_rx, t_rx, tuple(systems), m["svId"].astype(int), m["prMes"].astype(float),
        0.01 * 2.0 ** (m["prStdev"] & 0x0F).astype(float), -dop * lam,
        0.002 * 2.0 ** (m["doStdev"] & 0x0F).astype(float) * lam, pr_valid, tuple(codes),
        np.where(cp_valid, m["cpMes"], np.nan), dop, m["cno"].astype(float), m["locktime"].astype(float) * 1e-3,
        flags, freq)


class _NavDecoder:
    """RXM-SFRBX payloads -> records through the per-message assemblers."""

    def __init__(self, log: UbxLog):
        self.log = log
        self.lnav = {"G": gps_lnav.LnavAssembler("G"), "J": gps_lnav.LnavAssembler("J")}
        self.d1 = bds_d1.D1Assembler()
        self.inav = gal_inav.InavAssembler()

    def add(self, payload: bytes, offset: int, rx_week: int, t_gpst_s: float) -> None:
        log = self.log
        if len(payload) < 8:
            log.counts["sfrbx_short"] += 1
            log.error(f"RXM-SFRBX at byte {offset}: payload {len(payload)} bytes")
            return
        g, sv, sig, _, nw = payload[0], payload[1], payload[2], payload[3], payload[4]
        if len(payload) != 8 + 4 * nw:
            log.counts["sfrbx_bad_length"] += 1
            log.error(f"RXM-SFRBX at byte {offset}: numWords {nw} needs {8 + 4 * nw} bytes, payload has {len(payload)}")
            return
        words = np.frombuffer(payload, "<u4", nw, 8)
        sysc = UBX_GNSS.get(g, "?")
        log.counts["sfrbx"] += 1
        eph = None
        try:
            if sysc in ("G", "J") and sig == 0 and nw == 10:
                a = self.lnav[sysc]
                eph = a.add(int(sv), gps_lnav.data_bits_from_ubx(words), rx_week)
                if a.iono is not None and sysc == "G":
                    log.iono["G"] = a.iono
            elif sysc == "C" and sig in (0, 1, 2, 3, 4, 10) and nw == 10:
                eph = self.d1.add(int(sv), bds_d1.data_bits_from_ubx(words))
                if self.d1.iono is not None:
                    log.iono["C"] = self.d1.iono
            elif sysc == "E" and sig == 1 and nw >= 8:
                eph = self.inav.add(int(sv), gal_inav.page_from_ubx(words[:8]))
            else:
                log.counts[f"sfrbx_not_decoded_{sysc}_sig{sig}"] += 1
                return
        except (IndexError, ValueError) as exc:
            log.counts["sfrbx_malformed"] += 1
            log.error(f"RXM-SFRBX at byte {offset} ({sysc}{sv:02d} sig {sig}): {exc}")
            return
        if eph is not None:
            log.ephemerides.append((t_gpst_s, eph))
            log.counts[f"ephemerides_{eph.system}"] += 1

    def finish(self) -> None:
        c = self.log.counts
        for name, a in (("G", self.lnav["G"]), ("J", self.lnav["J"]), ("C", self.d1), ("E", self.inav)):
            c.update(a.counts)
            inc = a.incomplete()
            if inc:
                c[f"incomplete_subframe_sets_{name}"] += inc


def read_ubx(source) -> UbxLog:
    """Read a UBX log (a path or bytes) into a :class:`UbxLog` (module docstring)."""
    data = pathlib.Path(source).read_bytes() if not isinstance(source, (bytes, bytearray)) else bytes(source)
    log = UbxLog()
    frames = list(_frames(data, log))
    rx_week, t_gpst = None, None
    for off, raw in frames:                     # the receiver's week, for the 10-bit LNAV week
        if raw[2:4] == RAWX_ID and len(raw) >= 24:
            rx_week = int.from_bytes(raw[14:16], "little")
            break
    nav = _NavDecoder(log)
    for off, raw in frames:
        ident = raw[2:4]
        if not isvalid_checksum(raw):
            log.counts["bad_checksum"] += 1
            log.error(f"UBX 0x{raw[2]:02x} 0x{raw[3]:02x} at byte {off}: checksum mismatch")
            continue
        payload = raw[6:-2]
        if ident == RAWX_ID:
            ep = decode_rawx(payload, off, log)
            if ep is not None:
                log.epochs.append(ep)
                t_gpst = ep.t_rx_gpst_s
                rx_week = int(t_gpst // SECONDS_PER_WEEK)
        elif ident == SFRBX_ID:
            if rx_week is None:
                log.counts["sfrbx_without_week"] += 1
                continue
            nav.add(payload, off, rx_week, t_gpst if t_gpst is not None else np.nan)
        else:
            log.counts[f"other_0x{raw[2]:02x}_0x{raw[3]:02x}"] += 1
    nav.finish()
    return log
