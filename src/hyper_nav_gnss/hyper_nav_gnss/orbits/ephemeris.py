"""Broadcast-ephemeris satellite orbits and clocks (GPS, Galileo, BeiDou, QZSS).

Implements IS-GPS-200 Table 20-IV (seed 004 eq. 8: Kepler orbit with harmonic
corrections) and the satellite clock polynomial of seed 004 eq. 10
(``D_satelk = af0 + af1 (t - toc) + af2 (t - toc)^2``) plus the relativistic
term ``F e sqrtA sin E`` (IS-GPS-200 20.3.3.3.3.1). Galileo (OS SIS ICD 2.0,
5.1.1 and 5.1.3) and QZSS (IS-QZSS-PNT 4.1.2) use the same algorithm with
their own constants; BeiDou uses it with the CGCS2000 constants and, for the
GEO satellites, the -5 deg rotation transform of the BDS-SIS-ICD (B1I,
5.2.4.12).

Time convention
---------------
Every ``t_s`` passed to :func:`satellite_position_ecef` is *continuous seconds
in the satellite's own system time*: ``week * 604800 + seconds_of_week``, i.e.
seconds since 1980-01-06 00:00:00 GPST for GPS, QZSS and Galileo (GST is kept
on the GPS week count, as RINEX 3 writes it: Galileo week = GST week + 1024;
the GST - GPST offset, a few ns, is left to the receiver's inter-system bias)
and since 2006-01-01 00:00:00 BDT for BeiDou. Use :func:`system_time_s` to
convert from continuous GPST (BDT = GPST - 14 s, BDT week = GPS week - 1356).
Working with continuous time avoids every week-crossover special case.

Frames: positions/velocities in the Earth-fixed frame of the system (WGS-84
for GPS/QZSS, GTRF for Galileo, CGCS2000 for BDS; they agree at the cm level,
ignored here).

The RINEX navigation readers live in :mod:`.rinex_nav` (which imports this
module, not the other way round).
"""
from __future__ import annotations

import bisect
import datetime as _dt
import math
from dataclasses import dataclass, replace

import numpy as np

from hyper_nav_gnss.constants import C_MPS
SECONDS_PER_WEEK = 604800.0
BDT_WEEK_OFFSET = 1356               # BDT week = GPS week - 1356
BDT_MINUS_GPST_S = -14.0             # BDT = GPST - 14 s
# GPS (IS-GPS-200) and BeiDou (BDS-SIS-ICD, CGCS2000) constants.
MU_GPS_M3PS2 = 3.986005e14
OMEGA_E_GPS_RADPS = 7.2921151467e-5
MU_BDS_M3PS2 = 3.986004418e14
OMEGA_E_BDS_RADPS = 7.2921150e-5
MU_GAL_M3PS2 = 3.986004418e14        # Galileo OS SIS ICD 2.0, 5.1.1
OMEGA_E_GAL_RADPS = 7.2921151467e-5
GPST_SYSTEMS = ("G", "J", "E")       # time kept in continuous GPST seconds (see module docstring)
# maximum |t - toe| of a usable record (s), as RTKLIB's MAXDTOE*: GPS/QZSS 2 h, Galileo 4 h; BDS 1 h (hourly sets)
MAX_AGE_S = {"G": 7200.0, "J": 7200.0, "E": 14400.0, "C": 3600.0}
# Galileo data sources (RINEX 3.05 Table A8 / GnssEphemeris.data_source)
GAL_INAV_E1B, GAL_FNAV_E5A, GAL_INAV_E5B = 1 << 0, 1 << 1, 1 << 2
GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B = 1 << 8, 1 << 9
BDS_GEO_PRNS = frozenset({1, 2, 3, 4, 5, 59, 60, 61, 62, 63})
_GPS_EPOCH = _dt.datetime(1980, 1, 6)
_BDT_EPOCH = _dt.datetime(2006, 1, 1)


def constants(system: str) -> tuple[float, float]:
    """(mu [m^3/s^2], earth rotation rate [rad/s]) of a system 'G', 'J', 'E' or 'C'."""
    if system in ("G", "J"):
        return MU_GPS_M3PS2, OMEGA_E_GPS_RADPS
    if system == "E":
        return MU_GAL_M3PS2, OMEGA_E_GAL_RADPS
    if system == "C":
        return MU_BDS_M3PS2, OMEGA_E_BDS_RADPS
    raise ValueError(f"unsupported system {system!r}")


