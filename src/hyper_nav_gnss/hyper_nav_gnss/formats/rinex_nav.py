"""RINEX navigation files -> broadcast records (:class:`.ephemeris.BroadcastEphemeris`).

:func:`read_rinex_nav` reads any of the versions below from a file as
archives hold it (:mod:`.rinex_file`: gzip, .Z, zip, bzip2), by its
``RINEX VERSION / TYPE`` line, and refuses another version, a non-GPS
RINEX 2 file, an unknown RINEX 4 record, or a file with no record of the
systems asked for (RinexFormatError: file, line, what).

* RINEX 2.x GPS navigation files (RINEX 2.11 Table A4): :func:`read_rinex2_nav`.
* RINEX 4.0x navigation files (``> EPH`` / ``> ION`` / ``> STO`` / ``> EOP``
  records): :func:`_read_v4` (legacy-message ephemerides, Klobuchar ION).
* RINEX 3.0x mixed navigation files (RINEX 3.05 Tables A6 GPS, A8 Galileo,
  A14 BDS, A10 QZSS): :func:`read_rinex3_nav`, GPS, Galileo, BeiDou and QZSS
  records (GLONASS, SBAS and NavIC records are skipped and counted). A
  record starts with a line ``Snn yyyy mm dd hh mm ss`` and is followed by
  its broadcast-orbit lines (7 for these systems, 3 or 4 for GLONASS/SBAS);
  records are found by that start line, so a file whose GLONASS records have
  the RINEX 3.05 fifth line reads as well as an older one.

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

import re
from collections import Counter
from pathlib import Path

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import SECONDS_PER_WEEK, BroadcastEphemeris, calendar_to_system_s
from hyper_nav_gnss.formats.rinex_file import RinexFormatError, read_rinex_text, rinex_version

RINEX3_SYSTEMS = ("G", "E", "C", "J")
_START3 = re.compile(r"^[GRECJIS][ 0-9][0-9] \d{4} ")


def _f(s: str) -> float:
    s = s.strip().replace("D", "E").replace("d", "e")
    return float(s) if s else 0.0


def _fields(line: str, start: int, n: int = 4) -> list[float]:
    return [_f(line[start + 19 * k:start + 19 * (k + 1)]) for k in range(n)]


def _text(path) -> list[str]:
    return read_rinex_text(path).splitlines()


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
    (None if absent). :func:`read_rinex_nav` also gives counts and errors."""
    nav = _read_v2(_text(path), path)
    ab = nav.iono.get("G")
    return list(nav), (ab[0] if ab else None), (ab[1] if ab else None)


def _read_v2(lines, path) -> "Rinex3Nav":
    """RINEX 2.11 GPS navigation (Table A3/A4): ION ALPHA / ION BETA in the
    header; records of 8 lines (``PRN yy mm dd hh mm ss.s`` + 3 clock terms,
    7 broadcast-orbit lines of 3X,4D19.12)."""
    alpha = beta = None
    out = Rinex3Nav()
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
    while i < len(lines):
        h = lines[i]
        if not h.strip():
            i += 1
            continue
        try:
            if i + 8 > len(lines):
                raise ValueError(f"{len(lines) - i - 1} broadcast-orbit lines, expected 7")
            prn = int(h[0:2])
            yy, mo, dd, hh, mi = (int(h[3 + 3 * k:5 + 3 * k]) for k in range(5))
            ss = float(h[17:22])
            year = yy + (2000 if yy < 80 else 1900)
            toc_s = calendar_to_system_s("G", year, mo, dd, hh, mi, ss)
            clk = _fields(h.ljust(80), 22, 3)
            orb = [_fields(lines[i + k].ljust(80), 3) for k in range(1, 8)]
            out.append(_build("G", prn, toc_s, clk, orb))
            out.counts["G"] += 1
        except ValueError as exc:
            out.counts["malformed"] += 1
            out.errors.append(f"{Path(path).name} line {i + 1} ({h[:3]}): {exc}")
        i += 8
    if alpha is not None and beta is not None:
        out.iono["G"] = (alpha, beta)
    return out


