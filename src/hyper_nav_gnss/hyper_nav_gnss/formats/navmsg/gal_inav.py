"""Galileo I/NAV (E1-B) nominal pages -> broadcast records.

Galileo OS SIS ICD 2.0, 4.3.2 and 4.3.5. A nominal page is an even part
(120 bits: even/odd = 0, page type, data 112 bits, tail) and an odd part
(120 bits: even/odd = 1, page type, data 16 bits, reserved / SAR 64 bits,
CRC 24 bits, reserved 8, tail), each with its symbols decoded. u-blox
RXM-SFRBX gives them in 8 words (even part in words 0-3, odd part in words
4-7, MSB first, padded to 128 bits each). The CRC-24Q covers the even part's
first 114 bits and the odd part's first 82 bits (4.3.2.1.3): a page whose
CRC fails is counted and dropped. The 128-bit *word* is the 112 + 16 data
bits; its first 6 bits are the word type (Table 40):

* 1: IODnav, toe (14, 60 s), M0, e, sqrtA;
* 2: IODnav, Omega0, i0, omega, IDOT;
* 3: IODnav, OmegaDot, delta n, Cuc, Cus, Crc, Crs, SISA(E1,E5b);
* 4: IODnav, SVID, Cic, Cis, toc (14, 60 s), af0 (31, 2^-34), af1 (21, 2^-46), af2 (6, 2^-59);
* 5: ionosphere ai0..2 (NeQuick-G, not used here), BGD(E1,E5a), BGD(E1,E5b)
  (10 bits each, 2^-32 s), E5b/E1-B signal health and data validity, WN, TOW.

A record is emitted when word types 1-4 of a satellite share the IODnav
(5.1.9.2) and a word type 5 has been received; its clock refers to the
E1/E5b pair (data source bits 0 and 9 = 513, as RINEX 3 writes an I/NAV
record). Health bits are packed as RINEX 3.05 Table A8 (bit 0 E1-B DVS,
1-2 E1-B HS, 6 E5b DVS, 7-8 E5b HS). The week is GST WN + 1024 (the GPS week
count), taken within half a week of the transmission time.
"""
from __future__ import annotations

from collections import Counter

from hyper_nav_gnss.orbits.ephemeris import GAL_CLOCK_E1E5B, GAL_INAV_E1B, SECONDS_PER_WEEK, BroadcastEphemeris
from hyper_nav_gnss.formats.navmsg.bits import PI_GPS, Bits, crc24q, sisa_m

INAV_SOURCE = GAL_INAV_E1B | GAL_CLOCK_E1E5B


def page_from_ubx(words) -> Bits:
    """256 bits of a u-blox SFRBX Galileo I/NAV page (8 words)."""
    return Bits.from_words([int(w) & 0xFFFFFFFF for w in words], 32)


def check_page(page: Bits) -> str | None:
    """None for a nominal, CRC-valid even/odd page pair, else the reason."""
    if page.nbits < 256:
        return "short"
    if page.u(0, 1) != 0 or page.u(128, 1) != 1:
        return "even_odd"
    if page.u(1, 1) == 1 or page.u(129, 1) == 1:
        return "alert"
    crc_in = Bits((page.u(0, 114) << 82) | page.u(128, 82), 196)
    data = Bits(crc_in.value, 200).to_bytes()        # 4 leading zero bits + 196 bits = 25 bytes
    if crc24q(data) != page.u(210, 24):
        return "crc"
    return None


def word_of_page(page: Bits) -> Bits:
    """The 128-bit I/NAV word of a page (112 even + 16 odd data bits)."""
    return Bits((page.u(2, 112) << 16) | page.u(130, 16), 128)


def _w1(w):
    return {"iod": w.u(6, 10), "toe": w.u(16, 14) * 60.0, "M0": w.s(30, 32) * 2.0 ** -31 * PI_GPS,
            "e": w.u(62, 32) * 2.0 ** -33, "sqrtA": w.u(94, 32) * 2.0 ** -19}


def _w2(w):
    return {"iod": w.u(6, 10), "Omega0": w.s(16, 32) * 2.0 ** -31 * PI_GPS, "i0": w.s(48, 32) * 2.0 ** -31 * PI_GPS,
            "omega": w.s(80, 32) * 2.0 ** -31 * PI_GPS, "idot": w.s(112, 14) * 2.0 ** -43 * PI_GPS}


