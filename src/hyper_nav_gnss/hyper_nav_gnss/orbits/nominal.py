"""Nominal GPS and BDS-3 constellations as broadcast ephemerides, with no external file.

The simulator must run from a clean clone (no RINEX). This module builds one
:class:`~.ephemeris.BroadcastEphemeris` per satellite for any GPST epoch, toe =
that epoch (rounded to 16 s), harmonic terms ``c**`` = 0, from published
constellation designs. Each record is an exact Keplerian orbit (plus secular
J2 node regression) that the IS-GPS-200 / BDS-SIS-ICD algorithm of
:mod:`.ephemeris` propagates; truth and "broadcast" data are the same records.

Station keeping (ground-track repeat)
-------------------------------------
GPS and BDS orbits are kept on repeating ground tracks, so the Earth-fixed
geometry of a design epoch repeats indefinitely. We impose it exactly: the node
regression ``OmegaDot`` is the secular J2 rate
``-1.5 n J2 (Re/a)^2 cos i`` (J2 = 1.08263e-3, Re = 6378137 m, WGS-84), and the
mean motion is set to the repeat condition ``n = (k_rev / k_day) (we - OmegaDot)``
through ``delta_n = n - sqrt(mu/a^3)`` (|delta_n| < 6e-9 rad/s, same order as
real broadcast values 4-5e-9). Then the Earth-fixed node longitude
``Lambda(t) = Lambda_ref + (OmegaDot - we)(t - t_ref)`` and mean argument of
latitude ``u(t) = u_ref + n (t - t_ref)`` of a slot can be evaluated at any epoch
without drifting away from the design. The slot "argument of latitude" is used as
the *mean* argument of latitude ``omega + M`` (e <= 0.02 -> <= 2.3 deg from the
true one, inside the SPS slot tolerance).

GPS (``gps_nominal``)
--------------------
* GPS SPS Performance Standard (4th ed. 2008, 5th ed. 2020), section 3.1,
  Table 3.1-1 "Baseline 24-Slot Constellation Slot Assignments as of the Defined
  Epoch" (identical to Table 3-1 of the 2001 SPS PS): RAAN of planes A..F
  272.847, 332.847, 32.847, 92.847, 152.847, 212.847 deg (60 deg spacing) and
  the 24 arguments of latitude in :data:`GPS_BASELINE_SLOTS`. Defined epoch
  0000Z 1 July 1993 (= GPST 00:00:09, GPS-UTC = 9 s after the 1993-06-30 leap
  second), Greenwich hour angle 18 h 36 m 14.4 s (FK5/J2000), so the Earth-fixed
  node longitude at the epoch is RAAN - 279.06 deg.
* Reference orbit (same tables): semi-major axis 26559.7 km, inclination 55 deg,
  eccentricity 0.00-0.02. The two-revolutions-per-(we - OmegaDot) repeat gives a
  period 2 pi / n = 43077.4 s = 11 h 57 m 57 s (the usual "11 h 58 min" is the
  rounded half sidereal day 43082 s; with a = 26559.7 km the Keplerian period is
  43077.6 s, so the nominal figures themselves put it 2.4-4.6 s below 11 h 58 m).
* Expandable slots (SPS PS 2008 Table 3.1-2): B1 -> B1F/B1A, D2 -> D2F/D2A,
  F2 -> F2F/F2A (27 slots, the post-2011 "expandable 24" configuration).
  The values in :data:`GPS_EXPANDED_SLOTS` were quoted from memory of that
  table (not checked against the document here; they are consistent with the
  ~30 deg splitting of the expanded slots); see the module test for the sky
  they give.
* ``spares`` (0-4) extra satellites, *not* published slots: placed at the middle
  of the widest argument-of-latitude gap of planes A, C, E, then B (the real
  constellation of 31 carries such residual satellites near their slots).
* PRNs: assigned 1, 2, ... in slot order (real PRN-to-slot mapping changes
  with launches and is not part of the design).

BDS-3 (``bds_nominal``)
----------------------
* BeiDou OS Performance Standard v3.0 (CSNO, 2021) / BDS-SIS-ICD OS B1I v3.0,
  section 3: 24 MEO in a Walker 24/3/1 constellation, a = 27906.1 km (altitude
  21528 km), i = 55 deg, ground track repeating every 7 sidereal days / 13
  revolutions (period 12 h 53 m); 3 IGSO at 35786 km altitude (a = 42164 km),
  i = 55 deg, sub-satellite tracks crossing the equator at 118 deg E; GEO at
  80, 110.5, 140 deg E (BDS-3) and BDS-2 GEOs at 58.75, 160 deg E (PRNs C01..C05
  here in the BDS-2 order 140, 80, 110.5, 160, 58.75 deg E, which is what the
  IGS broadcast files of 2023 carry for C01..C05).
* The absolute phase of the Walker pattern and of the IGSO in their common
  figure-8 track is not given by these sources: ``MEO_PHASE`` / ``IGSO_PHASE``
  (Earth-fixed node longitude of plane 1 and mean argument of latitude of slot
  1 at the BDT origin 2006-01-01 00:00 BDT) are our choice. Walker 24/3/1:
  planes 120 deg apart, 8 slots 45 deg apart, +15 deg phase between adjacent
  planes (360 f / T). IGSO: 3 planes 120 deg apart, 120 deg apart in argument
  of latitude so they share one track.
* GEO: PRNs in :data:`~.ephemeris.BDS_GEO_PRNS` use the BDS GEO broadcast
  convention (orbit given in a frame tilted by +5 deg, BDS-SIS-ICD 5.2.4.12):
  i0 = 5 deg, Omega0 - we toe = 180 deg, OmegaDot = 0, mean argument of latitude
  lambda - 180 deg and n = we, which puts the satellite on the equator at
  longitude lambda, exactly geostationary in the ECEF.
* MEO PRNs C19..C30, C32..C37, C41..C46 (the 24 BDS-3 MEO PRNs in 2023), IGSO
  C38..C40, GEO C01..C05.

Random parts (seeded ``numpy.random.Generator``, ``seed``): eccentricity
(GPS U(0.001, 0.015): real values 0.001-0.02; BDS MEO U(2e-4, 1.5e-3); IGSO
U(5e-4, 3e-3); GEO U(5e-5, 3e-4): the 2e rad daily longitude swing stays
< 0.07 deg), argument of perigee U(0, 2 pi), clock
af0 ~ N(0, (2e-4 s)^2) clipped at +-9.5e-4 s (GPS/BDS broadcast af0 are
typically 1e-5..5e-4 s, |af0| < 1 ms), af1 ~ N(0, (5e-12)^2) clipped at +-2e-11
(real 1e-13..1e-11 s/s), af2 = 0, TGD/TGD1 U(-1e-8, 1e-8) s (real group delays
are a few ns). The draws depend only on ``seed`` and the satellite, not on the
epoch, so constellations built for different epochs of one run describe the same
satellites; the clock polynomial refers to ``clock_ref_gpst_s`` (default the
epoch) and is re-expanded to the toe, so it is continuous too.
"""
from __future__ import annotations