class Rinex3Nav(list):
    """The records of a RINEX 3 navigation file (a list of
    BroadcastEphemeris) with ``iono`` {system: (alpha, beta)}, ``counts``
    (records read per system, ``skipped_<system>`` for systems not read,
    ``malformed``) and ``errors`` (one line per malformed record)."""

    def __init__(self, records=(), iono=None, counts=None, errors=None):
        super().__init__(records)
        self.version = np.nan
        self.notes: list[str] = []
        self.iono = dict(iono or {})
        self.counts = Counter(counts or {})
        self.errors = list(errors or [])


def read_rinex3_nav_records(path, systems=RINEX3_SYSTEMS) -> Rinex3Nav:
    """All records of ``systems`` of a RINEX navigation file (2.xx GPS, 3.0x
    or 4.0x: :func:`read_rinex_nav`), with the Klobuchar sets, counters and
    the errors of malformed records (see the module docstring)."""
    return read_rinex_nav(path, systems)


def read_rinex_nav(path, systems=RINEX3_SYSTEMS, require_records: bool = True) -> Rinex3Nav:
    """Any RINEX navigation file the project reads, as archives hold it
    (:mod:`.rinex_file`), by its version: 2.xx GPS (``N``), 3.0x mixed,
    4.0x (``> EPH`` / ``> ION`` / ``> STO`` / ``> EOP`` records). Refused
    with file, line and what: another file type, another version, a RINEX 2
    navigation file of a system other than GPS, an unknown RINEX 4 record or
    message type, and (``require_records``) a file with no record of
    ``systems``."""
    lines = _text(path)
    v = rinex_version(lines, path)
    if v.major == 2:
        if v.file_type != "N":
            what = {"G": "GLONASS", "H": "SBAS", "E": "Galileo", "L": "Galileo"}.get(v.file_type, repr(v.file_type))
            raise RinexFormatError(path, 1, f"RINEX 2 navigation file of type {v.file_type!r} ({what}): "
                                            "only GPS ('N') RINEX 2 navigation files are read")
        out = _read_v2(lines, path) if "G" in systems else Rinex3Nav()
    elif v.file_type != "N":
        raise RinexFormatError(path, 1, f"file type {v.file_type!r}, not a navigation file ('N')")
    elif v.major == 3:
        out = _read_v3(lines, path, systems)
    elif v.major == 4:
        out = _read_v4(lines, path, systems)
    else:
        raise RinexFormatError(path, 1, f"RINEX navigation version {v.version:.2f} (read: 2.xx, 3.xx, 4.xx)")
    out.version = v.version
    if require_records and not len(out):
        raise RinexFormatError(path, None, f"no broadcast record of {'/'.join(systems)} "
                                           f"(RINEX {v.version:.2f}; {dict(out.counts) or 'nothing read'})")
    return out


def _header_iono(lines):
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
            return hdr, i
    raise RinexFormatError("?", None, "no END OF HEADER")


def _numbers(lines, firsts) -> list | None:
    """The 3 clock and 28 orbit fields of every record starting at the lines
    ``firsts`` (31 x 19 characters each), parsed by numpy in one call: the
    doubles ``float()`` gives (blank fields 0). None when some field is not a
    number: the records are then read one by one, the malformed ones named."""
    if not firsts:
        return []
    txt = "".join(lines[a].ljust(80)[23:80] + "".join(lines[a + k].ljust(80)[4:80] for k in range(1, 8))
                  for a in firsts).replace("D", "E").replace("d", "e")
    try:
        raw = txt.encode("ascii")
        f = np.frombuffer(raw, dtype="S19")
        blank = (np.frombuffer(raw, dtype=np.uint8).reshape(-1, 19) == 32).all(axis=1)
        f = np.where(blank, b"0", f).astype(float)
    except (ValueError, UnicodeEncodeError):
        return None
    return f.reshape(len(firsts), 31).tolist()


