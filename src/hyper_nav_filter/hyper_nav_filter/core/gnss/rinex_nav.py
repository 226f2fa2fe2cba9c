"""RINEX navigation files -> broadcast records (:class:`.ephemeris.BroadcastEphemeris`).

* RINEX 2.x GPS navigation files (RINEX 2.11 Table A4): :func:`read_rinex2_nav`.
* RINEX 3.0x mixed navigation files (RINEX 3.05 Tables A6 GPS, A8 Galileo,
  A14 BDS, A10 QZSS): :func:`read_rinex3_nav`, GPS, Galileo, BeiDou and QZSS
  records (GLONASS, SBAS and NavIC records are skipped and counted). A
  record starts with a line ``Snn yyyy mm dd hh mm ss`` and is followed by
  its broadcast-orbit lines (7 for these systems, 3 or 4 for GLONASS/SBAS);
  records are found by that start line, so a file whose GLONASS records have
  the RINEX 3.05 fifth line reads as well as an older one. ``.gz`` files
  are read through gzip.

Per record: toe/toc/week in the system's own time (GPST for GPS/QZSS, GST on
the GPS week count for Galileo as RINEX writes it, BDT for BeiDou);
``tgd`` / ``tgd2`` = GPS TGD / -, Galileo BGD(E1,E5a) / BGD(E1,E5b), BDS
TGD1 / TGD2; ``accuracy_m`` = SV accuracy / SISA [m]; ``health`` = the
record's health word; ``data_source`` = Galileo data sources (Table A8:
bit 0 I/NAV E1-B, 1 F/NAV E5a-I, 2 I/NAV E5b-I, 8 clock for E1/E5a, 9 clock
for E1/E5b).

Header ``IONOSPHERIC CORR`` lines give the Klobuchar sets of GPS (GPSA/GPSB),
BDS (BDSA/BDSB, the first of the per-satellite lines when several) and QZSS
(QZSA/QZSB); Galileo's NeQuick-G coefficients (GAL) are not used here.
A malformed record (a field that is not a number, too few lines) is skipped,
named in ``errors`` and counted; the rest of the file is read.
"""
from __future__ import annotations

import gzip
import re
from collections import Counter
from pathlib import Path

import numpy as np

from .ephemeris import SECONDS_PER_WEEK, BroadcastEphemeris, calendar_to_system_s

RINEX3_SYSTEMS = ("G", "E", "C", "J")
_START3 = re.compile(r"^[GRECJIS][ 0-9][0-9] \d{4} ")


def _f(s: str) -> float:
    s = s.strip().replace("D", "E").replace("d", "e")
    return float(s) if s else 0.0


def _fields(line: str, start: int, n: int = 4) -> list[float]:
    return [_f(line[start + 19 * k:start + 19 * (k + 1)]) for k in range(n)]


def _text(path) -> list[str]:
    path = Path(path)
    if path.suffix == ".gz":
        with gzip.open(path, "rt", errors="replace") as f:
            return f.read().splitlines()
    return path.read_text(errors="replace").splitlines()


def _build(system, prn, toc_s, clk, orb) -> BroadcastEphemeris:
    """orb: 7 broadcast-orbit lines of 4 values (RINEX order). Orbit line 1
    starts with IODE (GPS) / IODnav (Galileo) / AODE (BDS); line 5 holds the
    Galileo data sources; line 6 SV accuracy (SISA), health, TGD (BGD E5a/E1,
    TGD1) and IODC (BGD E5b/E1, TGD2)."""
    (iode, crs, dn, m0), (cuc, e, cus, sqa), (toe, cic, om0, cis), (i0, crc, w, omd), \
        (idot, l2codes_or_source, week, _), (acc, health, tgd, iodc_or_tgd2) = orb[:6]
    week = int(round(week))
    toc = toc_s - week * SECONDS_PER_WEEK
    tgd2 = iodc_or_tgd2 if system in ("E", "C") else 0.0
    source = int(round(l2codes_or_source)) if system == "E" else 0
    return BroadcastEphemeris(system, prn, toe, toc, week, sqa, e, i0, om0, w, m0, dn, idot, omd,
                              cuc, cus, crc, crs, cic, cis, clk[0], clk[1], clk[2], tgd,
                              iode=int(round(iode)), health=int(round(health)), tgd2=tgd2, data_source=source,
                              accuracy_m=float(acc))


