"""RINEX observation files (3.0x and 4.0x; 2.11 rewritten to the 3.0x layout
first, :func:`_rinex2_as_3`) -> raw measurement epochs (one channel per signal).

RINEX 3.05 (IGS/RTCM, 2020) section 5 and Appendix A1-A3: a header with
``SYS / # / OBS TYPES`` (per system, the observation types, e.g. ``C1C L1C
D1C S1C``; continuation lines), ``APPROX POSITION XYZ``, ``ANTENNA: DELTA
H/E/N``, ``GLONASS SLOT / FRQ #``, ``SIGNAL STRENGTH UNIT``, then epochs
``> yyyy mm dd hh mm ss.sssssss  flag nsat`` followed by one line per
satellite: ``Snn`` and, per observation type of that system, a 16-column
field (F14.3 value, loss-of-lock indicator LLI, signal strength SSI).
Files as archives hold them (gzip, .Z, zip, bzip2, Hatanaka; Hatanaka
1996, CRINEX 1/3) are expanded by :mod:`.rinex_file`, which also checks the
``RINEX VERSION / TYPE`` line: another file type or version is refused
(RinexFormatError: file, line, what).

Signals are selected by observation code: ``signals={"G": ["1C", "2W"],
"E": ["1X", "7X"]}`` keeps only those codes of those systems (``None`` = every
code of every system; a system absent from the mapping is dropped). A
requested code the header does not list is named in ``errors`` and counted
(``missing_code_<S><code>``); the rest is read. Each (satellite, code) with
a code observation C becomes one channel of a
:class:`~hyper_nav_gnss.observations.RawGnssEpoch`: pseudorange C [m], carrier
phase L [cycles] (NaN when blank), Doppler D [Hz] (rate = -D x wavelength),
C/N0 S [dB-Hz] (when ``SIGNAL STRENGTH UNIT`` is DBHZ or absent; NaN
without an S observation), tracking flags PR_VALID, CP_VALID (L present and
LLI bit 0 clear), HALF_CYCLE (LLI bit 1 clear), DOPPLER_VALID. RINEX has no
code sigma and no lock time: ``pseudorange_sigma_m`` comes from the C/N0
(:func:`.weighting.code_sigma_m`), lock time is left empty.

Epoch times are receiver time (``RCV CLOCK OFFS APPL`` 0) in the file's
time system (GPS for the project's files), as continuous GPST seconds.
Event epochs (flags 2-5: header records or comments follow) and cycle-slip
records (flag 6) are skipped and counted; a malformed epoch or satellite
line is skipped, named and counted.
"""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import calendar_to_system_s
from hyper_nav_gnss.observations import RawGnssEpoch
from hyper_nav_gnss.formats.rinex_file import RinexFormatError, read_rinex_text, rinex_version
from hyper_nav_gnss.signals import C_MPS, has_frequency, frequency_hz
from hyper_nav_gnss.corrections.weighting import code_sigma_m

TRACK_PR_VALID, TRACK_CP_VALID, TRACK_HALF_CYCLE, TRACK_DOPPLER_VALID = 1, 2, 4, 8
MAX_ERRORS = 20
_EPOCH = re.compile(r"^> *(\d{4}) +(\d{1,2}) +(\d{1,2}) +(\d{1,2}) +(\d{1,2}) +([\d.]+) +(\d) *(\d+)")
_GLO_F1_HZ, _GLO_DF1_HZ, _GLO_F2_HZ, _GLO_DF2_HZ = 1602.0e6, 0.5625e6, 1246.0e6, 0.4375e6


@dataclass
class RinexObs:
    """``epochs`` (RawGnssEpoch, t_s = t_rx_gpst_s = continuous GPST),
    ``header`` (marker, receiver, antenna, approx_xyz_m, antenna_delta_hen_m,
    obs_types {system: [types]}, interval_s, time_system), ``counts`` and
    ``errors`` (the first MAX_ERRORS problems, named)."""
    epochs: list = field(default_factory=list)
    header: dict = field(default_factory=dict)
    counts: Counter = field(default_factory=Counter)
    errors: list = field(default_factory=list)

    def error(self, text: str) -> None:
        self.counts["errors"] += 1
        if len(self.errors) < MAX_ERRORS:
            self.errors.append(text)


