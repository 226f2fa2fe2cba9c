"""GPS (and QZSS) LNAV subframes -> broadcast records and Klobuchar coefficients.

IS-GPS-200 20.3.2 and 20.3.3: a subframe is ten 30-bit words, 24 data bits
and 6 parity bits each. With the parity removed the 240 data bits hold:
word 1 TLM (preamble 0x8B), word 2 HOW (TOW count of the *next* subframe,
17 bits, x 6 s; subframe ID, 3 bits, at data bit 43), then

* subframe 1 (Figure 20-1, Table 20-I): week number (10 bits, modulo 1024),
  L2 codes, URA index, SV health (6), IODC (2 MSBs + 8 LSBs), TGD
  (8, 2^-31 s), toc (16, 2^4 s), af2 (8, 2^-55), af1 (16, 2^-43), af0 (22, 2^-31);
* subframe 2 (Table 20-III): IODE, Crs, delta n, M0, Cuc, e, Cus, sqrtA, toe, fit flag;
* subframe 3: Cic, Omega0, Cis, i0, Crc, omega, OmegaDot, IODE, IDOT;
* subframe 4 page 18 (SV ID 56; 20.3.3.5.1.7): alpha_0..3, beta_0..3.

A record is emitted when subframes 1-3 of one satellite share the issue of
data (IODC LSBs = IODE of subframe 2 = IODE of subframe 3, 20.3.4.4); a new
set replaces the stored one. The 10-bit week is resolved with the receiver's
week, and the week of toe is taken within half a week of the transmission
time (the subframe's TOW), as RTKLIB does. u-blox RXM-SFRBX gives each word in
the 30 LSBs of a U4 with the data bits in bits 29..6 (already corrected for
the D30* polarity); :func:`data_bits_from_ubx` extracts them.
"""
from __future__ import annotations

from collections import Counter

from hyper_nav_gnss.orbits.ephemeris import SECONDS_PER_WEEK, BroadcastEphemeris
from hyper_nav_gnss.formats.navmsg.bits import PI_GPS, Bits, ura_m

PREAMBLE = 0x8B


def data_bits_from_ubx(words) -> Bits:
    """240 data bits of a u-blox SFRBX GPS/QZSS LNAV subframe (10 words)."""
    return Bits.from_words([(int(w) >> 6) & 0xFFFFFF for w in words], 24)


def subframe_id(b: Bits) -> int:
    return b.u(43, 3)


def tow_s(b: Bits) -> float:
    """TOW of the HOW (the start of the next subframe), s."""
    return b.u(24, 17) * 6.0


def _sf1(b: Bits) -> dict:
    return {"wn10": b.u(48, 10), "ura": b.u(60, 4), "health": b.u(64, 6),
            "iodc": (b.u(70, 2) << 8) | b.u(168, 8), "tgd": b.s(160, 8) * 2.0 ** -31,
            "toc": b.u(176, 16) * 16.0, "af2": b.s(192, 8) * 2.0 ** -55, "af1": b.s(200, 16) * 2.0 ** -43,
            "af0": b.s(216, 22) * 2.0 ** -31, "tow": tow_s(b)}


def _sf2(b: Bits) -> dict:
    return {"iode": b.u(48, 8), "crs": b.s(56, 16) * 2.0 ** -5, "delta_n": b.s(72, 16) * 2.0 ** -43 * PI_GPS,
            "M0": b.s(88, 32) * 2.0 ** -31 * PI_GPS, "cuc": b.s(120, 16) * 2.0 ** -29,
            "e": b.u(136, 32) * 2.0 ** -33, "cus": b.s(168, 16) * 2.0 ** -29, "sqrtA": b.u(184, 32) * 2.0 ** -19,
            "toe": b.u(216, 16) * 16.0}


def _sf3(b: Bits) -> dict:
    return {"cic": b.s(48, 16) * 2.0 ** -29, "Omega0": b.s(64, 32) * 2.0 ** -31 * PI_GPS,
            "cis": b.s(96, 16) * 2.0 ** -29, "i0": b.s(112, 32) * 2.0 ** -31 * PI_GPS,
            "crc": b.s(144, 16) * 2.0 ** -5, "omega": b.s(160, 32) * 2.0 ** -31 * PI_GPS,
            "OmegaDot": b.s(192, 24) * 2.0 ** -43 * PI_GPS, "iode": b.u(216, 8),
            "idot": b.s(224, 14) * 2.0 ** -43 * PI_GPS}


