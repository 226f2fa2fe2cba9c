"""Broadcast-ephemeris satellite orbits and clocks (GPS and BeiDou) and RINEX readers.

Implements IS-GPS-200 Table 20-IV (seed 004 eq. 8: Kepler orbit with harmonic
corrections) and the satellite clock polynomial of seed 004 eq. 10
(``D_satelk = af0 + af1 (t - toc) + af2 (t - toc)^2``) plus the relativistic
term ``F e sqrtA sin E`` (IS-GPS-200 20.3.3.3.3.1). BeiDou uses the same
algorithm with the CGCS2000 constants and, for the GEO satellites, the -5 deg
rotation transform of the BDS-SIS-ICD (B1I, 5.2.4.12).

Time convention
---------------
Every ``t_s`` passed to :func:`satellite_position_ecef` is *continuous seconds
in the satellite's own system time*: ``week * 604800 + seconds_of_week``, i.e.
seconds since 1980-01-06 00:00:00 GPST for GPS and since 2006-01-01 00:00:00
BDT for BeiDou. Use :func:`system_time_s` to convert from continuous GPST
(BDT = GPST - 14 s, BDT week = GPS week - 1356). Working with continuous time
avoids every week-crossover special case.

Frames: positions/velocities in the Earth-fixed frame of the system (WGS-84
for GPS, CGCS2000 for BDS; they agree at the cm level, ignored here).
"""
from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

C_MPS = 299792458.0
SECONDS_PER_WEEK = 604800.0
BDT_WEEK_OFFSET = 1356               # BDT week = GPS week - 1356
BDT_MINUS_GPST_S = -14.0             # BDT = GPST - 14 s
# GPS (IS-GPS-200) and BeiDou (BDS-SIS-ICD, CGCS2000) constants.
MU_GPS_M3PS2 = 3.986005e14
OMEGA_E_GPS_RADPS = 7.2921151467e-5
MU_BDS_M3PS2 = 3.986004418e14
OMEGA_E_BDS_RADPS = 7.2921150e-5
BDS_GEO_PRNS = frozenset({1, 2, 3, 4, 5, 59, 60, 61, 62, 63})
_GPS_EPOCH = _dt.datetime(1980, 1, 6)
_BDT_EPOCH = _dt.datetime(2006, 1, 1)


def constants(system: str) -> tuple[float, float]:
    """(mu [m^3/s^2], earth rotation rate [rad/s]) of a system 'G' or 'C'."""
    if system == "G":
        return MU_GPS_M3PS2, OMEGA_E_GPS_RADPS
    if system == "C":
        return MU_BDS_M3PS2, OMEGA_E_BDS_RADPS
    raise ValueError(f"unsupported system {system!r}")


def system_time_s(system: str, t_gpst_s):
    """Continuous GPST seconds -> continuous seconds in the system's time scale."""
    if system == "G":
        return t_gpst_s
    if system == "C":
        return np.asarray(t_gpst_s, float) - BDT_WEEK_OFFSET * SECONDS_PER_WEEK + BDT_MINUS_GPST_S
    raise ValueError(f"unsupported system {system!r}")


def gpst_s(system: str, t_sys_s):
    """Inverse of :func:`system_time_s`: system time -> continuous GPST seconds."""
    if system == "G":
        return t_sys_s
    return np.asarray(t_sys_s, float) + BDT_WEEK_OFFSET * SECONDS_PER_WEEK - BDT_MINUS_GPST_S