import datetime as _dt

import numpy as np

from hyper_nav_gnss.orbits.ephemeris import (
    BDS_GEO_PRNS, SECONDS_PER_WEEK, BroadcastEphemeris, calendar_to_system_s, constants, gpst_s, system_time_s,
)

J2 = 1.08263e-3
RE_M = 6378137.0

# --- GPS: SPS PS Table 3.1-1 (defined epoch 0000Z 1 July 1993) -------------------------
GPS_PLANE_RAAN_DEG = {"A": 272.847, "B": 332.847, "C": 32.847, "D": 92.847, "E": 152.847, "F": 212.847}
GPS_BASELINE_SLOTS = {        # slot -> argument of latitude [deg]
    "A1": 268.126, "A2": 161.786, "A3": 11.676, "A4": 41.806,
    "B1": 80.956, "B2": 173.336, "B3": 309.976, "B4": 204.376,
    "C1": 111.876, "C2": 11.796, "C3": 339.666, "C4": 241.556,
    "D1": 135.226, "D2": 265.446, "D3": 35.156, "D4": 167.356,
    "E1": 197.046, "E2": 302.596, "E3": 66.066, "E4": 333.686,
    "F1": 238.886, "F2": 345.226, "F3": 105.206, "F4": 135.346,
}
# SPS PS 2008 Table 3.1-2: each expandable slot is replaced by a fore/aft pair.
GPS_EXPANDED_SLOTS = {"B1": {"B1F": 94.916, "B1A": 66.356},
                      "D2": {"D2F": 282.676, "D2A": 257.976},
                      "F2": {"F2F": 0.456, "F2A": 334.016}}