def system_time_s(system: str, t_gpst_s):
    """Continuous GPST seconds -> continuous seconds in the system's time scale."""
    if system in GPST_SYSTEMS:
        return t_gpst_s
    if system == "C":
        return np.asarray(t_gpst_s, float) - BDT_WEEK_OFFSET * SECONDS_PER_WEEK + BDT_MINUS_GPST_S
    raise ValueError(f"unsupported system {system!r}")


def gpst_s(system: str, t_sys_s):
    """Inverse of :func:`system_time_s`: system time -> continuous GPST seconds."""
    if system in GPST_SYSTEMS:
        return t_sys_s
    if system != "C":
        raise ValueError(f"unsupported system {system!r}")
    return np.asarray(t_sys_s, float) + BDT_WEEK_OFFSET * SECONDS_PER_WEEK - BDT_MINUS_GPST_S


def calendar_to_system_s(system: str, year, month, day, hour=0, minute=0, second=0.0) -> float:
    """Calendar date *read in the system's own time scale* -> continuous seconds
    of that scale (e.g. a RINEX epoch of a BDS record is in BDT)."""
    epoch = _BDT_EPOCH if system == "C" else _GPS_EPOCH
    d = _dt.datetime(int(year), int(month), int(day), int(hour), int(minute)) - epoch
    return d.days * 86400.0 + d.seconds + float(second)


@dataclass(frozen=True)
class BroadcastEphemeris:
    """One broadcast navigation record (IS-GPS-200 / BDS-SIS-ICD).

    ``toe``/``toc`` are seconds of week of ``week`` (the toe week; toc is
    re-referenced to the toe week if it falls across a week boundary) in the
    system's time (GPST or BDT). Angles in rad, rates in rad/s, ``sqrtA`` in
    m^0.5, ``c**`` radian/metre harmonic amplitudes, clock terms in s, s/s,
    s/s^2; ``tgd`` [s] is TGD (GPS, L1/L2) or TGD1 (BDS, B1I/B3I).
    ``iode``: issue of data (GPS IODE, BDS AODE, Galileo IODnav; -1 = not
    known) and ``health``: the broadcast satellite health word (GPS SV health,
    BDS SatH1, Galileo E5b/E1B/E5a HS and DVS bits as RINEX 3 packs them),
    0 = healthy; :func:`select_ephemeris` never picks an unhealthy record.
    ``tgd`` / ``tgd2``: the group delays of the record's clock reference
    (GPS TGD; BDS TGD1 (B1I-B3I) / TGD2 (B2I-B3I); Galileo BGD(E1,E5a) /
    BGD(E1,E5b)); :mod:`.signal_delays` applies them per signal.
    ``data_source``: Galileo data-source bits (``GAL_*``; 0 otherwise);
    ``accuracy_m``: URA / SISA / URAI in metres (0 = not known)."""
    system: str
    prn: int
    toe: float
    toc: float
    week: int
    sqrtA: float
    e: float
    i0: float
    Omega0: float
    omega: float
    M0: float
    delta_n: float
    idot: float
    OmegaDot: float
    cuc: float
    cus: float
    crc: float
    crs: float
    cic: float
    cis: float
    af0: float
    af1: float
    af2: float
    tgd: float = 0.0
    iode: int = -1
    health: int = 0
    tgd2: float = 0.0
    data_source: int = 0
    accuracy_m: float = 0.0

    @property
    def sat_id(self) -> str:
        return f"{self.system}{self.prn:02d}"

    @property
    def toe_s(self) -> float:
        """toe as continuous system-time seconds."""
        return self.week * SECONDS_PER_WEEK + self.toe

    @property
    def toc_s(self) -> float:
        """toc as continuous system-time seconds."""
        return self.week * SECONDS_PER_WEEK + self.toc

    @property
    def is_geo(self) -> bool:
        return self.system == "C" and self.prn in BDS_GEO_PRNS


