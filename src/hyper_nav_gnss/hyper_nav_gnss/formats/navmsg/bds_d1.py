"""BeiDou D1 navigation message (MEO/IGSO satellites) -> broadcast records and
the BDS Klobuchar coefficients.

BDS-SIS-ICD-B1I 3.0 (and B3I 1.0), 5.2: a D1 subframe is ten 30-bit words;
word 1 = preamble (11) + Rev (4) + FraID (3) + SOW MSBs (8) + 4 parity bits,
words 2-10 = 22 information bits + 8 BCH parity bits each (the receiver has
de-interleaved them; u-blox RXM-SFRBX gives each word in the 30 LSBs of a
U4). Bit positions below count over the 300 bits *with* the parity bits in
place, so a field that crosses a word is read in two parts (5.2.4, Figures
5-4 .. 5-6):

* subframe 1: SatH1, AODC, URAI, WN (13, BDT week), toc (17, 2^3 s), TGD1 and
  TGD2 (10 each, 0.1 ns), alpha_0..3 / beta_0..3 (Klobuchar, 5.2.4.7),
  a2 (11, 2^-66), a0 (24, 2^-33), a1 (22, 2^-50), AODE;
* subframe 2: delta n, Cuc, M0, e, Cus, Crc, Crs, sqrtA, toe 2 MSBs;
* subframe 3: toe 15 LSBs (toe = 17 bits x 2^3 s), i0, Cic, OmegaDot, Cis,
  IDOT, Omega0, omega.

A record is emitted when subframes 1, 2, 3 of one satellite come from one
frame (SOW 6 s apart) and toc = toe (5.2.4.9), as RTKLIB checks. The BDS
clock (a0..a2) refers to B3I; TGD1 / TGD2 are the B1I / B2I group delays
relative to it. The GEO satellites' D2 message (C01-C05, C59-C63) is not
decoded (none in the project's u-blox log); its subframes are counted.
"""
from __future__ import annotations

from collections import Counter

from hyper_nav_gnss.orbits.ephemeris import BDS_GEO_PRNS, SECONDS_PER_WEEK, BroadcastEphemeris
from hyper_nav_gnss.formats.navmsg.bits import PI_GPS, Bits, ura_m

PREAMBLE = 0x712                # 11100010010 (5.2.3.1)


def data_bits_from_ubx(words) -> Bits:
    """300 bits of a u-blox SFRBX BeiDou D1/D2 subframe (10 words, 30 LSBs each)."""
    return Bits.from_words([int(w) & 0x3FFFFFFF for w in words], 30)


def subframe_id(b: Bits) -> int:
    return b.u(15, 3)


def sow_s(b: Bits) -> float:
    return float(b.u2(18, 8, 30, 12))


def _sf1(b: Bits) -> dict:
    return {"sow": sow_s(b), "health": b.u(42, 1), "aodc": b.u(43, 5), "urai": b.u(48, 4), "week": b.u(60, 13),
            "toc": b.u2(73, 9, 90, 8) * 8.0, "tgd1": b.s(98, 10) * 0.1e-9, "tgd2": b.s2(108, 4, 120, 6) * 0.1e-9,
            "alpha": (b.s(126, 8) * 2.0 ** -30, b.s(134, 8) * 2.0 ** -27, b.s(150, 8) * 2.0 ** -24,
                      b.s(158, 8) * 2.0 ** -24),
            "beta": (b.s2(166, 6, 180, 2) * 2.0 ** 11, b.s(182, 8) * 2.0 ** 14, b.s(190, 8) * 2.0 ** 16,
                     b.s2(198, 4, 210, 4) * 2.0 ** 16),
            "a2": b.s(214, 11) * 2.0 ** -66, "a0": b.s2(225, 7, 240, 17) * 2.0 ** -33,
            "a1": b.s2(257, 5, 270, 17) * 2.0 ** -50, "aode": b.u(287, 5)}