def _w3(w):
    return {"iod": w.u(6, 10), "OmegaDot": w.s(16, 24) * 2.0 ** -43 * PI_GPS,
            "delta_n": w.s(40, 16) * 2.0 ** -43 * PI_GPS, "cuc": w.s(56, 16) * 2.0 ** -29,
            "cus": w.s(72, 16) * 2.0 ** -29, "crc": w.s(88, 16) * 2.0 ** -5, "crs": w.s(104, 16) * 2.0 ** -5,
            "sisa": w.u(120, 8)}


def _w4(w):
    return {"iod": w.u(6, 10), "svid": w.u(16, 6), "cic": w.s(22, 16) * 2.0 ** -29, "cis": w.s(38, 16) * 2.0 ** -29,
            "toc": w.u(54, 14) * 60.0, "af0": w.s(68, 31) * 2.0 ** -34, "af1": w.s(99, 21) * 2.0 ** -46,
            "af2": w.s(120, 6) * 2.0 ** -59}


def _w5(w):
    e5b_hs, e1b_hs, e5b_dvs, e1b_dvs = w.u(67, 2), w.u(69, 2), w.u(71, 1), w.u(72, 1)
    return {"ai": (w.u(6, 11) * 0.25, w.s(17, 11) * 2.0 ** -8, w.s(28, 14) * 2.0 ** -15),
            "bgd_e1e5a": w.s(47, 10) * 2.0 ** -32, "bgd_e1e5b": w.s(57, 10) * 2.0 ** -32,
            "health": (e5b_hs << 7) | (e5b_dvs << 6) | (e1b_hs << 1) | e1b_dvs,
            "wn": w.u(73, 12), "tow": float(w.u(85, 20))}


_WORDS = {1: _w1, 2: _w2, 3: _w3, 4: _w4, 5: _w5}


class InavAssembler:
    """I/NAV pages of several satellites -> records (module docstring).
    ``add(prn, page)`` returns a new BroadcastEphemeris or None."""

    def __init__(self):
        self._w: dict[int, dict[int, dict]] = {}
        self._last: dict[int, tuple] = {}
        self.counts: Counter = Counter()
        self.nequick_ai = None

    def add(self, prn: int, page: Bits):
        bad = check_page(page)
        if bad is not None:
            self.counts[f"inav_{bad}"] += 1
            return None
        w = word_of_page(page)
        wt = w.u(0, 6)
        if wt not in _WORDS:
            self.counts["inav_other_word"] += 1
            return None
        self.counts[f"inav_word_{wt}"] += 1
        sv = self._w.setdefault(prn, {})
        sv[wt] = _WORDS[wt](w)
        if wt == 5:
            self.nequick_ai = sv[5]["ai"]
        if not all(k in sv for k in _WORDS):
            return None
        w1, w2, w3, w4, w5 = (sv[k] for k in (1, 2, 3, 4, 5))
        if not (w1["iod"] == w2["iod"] == w3["iod"] == w4["iod"]):
            self.counts["inav_iod_mismatch"] += 1
            return None
        if w4["svid"] != prn:
            self.counts["inav_svid_mismatch"] += 1
            return None
        key = (w1["iod"], w1["toe"], w4["toc"])
        if self._last.get(prn) == key:
            return None
        week = w5["wn"] + 1024
        dt = w1["toe"] - w5["tow"]
        if dt > SECONDS_PER_WEEK / 2:
            week -= 1
        elif dt < -SECONDS_PER_WEEK / 2:
            week += 1
        self._last[prn] = key
        self.counts["inav_records"] += 1
        return BroadcastEphemeris(
            "E", int(prn), w1["toe"], w4["toc"], int(week), w1["sqrtA"], w1["e"], w2["i0"], w2["Omega0"], w2["omega"],
            w1["M0"], w3["delta_n"], w2["idot"], w3["OmegaDot"], w3["cuc"], w3["cus"], w3["crc"], w3["crs"],
            w4["cic"], w4["cis"], w4["af0"], w4["af1"], w4["af2"], w5["bgd_e1e5a"], iode=int(w1["iod"]),
            health=int(w5["health"]), tgd2=w5["bgd_e1e5b"], data_source=INAV_SOURCE, accuracy_m=sisa_m(w3["sisa"]))

    def incomplete(self) -> int:
        return sum(1 for prn in self._w if prn not in self._last)
