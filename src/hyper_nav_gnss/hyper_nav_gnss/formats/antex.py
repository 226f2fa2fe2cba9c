"""ANTEX 1.4 antenna files (IGS ANTEX format description 1.4, 2011): the
satellite antennas' phase-centre offsets (PCO), for precise orbits, which
refer to the satellite's centre of mass.

Read: every satellite entry (``TYPE / SERIAL NO`` with a PRN code such as
``G01`` in columns 21-23), its ``VALID FROM`` / ``VALID UNTIL`` (GPST;
open-ended without ``VALID UNTIL``) and, per frequency (``G01``, ``G02``,
``E05``, ``C06`` ...: system + RINEX band), the ``NORTH / EAST / UP`` line,
for a satellite the x / y / z offset in the satellite body frame [mm] ->
metres. Receiver antenna entries and phase-centre variations are skipped
(counted). Files plain or compressed.

Refused with :class:`.rinex_file.RinexFormatError` (file, line, what): a
file whose first line is not ``ANTEX VERSION / SYST``, a version other
than 1.4, a malformed offset or date line, an antenna never ended.
"""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss.formats.rinex_file import RinexFormatError, read_rinex_text
from hyper_nav_gnss.orbits.ephemeris import calendar_to_system_s

_PRN = re.compile(r"^[GRECJIS]\d\d$")


@dataclass
class SatelliteAntennas:
    """``entries[sat]``: [(valid_from_gpst_s, valid_until_gpst_s, {freq: pco_body_m (3,)}, antenna type)];
    ``source`` the file name; ``counts`` of what was read and skipped."""
    entries: dict = field(default_factory=dict)
    source: str = ""
    counts: Counter = field(default_factory=Counter)

    def pco_body_m(self, sat: str, freq: str, t_gpst_s: float):
        """x, y, z [m] in the body frame of ``sat`` on ``freq`` (e.g. 'G01')
        valid at t, or None."""
        for a, b, pcos, _ in self.entries.get(sat, ()):
            if a <= t_gpst_s < b:
                return pcos.get(freq)
        return None


def _date(line: str, path, no: int) -> float:
    try:
        f = line[:60].split()
        return calendar_to_system_s("G", int(f[0]), int(f[1]), int(f[2]), int(f[3]), int(f[4]), float(f[5]))
    except (ValueError, IndexError):
        raise RinexFormatError(path, no, f"bad date {line[:60].strip()!r}") from None


def read_antex(path) -> SatelliteAntennas:
    """The satellite PCOs of the ANTEX file ``path`` (module docstring)."""
    from pathlib import Path
    lines = read_rinex_text(path).splitlines()
    if not lines or "ANTEX VERSION / SYST" not in lines[0]:
        raise RinexFormatError(path, 1, "not an ANTEX file (line 1: ANTEX VERSION / SYST)")
    try:
        version = float(lines[0][:8])
    except ValueError:
        raise RinexFormatError(path, 1, f"bad version {lines[0][:8]!r}") from None
    if abs(version - 1.4) > 1e-6:
        raise RinexFormatError(path, 1, f"ANTEX version {version:.1f} is not read (1.4 is)")
    out = SatelliteAntennas(source=Path(path).name)
    cur = None
    freq = None
    for no, ln in enumerate(lines, start=1):
        label = ln[60:].strip()
        if label == "START OF ANTENNA":
            if cur is not None:
                raise RinexFormatError(path, no, "START OF ANTENNA before END OF ANTENNA")
            cur = {"sat": None, "from": -np.inf, "until": np.inf, "pcos": {}, "type": ""}
        elif cur is None:
            continue
        elif label == "TYPE / SERIAL NO":
            sat = ln[20:23].strip()
            cur["type"] = ln[:20].strip()
            cur["sat"] = sat if _PRN.match(sat) else None
        elif label == "VALID FROM":
            cur["from"] = _date(ln, path, no)
        elif label == "VALID UNTIL":
            cur["until"] = _date(ln, path, no)
        elif label == "START OF FREQUENCY":
            freq = ln[3:6].strip()
        elif label == "NORTH / EAST / UP" and freq is not None and cur["sat"]:
            try:
                cur["pcos"][freq] = np.array([float(x) for x in ln[:30].split()[:3]]) * 1e-3
            except ValueError:
                raise RinexFormatError(path, no, f"bad offset line {ln[:30]!r}") from None
        elif label == "END OF FREQUENCY":
            freq = None
        elif label == "END OF ANTENNA":
            if cur["sat"]:
                out.entries.setdefault(cur["sat"], []).append((cur["from"], cur["until"], cur["pcos"], cur["type"]))
                out.counts["satellite_antennas"] += 1
            else:
                out.counts["receiver_antennas_skipped"] += 1
            cur = None
    if cur is not None:
        raise RinexFormatError(path, None, "the last antenna has no END OF ANTENNA")
    return out
