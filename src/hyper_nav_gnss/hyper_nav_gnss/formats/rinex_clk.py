"""RINEX clock files (RINEX CLK 2.00, 3.00-3.04): the satellite clock
records (``AS``) as a :class:`~hyper_nav_gnss.orbits.precise.ClockGrid`
(continuous GPST seconds, clocks in s, NaN where a satellite has no record
at an epoch). Receiver / station records (``AR``), calibration and
discontinuity records (``CR``, ``DR``, ``MS``) are counted, not used.
Files plain or compressed as archives hold them.

Refused with :class:`.rinex_file.RinexFormatError` (file, line, what): a
file whose first line is not a RINEX clock header (type ``C``), a version
outside 2.00-3.04, a ``TIME SYSTEM ID`` other than GPS, a malformed ``AS``
record, a file without satellite clocks.
"""
from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from hyper_nav_gnss.formats.rinex_file import RinexFormatError, read_rinex_text
from hyper_nav_gnss.orbits.ephemeris import calendar_to_system_s
from hyper_nav_gnss.orbits.precise import ClockGrid

RECORD_TYPES = ("AS", "AR", "CR", "DR", "MS")


def read_rinex_clk(path, counts: Counter | None = None) -> ClockGrid:
    """The satellite clocks of the RINEX CLK file ``path`` (module docstring);
    ``counts`` receives the records read per type."""
    counts = counts if counts is not None else Counter()
    lines = read_rinex_text(path).splitlines()
    first = lines[0] if lines else ""
    if "RINEX VERSION / TYPE" not in first or first[:60].split()[1:2] != ["C"]:
        raise RinexFormatError(path, 1, "not a RINEX clock file (line 1: RINEX VERSION / TYPE with type C)")
    try:
        version = float(first[:9])
    except ValueError:
        raise RinexFormatError(path, 1, f"bad version {first[:9]!r}") from None
    if not 2.0 <= version < 3.05:
        raise RinexFormatError(path, 1, f"RINEX clock version {version:.2f} is not read (2.00 to 3.04 are)")
    k = 1
    while k < len(lines) and "END OF HEADER" not in lines[k]:
        if "TIME SYSTEM ID" in lines[k][60:] and lines[k][:60].strip() not in ("", "GPS"):
            raise RinexFormatError(path, k + 1, f"time system {lines[k][:60].strip()!r} not read (GPS only)")
        k += 1
    if k >= len(lines):
        raise RinexFormatError(path, None, "no END OF HEADER")
    recs: dict = {}
    for no, ln in enumerate(lines[k + 1:], start=k + 2):
        tok = ln.split()
        if not tok or tok[0] not in RECORD_TYPES:
            continue                            # continuation lines of records with more than 2 values
        counts[f"clk_{tok[0]}"] += 1
        if tok[0] != "AS":
            continue
        try:
            sat = tok[1]
            y, mo, d, h, mi = (int(x) for x in tok[2:7])
            t = calendar_to_system_s("G", y, mo, d, h, mi, float(tok[7]))
            val = float(tok[9].replace("D", "E"))
        except (ValueError, IndexError):
            raise RinexFormatError(path, no, f"bad AS record {ln.rstrip()!r}") from None
        recs[(t, sat)] = val
    if not recs:
        raise RinexFormatError(path, None, "no satellite clock (AS) record")
    times = np.array(sorted({t for t, _ in recs}))
    sats = tuple(sorted({s for _, s in recs}))
    ti = {t: i for i, t in enumerate(times)}
    si = {s: j for j, s in enumerate(sats)}
    clk = np.full((len(times), len(sats)), np.nan)
    for (t, s), v in recs.items():
        clk[ti[t], si[s]] = v
    if len(times) < 2:
        raise RinexFormatError(path, None, "one epoch: a clock product needs at least 2")
    return ClockGrid(times, sats, clk, Path(path).name)