def read_text(path) -> str:
    """The text of a RINEX file as archives hold it (gzip, .Z, zip, bzip2,
    Hatanaka; :mod:`.rinex_file`)."""
    return read_rinex_text(path)


# RINEX 2.11 (Table A1) / 2.12 observation types -> RINEX 3 three-character types per system
# (RTKLIB rinex.c convcode; a band's phase, Doppler and SNR go with the code RTKLIB pairs them with)
_V2_TYPES = {
    "G": {"C1": "C1C", "P1": "C1W", "C2": "C2X", "P2": "C2W", "C5": "C5X", "L1": "L1C", "L2": "L2W", "L5": "L5X",
          "D1": "D1C", "D2": "D2W", "D5": "D5X", "S1": "S1C", "S2": "S2W", "S5": "S5X"},
    "R": {"C1": "C1C", "P1": "C1P", "C2": "C2C", "P2": "C2P", "L1": "L1C", "L2": "L2P", "D1": "D1C", "D2": "D2P",
          "S1": "S1C", "S2": "S2P"},
    "E": {"C1": "C1X", "C5": "C5X", "C6": "C6X", "C7": "C7X", "C8": "C8X", "L1": "L1X", "L5": "L5X", "L6": "L6X",
          "L7": "L7X", "L8": "L8X", "D1": "D1X", "D5": "D5X", "D7": "D7X", "D8": "D8X", "S1": "S1X", "S5": "S5X",
          "S7": "S7X", "S8": "S8X"},
    "S": {"C1": "C1C", "C5": "C5X", "L1": "L1C", "L5": "L5X", "D1": "D1C", "D5": "D5X", "S1": "S1C", "S5": "S5X"},
    "J": {"C1": "C1C", "C2": "C2X", "C5": "C5X", "L1": "L1C", "L2": "L2X", "L5": "L5X", "S1": "S1C", "S2": "S2X",
          "S5": "S5X"},
    "C": {"C1": "C2I", "C2": "C2I", "C7": "C7I", "C6": "C6I", "L1": "L2I", "L2": "L2I", "L7": "L7I", "L6": "L6I",
          "S1": "S2I", "S2": "S2I", "S7": "S7I", "S6": "S6I"},
}
_V2_SYSTEMS = {"G": "G", " ": "G", "R": "R", "E": "E", "S": "S", "M": "GRESCJ"}