def _sf2(b: Bits) -> dict:
    return {"sow": sow_s(b), "delta_n": b.s2(42, 10, 60, 6) * 2.0 ** -43 * PI_GPS,
            "cuc": b.s2(66, 16, 90, 2) * 2.0 ** -31, "M0": b.s2(92, 20, 120, 12) * 2.0 ** -31 * PI_GPS,
            "e": b.u2(132, 10, 150, 22) * 2.0 ** -33, "cus": b.s(180, 18) * 2.0 ** -31,
            "crc": b.s2(198, 4, 210, 14) * 2.0 ** -6, "crs": b.s2(224, 8, 240, 10) * 2.0 ** -6,
            "sqrtA": b.u2(250, 12, 270, 20) * 2.0 ** -19, "toe_msb": b.u(290, 2)}


def _sf3(b: Bits) -> dict:
    return {"sow": sow_s(b), "toe_lsb": b.u2(42, 10, 60, 5), "i0": b.s2(65, 17, 90, 15) * 2.0 ** -31 * PI_GPS,
            "cic": b.s2(105, 7, 120, 11) * 2.0 ** -31, "OmegaDot": b.s2(131, 11, 150, 13) * 2.0 ** -43 * PI_GPS,
            "cis": b.s2(163, 9, 180, 9) * 2.0 ** -31, "idot": b.s2(189, 13, 210, 1) * 2.0 ** -43 * PI_GPS,
            "Omega0": b.s2(211, 21, 240, 11) * 2.0 ** -31 * PI_GPS, "omega": b.s2(251, 11, 270, 21) * 2.0 ** -31 * PI_GPS}


class D1Assembler:
    """D1 subframes of several satellites -> records (module docstring).
    ``add(prn, bits)`` returns a new BroadcastEphemeris or None; ``iono``
    holds the latest (alpha, beta) of a subframe 1; ``counts`` counts
    subframes by outcome."""

    def __init__(self):
        self._sf: dict[int, dict[int, dict]] = {}
        self._last: dict[int, tuple] = {}
        self.iono = None
        self.counts: Counter = Counter()

    def add(self, prn: int, b: Bits):
        if b.u(0, 11) != PREAMBLE:
            self.counts["d1_bad_preamble"] += 1
            return None
        if prn in BDS_GEO_PRNS:
            self.counts["d2_geo_not_decoded"] += 1
            return None
        sid = subframe_id(b)
        if sid in (4, 5):
            self.counts["d1_almanac_subframe"] += 1
            return None
        if sid not in (1, 2, 3):
            self.counts["d1_bad_subframe_id"] += 1
            return None
        self.counts[f"d1_subframe_{sid}"] += 1
        sv = self._sf.setdefault(prn, {})
        sv[sid] = (_sf1, _sf2, _sf3)[sid - 1](b)
        if sid == 1:
            self.iono = (sv[1]["alpha"], sv[1]["beta"])
        if len(sv) < 3:
            return None
        s1, s2, s3 = sv[1], sv[2], sv[3]
        if not (s2["sow"] == s1["sow"] + 6.0 and s3["sow"] == s2["sow"] + 6.0):
            return None                        # not one frame yet
        toe = float((s2["toe_msb"] << 15) | s3["toe_lsb"]) * 8.0
        if toe != s1["toc"]:
            self.counts["d1_toe_toc_mismatch"] += 1
            return None
        key = (s1["aode"], toe)
        if self._last.get(prn) == key:
            return None
        week = s1["week"]
        dt = toe - s1["sow"]
        if dt > SECONDS_PER_WEEK / 2:
            week -= 1
        elif dt < -SECONDS_PER_WEEK / 2:
            week += 1
        self._last[prn] = key
        self.counts["d1_records"] += 1
        return BroadcastEphemeris(
            "C", int(prn), toe, s1["toc"], int(week), s2["sqrtA"], s2["e"], s3["i0"], s3["Omega0"], s3["omega"],
            s2["M0"], s2["delta_n"], s3["idot"], s3["OmegaDot"], s2["cuc"], s2["cus"], s2["crc"], s2["crs"],
            s3["cic"], s3["cis"], s1["a0"], s1["a1"], s1["a2"], s1["tgd1"], iode=int(s1["aode"]),
            health=int(s1["health"]), tgd2=s1["tgd2"], accuracy_m=ura_m(s1["urai"]))

    def incomplete(self) -> int:
        return sum(1 for prn in self._sf if prn not in self._last)