def read_rinex2_nav(path):
    """Read a RINEX 2.x GPS navigation file.

    Returns ``(ephs, alpha, beta)``: list of BroadcastEphemeris (system 'G') and
    the Klobuchar ION ALPHA [s, s/sc, s/sc^2, s/sc^3] / ION BETA [s, ...] arrays
    (None if absent)."""
    lines = _text(path)
    alpha = beta = None
    i = 0
    while i < len(lines):
        lab = lines[i][60:].strip()
        if lab == "ION ALPHA":
            alpha = np.array([_f(lines[i][2 + 12 * k:14 + 12 * k]) for k in range(4)])
        elif lab == "ION BETA":
            beta = np.array([_f(lines[i][2 + 12 * k:14 + 12 * k]) for k in range(4)])
        i += 1
        if lab == "END OF HEADER":
            break
    ephs = []
    while i < len(lines):
        h = lines[i]
        if not h.strip():
            i += 1
            continue
        prn = int(h[0:2])
        yy, mo, dd, hh, mi = (int(h[3 + 3 * k:5 + 3 * k]) for k in range(5))
        ss = float(h[17:22])
        year = yy + (2000 if yy < 80 else 1900)
        toc_s = calendar_to_system_s("G", year, mo, dd, hh, mi, ss)
        clk = _fields(h, 22, 3)
        orb = [_fields(lines[i + k].ljust(80), 3) for k in range(1, 8)]
        ephs.append(_build("G", prn, toc_s, clk, orb))
        i += 8
    return ephs, alpha, beta


class Rinex3Nav(list):
    """The records of a RINEX 3 navigation file (a list of
    BroadcastEphemeris) with ``iono`` {system: (alpha, beta)}, ``counts``
    (records read per system, ``skipped_<system>`` for systems not read,
    ``malformed``) and ``errors`` (one line per malformed record)."""

    def __init__(self, records=(), iono=None, counts=None, errors=None):
        super().__init__(records)
        self.iono = dict(iono or {})
        self.counts = Counter(counts or {})
        self.errors = list(errors or [])


def read_rinex3_nav_records(path, systems=RINEX3_SYSTEMS) -> Rinex3Nav:
    """All records of ``systems`` of a RINEX 3.0x navigation file, with the
    header's Klobuchar sets, counters and the errors of malformed records
    (see the module docstring)."""
    lines = _text(path)
    hdr: dict[str, np.ndarray] = {}
    i = 0
    while i < len(lines):
        ln = lines[i]
        i += 1
        lab = ln[60:].strip()
        if lab == "IONOSPHERIC CORR":
            key = ln[0:4].strip()
            if key not in hdr:
                hdr[key] = np.array([_f(ln[5 + 12 * k:17 + 12 * k]) for k in range(4)])
        if lab == "END OF HEADER":
            break
    out = Rinex3Nav()
    starts = [k for k in range(i, len(lines)) if _START3.match(lines[k])]
    starts.append(len(lines))
    for a, b in zip(starts[:-1], starts[1:]):
        h = lines[a]
        sysc = h[0]
        if sysc not in systems:
            out.counts[f"skipped_{sysc}"] += 1
            continue
        try:
            if b - a < 8:
                raise ValueError(f"{b - a - 1} broadcast-orbit lines, expected 7")
            prn = int(h[1:3])
            y, mo, dd, hh, mi, ss = (int(h[4:8]), int(h[9:11]), int(h[12:14]), int(h[15:17]),
                                     int(h[18:20]), int(h[21:23]))
            toc_s = calendar_to_system_s(sysc, y, mo, dd, hh, mi, ss)
            clk = _fields(h.ljust(80), 23, 3)
            orb = [_fields(lines[a + k].ljust(80), 4) for k in range(1, 8)]
            out.append(_build(sysc, prn, toc_s, clk, orb))
            out.counts[sysc] += 1
        except ValueError as exc:
            out.counts["malformed"] += 1
            out.errors.append(f"{Path(path).name} line {a + 1} ({h[:3]}): {exc}")
    for s, ka, kb in (("G", "GPSA", "GPSB"), ("C", "BDSA", "BDSB"), ("J", "QZSA", "QZSB")):
        if ka in hdr and kb in hdr:
            out.iono[s] = (hdr[ka], hdr[kb])
    return out