def _record(lines, a, b, sysc, path, out, values=None) -> None:
    """One 3.x-layout broadcast record at lines[a:b] (start line + 7 orbit lines);
    ``values``: its 31 numeric fields already parsed (:func:`_numbers`)."""
    h = lines[a]
    try:
        if b - a < 8:
            raise ValueError(f"{b - a - 1} broadcast-orbit lines, expected 7")
        prn = int(h[1:3])
        y, mo, dd, hh, mi, ss = (int(h[4:8]), int(h[9:11]), int(h[12:14]), int(h[15:17]),
                                 int(h[18:20]), int(h[21:23]))
        toc_s = calendar_to_system_s(sysc, y, mo, dd, hh, mi, ss)
        if values is not None:
            out.append(_build(sysc, prn, toc_s, values[:3], [values[3 + 4 * k:7 + 4 * k] for k in range(7)]))
            out.counts[sysc] += 1
            return
        # the 3 clock and 28 orbit fields (19 characters each) as one text: one D -> E pass, float() per field
        # (it takes the blanks around a number); the same values as _fields, a third of its time
        txt = (h.ljust(80)[23:80] + "".join(lines[a + k].ljust(80)[4:80] for k in range(1, 8))) \
            .replace("D", "E").replace("d", "e")
        v = [float(x) if not x.isspace() else 0.0 for x in
             (txt[19 * j:19 * (j + 1)] for j in range(31))]
        clk = v[:3]
        orb = [v[3 + 4 * k:7 + 4 * k] for k in range(7)]
        out.append(_build(sysc, prn, toc_s, clk, orb))
        out.counts[sysc] += 1
    except ValueError as exc:
        out.counts["malformed"] += 1
        out.errors.append(f"{Path(path).name} line {a + 1} ({h[:3]}): {exc}")


def _read_v3(lines, path, systems) -> Rinex3Nav:
    try:
        hdr, i = _header_iono(lines)
    except RinexFormatError:
        raise RinexFormatError(path, None, "no END OF HEADER") from None
    out = Rinex3Nav()
    starts = [k for k in range(i, len(lines)) if _START3.match(lines[k])]
    starts.append(len(lines))
    chosen = []
    for a, b in zip(starts[:-1], starts[1:]):
        sysc = lines[a][0]
        if sysc not in systems:
            out.counts[f"skipped_{sysc}"] += 1
            continue
        chosen.append((a, b, sysc))
    values = _numbers(lines, [a for a, b, _ in chosen if b - a >= 8])
    k = 0
    for a, b, sysc in chosen:
        if values is not None and b - a >= 8:
            _record(lines, a, b, sysc, path, out, values[k])
            k += 1
        else:
            _record(lines, a, b, sysc, path, out)
    for s, ka, kb in (("G", "GPSA", "GPSB"), ("C", "BDSA", "BDSB"), ("J", "QZSA", "QZSB")):
        if ka in hdr and kb in hdr:
            out.iono[s] = (hdr[ka], hdr[kb])
    return out


# RINEX 4.01 Table A5 (record types) and the message types of each system's > EPH records
RINEX4_EPH_TYPES = {"G": {"LNAV", "CNAV", "CNV2"}, "J": {"LNAV", "CNAV", "CNV2"}, "E": {"INAV", "FNAV"},
                    "C": {"D1", "D2", "CNV1", "CNV2", "CNV3"}, "R": {"FDMA", "L1OC", "L3OC"}, "S": {"SBAS"},
                    "I": {"LNAV", "L1NV"}}
# the records read into BroadcastEphemeris: the legacy messages the 3.x layout holds
RINEX4_EPH_READ = {"G": {"LNAV"}, "J": {"LNAV"}, "E": {"INAV", "FNAV"}, "C": {"D1", "D2"}}
RINEX4_RECORDS = ("EPH", "ION", "STO", "EOP")
# > ION message types holding the Klobuchar model (alpha0-3, beta0-3)
_ION_KLOBUCHAR = {("G", "LNAV"), ("J", "LNAV"), ("C", "D1D2"), ("G", "CNVX"), ("J", "CNVX")}
_ION_KNOWN = _ION_KLOBUCHAR | {("E", "IFNV"), ("C", "CNVX"), ("I", "LNAV"), ("I", "L1NV")}


