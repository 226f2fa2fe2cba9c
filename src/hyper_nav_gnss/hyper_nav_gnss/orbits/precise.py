"""Precise satellite orbits and clocks (SP3 and RINEX CLK products) at a
transmit time: the method of RTKLIB 2.4.3 ``peph.c`` (``pephpos``,
``pephclk``, ``peph2pos``), strict at the product's ends.

Position (centre of mass, ECEF of the product's frame):
    Lagrange polynomial through ``n_points`` (default 10) grid epochs t_j
    around t: the window centred (5 before, 5 after t on a 5 min grid),
    shifted inwards at the product's ends (never past them). Each grid
    position is first rotated from ECEF(t_j) into ECEF(t),
    ``R3(-we (t_j - t)) r_j`` (RTKLIB's "correction for earth rotation"),
    so the polynomial fits a smooth inertial-like arc.
Velocity: by differentiation, (r(t + h) - r(t)) / h with h = 1 ms, each
    evaluated in its own ECEF (as RTKLIB): the velocity in the rotating
    Earth-fixed frame, like :func:`.ephemeris.satellite_position_ecef`.
Clock: linear interpolation between the two bracketing clock epochs (SP3
    clocks every 5 min, or a RINEX CLK product, usually 30 s); clocks are
    not smooth enough for a high-degree polynomial. Both epochs must hold a
    clock (RTKLIB holds the nearest one; this does not).
Relativity: SP3 and CLK clocks exclude the periodic relativistic term
    (IGS convention); it is added as for broadcast clocks,
    ``dt_rel = -2 r . v / c^2`` (IS-GPS-200 20.3.3.3.3.1, equal to
    ``F e sqrtA sinE``; RTKLIB ``peph2pos``), so the returned clock means
    what :func:`.ephemeris.satellite_position_ecef`'s clock means. The
    clock drift is the derivative of the same (difference over 1 s, each
    end with its own velocity).

Never extrapolated: a time before the first or after the last grid epoch
(of the orbit or of the clock product), a satellite the product does not
list, a window holding a missing position or a bracket holding a missing
clock: NaN state and the reason per row (``REASONS``); the caller excludes
the satellite and counts the reason.

Times: ``t_gpst_s`` continuous GPST seconds (SP3 products of every
system are in GPST, :mod:`hyper_nav_gnss.formats.sp3`), with a small
offset ``dt_s`` passed apart (as in :mod:`.ephemeris`: a float64 time near
1.4e9 s resolves only 2.4e-7 s).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss.constants import C_MPS
from hyper_nav_gnss.orbits.ephemeris import OMEGA_E_GPS_RADPS

N_POINTS = 10            # RTKLIB NMAX = 10 (it uses 11 nodes); 10 keeps the window centred on the interval
VEL_STEP_S = 1e-3        # RTKLIB peph2pos tt
DRIFT_STEP_S = 1.0       # step of the clock drift's difference (the relativistic term's change resolved to 1e-15 s/s)
REASONS = ("precise_not_listed", "precise_outside_span", "precise_no_orbit", "precise_no_clock",
           "precise_no_antenna")     # the last: set by the users of ``antennas`` (positioning/spp.py)


@dataclass(frozen=True)
class ClockGrid:
    """Satellite clocks on epochs: ``t_gpst_s`` (n,), ``sat_ids`` (m,),
    ``clock_s`` (n, m) NaN = no clock; ``source`` a file name."""
    t_gpst_s: np.ndarray
    sat_ids: tuple
    clock_s: np.ndarray
    source: str

    @property
    def span_gpst_s(self) -> tuple[float, float]:
        return float(self.t_gpst_s[0]), float(self.t_gpst_s[-1])


class PreciseEphemeris:
    """Orbits of an :class:`~hyper_nav_gnss.formats.sp3.Sp3Product` and the
    clocks of ``clocks`` (a :class:`ClockGrid`, e.g. from
    :func:`hyper_nav_gnss.formats.rinex_clk.read_rinex_clk`) or, without
    it, the SP3 file's own clocks. ``states`` evaluates many rows at once.
    ``antennas``: the satellites' phase-centre offsets
    (:class:`hyper_nav_gnss.formats.antex.SatelliteAntennas`), which the
    user applies per signal (:mod:`.satellite_antenna`); None = not known."""

    def __init__(self, orbits, clocks: ClockGrid | None = None, n_points: int = N_POINTS, antennas=None):
        if len(orbits.t_gpst_s) < n_points:
            raise ValueError(f"{orbits.source}: {len(orbits.t_gpst_s)} epochs, fewer than the "
                             f"{n_points} the interpolation needs")
        self.orbits = orbits
        self.clocks = clocks if clocks is not None else ClockGrid(orbits.t_gpst_s, orbits.sat_ids,
                                                                  orbits.clock_s, orbits.source)
        self.n_points = int(n_points)
        self.antennas = antennas
        self._col = {s: j for j, s in enumerate(orbits.sat_ids)}
        self._ccol = {s: j for j, s in enumerate(self.clocks.sat_ids)}

    @property
    def systems(self) -> tuple:
        return tuple(sorted({s[0] for s in self.orbits.sat_ids}))

    @property
    def span_gpst_s(self) -> tuple[float, float]:
        """The span where both orbits and clocks are given."""
        a, b = self.orbits.span_gpst_s
        c, d = self.clocks.span_gpst_s
        return max(a, c), min(b, d)

    def positions(self, sat_ids, t_gpst_s, dt_s=0.0):
        """ECEF position [m] (n, 3) of each row at ``t_gpst_s + dt_s`` in
        ECEF(t) (module docstring), and its reason code (n,) int: -1 = ok,
        else the index into ``REASONS``."""
        sat_ids = list(sat_ids)
        n = len(sat_ids)
        t = np.broadcast_to(np.asarray(t_gpst_s, float), (n,))
        dt = np.broadcast_to(np.asarray(dt_s, float), (n,))
        out = np.full((n, 3), np.nan)
        why = np.full(n, -1, int)
        col = np.array([self._col.get(s, -1) for s in sat_ids], int)
        why[col < 0] = 0
        tg = self.orbits.t_gpst_s
        ok = col >= 0
        rel0 = (tg[0] - t) - dt                   # grid - t, small numbers
        rel1 = (tg[-1] - t) - dt
        outside = ok & ((rel0 > 0.0) | (rel1 < 0.0))
        why[outside] = 1
        ok &= ~outside
        rows = np.flatnonzero(ok)
        if rows.size:
            k = np.searchsorted(tg, t[rows] + dt[rows], side="right")
            i0 = np.clip(k - self.n_points // 2, 0, len(tg) - self.n_points)
            idx = i0[:, None] + np.arange(self.n_points)[None, :]
            trel = (tg[idx] - t[rows, None]) - dt[rows, None]
            P = self.orbits.pos_e_m[idx, col[rows, None]]              # (m, N, 3)
            r = _lagrange_rotated(trel, P)
            bad = ~np.all(np.isfinite(r), axis=1)
            why[rows[bad]] = 2
            out[rows] = r
            out[rows[bad]] = np.nan
        return out, why

    def clock(self, sat_ids, t_gpst_s, dt_s=0.0):
        """Satellite clock [s] (n,) from the clock grid by linear
        interpolation, without the relativistic term, and its reason (n,)."""
        sat_ids = list(sat_ids)
        n = len(sat_ids)
        t = np.broadcast_to(np.asarray(t_gpst_s, float), (n,))
        dt = np.broadcast_to(np.asarray(dt_s, float), (n,))
        out = np.full(n, np.nan)
        why = np.full(n, -1, int)
        col = np.array([self._ccol.get(s, -1) for s in sat_ids], int)
        why[col < 0] = 0
        tc = self.clocks.t_gpst_s
        ok = col >= 0
        outside = ok & ((((tc[0] - t) - dt) > 0.0) | (((tc[-1] - t) - dt) < 0.0))
        why[outside] = 1
        ok &= ~outside
        rows = np.flatnonzero(ok)
        if rows.size:
            k = np.clip(np.searchsorted(tc, t[rows] + dt[rows], side="right") - 1, 0, len(tc) - 2)
            a = (tc[k] - t[rows]) - dt[rows]               # <= 0
            b = (tc[k + 1] - t[rows]) - dt[rows]           # >= 0
            c0, c1 = self.clocks.clock_s[k, col[rows]], self.clocks.clock_s[k + 1, col[rows]]
            c = c0 + (c1 - c0) * (-a) / (b - a)
            bad = ~np.isfinite(c)
            why[rows[bad]] = 3
            out[rows] = c
        return out, why

    def states(self, sat_ids, t_gpst_s, dt_s=0.0):
        """Position (n, 3) [m], velocity (n, 3) [m/s] (rotating ECEF),
        clock (n,) [s] with the relativistic term, clock drift (n,) [s/s]
        at ``t_gpst_s + dt_s``, and the reason (n,) (-1 = ok; NaN rows
        otherwise)."""
        dt = np.asarray(dt_s, float)
        r, why = self.positions(sat_ids, t_gpst_s, dt)
        r2, why2 = self.positions(sat_ids, t_gpst_s, dt + VEL_STEP_S)
        r3, _ = self.positions(sat_ids, t_gpst_s, dt + DRIFT_STEP_S)
        r4, _ = self.positions(sat_ids, t_gpst_s, dt + DRIFT_STEP_S + VEL_STEP_S)
        c, whyc = self.clock(sat_ids, t_gpst_s, dt)
        c3, _ = self.clock(sat_ids, t_gpst_s, dt + DRIFT_STEP_S)
        why = np.where(why >= 0, why, np.where(why2 >= 0, why2, whyc))
        v = (r2 - r) / VEL_STEP_S
        rel = -2.0 * np.einsum("ij,ij->i", r, v) / C_MPS ** 2
        rel3 = -2.0 * np.einsum("ij,ij->i", r3, (r4 - r3) / VEL_STEP_S) / C_MPS ** 2
        clk = c + rel
        # the drift of clock + relativistic term over DRIFT_STEP_S, each term with its own velocity (RTKLIB's
        # peph2pos reuses v(t) at t + tt and so drops r.a: measured 2.1e-10 s/s = 6 cm/s off on G05)
        drift = ((c3 + rel3) - clk) / DRIFT_STEP_S
        bad = why >= 0
        for a in (r, v):
            a[bad] = np.nan
        clk[bad] = np.nan
        drift[bad] = np.nan
        return r, v, clk, drift, why


def _lagrange_rotated(trel, P):
    """Lagrange value at 0 of the nodes ``trel`` (m, N) [s, node - t] and
    values ``P`` (m, N, 3), each node's position first rotated into ECEF(t)
    by R3(-we trel) (RTKLIB pephpos)."""
    a = OMEGA_E_GPS_RADPS * trel
    ca, sa = np.cos(a), np.sin(a)
    x = ca * P[..., 0] - sa * P[..., 1]
    y = sa * P[..., 0] + ca * P[..., 1]
    z = P[..., 2]
    N = trel.shape[1]
    diff = trel[:, :, None] - trel[:, None, :]                   # t_j - t_m
    eye = np.eye(N, dtype=bool)
    num = np.where(eye[None], 1.0, -trel[:, None, :])            # (0 - t_m), m != j
    den = np.where(eye[None], 1.0, diff)
    w = np.prod(num / den, axis=2)                               # (m, N)
    return np.stack([np.sum(w * x, 1), np.sum(w * y, 1), np.sum(w * z, 1)], axis=1)
