"""Synthetic broadcast-ephemeris constellations for an arbitrary epoch, and
satellite visibility.

Choice (documented as the "simplest honest way"): the constellation is built
from *real* RINEX records. For each PRN one real record is the template and is
re-referenced to the scenario epoch by :func:`ephemeris.shift_ephemeris`
(M0 += n dt, Omega0 += (OmegaDot - we) dt + we d(toe_sow), i0 += idot dt, clock
polynomial re-expanded). The result is a self-consistent Keplerian orbit with the
real plane geometry (GPS's six planes and real slots; BDS MEO 24/3/1 Walker at
21528 km / 55 deg, the IGSO at 55 deg and GEO at their real longitudes), so the
simulated sky at the scenario epoch looks like a real one. Limits: beyond a few
days from the template epoch it is the template's secular propagation, not the
real constellation of that day (no manoeuvres, drag-free secular J2 only via
OmegaDot), which does not matter for a simulator that uses the same records as
truth and as "broadcast" data.
BDS geosynchronous satellites (GEO and IGSO, a > 35000 km) are shifted by a
whole number of sidereal days with ``secular=False``: their Earth-fixed ground
track repeats exactly, as station-keeping enforces in reality (secular
propagation of a fitted n drifts a GEO by ~8 deg of longitude in 1.5 years);
for GEO this is also the only exact shift of the -5 deg transform. Their toe
thus lies within +-12 h of the epoch, still a valid orbit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import (
    BroadcastEphemeris, constants, satellite_position_ecef, shift_ephemeris, system_time_s,
)
from hyper_nav_gnss.earth import elevation_azimuth


def is_geosynchronous(eph: BroadcastEphemeris) -> bool:
    """GEO or IGSO (semi-major axis > 35000 km)."""
    return eph.sqrtA ** 2 > 35000e3


def synthetic_constellation(templates, t_gpst_s: float, systems=("G", "C")) -> list[BroadcastEphemeris]:
    """One record per satellite of ``templates`` (e.g. from read_rinex3_nav), with
    toe/toc moved to the scenario epoch ``t_gpst_s`` (continuous GPST) as
    described in the module docstring. toe is rounded to 16 s like a real one."""
    by_sat: dict[str, BroadcastEphemeris] = {}
    for e in templates:
        if e.system in systems and e.sat_id not in by_sat:
            by_sat[e.sat_id] = e            # first (earliest) record per PRN
    out = []
    for sat in sorted(by_sat):
        e = by_sat[sat]
        t_sys = float(system_time_s(e.system, t_gpst_s))
        if is_geosynchronous(e):
            sidereal = 2.0 * np.pi / constants(e.system)[1]
            toe_new = e.toe_s + np.round((t_sys - e.toe_s) / sidereal) * sidereal
            out.append(shift_ephemeris(e, toe_new, secular=False))
        else:
            out.append(shift_ephemeris(e, 16.0 * np.round(t_sys / 16.0)))
    return out


@dataclass
class Visibility:
    """Satellites above the mask: ids, records, ECEF positions at t [m],
    elevation/azimuth [rad] (local ENU of the receiver, azimuth from north, east positive)."""
    sat_ids: list
    ephs: list
    r_sat_e_m: np.ndarray
    el_rad: np.ndarray
    az_rad: np.ndarray


def visible_satellites(ephs, r_rx_e_m, t_s: float, mask_deg: float = 5.0) -> Visibility:
    """Satellites with elevation >= mask_deg at receiver ECEF position r_rx_e_m [m]
    and time t_s [continuous GPST s; BDS records are evaluated at BDT = GPST - 14 s].
    Geometric (no light-time) positions; mask may be negative for a high-altitude
    receiver (horizon dip is -5.6 deg at 30 km)."""
    r_rx = np.asarray(r_rx_e_m, float)
    if not ephs:
        return Visibility([], [], np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    r_sat = np.array([satellite_position_ecef(e, system_time_s(e.system, t_s))[0] for e in ephs])
    el, az = elevation_azimuth(r_rx, r_sat)
    keep = el >= np.deg2rad(mask_deg)
    idx = np.flatnonzero(keep)
    return Visibility([ephs[i].sat_id for i in idx], [ephs[i] for i in idx], r_sat[keep], el[keep], az[keep])
