"""Inertial/geomagnetic navigation flown offline (no ROS): the scenario's
IMU, barometer and magnetometer streams through the fusion core
(``hyper_nav_filter.core.fusion.FusionEngine``) with the geomagnetic aiding
engine (``core.geomag_aiding.GeomagAiding``, the node's core) in the loop,
as the graph runs it:

* barometric height (seed 003 eqs. 20-26, Z_2) at its epochs, from t = 0
  (our reading: "pure inertial" 0-420 s is the horizontal channel; the
  vertical channel of a real INS is always baro-damped);
* at each magnetometer epoch t, the solution at t (what ``nav/state``
  carries) and the measured |B| go to ``GeomagAiding.process``; a fix is
  added to the engine as a ``HorizontalFix`` at its epoch t (Z_1).

The engine runs with ``output_delay_s = 0`` and releases every epoch, so the
solution at t is out as soon as the IMU sample at t is in, and the fix at t
is applied to epoch t on the next IMU sample (one epoch re-processed). The
live node gets the same solution 1 s later (the fusion node's output delay)
and the fusion node applies the late fix at the same epoch: same numbers.
Kept per whole second t: ``solutions[t]`` (before the fix of t: what the
matcher sees) and ``posterior[t]``, the first solution after t (after the
fix of t, one IMU interval later), on which errors are evaluated, as the
PCRB is a posterior bound.

``decimate`` sums consecutive IMU increments (the exact integral over the
longer interval); see ``seed003.reproduce`` for the accuracy cost.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import numpy as np

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import BaroHeight
from hyper_nav_workbench.core import scoring

from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.matching import MagSample, NavPoint
from hyper_nav_aiding.geomag.conversions import fix_measurement


@dataclass
class Streams:
    """Sensor streams of one scenario realisation."""
    imu_t_s: np.ndarray
    dtheta_b_rad: np.ndarray
    dvel_b_mps: np.ndarray
    baro: list                    # BaroHeight measurements
    mag_t_s: np.ndarray
    mag_total_nT: np.ndarray


def imu_streams(sc, traj, decimate: int = 1):
    from hyper_nav_sim.core import simulate
    imu = simulate.imu_stream(sc, traj)
    n = len(imu.t_s) - len(imu.t_s) % decimate
    return (imu.t_s[decimate - 1:n:decimate], imu.dtheta_b_rad[:n].reshape(-1, decimate, 3).sum(axis=1),
            imu.dvel_b_mps[:n].reshape(-1, decimate, 3).sum(axis=1))


def baro_measurements(sc, traj) -> list:
    """BaroHeight from the simulated pressures: the filter side inverts the
    US76 profile and takes the pressure sigma through dp/dh."""
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.baro_model import BaroErrors, altitude_from_pressure_m, altitude_sigma_m
    t, p, _ = simulate.baro_stream(sc, traj)
    ok = np.isfinite(p)
    h = altitude_from_pressure_m(p[ok])
    err = BaroErrors.from_config(sc.data["barometer"], prefix="barometer")
    var = altitude_sigma_m(h, err) ** 2
    return [BaroHeight(float(ti), float(hi), float(vi)) for ti, hi, vi in zip(t[ok], h, var)]


def mag_total(sc, traj):
    """(t_s, |B| nT) of the simulated magnetometer (the norm of the body
    vector: attitude-free; no hard/soft iron in seed 003)."""
    from hyper_nav_sim.core import simulate
    t, field_T = simulate.mag_stream(sc, traj)
    return t, np.linalg.norm(field_T, axis=1) * 1e9


def nav_point(sol, layout) -> NavPoint:
    p = layout.sl("pos")
    P = sol.P[p, p]
    s = sol.state
    return NavPoint(sol.t_s, s.lat_rad, s.lon_rad, s.alt_m, s.vel_enu_mps.copy(), P[:2, :2].copy(), float(P[2, 2]))


class AidedFlight:
    """The engine stepped over the streams, resumable: ``run_until(t)``
    advances; ``fork()`` copies the whole state (used to share the pure
    inertial 0-420 s between algorithms)."""

    def __init__(self, cfg, initial_state, imu_t_s, dtheta, dvel, baro: list):
        rate = 1.0 / float(np.min(np.diff(imu_t_s[:3]))) if len(imu_t_s) > 2 else cfg.output_rate_hz
        self.cfg = replace(cfg, output_delay_s=0.0, output_rate_hz=rate)
        self.eng = FusionEngine(self.cfg, initial_state)
        self.imu = (imu_t_s, dtheta, dvel)
        self.baro = baro
        self.k = 0
        self.j = 0
        self.solutions: dict[float, object] = {}
        self.posterior: dict[float, object] = {}
        self._pending: float | None = None

    def fork(self) -> "AidedFlight":
        return copy.deepcopy(self)

    def run_until(self, t_end_s: float, aiding: GeomagAiding | None = None, mag_t_s=None, mag_nT=None,
                  on_result=None) -> None:
        t, dth, dv = self.imu
        mi = 0 if mag_t_s is None else int(np.searchsorted(mag_t_s, t[self.k] - 1e-9 if self.k < len(t) else np.inf))
        lay = self.cfg.layout
        while self.k < len(t) and t[self.k] <= t_end_s + 1e-9:
            tk = t[self.k]
            while self.j < len(self.baro) and self.baro[self.j].t_s <= tk + 1e-9:
                self.eng.add_measurement(self.baro[self.j])
                self.j += 1
            self.eng.add_imu(tk, dth[self.k], dv[self.k])
            self.k += 1
            for sol in self.eng.release():
                if self._pending is not None:
                    self.posterior[self._pending] = sol
                    self._pending = None
                ts = float(sol.t_s)
                whole = float(int(ts + 0.5))
                if abs(ts - whole) < 1e-6:
                    self.solutions[whole] = sol
                    self._pending = whole
            if aiding is None or mag_t_s is None:
                continue
            while mi < len(mag_t_s) and mag_t_s[mi] <= tk + 1e-9:
                tm = float(mag_t_s[mi])
                sol = self.solutions.get(float(round(tm)))
                if sol is not None:
                    res = aiding.process(MagSample(tm, float(mag_nT[mi])), nav_point(sol, lay))
                    if res is not None and res.valid:
                        self.eng.add_measurement(fix_measurement(res))
                    if on_result is not None:
                        on_result(res)
                mi += 1


def position_errors(solutions: dict, traj, t_s) -> np.ndarray:
    """(N, 3) ENU position errors (estimate - truth at the solution's own
    epoch) of the solutions keyed by whole seconds t_s (NaN where none)."""
    t_s = np.asarray(t_s, float)
    sols = [solutions.get(float(round(t))) for t in t_s]
    have = np.array([s is not None for s in sols], bool)
    out = np.full((len(t_s), 3), np.nan)
    if have.any():
        out[have] = scoring.solution_errors([s for s in sols if s is not None], traj)["pos_enu_m"]
    return out