class EphemerisStack:
    """Broadcast records of several satellites of one system (and one orbit
    kind: BDS GEO or not) as arrays, the fields of ``BroadcastEphemeris`` of
    shape (N,): :func:`satellite_position_ecef` takes it in place of one record,
    with ``t_s`` of shape (N,), and evaluates every satellite in one pass."""

    def __init__(self, ephs):
        ephs = list(ephs)
        kinds = {(e.system, e.is_geo) for e in ephs}
        if len(kinds) != 1:
            raise ValueError(f"an EphemerisStack holds one system and orbit kind, got {sorted(kinds)}")
        (self.system, self.is_geo), = kinds
        for name in _STACKED_FIELDS:
            setattr(self, name, np.array([getattr(e, name) for e in ephs], dtype=float))
        self.toe_s = self.week * SECONDS_PER_WEEK + self.toe
        self.toc_s = self.week * SECONDS_PER_WEEK + self.toc

    def __len__(self) -> int:
        return len(self.toe)


def _kepler_E(M, e, iters=12):
    """Eccentric anomaly from mean anomaly (Newton; converged to 1e-15 rad:
    stops when every correction is below 1e-15 rad, at most ``iters``
    steps; 3-4 steps for GNSS eccentricities)."""
    E = M.copy()
    for _ in range(iters):
        d = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
        E = E - d
        if np.all(np.abs(d) < 1e-15):
            break
    return E


def satellite_position_ecef(eph: BroadcastEphemeris, t_s, dt_s=0.0):
    """Satellite ECEF state and clock from a broadcast record (seed 004 eq. 8, 10;
    IS-GPS-200 Table 20-IV and 20.3.3.3.3.1; BDS-SIS-ICD 5.2.4.12 for GEO).

    ``eph``: one record, or an :class:`EphemerisStack` of N records with
    ``t_s`` of shape (N,) (one epoch per satellite).
    t_s: continuous seconds in the satellite's system time (GPST for 'G', BDT
    for 'C'), scalar or array of shape (N,). ``dt_s`` (same shape or scalar) is
    added to t_s *after* subtracting toe: pass small offsets (e.g. -light time)
    there, since a float64 continuous time ~1.4e9 s only resolves 2.4e-7 s
    (0.9 mm of satellite motion).
    Returns ``r_e_m`` (N,3) [m], ``v_e_mps`` (N,3) [m/s] (analytic derivative of
    the same model, in the rotating Earth-fixed frame), ``clock_bias_s`` (N,)
    (af0 + af1 dt + af2 dt^2 + relativistic F e sqrtA sinE; TGD *not* applied) and
    ``clock_drift_sps`` (N,) (its exact time derivative). Scalars in -> shapes
    (3,), (3,), (), ().
    """
    scalar = np.ndim(t_s) == 0
    t = np.atleast_1d(np.asarray(t_s, float))
    dt_off = np.broadcast_to(np.atleast_1d(np.asarray(dt_s, float)), t.shape)
    mu, we = constants(eph.system)
    A = eph.sqrtA ** 2
    n = np.sqrt(mu / A ** 3) + eph.delta_n
    tk = (t - eph.toe_s) + dt_off
    M = eph.M0 + n * tk
    E = _kepler_E(M, eph.e)
    sE, cE = np.sin(E), np.cos(E)
    den = 1.0 - eph.e * cE
    Edot = n / den
    sq = np.sqrt(1.0 - eph.e ** 2)
    nu = np.arctan2(sq * sE, cE - eph.e)
    nudot = sq * Edot / den
    phi = nu + eph.omega
    s2, c2 = np.sin(2 * phi), np.cos(2 * phi)
    du = eph.cus * s2 + eph.cuc * c2
    dr = eph.crs * s2 + eph.crc * c2
    di = eph.cis * s2 + eph.cic * c2
    u = phi + du
    r = A * den + dr
    inc = eph.i0 + eph.idot * tk + di
    udot = nudot * (1.0 + 2.0 * (eph.cus * c2 - eph.cuc * s2))
    rdot = A * eph.e * sE * Edot + 2.0 * nudot * (eph.crs * c2 - eph.crc * s2)
    incdot = eph.idot + 2.0 * nudot * (eph.cis * c2 - eph.cic * s2)
    xp, yp = r * np.cos(u), r * np.sin(u)
    xpd = rdot * np.cos(u) - r * udot * np.sin(u)
    ypd = rdot * np.sin(u) + r * udot * np.cos(u)
    if eph.is_geo:
        Om = eph.Omega0 + eph.OmegaDot * tk - we * eph.toe
        Omdot = eph.OmegaDot * np.ones_like(tk)
    else:
        Om = eph.Omega0 + (eph.OmegaDot - we) * tk - we * eph.toe
        Omdot = (eph.OmegaDot - we) * np.ones_like(tk)
    cO, sO, ci, si = np.cos(Om), np.sin(Om), np.cos(inc), np.sin(inc)
    X = xp * cO - yp * ci * sO
    Y = xp * sO + yp * ci * cO
    Z = yp * si
    Xd = xpd * cO - ypd * ci * sO + yp * si * sO * incdot - Y * Omdot
    Yd = xpd * sO + ypd * ci * cO - yp * si * cO * incdot + X * Omdot
    Zd = ypd * si + yp * ci * incdot
    r_e = np.stack([X, Y, Z], axis=-1)
    v_e = np.stack([Xd, Yd, Zd], axis=-1)
    if eph.is_geo:
        # BDS GEO: r = Rz(we tk) Rx(-5 deg) r_GK (user-defined inertial frame).
        f = np.deg2rad(-5.0)
        Rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(f), np.sin(f)], [0.0, -np.sin(f), np.cos(f)]])
        r_gk, v_gk = r_e @ Rx.T, v_e @ Rx.T
        a = we * tk
        ca, sa = np.cos(a), np.sin(a)
        r_e = np.stack([ca * r_gk[:, 0] + sa * r_gk[:, 1], -sa * r_gk[:, 0] + ca * r_gk[:, 1], r_gk[:, 2]], -1)
        v_e = np.stack([ca * v_gk[:, 0] + sa * v_gk[:, 1] + we * (-sa * r_gk[:, 0] + ca * r_gk[:, 1]),
                        -sa * v_gk[:, 0] + ca * v_gk[:, 1] + we * (-ca * r_gk[:, 0] - sa * r_gk[:, 1]),
                        v_gk[:, 2]], -1)
    F = -2.0 * np.sqrt(mu) / C_MPS ** 2
    dtc = (t - eph.toc_s) + dt_off
    clk = eph.af0 + eph.af1 * dtc + eph.af2 * dtc ** 2 + F * eph.e * eph.sqrtA * sE
    clk_dot = eph.af1 + 2.0 * eph.af2 * dtc + F * eph.e * eph.sqrtA * cE * Edot
    if scalar:
        return r_e[0], v_e[0], clk[0], clk_dot[0]
    return r_e, v_e, clk, clk_dot