GPS_A_M = 26559.7e3
GPS_INC_DEG = 55.0
GPS_EPOCH_GPST_S = calendar_to_system_s("G", 1993, 7, 1, 0, 0, 9.0)   # 0000Z UTC + 9 s
GPS_GHA_EPOCH_DEG = (18.0 + 36.0 / 60.0 + 14.4 / 3600.0) * 15.0      # 279.06 deg

# --- BDS-3 -------------------------------------------------------------------------------
BDS_MEO_A_M = 27906.1e3
BDS_GEOSYNC_A_M = 42164.17e3
BDS_INC_DEG = 55.0
BDS_MEO_PRNS = tuple(list(range(19, 31)) + list(range(32, 38)) + list(range(41, 47)))
BDS_IGSO_PRNS = (38, 39, 40)
BDS_GEO_LON_DEG = {1: 140.0, 2: 80.0, 3: 110.5, 4: 160.0, 5: 58.75}
BDS_IGSO_CROSS_LON_DEG = 118.0
BDS_REF_GPST_S = float(gpst_s("C", 0.0))       # BDT origin 2006-01-01 00:00:00 BDT
MEO_PHASE = (0.0, 0.0)     # (node longitude of plane 1, mean arg. of latitude of slot 1) [deg] at BDS_REF
IGSO_PHASE = 0.0           # mean argument of latitude of the first IGSO [deg] at BDS_REF


def gpst_from_date(date: str) -> float:
    """Continuous GPST seconds of a calendar date/time string read as GPST,
    ISO 8601 ('2024-06-15', '2024-06-15T03:20:00', '2024-06-15 03:20:00.5').
    (GPST = UTC + 18 s since 2017; a UTC date is 18 s earlier in GPST.)"""
    try:
        d = _dt.datetime.fromisoformat(str(date).strip().replace("Z", ""))
    except ValueError as exc:
        raise ValueError(f"bad calendar date {date!r}: {exc}") from None
    return calendar_to_system_s("G", d.year, d.month, d.day, d.hour, d.minute,
                                d.second + d.microsecond * 1e-6)


def j2_node_rate(a_m: float, inc_rad: float, mu: float, e: float = 0.0) -> float:
    """Secular J2 regression of the node [rad/s] (Vallado eq. 9-41)."""
    n = np.sqrt(mu / a_m ** 3)
    return -1.5 * n * J2 * (RE_M / (a_m * (1.0 - e ** 2))) ** 2 * np.cos(inc_rad)


def _wrap(x):
    return float(np.mod(x, 2.0 * np.pi))


def _sat_rng(seed: int, system: str, prn: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), ord(system), int(prn)])