def read_rinex3_nav(path, systems=("G", "C")):
    """Records of ``systems`` (default GPS and BeiDou, as before Galileo was
    read; pass :data:`RINEX3_SYSTEMS` for all four) of a RINEX 3.x navigation
    file. Returns ``(ephs, iono)`` with ``iono = {'G': (alpha, beta), 'C': ...,
    'J': ...}`` from the header. For BDS records toe/toc/week are BDT, ``tgd``
    is TGD1 (B1I) and ``tgd2`` TGD2 (B2I). :func:`read_rinex3_nav_records`
    also gives the counts and the malformed records."""
    recs = read_rinex3_nav_records(path, systems)
    return list(recs), recs.iono


def _d(x: float) -> str:
    """One RINEX 3 navigation value: D19.12 (written with an E exponent)."""
    return f"{x:19.12E}"


def write_rinex3_nav(path, records, iono: dict | None = None) -> int:
    """Write GPS, Galileo, BDS and QZSS records as a RINEX 3.04 mixed
    navigation file (Tables A6, A8, A14, A10; the inverse of
    :func:`read_rinex3_nav_records`), e.g. to hand records decoded from a
    receiver log to a program that reads RINEX (RTKLIB). ``iono``: Klobuchar
    sets {system: (alpha, beta)} for the header. Returns the record count."""
    import datetime as _dtm
    lines = [f"{3.04:9.2f}{'':11s}{'N: GNSS NAV DATA':20s}{'M: MIXED':20s}RINEX VERSION / TYPE",
             f"{'hyper-nav':20s}{'':20s}{'':20s}PGM / RUN BY / DATE"]
    for sysc, (ka, kb) in (("G", ("GPSA", "GPSB")), ("C", ("BDSA", "BDSB")), ("J", ("QZSA", "QZSB"))):
        if iono and sysc in iono:
            for key, vals in zip((ka, kb), iono[sysc]):
                lines.append(f"{key:4s} " + "".join(f"{float(v):12.4E}" for v in vals) + f"{'':7s}IONOSPHERIC CORR")
    lines.append(f"{'':60s}END OF HEADER")
    n = 0
    epoch0 = {"C": _dtm.datetime(2006, 1, 1)}
    for e in records:
        if e.system not in RINEX3_SYSTEMS:
            continue
        t = _dtm.datetime(1980, 1, 6) if e.system != "C" else epoch0["C"]
        toc = t + _dtm.timedelta(seconds=float(e.toc_s))
        head = f"{e.system}{e.prn:02d} {toc:%Y %m %d %H %M %S}" + _d(e.af0) + _d(e.af1) + _d(e.af2)
        if e.system == "E":
            l5 = (e.idot, float(e.data_source), float(e.week), 0.0)
            l6 = (e.accuracy_m if np.isfinite(e.accuracy_m) else -1.0, float(e.health), e.tgd, e.tgd2)
        elif e.system == "C":
            l5 = (e.idot, 0.0, float(e.week), 0.0)
            l6 = (e.accuracy_m if np.isfinite(e.accuracy_m) else 0.0, float(e.health), e.tgd, e.tgd2)
        else:
            l5 = (e.idot, 0.0, float(e.week), 0.0)
            l6 = (e.accuracy_m if np.isfinite(e.accuracy_m) else 0.0, float(e.health), e.tgd, float(max(e.iode, 0)))
        orbit = [(float(max(e.iode, 0)), e.crs, e.delta_n, e.M0), (e.cuc, e.e, e.cus, e.sqrtA),
                 (e.toe, e.cic, e.Omega0, e.cis), (e.i0, e.crc, e.omega, e.OmegaDot), l5, l6,
                 (e.toe, 0.0, 0.0, 0.0)]
        lines.append(head)
        lines += ["    " + "".join(_d(v) for v in row) for row in orbit]
        n += 1
    Path(path).write_text("\n".join(lines) + "\n")
    return n