def klobuchar_from_page18(b: Bits):
    """(alpha[4], beta[4]) of subframe 4 page 18 (SV ID 56), else None."""
    if subframe_id(b) != 4 or b.u(50, 6) != 56:
        return None
    alpha = (b.s(56, 8) * 2.0 ** -30, b.s(64, 8) * 2.0 ** -27, b.s(72, 8) * 2.0 ** -24, b.s(80, 8) * 2.0 ** -24)
    beta = (b.s(88, 8) * 2.0 ** 11, b.s(96, 8) * 2.0 ** 14, b.s(104, 8) * 2.0 ** 16, b.s(112, 8) * 2.0 ** 16)
    return alpha, beta


def _full_week(wn10: int, ref_week: int) -> int:
    """The full GPS week nearest ``ref_week`` with ``wn10`` = week mod 1024."""
    k = round((ref_week - wn10) / 1024.0)
    return wn10 + 1024 * k


class LnavAssembler:
    """Subframes of several satellites -> records (see the module docstring).

    ``add(system, prn, bits, rx_week)`` returns a new BroadcastEphemeris when
    the subframe completes a consistent set, else None; ``iono`` holds the
    latest Klobuchar set; ``counts`` counts subframes by outcome."""

    def __init__(self, system: str = "G"):
        self.system = system
        self._sf: dict[int, dict[int, dict]] = {}
        self.iono = None
        self.counts: Counter = Counter()
        self._last: dict[int, tuple] = {}

    def add(self, prn: int, b: Bits, rx_week: int):
        if b.u(0, 8) != PREAMBLE:
            self.counts["lnav_bad_preamble"] += 1
            return None
        sid = subframe_id(b)
        if sid in (4, 5):
            ion = klobuchar_from_page18(b) if sid == 4 else None
            if ion is not None:
                self.iono = ion
                self.counts["lnav_iono"] += 1
            else:
                self.counts["lnav_almanac_page"] += 1
            return None
        if sid not in (1, 2, 3):
            self.counts["lnav_bad_subframe_id"] += 1
            return None
        self.counts[f"lnav_subframe_{sid}"] += 1
        sv = self._sf.setdefault(prn, {})
        sv[sid] = (_sf1, _sf2, _sf3)[sid - 1](b)
        if len(sv) < 3:
            return None
        s1, s2, s3 = sv[1], sv[2], sv[3]
        if not ((s1["iodc"] & 0xFF) == s2["iode"] == s3["iode"]):
            self.counts["lnav_iode_mismatch"] += 1
            return None
        key = (s1["iodc"], s2["toe"], s1["toc"])
        if self._last.get(prn) == key:
            return None                      # the same set again
        week = _full_week(s1["wn10"], rx_week)
        tow = s1["tow"] - 6.0                # transmission of subframe 1
        dt = s2["toe"] - tow
        toe_week = week - 1 if dt > SECONDS_PER_WEEK / 2 else (week + 1 if dt < -SECONDS_PER_WEEK / 2 else week)
        dtc = s1["toc"] - tow
        toc_week = week - 1 if dtc > SECONDS_PER_WEEK / 2 else (week + 1 if dtc < -SECONDS_PER_WEEK / 2 else week)
        toc = s1["toc"] + (toc_week - toe_week) * SECONDS_PER_WEEK
        self._last[prn] = key
        self.counts["lnav_records"] += 1
        return BroadcastEphemeris(
            self.system, int(prn), s2["toe"], toc, int(toe_week), s2["sqrtA"], s2["e"], s3["i0"], s3["Omega0"],
            s3["omega"], s2["M0"], s2["delta_n"], s3["idot"], s3["OmegaDot"], s2["cuc"], s2["cus"], s3["crc"],
            s2["crs"], s3["cic"], s3["cis"], s1["af0"], s1["af1"], s1["af2"], s1["tgd"], iode=int(s2["iode"]),
            health=int(s1["health"]), accuracy_m=ura_m(s1["ura"]))

    def incomplete(self) -> int:
        """Satellites whose stored subframes never formed a record."""
        return sum(1 for prn, sv in self._sf.items() if prn not in self._last)
