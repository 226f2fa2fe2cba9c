"""Broadcast group delays per signal: what a pseudorange on signal s carries
besides the satellite clock the navigation message broadcasts.

With dt_sv the broadcast clock (polynomial + relativity), a code measurement
on signal s reads P_s = rho + c (dt_r - dt_sv) + c d_s + I_s + T + e, and the
receiver removes c d_s. d_s per system (gamma_ab = (f_a / f_b)^2):

* GPS / QZSS LNAV (clock for the L1 P(Y) / L2 P(Y) ionosphere-free pair,
  IS-GPS-200 20.3.3.3.3.2): L1 d = TGD, L2 d = gamma_12 TGD; L5 d = gamma_15
  TGD (the L5 inter-signal correction ISC_L5 is in CNAV, not decoded here:
  an approximation of a few decimetres);
* Galileo (OS SIS ICD 2.0, 5.1.5): an I/NAV record's clock refers to E1/E5b:
  E1 d = BGD(E1,E5b), E5b d = gamma_17 BGD(E1,E5b) and, through the F/NAV
  clock relation dt_FNAV = dt_INAV - BGD(E1,E5b) + BGD(E1,E5a), E5a d =
  BGD(E1,E5b) + (gamma_15 - 1) BGD(E1,E5a); an F/NAV record's clock refers
  to E1/E5a: E1 d = BGD(E1,E5a), E5a d = gamma_15 BGD(E1,E5a);
* BeiDou D1/D2 (clock for B3I, BDS-SIS-ICD-B1I 3.0 5.2.4.10): B1I d = TGD1,
  B2I d = TGD2, B3I d = 0. B1C / B2a need TGD_B1Cp / TGD_B2ap of B-CNAV1/2
  (not decoded): no group delay is known for them.

Then the ionosphere-free combination of two signals corrected this way needs
no further term, and single frequency on the reference pair's first signal
is exact to the message's resolution.
"""
from __future__ import annotations

from hyper_nav_gnss.orbits.ephemeris import GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B, BroadcastEphemeris
from hyper_nav_gnss.signals import frequency_hz


class NoGroupDelay(ValueError):
    """The record gives no group delay for this signal."""


def galileo_clock_for(codes) -> int:
    """The Galileo clock pair to prefer for a set of RINEX codes: F/NAV
    (E1/E5a) when E5a is used without E5b, else I/NAV (E1/E5b)."""
    bands = {c[0] for c in codes}
    return GAL_CLOCK_E1E5A if ("5" in bands and "7" not in bands) else GAL_CLOCK_E1E5B


def group_delay_s(eph: BroadcastEphemeris, code: str) -> float:
    """d_s [s] of signal ``code`` (RINEX code, e.g. '1C') for record ``eph``
    (see the module docstring); raises NoGroupDelay where none is known."""
    sysc, band = eph.system, code[0]
    if sysc in ("G", "J"):
        f1 = frequency_hz("G", "1C")
        if band == "1":
            return eph.tgd
        if band in ("2", "5"):
            return (f1 / frequency_hz(sysc, code)) ** 2 * eph.tgd
    elif sysc == "E":
        f1 = frequency_hz("E", "1C")
        g15 = (f1 / frequency_hz("E", "5Q")) ** 2
        g17 = (f1 / frequency_hz("E", "7Q")) ** 2
        fnav = bool(eph.data_source & GAL_CLOCK_E1E5A) and not (eph.data_source & GAL_CLOCK_E1E5B)
        bgd_a, bgd_b = eph.tgd, eph.tgd2
        if fnav:
            if band == "1":
                return bgd_a
            if band == "5":
                return g15 * bgd_a
        else:
            if band == "1":
                return bgd_b
            if band == "7":
                return g17 * bgd_b
            if band == "5":
                return bgd_b + (g15 - 1.0) * bgd_a
    elif sysc == "C":
        if code in ("2I", "2Q", "2X"):
            return eph.tgd
        if code in ("7I", "7Q", "7X"):
            return eph.tgd2
        if band == "6":
            return 0.0
    raise NoGroupDelay(f"no broadcast group delay for {eph.sat_id} signal {code} "
                       f"(data source {eph.data_source})")