def _rinex2_as_3(lines: list, path, sysc: str) -> list:
    """A RINEX 2.11 observation file's lines rewritten in RINEX 3 layout
    (RINEX 2.11 section 5.1, Table A1: ``# / TYPES OF OBSERV`` in the
    header; epoch lines ``yy mm dd hh mm ss.sssssss  f nnn`` with up to 12
    satellites a line, continued on lines starting with 32 blanks; per
    satellite ceil(n/5) lines of 5 fields of 16 columns) so that one epoch
    parser reads both: each satellite's lines joined behind its ``Snn``,
    each type renamed per system (``_V2_TYPES``; a type a system does not
    have there is kept under a name no signal plan asks for)."""
    systems = _V2_SYSTEMS.get(sysc)
    if systems is None:
        raise RinexFormatError(path, 1, f"RINEX 2 satellite system {sysc!r} (known: G, R, E, S, M)")
    out, types, i = [], [], 0
    while i < len(lines):
        ln = lines[i]
        lab = ln[60:].strip()
        i += 1
        if lab == "# / TYPES OF OBSERV":
            if ln[:6].strip():
                types = []
            types += [ln[6 + 6 * k:12 + 6 * k].strip() for k in range(9) if ln[6 + 6 * k:12 + 6 * k].strip()]
            continue
        if lab == "END OF HEADER":
            if not types:
                raise RinexFormatError(path, i, "RINEX 2 header without # / TYPES OF OBSERV")
            for s in systems:
                m = _V2_TYPES.get(s, {})
                names = [m.get(t, f"X{t}{s}") for t in types]
                for k in range(0, len(names), 13):
                    head = f"{s}  {len(names):3d}" if k == 0 else " " * 6
                    out.append(f"{head} {' '.join(names[k:k + 13]):53s}SYS / # / OBS TYPES")
            out.append(ln)
            break
        out.append(ln)
    else:
        raise RinexFormatError(path, None, "no END OF HEADER")
    n_lines = max(1, -(-len(types) // 5))
    n = len(lines)
    while i < n:
        ln = lines[i]
        if not ln.strip():
            i += 1
            continue
        try:
            yy, mo, dd, hh, mi = (int(ln[1 + 3 * k:3 + 3 * k]) for k in range(5))
            sec, flag, nsat = float(ln[15:26]), int(ln[28:29] or 0), int(ln[29:32])
        except ValueError:
            out.append(f"? {ln}")                 # named by the epoch parser with its line number
            i += 1
            continue
        year = yy + (2000 if yy < 80 else 1900)
        out.append(f"> {year:4d} {mo:02d} {dd:02d} {hh:02d} {mi:02d}{sec:11.7f}  {flag:d}{nsat:3d}")
        i += 1
        if flag > 1:                              # event: nsat header or comment lines follow
            out += lines[i:i + nsat]
            i += nsat
            continue
        sats, row = [], ln
        while True:
            body = row[32:68]
            sats += [body[3 * k:3 * k + 3] for k in range(12) if body[3 * k:3 * k + 3].strip()]
            if len(sats) >= nsat or i >= n or not lines[i].startswith(" " * 32):
                break
            row = lines[i]
            i += 1
        for s in sats[:nsat]:
            sid = (s[0] if s[0] != " " else "G") + f"{int(s[1:]):02d}"
            out.append(sid + "".join(x.ljust(80)[:80] for x in lines[i:i + n_lines]))
            i += n_lines
    return out


def _parse_header(lines, obs: RinexObs) -> int:
    h = obs.header
    h["obs_types"] = {}
    h["glonass_k"] = {}
    h["signal_strength_unit"] = ""
    i = 0
    cur_sys, cur_n = None, 0
    slot_pending = 0
    while i < len(lines):
        ln = lines[i]
        lab = ln[60:].strip()
        i += 1
        if lab == "RINEX VERSION / TYPE":
            h["version"] = float(ln[:9])
        elif lab == "MARKER NAME":
            h["marker"] = ln[:60].strip()
        elif lab == "REC # / TYPE / VERS":
            h["receiver"] = ln[20:40].strip()
        elif lab == "ANT # / TYPE":
            h["antenna"] = ln[20:40].strip()
        elif lab == "APPROX POSITION XYZ":
            h["approx_xyz_m"] = np.array([float(ln[k * 14:(k + 1) * 14]) for k in range(3)])
        elif lab == "ANTENNA: DELTA H/E/N":
            h["antenna_delta_hen_m"] = np.array([float(ln[k * 14:(k + 1) * 14]) for k in range(3)])
        elif lab == "INTERVAL":
            h["interval_s"] = float(ln[:10])
        elif lab == "TIME OF FIRST OBS":
            h["time_system"] = ln[48:51].strip() or "GPS"
        elif lab == "SIGNAL STRENGTH UNIT":
            h["signal_strength_unit"] = ln[:20].strip()
        elif lab == "SYS / # / OBS TYPES":
            if ln[0] != " ":
                cur_sys, cur_n = ln[0], int(ln[3:6])
                h["obs_types"][cur_sys] = []
            types = ln[7:60].split()
            h["obs_types"][cur_sys] += types
        elif lab == "GLONASS SLOT / FRQ #":
            if ln[:3].strip():
                slot_pending = int(ln[:3])
            body = ln[4:60]
            for k in range(8):
                f = body[k * 7:(k + 1) * 7]
                if f.strip():
                    sat, kk = f[:3], int(f[4:7])
                    h["glonass_k"][int(sat[1:])] = kk
        elif lab == "END OF HEADER":
            break
    else:
        raise ValueError("no END OF HEADER")
    if not h["obs_types"]:
        raise ValueError("no SYS / # / OBS TYPES record in the header")
    del cur_n, slot_pending
    return i


def _frequency(sysc: str, code: str, prn: int, header: dict) -> float:
    if sysc == "R":
        k = header["glonass_k"].get(prn)
        if k is None:
            return np.nan
        return _GLO_F1_HZ + k * _GLO_DF1_HZ if code[0] == "1" else (
            _GLO_F2_HZ + k * _GLO_DF2_HZ if code[0] == "2" else np.nan)
    return frequency_hz(sysc, code) if has_frequency(sysc, code) else np.nan


def _plan(obs: RinexObs, signals, observables: str = "CLDS") -> dict:
    """{system: [(code, iC, iL, iD, iS)]} column indices of the kept signals."""
    plan = {}
    for sysc, types in obs.header["obs_types"].items():
        wanted = None if signals is None else signals.get(sysc)
        if signals is not None and wanted is None:
            obs.counts[f"system_not_selected_{sysc}"] += 1
            continue
        codes = [t[1:] for t in types if t[0] == "C"]
        if wanted is not None:
            for c in wanted:
                if c not in codes:
                    obs.counts[f"missing_code_{sysc}{c}"] += 1
                    obs.error(f"signal {sysc} {c}: no C{c} in the header's SYS / # / OBS TYPES "
                              f"({' '.join(types)})")
            codes = [c for c in codes if c in wanted]
        rows = []
        for c in codes:
            idx = {t: (types.index(t + c) if (t + c) in types and t in observables else -1) for t in "CLDS"}
            rows.append((c, idx["C"], idx["L"], idx["D"], idx["S"]))
        if rows:
            plan[sysc] = rows
    return plan


def _field(line: str, k: int):
    """(value or nan, LLI int) of observation field k of a satellite line."""
    f = line[3 + 16 * k:3 + 16 * (k + 1)]
    v = f[:14].strip()
    lli = f[14:15].strip()
    return (float(v) if v else np.nan), (int(lli) if lli.isdigit() else 0)


def read_rinex_obs(path, signals=None, max_epochs: int | None = None, observables: str = "CLDS") -> RinexObs:
    """Read a RINEX observation file (see the module docstring).
    ``observables``: the observation kinds read besides the code C (e.g.
    ``"CS"``: code and C/N0 only, for single-point positioning: a third less
    parsing; phases and Dopplers are then NaN)."""
    obs = RinexObs()
    lines = read_text(path).splitlines()
    v = rinex_version(lines, path)
    if v.file_type != "O":
        raise RinexFormatError(path, 1, f"file type {v.file_type!r}, not an observation file ('O')")
    if v.major == 2:
        lines = _rinex2_as_3(lines, path, v.system)
    elif v.major not in (3, 4):
        raise RinexFormatError(path, 1, f"RINEX observation version {v.version:.2f} (read: 2.xx, 3.xx, 4.xx)")
    i = _parse_header(lines, obs)
    obs.header["version"] = v.version
    if obs.header.get("time_system", "GPS") not in ("GPS", ""):
        raise ValueError(f"{Path(path).name}: time system {obs.header['time_system']} (only GPS time is read)")
    plan = _plan(obs, signals, "C" + observables)
    dbhz = obs.header["signal_strength_unit"] in ("DBHZ", "")
    name = Path(path).name
    n_lines = len(lines)
    if max_epochs is None and plan and all(r[2] < 0 and r[3] < 0 for rows in plan.values() for r in rows):
        fast = _read_code_and_cn0(lines, i, plan, dbhz, obs.header)
        if fast is not None:                         # a well-formed file: every epoch at once
            epochs, counts = fast
            obs.epochs += epochs
            obs.counts.update(counts)
            return obs
    while i < n_lines:
        ln = lines[i]
        if not ln.startswith(">"):
            obs.error(f"{name} line {i + 1}: expected an epoch record ('>'), got {ln[:20]!r}")
            i += 1
            continue
        m = _EPOCH.match(ln)
        if not m:
            obs.error(f"{name} line {i + 1}: malformed epoch record {ln[:40]!r}")
            i += 1
            continue
        y, mo, d, hh, mi = (int(m.group(k)) for k in range(1, 6))
        sec, flag, nsat = float(m.group(6)), int(m.group(7)), int(m.group(8))
        body = lines[i + 1:i + 1 + nsat]
        i += 1 + nsat
        if flag > 1:
            obs.counts[f"event_epochs_flag{flag}"] += 1
            continue
        t = calendar_to_system_s("G", y, mo, d, hh, mi, sec)
        ep = _epoch(t, body, plan, dbhz, obs, name, i - nsat)
        if ep is not None:
            obs.epochs.append(ep)
            obs.counts["epochs"] += 1
            if max_epochs is not None and len(obs.epochs) >= max_epochs:
                break
        if flag == 1:
            obs.counts["epochs_power_failure_flag"] += 1
    return obs


def _read_code_and_cn0(lines, i, plan, dbhz, header):
    """The epochs of a file read for codes and C/N0 only (no phase, no
    Doppler: single-point positioning) with the numbers of every satellite
    line parsed by numpy at once: the same epochs, channels and values as
    the line-by-line reading below. Returns (epochs, counts), or None when a
    line is not as the format says (the line-by-line reading then names it)."""
    n_lines = len(lines)
    counts = Counter()
    bodies = []                                           # (t, first body line, n satellites)
    while i < n_lines:
        ln = lines[i]
        m = _EPOCH.match(ln) if ln.startswith(">") else None
        if not m:
            return None
        y, mo, d, hh, mi = (int(m.group(k)) for k in range(1, 6))
        sec, flag, nsat = float(m.group(6)), int(m.group(7)), int(m.group(8))
        if i + 1 + nsat > n_lines:
            return None
        if flag > 1:
            counts[f"event_epochs_flag{flag}"] += 1
        else:
            bodies.append((calendar_to_system_s("G", y, mo, d, hh, mi, sec), i + 1, nsat, flag))
        i += 1 + nsat
    # every satellite line of the kept epochs, by system
    line_no, ep_of = [], []
    for e, (_, a, n, _) in enumerate(bodies):
        line_no.extend(range(a, a + n))
        ep_of.extend([e] * n)
    line_no = np.asarray(line_no, int)
    ep_of = np.asarray(ep_of, int)
    first = np.array([lines[k][:1] for k in line_no]) if len(line_no) else np.zeros(0, "U1")
    parts = []                        # (global line position, row, system, code, value, C/N0, prn)
    for sysc, rows in plan.items():
        pos = np.flatnonzero(first == sysc)
        if not len(pos):
            continue
        width = 3 + 16 * (max(max(r[1], r[4]) for r in rows) + 1)
        try:
            txt = "".join(lines[k][:width].ljust(width) for k in line_no[pos]).encode("ascii")
        except UnicodeEncodeError:
            return None
        mat = np.frombuffer(txt, dtype="S1").reshape(len(pos), width)

        def column(a, b):
            block = np.ascontiguousarray(mat[:, a:b])
            return block.view(f"S{b - a}")[:, 0], (block.view(np.uint8) == 32).all(axis=1)

        try:
            prn, _ = column(1, 3)
            u = np.frombuffer(prn.tobytes(), np.uint8).reshape(-1, 2)
            digit = (u >= 48) & (u <= 57)
            if not np.all((digit | (u == 32)).all(axis=1) & digit.any(axis=1) & ~((u[:, 0] != 32) & (u[:, 1] == 32))):
                return None                               # not "nn" or " n": the line-by-line reading names it
            prn = prn.astype(int)
            for r, (c, iC, _, _, iS) in enumerate(rows):
                f, blank = column(3 + 16 * iC, 17 + 16 * iC)
                v = np.where(blank, b"nan", f).astype(float)
                if iS >= 0:
                    g, gblank = column(3 + 16 * iS, 17 + 16 * iS)
                    sv = np.where(gblank, b"nan", g).astype(float)
                else:
                    sv = np.full(len(pos), np.nan)
                ok = ~np.isnan(v)
                pn = prn[ok]
                if sysc == "R":
                    fr = np.array([_frequency(sysc, c, q, header) for q in pn.tolist()], float)
                else:
                    fr = np.full(len(pn), _frequency(sysc, c, 0, header))
                parts.append((pos[ok], np.full(ok.sum(), r), sysc, c, v[ok], sv[ok], pn, fr))
        except ValueError:
            return None
    if parts:
        gpos = np.concatenate([q[0] for q in parts])
        order = np.lexsort((np.concatenate([q[1] for q in parts]), gpos))      # file order, then plan order
        gpos = gpos[order]
        sysl = np.concatenate([np.full(len(q[0]), q[2]) for q in parts])[order].tolist()
        code = np.concatenate([np.full(len(q[0]), q[3], dtype=object) for q in parts])[order].tolist()
        pr = np.concatenate([q[4] for q in parts])[order]
        cn0 = np.concatenate([q[5] for q in parts])[order] if dbhz else np.full(len(gpos), np.nan)
        prn = np.concatenate([q[6] for q in parts])[order].astype(int)
        freq = np.concatenate([q[7] for q in parts])[order]
    else:
        gpos, sysl, code, pr, cn0 = np.zeros(0, int), [], [], np.zeros(0), np.zeros(0)
        prn, freq = np.zeros(0, int), np.zeros(0)
    sig_ep = ep_of[gpos] if len(gpos) else np.zeros(0, int)
    bounds = np.searchsorted(sig_ep, np.arange(len(bodies) + 1)).tolist()
    # every channel's arrays once (the same expressions, element by element), then cut per epoch
    sigma = code_sigma_m(cn0)
    nan = np.full(len(gpos), np.nan)
    lam = C_MPS / freq
    rate, rate_sig = -nan * lam, np.full(len(gpos), 0.1) * lam
    locked, flags = np.ones(len(gpos), bool), np.full(len(gpos), TRACK_PR_VALID, np.uint8)
    epochs = []
    for e, (t, _, _, flag) in enumerate(bodies):
        a, b = bounds[e], bounds[e + 1]
        if a == b:
            counts["epochs_without_selected_signal"] += 1
        else:
            counts["signals"] += b - a
            epochs.append(RawGnssEpoch(float(t), float(t), tuple(sysl[a:b]), prn[a:b].copy(), pr[a:b].copy(),
                                       sigma[a:b].copy(), rate[a:b].copy(), rate_sig[a:b].copy(), locked[a:b].copy(),
                                       tuple(code[a:b]), nan[a:b].copy(), nan[a:b].copy(), cn0[a:b].copy(),
                                       np.zeros(0), flags[a:b].copy(), freq[a:b].copy()))
            counts["epochs"] += 1
        if flag == 1:
            counts["epochs_power_failure_flag"] += 1
    return epochs, counts


def _value(ln: str, k: int) -> float:
    """F14.3 value of observation field k of a satellite line (NaN when blank)."""
    v = ln[3 + 16 * k:17 + 16 * k].strip()
    return float(v) if v else np.nan


def _epoch(t, body, plan, dbhz, obs, name, first_line) -> RawGnssEpoch | None:
    sysl, prn, code, pr, cp, dop, cn0, flags, freq = [], [], [], [], [], [], [], [], []
    fcache = obs.__dict__.setdefault("_freq_cache", {})
    nan = np.nan
    for j, ln in enumerate(body):
        sysc = ln[:1]
        rows = plan.get(sysc)
        if rows is None:
            continue
        try:
            p = int(ln[1:3])
            for c, iC, iL, iD, iS in rows:
                v = _value(ln, iC)
                if v != v:                                  # NaN: no code observation
                    continue
                if iL >= 0:
                    lv, lli = _field(ln, iL)
                else:
                    lv, lli = nan, 0
                dv = _value(ln, iD) if iD >= 0 else nan
                sv = _value(ln, iS) if iS >= 0 else nan
                fl = TRACK_PR_VALID
                if lv == lv:
                    if not (lli & 1):
                        fl |= TRACK_CP_VALID
                    if not (lli & 2):
                        fl |= TRACK_HALF_CYCLE
                if dv == dv:
                    fl |= TRACK_DOPPLER_VALID
                key = (sysc, c, p if sysc == "R" else 0)
                fr = fcache.get(key)
                if fr is None:
                    fr = fcache[key] = _frequency(sysc, c, p, obs.header)
                sysl.append(sysc)
                prn.append(p)
                code.append(c)
                pr.append(v)
                cp.append(lv)
                dop.append(dv)
                cn0.append(sv if dbhz else nan)
                flags.append(fl)
                freq.append(fr)
        except ValueError as exc:
            obs.error(f"{name} line {first_line + j + 1} ({ln[:3]}): {exc}")
            continue
    if not sysl:
        obs.counts["epochs_without_selected_signal"] += 1
        return None
    f = np.asarray(freq, float)
    d = np.asarray(dop, float)
    c0 = np.asarray(cn0, float)
    lam = C_MPS / f
    obs.counts["signals"] += len(sysl)
    return RawGnssEpoch(float(t), float(t), tuple(sysl), np.asarray(prn, int), np.asarray(pr, float),
                        code_sigma_m(c0), -d * lam, np.full(len(d), 0.1) * lam, np.ones(len(sysl), bool),
                        tuple(code), np.asarray(cp, float), d, c0, np.zeros(0), np.asarray(flags, np.uint8), f)