def _record(system, prn, t_gpst_s, a_m, inc_rad, node_lon_rad, mean_arglat_rad, node_rate, n_radps,
            ecc_range, seed, clock_ref_gpst_s, geo=False) -> BroadcastEphemeris:
    """Broadcast record with toe = t_gpst_s (rounded to 16 s, system time) of an
    orbit whose Earth-fixed node longitude and mean argument of latitude at toe
    are given (non-GEO), or (GEO) whose longitude is node_lon_rad."""
    mu, we = constants(system)
    r = _sat_rng(seed, system, prn)
    e = float(r.uniform(*ecc_range))
    omega = float(r.uniform(0.0, 2.0 * np.pi))
    af0 = float(np.clip(r.normal(0.0, 2e-4), -9.5e-4, 9.5e-4))
    af1 = float(np.clip(r.normal(0.0, 5e-12), -2e-11, 2e-11))
    tgd = float(r.uniform(-1e-8, 1e-8))
    t_sys = float(system_time_s(system, t_gpst_s))
    toe_s = 16.0 * np.round(t_sys / 16.0)
    week = int(np.floor(toe_s / SECONDS_PER_WEEK))
    toe = toe_s - week * SECONDS_PER_WEEK
    # the caller gives the state at t_gpst_s; move it to toe (a few seconds)
    dt = toe_s - t_sys
    node_lon = node_lon_rad + (node_rate - (0.0 if geo else we)) * dt
    arglat = mean_arglat_rad + n_radps * dt
    if geo:
        # BDS GEO: +5 deg tilted frame, Om(tk=0) = Omega0 - we toe = pi; u = lon - pi.
        om0, inc, arglat = np.pi + we * toe, np.deg2rad(5.0), node_lon_rad - np.pi
    else:
        om0, inc = node_lon + we * toe, inc_rad
    clk_dt = float(system_time_s(system, clock_ref_gpst_s)) - toe_s      # ref - toe
    return BroadcastEphemeris(
        system=system, prn=int(prn), toe=toe, toc=toe, week=week, sqrtA=float(np.sqrt(a_m)), e=e,
        i0=float(inc), Omega0=float(np.angle(np.exp(1j * om0))), omega=float(np.angle(np.exp(1j * omega))),
        M0=float(np.angle(np.exp(1j * (arglat - omega)))), delta_n=float(n_radps - np.sqrt(mu / a_m ** 3)),
        idot=0.0, OmegaDot=float(node_rate), cuc=0.0, cus=0.0, crc=0.0, crs=0.0, cic=0.0, cis=0.0,
        af0=af0 - af1 * clk_dt, af1=af1, af2=0.0, tgd=tgd)


def gps_slots(expandable: bool = True, spares: int = 0) -> list[tuple[str, float, float]]:
    """[(slot name, RAAN at the 1993 epoch [deg], argument of latitude [deg])]."""
    slots = []
    for name, u in GPS_BASELINE_SLOTS.items():
        if expandable and name in GPS_EXPANDED_SLOTS:
            slots += [(n2, GPS_PLANE_RAAN_DEG[name[0]], u2) for n2, u2 in GPS_EXPANDED_SLOTS[name].items()]
        else:
            slots.append((name, GPS_PLANE_RAAN_DEG[name[0]], u))
    if not 0 <= spares <= 4:
        raise ValueError("spares must be 0..4")
    for plane in "ACEB"[:spares]:
        us = np.sort([u for s, _, u in slots if s[0] == plane])
        gaps = np.diff(np.r_[us, us[0] + 360.0])
        k = int(np.argmax(gaps))
        slots.append((f"{plane}S", GPS_PLANE_RAAN_DEG[plane], float(np.mod(us[k] + gaps[k] / 2, 360.0))))
    return slots


def gps_nominal(t_gpst_s: float, expandable: bool = True, spares: int = 4, seed: int = 0,
                clock_ref_gpst_s: float | None = None) -> list[BroadcastEphemeris]:
    """GPS constellation (SPS PS 24 baseline slots, + 3 expanded pairs -> 27,
    + ``spares`` -> up to 31) as broadcast records with toe at ``t_gpst_s``
    (continuous GPST; rounded to 16 s)."""
    mu, we = constants("G")
    inc = np.deg2rad(GPS_INC_DEG)
    odot = j2_node_rate(GPS_A_M, inc, mu)
    n = 2.0 * (we - odot)                       # 2 revolutions per nodal day
    dt = t_gpst_s - GPS_EPOCH_GPST_S
    ref = t_gpst_s if clock_ref_gpst_s is None else clock_ref_gpst_s
    out = []
    for prn, (_, raan, u) in enumerate(gps_slots(expandable, spares), start=1):
        lam = np.deg2rad(raan - GPS_GHA_EPOCH_DEG) + (odot - we) * dt
        arg = np.deg2rad(u) + n * dt
        out.append(_record("G", prn, t_gpst_s, GPS_A_M, inc, _wrap(lam), _wrap(arg), odot, n,
                           (0.001, 0.015), seed, ref))
    return out