_STACKED_FIELDS = ("toe", "toc", "week", "sqrtA", "e", "i0", "Omega0", "omega", "M0", "delta_n", "idot",
                   "OmegaDot", "cuc", "cus", "crc", "crs", "cic", "cis", "af0", "af1", "af2", "tgd")


def select_ephemeris(ephs, sat_id: str, t_s: float, max_age_s: float | None = None, clock: int = 0):
    """Healthy record of satellite ``sat_id`` whose toe is nearest ``t_s``
    (system time); None if there is none, or if |t - toe| > max_age_s (default
    :data:`MAX_AGE_S`: 7200 s GPS/QZSS, 14400 s Galileo, 3600 s BDS). Records
    with a non-zero health word are skipped (IS-GPS-200 20.3.3.3.1.4;
    BDS-SIS-ICD 5.2.4.6; Galileo OS SIS ICD 5.1.9.3): a satellite flagged
    unhealthy is not used even if its record is the nearest. ``clock``
    (Galileo): ``GAL_CLOCK_E1E5A`` or ``GAL_CLOCK_E1E5B`` keeps only records
    whose clock refers to that pair (F/NAV or I/NAV), falling back to any
    record when none does; 0 = any."""
    # one pass, no per-record string or property: a station's day of records (77 per satellite) made the
    # list-and-min form 60 % of spp's solve (1.8 M sat_id strings for 42,000 choices); the same choice:
    # the first record of least |t - toe| among the healthy ones, among those of the preferred clock if any
    system, prn = sat_id[0], int(sat_id[1:])
    best = best_pref = None
    d_best = d_pref = math.inf
    for e in ephs:
        if e.prn != prn or e.system != system or e.health != 0:
            continue
        d = abs(t_s - (e.week * SECONDS_PER_WEEK + e.toe))          # e.toe_s
        if d < d_best:
            best, d_best = e, d
        if clock and e.data_source & clock and d < d_pref:
            best_pref, d_pref = e, d
    if best_pref is not None:
        best, d_best = best_pref, d_pref
    if best is None:
        return None
    lim = max_age_s if max_age_s is not None else MAX_AGE_S.get(best.system, 3600.0)
    return best if d_best <= lim + 1e-6 else None


