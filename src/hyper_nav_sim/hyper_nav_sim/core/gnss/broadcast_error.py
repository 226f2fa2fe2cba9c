"""Broadcast-minus-precise orbit and clock errors measured on real data.

Reads precise orbits/clocks (the SP3 extracts of ``../shared/gnss-real``,
CSV ``epoch_gpst, sat, x_km, y_km, z_km, clk_us``) and compares them with
the broadcast records valid at each epoch (GPS toe +-2 h, BDS +-1 h):
the error in the satellite's radial / along-track / cross-track frame
(RAC, from the precise position and the inertial velocity of the broadcast
orbit) and the clock error in metres. The simulator's world model
(:mod:`.world`) takes its orbit/clock error sizes from these figures.

Conventions: error = broadcast - precise. Clocks: SP3 excludes the periodic
relativistic term, so it is removed from the broadcast clock too; BeiDou
broadcast clocks refer to B3I and are converted to the B1I/B3I iono-free
reference of the SP3 clocks with TGD1 (dt_IF = dt_B3I - f1^2/(f1^2 - f3^2)
TGD1). The SP3 clocks refer to the analysis centre's time scale, not to
GPST/BDT: a common offset per epoch and system, which a receiver absorbs in
its clock bias, so ``clk_m`` has the per-epoch mean over the system's
satellites removed (``clk_raw_m`` keeps it). Broadcast orbits refer to the
antenna phase centre, SP3 to the centre of mass: the phase-centre offset
(up to ~2.5 m, mostly radial) is part of the measured error, as it is
part of what a receiver sees.
"""
from __future__ import annotations

import csv
import datetime as _dt
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hyper_nav_filter.core.attitude import cross3
from hyper_nav_gnss.orbits.ephemeris import (
    BDS_GEO_PRNS, C_MPS, calendar_to_system_s, constants, satellite_position_ecef, select_ephemeris, system_time_s,
)

F_B1I_HZ, F_B3I_HZ = 1561.098e6, 1268.52e6
BDS_IGSO_PRNS = frozenset({6, 7, 8, 9, 10, 13, 16, 38, 39, 40})
CLASSES = ("GPS", "BDS_MEO", "BDS_IGSO", "BDS_GEO")


def satellite_class(sat_id: str) -> str:
    """'GPS', 'BDS_MEO', 'BDS_IGSO' or 'BDS_GEO' of a satellite id 'G05', 'C38', ..."""
    if sat_id[0] == "G":
        return "GPS"
    prn = int(sat_id[1:])
    if prn in BDS_GEO_PRNS:
        return "BDS_GEO"
    return "BDS_IGSO" if prn in BDS_IGSO_PRNS else "BDS_MEO"


def read_sp3_csv(path):
    """Rows (t_gpst_s, sat, r_e_m (3,), clk_s or nan) of an SP3 extract."""
    rows = []
    with open(Path(path)) as fh:
        for r in csv.DictReader(fh):
            t = _dt.datetime.fromisoformat(r["epoch_gpst"])
            ts = calendar_to_system_s("G", t.year, t.month, t.day, t.hour, t.minute, t.second)
            clk = float(r["clk_us"])
            rows.append((ts, r["sat"], np.array([float(r["x_km"]), float(r["y_km"]), float(r["z_km"])]) * 1e3,
                         np.nan if clk > 999990 else clk * 1e-6))
    return rows


def rac_frame(r_e_m, v_inertial_mps):
    """Rows of the radial, along-track, cross-track unit vectors (3, 3)."""
    e_r = r_e_m / np.linalg.norm(r_e_m)
    h = cross3(r_e_m, v_inertial_mps)
    e_c = h / np.linalg.norm(h)
    return np.stack([e_r, cross3(e_c, e_r), e_c])


def _relativistic_s(eph, t_sys_s):
    mu, _ = constants(eph.system)
    r, _, clk, _ = satellite_position_ecef(eph, t_sys_s)
    # F e sqrtA sinE = clk - polynomial
    dtc = t_sys_s - eph.toc_s
    return clk - (eph.af0 + eph.af1 * dtc + eph.af2 * dtc ** 2)


@dataclass
class SatelliteErrors:
    """Broadcast - precise of one satellite at the precise epochs."""
    sat_id: str
    t_gpst_s: np.ndarray
    age_s: np.ndarray          # t - toe of the record used [s]
    toe_s: np.ndarray          # toe of the record used (system time) [s]
    rac_m: np.ndarray          # (N, 3) radial, along, cross [m]
    clk_raw_m: np.ndarray      # c (dt_broadcast - dt_precise) [m]
    clk_m: np.ndarray          # the same, per-epoch system mean removed [m]


