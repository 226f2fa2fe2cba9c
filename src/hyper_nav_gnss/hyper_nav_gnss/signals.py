"""GNSS systems, signals and carrier frequencies, named once.

A signal is named by its RINEX 3 observation code without the type letter
(RINEX 3.05 section 5.1, Table 4): band digit + tracking attribute, e.g.
``"1C"`` (GPS L1 C/A), ``"2W"`` (GPS L2 P(Y) semi-codeless), ``"5Q"`` (L5 /
E5a pilot), ``"7I"`` (BDS B2I / Galileo E5b data), ``"6I"`` (BDS B3I). An
empty code means the system's legacy civil signal (GPS L1 C/A, Galileo E1,
BDS B1I), which is what the simulated receiver tracks.

Systems are the RINEX letters 'G' GPS, 'E' Galileo, 'C' BeiDou, 'J' QZSS,
'R' GLONASS, 'S' SBAS, 'I' NavIC. ``hyper_nav_msgs`` numbers them as the
u-blox gnssId except GPS = 1 (:data:`MSG_SYSTEM`): SBAS (u-blox gnssId 1)
and NavIC have no message code and are dropped at the message edge.

u-blox signal identifiers (UBX-RXM-RAWX / RXM-SFRBX ``gnssId``, ``sigId``;
u-blox F9/X20 interface descriptions, "GNSS signal identifiers") map to the
RINEX codes in :data:`UBX_SIGNALS`.
"""
from __future__ import annotations

from hyper_nav_gnss.constants import C_MPS

# carrier frequency [Hz] by (system, RINEX band digit)
_F_L1, _F_L2, _F_L5 = 1575.42e6, 1227.60e6, 1176.45e6
_F_E5B, _F_E5, _F_E6 = 1207.14e6, 1191.795e6, 1278.75e6
_F_B1I, _F_B3I = 1561.098e6, 1268.52e6
BAND_FREQUENCY_HZ = {
    ("G", "1"): _F_L1, ("G", "2"): _F_L2, ("G", "5"): _F_L5,
    ("E", "1"): _F_L1, ("E", "5"): _F_L5, ("E", "7"): _F_E5B, ("E", "8"): _F_E5, ("E", "6"): _F_E6,
    ("C", "2"): _F_B1I, ("C", "1"): _F_L1, ("C", "5"): _F_L5, ("C", "7"): _F_E5B, ("C", "8"): _F_E5,
    ("C", "6"): _F_B3I,
    ("J", "1"): _F_L1, ("J", "2"): _F_L2, ("J", "5"): _F_L5, ("J", "6"): _F_E6,
    ("S", "1"): _F_L1, ("S", "5"): _F_L5, ("I", "5"): _F_L5,
}
# the signal a code-less (legacy) channel carries
LEGACY_SIGNAL = {"G": "1C", "E": "1C", "C": "2I", "J": "1C"}

# hyper_nav_msgs GnssMeasurements.system codes (u-blox gnssId, GPS = 1)
MSG_SYSTEM = {"G": 1, "E": 2, "C": 3, "J": 5, "R": 6}
SYSTEM_OF_MSG = {v: k for k, v in MSG_SYSTEM.items()}

# u-blox gnssId -> system letter
UBX_GNSS = {0: "G", 1: "S", 2: "E", 3: "C", 4: "IMES", 5: "J", 6: "R", 7: "I"}
# (gnssId, sigId) -> RINEX code (u-blox interface description, signal identifiers)
UBX_SIGNALS = {
    (0, 0): "1C", (0, 3): "2L", (0, 4): "2S", (0, 6): "5I", (0, 7): "5Q",
    (1, 0): "1C",
    (2, 0): "1C", (2, 1): "1B", (2, 3): "5I", (2, 4): "5Q", (2, 5): "7I", (2, 6): "7Q", (2, 8): "6B", (2, 9): "6C",
    (2, 10): "6A",
    (3, 0): "2I", (3, 1): "2I", (3, 2): "7I", (3, 3): "7I", (3, 4): "6I", (3, 10): "6I", (3, 5): "1P", (3, 6): "1D",
    (3, 7): "5P", (3, 8): "5D",
    (5, 0): "1C", (5, 1): "1Z", (5, 4): "2S", (5, 5): "2L", (5, 8): "5I", (5, 9): "5Q", (5, 12): "1E",
    (6, 0): "1C", (6, 2): "2C",
    (7, 0): "5A",
}


def signal_code(system: str, code: str) -> str:
    """The RINEX code of a channel ('' -> the system's legacy signal)."""
    if code:
        return code
    if system not in LEGACY_SIGNAL:
        raise ValueError(f"no legacy signal defined for system {system!r}")
    return LEGACY_SIGNAL[system]


def frequency_hz(system: str, code: str = "") -> float:
    """Carrier frequency [Hz] of a signal (GLONASS FDMA is not supported:
    its frequency depends on the channel number)."""
    code = signal_code(system, code)
    try:
        return BAND_FREQUENCY_HZ[(system, code[0])]
    except KeyError:
        raise ValueError(f"unknown signal {system}{code}") from None


def wavelength_m(system: str, code: str = "") -> float:
    return C_MPS / frequency_hz(system, code)


def has_frequency(system: str, code: str) -> bool:
    return bool(code) and (system, code[0]) in BAND_FREQUENCY_HZ
