"""The receiver formats the project reads, one registry keyed by format name.

Every command that takes a user's receiver file (``import_data``'s receiver presets, ``spp``'s description files
and its ``OBS NAV`` pair) chooses its reader here and nowhere else. A new receiver format is its reader module
(in this folder) and its entry below: two files.

Each entry turns a file into a :class:`ReceiverLog`: raw epochs (:class:`~hyper_nav_gnss.observations.RawGnssEpoch`,
``t_s`` = ``t_rx_gpst_s`` = continuous GPST), the broadcast records the file itself carries with the GPST second
each was complete, the Klobuchar sets, counts and the first errors (named), and header facts. ``needs_nav``: the
format carries no broadcast records, so a navigation file must be given beside it. ``detect`` tells the format of a
file from its first bytes (for commands given a bare path).
"""
from __future__ import annotations

import pathlib
import re
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable


@dataclass
class ReceiverLog:
    """What a receiver file holds, whatever its format (module docstring)."""
    epochs: list = field(default_factory=list)
    ephemerides: list = field(default_factory=list)      # [(t_gpst_s when complete or NaN, BroadcastEphemeris)]
    iono: dict = field(default_factory=dict)             # {system: (alpha[4], beta[4])}
    counts: Counter = field(default_factory=Counter)
    errors: list = field(default_factory=list)
    header: dict | None = None


@dataclass(frozen=True)
class ReceiverFormat:
    """One registered receiver format: its name (the ``preset`` of a description file), what it is, its reader
    ``read(path, signals=None, max_epochs=None, observables="CLDS") -> ReceiverLog``, whether a navigation file
    must come with it, and ``sniff(first_bytes) -> bool``."""
    name: str
    description: str
    read: Callable[..., ReceiverLog]
    needs_nav: bool
    sniff: Callable[[bytes], bool]


def _read_ubx(path, signals=None, max_epochs=None, observables="CLDS") -> ReceiverLog:
    from .ubx import read_ubx
    log = read_ubx(path)
    epochs = log.epochs[:max_epochs] if max_epochs else log.epochs
    return ReceiverLog(epochs, list(log.ephemerides), dict(log.iono), Counter(log.counts), list(log.errors))


def _read_rinex(path, signals=None, max_epochs=None, observables="CLDS") -> ReceiverLog:
    from .rinex_obs import read_rinex_obs
    obs = read_rinex_obs(path, signals=signals, max_epochs=max_epochs, observables=observables)
    return ReceiverLog(obs.epochs, [], {}, Counter(obs.counts), list(obs.errors), header=obs.header)


def _sniff_ubx(head: bytes) -> bool:
    return head[:2] == b"\xb5\x62"


def _sniff_rinex_obs(head: bytes) -> bool:
    line = head.split(b"\n", 1)[0]
    return b"RINEX VERSION / TYPE" in line and line[20:21] in (b"O", b"o")


RECEIVER_FORMATS: dict[str, ReceiverFormat] = {
    "ubx": ReceiverFormat("ubx", "u-blox UBX log (RXM-RAWX epochs, RXM-SFRBX navigation words)", _read_ubx,
                          needs_nav=False, sniff=_sniff_ubx),
    "rinex": ReceiverFormat("rinex", "RINEX observation file 2.xx / 3.0x / 4.0x (plain or as archives hold it: "
                                     "gzip, .Z, zip, Hatanaka)", _read_rinex, needs_nav=True, sniff=_sniff_rinex_obs),
}


def receiver_format(name: str) -> ReceiverFormat:
    """The registered format ``name``; KeyError (the caller names the field and suggests) when there is none."""
    return RECEIVER_FORMATS[name]


def detect(path) -> str | None:
    """The registered format of the file at ``path`` from its first bytes, or None. A compressed RINEX file
    (.gz, .Z, .zip, .crx, ...) is read as RINEX: archives hold observation files only in that form."""
    p = pathlib.Path(path)
    with open(p, "rb") as f:
        head = f.read(256)
    for fmt in RECEIVER_FORMATS.values():
        if fmt.sniff(head):
            return fmt.name
    if _RINEX_OBS_NAME.search(p.name):
        return "rinex"
    return None


# RINEX 2 short names (ssssdddf.yyO / .yyD Hatanaka) and RINEX 3/4 long names (..._MO.rnx / .crx), compressed or not
_RINEX_OBS_NAME = re.compile(r"(\.\d\d[od]|_[a-z]o\.(rnx|crx))(\.(gz|z|zip|bz2))?$", re.IGNORECASE)