def broadcast_minus_precise(ephs, rows) -> dict[str, SatelliteErrors]:
    """Per satellite: broadcast (``ephs``) - precise (``rows`` of :func:`read_sp3_csv`)."""
    k_if = F_B1I_HZ ** 2 / (F_B1I_HZ ** 2 - F_B3I_HZ ** 2)
    acc: dict[str, list] = {}
    for t_gpst, sat, r_p, clk_p in rows:
        if sat[0] not in "GC":
            continue
        t = float(system_time_s(sat[0], t_gpst))
        eph = select_ephemeris(ephs, sat, t)
        if eph is None:
            continue
        r, v, clk, _ = satellite_position_ecef(eph, t)
        we = constants(eph.system)[1]
        v_i = v + np.cross([0.0, 0.0, we], r)
        rac = rac_frame(r_p, v_i) @ (r - r_p)
        clk_b = clk - _relativistic_s(eph, t) - (k_if * eph.tgd if eph.system == "C" else 0.0)
        acc.setdefault(sat, []).append((t_gpst, t - eph.toe_s, eph.toe_s, rac, C_MPS * (clk_b - clk_p)))
    out = {}
    for sat, v in acc.items():
        out[sat] = SatelliteErrors(sat, np.array([x[0] for x in v]), np.array([x[1] for x in v]),
                                   np.array([x[2] for x in v]), np.array([x[3] for x in v]),
                                   np.array([x[4] for x in v]), np.zeros(len(v)))
    for system in "GC":
        sats = [s for s in out if s[0] == system]
        if not sats:
            continue
        t_all = np.unique(np.concatenate([out[s].t_gpst_s for s in sats]))
        mean = {}
        for t in t_all:
            vals = [out[s].clk_raw_m[out[s].t_gpst_s == t] for s in sats]
            vals = np.concatenate(vals)
            vals = vals[np.isfinite(vals)]
            mean[t] = np.mean(vals) if vals.size else np.nan
        for s in sats:
            out[s].clk_m = out[s].clk_raw_m - np.array([mean[t] for t in out[s].t_gpst_s])
    return out


@dataclass
class ClassStatistics:
    """Error statistics of a satellite class (all values [m] unless stated)."""
    n_points: int
    n_satellites: int
    rms_3d_m: float
    rms_rac_m: np.ndarray              # (3,)
    rms_clk_m: float                   # per-epoch system mean removed, per-satellite mean kept
    corr_radial_clk: float
    lags_s: np.ndarray
    change_rms_rac_m: np.ndarray       # (n_lags, 3): RMS of e(t + lag) - e(t), same record
    change_rms_clk_m: np.ndarray       # (n_lags,)
    bias_rms_rac_m: np.ndarray         # (3,) RMS over satellites of the per-satellite mean
    bias_rms_clk_m: float
    variation_rms_rac_m: np.ndarray    # (3,) RMS of the deviation from the per-satellite mean
    variation_rms_clk_m: float

    @property
    def correlation_time_rac_s(self) -> np.ndarray:
        """tau of a smooth process with the measured variation whose RMS change
        over the first lag is the measured one: tau = sigma lag / D(lag)
        (squared-exponential covariance, small-lag limit)."""
        return self.variation_rms_rac_m * self.lags_s[0] / self.change_rms_rac_m[0]

    @property
    def correlation_time_clk_s(self) -> float:
        return float(self.variation_rms_clk_m * self.lags_s[0] / self.change_rms_clk_m[0])

    @property
    def rms_3d_without_radial_mean_m(self) -> float:
        """3D RMS with each satellite's mean radial offset (the antenna
        phase-centre offset, broadcast APC vs precise centre of mass) removed."""
        r = np.hypot(self.variation_rms_rac_m, np.r_[0.0, self.bias_rms_rac_m[1:]])
        return float(np.sqrt(np.sum(r ** 2)))


def class_statistics(errors: dict[str, SatelliteErrors], sat_class: str,
                     lags_s=(300.0, 600.0, 900.0, 1800.0)) -> ClassStatistics | None:
    """RMS sizes, radial-clock correlation and the RMS change over time lags
    (pairs of epochs of one satellite using the same broadcast record)."""
    sats = [s for s in errors if satellite_class(s) == sat_class]
    if not sats:
        return None
    rac = np.concatenate([errors[s].rac_m for s in sats])
    clk = np.concatenate([errors[s].clk_m for s in sats])
    ok = np.isfinite(clk)
    lags = np.asarray(lags_s, float)
    d_rac = np.full((lags.size, 3), np.nan)
    d_clk = np.full(lags.size, np.nan)
    for i, lag in enumerate(lags):
        pr, pc = [], []
        for s in sats:
            e = errors[s]
            for a in range(e.t_gpst_s.size):
                b = np.flatnonzero((np.abs(e.t_gpst_s - e.t_gpst_s[a] - lag) < 1.0) & (e.toe_s == e.toe_s[a]))
                if b.size:
                    pr.append(e.rac_m[b[0]] - e.rac_m[a])
                    pc.append(e.clk_m[b[0]] - e.clk_m[a])
        if pr:
            d_rac[i] = np.sqrt(np.mean(np.square(pr), axis=0))
            pc = np.asarray(pc)
            pc = pc[np.isfinite(pc)]
            d_clk[i] = np.sqrt(np.mean(pc ** 2)) if pc.size else np.nan
    mean_rac = np.array([errors[s].rac_m.mean(axis=0) for s in sats])
    dev_rac = np.concatenate([errors[s].rac_m - errors[s].rac_m.mean(axis=0) for s in sats])
    mean_clk = np.array([np.nanmean(errors[s].clk_m) for s in sats])
    dev_clk = np.concatenate([errors[s].clk_m - np.nanmean(errors[s].clk_m) for s in sats])
    return ClassStatistics(int(rac.shape[0]), len(sats), float(np.sqrt(np.mean(np.sum(rac ** 2, axis=1)))),
                           np.sqrt(np.mean(rac ** 2, axis=0)), float(np.sqrt(np.mean(clk[ok] ** 2))),
                           float(np.corrcoef(rac[ok, 0], clk[ok])[0, 1]), lags, d_rac, d_clk,
                           np.sqrt(np.mean(mean_rac ** 2, axis=0)), float(np.sqrt(np.nanmean(mean_clk ** 2))),
                           np.sqrt(np.mean(dev_rac ** 2, axis=0)), float(np.sqrt(np.nanmean(dev_clk ** 2))))