def bds_nominal(t_gpst_s: float, seed: int = 0, clock_ref_gpst_s: float | None = None,
                geo_prns=tuple(BDS_GEO_LON_DEG)) -> list[BroadcastEphemeris]:
    """BDS-3 nominal constellation (24 MEO Walker 24/3/1, 3 IGSO, GEO ``geo_prns``
    among C01..C05) as broadcast records with toe at ``t_gpst_s`` (in BDT)."""
    mu, we = constants("C")
    inc = np.deg2rad(BDS_INC_DEG)
    dt = t_gpst_s - BDS_REF_GPST_S
    ref = t_gpst_s if clock_ref_gpst_s is None else clock_ref_gpst_s
    out = []
    for prn in geo_prns:
        out.append(_record("C", prn, t_gpst_s, BDS_GEOSYNC_A_M, 0.0, np.deg2rad(BDS_GEO_LON_DEG[prn]), 0.0,
                           0.0, we, (5e-5, 3e-4), seed, ref, geo=True))
    # IGSO: n = we - OmegaDot (one revolution per nodal day), common 8-shaped track
    odot = j2_node_rate(BDS_GEOSYNC_A_M, inc, mu)
    n = we - odot
    for k, prn in enumerate(BDS_IGSO_PRNS):
        u0 = np.deg2rad(IGSO_PHASE + 120.0 * k)
        lam0 = np.deg2rad(BDS_IGSO_CROSS_LON_DEG) - u0 * (we - odot) / n
        lam = lam0 + (odot - we) * dt
        out.append(_record("C", prn, t_gpst_s, BDS_GEOSYNC_A_M, inc, _wrap(lam), _wrap(u0 + n * dt), odot, n,
                           (5e-4, 3e-3), seed, ref))
    # MEO Walker 24/3/1, 13 revolutions in 7 nodal days
    odot = j2_node_rate(BDS_MEO_A_M, inc, mu)
    n = 13.0 / 7.0 * (we - odot)
    for k, prn in enumerate(BDS_MEO_PRNS):
        plane, slot = divmod(k, 8)
        lam = np.deg2rad(MEO_PHASE[0] + 120.0 * plane) + (odot - we) * dt
        u = np.deg2rad(MEO_PHASE[1] + 45.0 * slot + 15.0 * plane) + n * dt
        out.append(_record("C", prn, t_gpst_s, BDS_MEO_A_M, inc, _wrap(lam), _wrap(u), odot, n,
                           (2e-4, 1.5e-3), seed, ref))
    return sorted(out, key=lambda e: e.prn)


def nominal_constellation(t_gpst_s: float, systems=("G", "C"), seed: int = 0,
                          clock_ref_gpst_s: float | None = None, gps_expandable: bool = True,
                          gps_spares: int = 4) -> list[BroadcastEphemeris]:
    """GPS ('G') and/or BDS ('C') nominal records for the epoch ``t_gpst_s``."""
    out: list[BroadcastEphemeris] = []
    for s in systems:
        if s == "G":
            out += gps_nominal(t_gpst_s, gps_expandable, gps_spares, seed, clock_ref_gpst_s)
        elif s == "C":
            out += bds_nominal(t_gpst_s, seed, clock_ref_gpst_s)
        else:
            raise ValueError(f"unsupported system {s!r} (use 'G' and/or 'C')")
    return out


assert not set(BDS_MEO_PRNS) & BDS_GEO_PRNS and not set(BDS_IGSO_PRNS) & BDS_GEO_PRNS