class NearestToe:
    """``select_ephemeris`` over one satellite's fixed list of records, by
    bisection: the healthy records' distinct toe values sorted once (for
    each, the first record in list order that has it), then per call the
    nearest of the two or three values around ``t``, compared exactly as
    ``select_ephemeris`` compares them (|t - toe| in the same floating-point
    form, a tie to the first in list order): the same record. A station's
    day has 77 records per satellite and spp asks 42,000 times; the scan
    was a third of its solve. Build a new one when the list changes."""

    def __init__(self, recs):
        self.recs = recs
        self._sets = {}                        # clock -> (sorted toe values, their first records' list indices)

    def _set(self, clock: int):
        got = self._sets.get(clock)
        if got is None:
            healthy = [i for i, e in enumerate(self.recs) if e.health == 0]
            if clock:
                pref = [i for i in healthy if self.recs[i].data_source & clock]
                healthy = pref or healthy
            first = {}
            for i in healthy:
                e = self.recs[i]
                first.setdefault(e.week * SECONDS_PER_WEEK + e.toe, i)      # e.toe_s
            toes = sorted(first)
            got = self._sets[clock] = (toes, [first[v] for v in toes])
        return got

    def select(self, t_s: float, max_age_s: float | None = None, clock: int = 0):
        toes, idx = self._set(clock)
        if not toes:
            return None
        j = bisect.bisect_left(toes, t_s)
        best_d, best_i = math.inf, -1
        for k in range(max(j - 2, 0), min(j + 2, len(toes))):      # |t - toe| is unimodal over sorted toes
            d = abs(t_s - toes[k])
            if d < best_d or (d == best_d and idx[k] < best_i):
                best_d, best_i = d, idx[k]
        best = self.recs[best_i]
        lim = max_age_s if max_age_s is not None else MAX_AGE_S.get(best.system, 3600.0)
        return best if best_d <= lim + 1e-6 else None


def shift_ephemeris(eph: BroadcastEphemeris, toe_new_s: float, secular: bool = True) -> BroadcastEphemeris:
    """Same orbit and clock, re-referenced to a new toe (continuous system time):
    M0 += n dt, Omega0 += OmegaDot dt - we dt + we (toe_new_sow - toe_sow),
    i0 += idot dt, clock polynomial re-expanded about toc + dt. Exact for the
    non-GEO model (the Keplerian/secular part; harmonic terms depend only on the
    argument of latitude). For BDS GEO it is exact only if dt is an integer
    number of sidereal days (2 pi / we), because the -5 deg transform is tied to
    the Earth-fixed frame at toe; :mod:`constellation` respects that.

    ``secular=False`` ("station-kept", for geosynchronous GEO/IGSO and a shift of
    whole sidereal days): M0, i0 and the OmegaDot part are *not* advanced, so
    the Earth-fixed ground track repeats exactly, as station-keeping enforces,
    instead of drifting with the template's fitted n / OmegaDot (~0.015 deg/day)."""
    mu, we = constants(eph.system)
    dt = toe_new_s - eph.toe_s
    week = int(np.floor(toe_new_s / SECONDS_PER_WEEK))
    toe = toe_new_s - week * SECONDS_PER_WEEK
    n = np.sqrt(mu / eph.sqrtA ** 6) + eph.delta_n
    k = 1.0 if secular else 0.0
    om0 = eph.Omega0 + k * eph.OmegaDot * dt - we * dt + we * (toe - eph.toe)
    om0 = float(np.angle(np.exp(1j * om0)))
    m0 = float(np.angle(np.exp(1j * (eph.M0 + k * n * dt))))
    toc_new_s = eph.toc_s + dt
    return replace(eph, toe=toe, toc=toc_new_s - week * SECONDS_PER_WEEK, week=week, M0=m0,
                   Omega0=om0, i0=eph.i0 + k * eph.idot * dt,
                   af0=eph.af0 + eph.af1 * dt + eph.af2 * dt ** 2, af1=eph.af1 + 2 * eph.af2 * dt)