def calendar_to_system_s(system: str, year, month, day, hour=0, minute=0, second=0.0) -> float:
    """Calendar date *read in the system's own time scale* -> continuous seconds
    of that scale (e.g. a RINEX epoch of a BDS record is in BDT)."""
    epoch = _GPS_EPOCH if system == "G" else _BDT_EPOCH
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
    ``iode``: issue of data (GPS IODE, BDS AODE; -1 = not known) and
    ``health``: the broadcast satellite health word (GPS SV health, BDS SatH1),
    0 = healthy; :func:`select_ephemeris` never picks an unhealthy record."""
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
    """Eccentric anomaly from mean anomaly (Newton; converged to 1e-15 rad)."""
    E = M.copy()
    for _ in range(iters):
        E = E - (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
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


def select_ephemeris(ephs, sat_id: str, t_s: float, max_age_s: float | None = None):
    """Healthy record of satellite ``sat_id`` whose toe is nearest ``t_s``
    (system time); None if there is none, or if |t - toe| > max_age_s (default
    7200 s GPS, 3600 s BDS). Records with a non-zero health word are skipped
    (IS-GPS-200 20.3.3.3.1.4; BDS-SIS-ICD 5.2.4.6): a satellite flagged
    unhealthy is not used even if its record is the nearest."""
    cands = [e for e in ephs if e.sat_id == sat_id and e.health == 0]
    if not cands:
        return None
    best = min(cands, key=lambda e: abs(t_s - e.toe_s))
    lim = max_age_s if max_age_s is not None else (7200.0 if best.system == "G" else 3600.0)
    return best if abs(t_s - best.toe_s) <= lim + 1e-6 else None


# ----------------------------------------------------------------- RINEX readers
def _f(s: str) -> float:
    s = s.strip().replace("D", "E").replace("d", "e")
    return float(s) if s else 0.0


def _fields(line: str, start: int, n: int = 4) -> list[float]:
    return [_f(line[start + 19 * k:start + 19 * (k + 1)]) for k in range(n)]


def _build(system, prn, toc_s, clk, orb) -> BroadcastEphemeris:
    """orb: 7 broadcast-orbit lines of 4 values (RINEX order). Orbit line 1
    starts with IODE (GPS) / AODE (BDS); line 6 holds SV accuracy, health
    (GPS SV health / BDS SatH1), TGD (TGD1) and IODC (TGD2)."""
    (iode, crs, dn, m0), (cuc, e, cus, sqa), (toe, cic, om0, cis), (i0, crc, w, omd), \
        (idot, _, week, _), (_, health, tgd, _) = orb[:6]
    week = int(round(week))
    toc = toc_s - week * SECONDS_PER_WEEK
    return BroadcastEphemeris(system, prn, toe, toc, week, sqa, e, i0, om0, w, m0, dn, idot, omd,
                              cuc, cus, crc, crs, cic, cis, clk[0], clk[1], clk[2], tgd,
                              iode=int(round(iode)), health=int(round(health)))


def read_rinex2_nav(path):
    """Read a RINEX 2.x GPS navigation file.

    Returns ``(ephs, alpha, beta)``: list of BroadcastEphemeris (system 'G') and
    the Klobuchar ION ALPHA [s, s/sc, s/sc^2, s/sc^3] / ION BETA [s, ...] arrays
    (None if absent)."""
    lines = Path(path).read_text().splitlines()
    alpha = beta = None
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
    ephs = []
    while i + 7 < len(lines) + 1 and i < len(lines):
        h = lines[i]
        if not h.strip():
            i += 1
            continue
        prn = int(h[0:2])
        yy, mo, dd, hh, mi = (int(h[3 + 3 * k:5 + 3 * k]) for k in range(5))
        ss = float(h[17:22])
        year = yy + (2000 if yy < 80 else 1900)
        toc_s = calendar_to_system_s("G", year, mo, dd, hh, mi, ss)
        clk = _fields(h, 22, 3)
        orb = [_fields(lines[i + k].ljust(80), 3) for k in range(1, 8)]
        ephs.append(_build("G", prn, toc_s, clk, orb))
        i += 8
    return ephs, alpha, beta


def read_rinex3_nav(path):
    """Read GPS ('G') and BeiDou ('C') records of a RINEX 3.x navigation file
    (other systems are skipped).

    Returns ``(ephs, iono)`` with ``iono = {'G': (alpha, beta), 'C': (alpha, beta)}``
    from the GPSA/GPSB and (first) BDSA/BDSB header lines. For BDS records
    toe/toc/week are BDT, and ``tgd`` is TGD1 (B1I)."""
    lines = Path(path).read_text().splitlines()
    hdr: dict[str, np.ndarray] = {}
    i = 0
    while i < len(lines):
        ln = lines[i]
        i += 1
        if ln[60:].strip() == "IONOSPHERIC CORR":
            key = ln[0:4]
            if key not in hdr:
                hdr[key] = np.array([_f(ln[5 + 12 * k:17 + 12 * k]) for k in range(4)])
        if ln[60:].strip() == "END OF HEADER":
            break
    nlines = {"G": 8, "C": 8, "E": 8, "J": 8, "I": 8, "R": 4, "S": 4}
    ephs = []
    while i < len(lines):
        h = lines[i]
        if not h.strip():
            i += 1
            continue
        sysc = h[0]
        nl = nlines.get(sysc, 8)
        if sysc in ("G", "C"):
            prn = int(h[1:3])
            y, mo, dd, hh, mi, ss = (int(h[4:8]), int(h[9:11]), int(h[12:14]), int(h[15:17]),
                                     int(h[18:20]), int(h[21:23]))
            toc_s = calendar_to_system_s(sysc, y, mo, dd, hh, mi, ss)
            clk = _fields(h.ljust(80), 23, 3)
            orb = [_fields(lines[i + k].ljust(80), 4) for k in range(1, 8)]
            ephs.append(_build(sysc, prn, toc_s, clk, orb))
        i += nl
    iono = {}
    for s, a, b in (("G", "GPSA", "GPSB"), ("C", "BDSA", "BDSB")):
        if a in hdr and b in hdr:
            iono[s] = (hdr[a], hdr[b])
    return ephs, iono


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