def _read_v4(lines, path, systems) -> Rinex3Nav:
    """RINEX 4.0x navigation (RINEX 4.01 section 5.4, Tables A5-A35): after
    the header, records introduced by ``> REC SNN MSG``. ``> EPH`` of GPS/QZSS
    LNAV, Galileo INAV/FNAV and BDS D1/D2 are read (the RINEX 3 layout
    follows); the other message types (CNAV, CNV1-3, FDMA, SBAS, NavIC) and
    systems are counted as ``skipped_EPH_<S>_<MSG>``. ``> ION`` Klobuchar
    records (GPS/QZSS LNAV and CNVX, BDS D1D2: epoch + alpha0-2, alpha3 +
    beta0-2, beta3) give ``iono``; NeQuick-G (Galileo IFNV) and BDGIM (BDS
    CNVX) are counted as ``skipped_ION_<S>_<MSG>`` and named in ``notes``
    (not used here); ``> STO`` and ``> EOP`` are counted. An unknown record
    or message type is refused (RinexFormatError: file, line, what)."""
    try:
        _, i = _header_iono(lines)
    except RinexFormatError:
        raise RinexFormatError(path, None, "no END OF HEADER") from None
    out = Rinex3Nav()
    starts = [k for k in range(i, len(lines)) if lines[k].startswith(">")]
    if i < len(lines) and lines[i].strip() and not lines[i].startswith(">"):
        raise RinexFormatError(path, i + 1, f"expected a '> EPH/ION/STO/EOP' record, got {lines[i][:30]!r}")
    starts.append(len(lines))
    iono_t: dict = {}
    for a, b in zip(starts[:-1], starts[1:]):
        tok = lines[a][1:].split()
        if len(tok) < 2 or tok[0] not in RINEX4_RECORDS:
            raise RinexFormatError(path, a + 1, f"unknown RINEX 4 record {lines[a][:30].rstrip()!r} "
                                                f"(known: {', '.join(RINEX4_RECORDS)})")
        rec, sv = tok[0], tok[1]
        msg = tok[2] if len(tok) > 2 else ""
        sysc = sv[0]
        if rec == "EPH":
            if msg not in RINEX4_EPH_TYPES.get(sysc, ()):
                raise RinexFormatError(path, a + 1, f"unknown > EPH message type {msg!r} of system {sysc!r} "
                                                    f"(RINEX 4.01: {sorted(RINEX4_EPH_TYPES.get(sysc, ()))})")
            if sysc not in systems or msg not in RINEX4_EPH_READ.get(sysc, ()):
                out.counts[f"skipped_EPH_{sysc}_{msg}"] += 1
                continue
            _record(lines, a + 1, b, sysc, path, out)
        elif rec == "ION":
            if (sysc, msg) not in _ION_KNOWN:
                raise RinexFormatError(path, a + 1, f"unknown > ION message type {msg!r} of system {sysc!r}")
            if (sysc, msg) not in _ION_KLOBUCHAR:
                out.counts[f"skipped_ION_{sysc}_{msg}"] += 1
                note = {"IFNV": "Galileo NeQuick-G", "CNVX": "BDS BDGIM"}.get(msg, f"{sysc} {msg}")
                if note + " ionosphere records not used" not in out.notes:
                    out.notes.append(note + " ionosphere records not used")
                continue
            try:
                body = [ln.ljust(80) for ln in lines[a + 1:b]]
                if len(body) < 3:
                    raise ValueError(f"{len(body)} lines, expected 3")
                h = body[0]
                t = calendar_to_system_s("G", int(h[4:8]), int(h[9:11]), int(h[12:14]), int(h[15:17]),
                                         int(h[18:20]), int(h[21:23]))
                v = _fields(h, 23, 3) + _fields(body[1], 4, 4) + _fields(body[2], 4, 1)
            except ValueError as exc:
                out.counts["malformed"] += 1
                out.errors.append(f"{Path(path).name} line {a + 1} (ION {sv} {msg}): {exc}")
                continue
            out.counts[f"ION_{sysc}_{msg}"] += 1
            if sysc not in iono_t or t < iono_t[sysc]:          # the first broadcast of the file
                iono_t[sysc] = t
                out.iono[sysc] = (np.array(v[:4]), np.array(v[4:8]))
        else:
            out.counts[f"skipped_{rec}"] += 1
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
