"""RTKLIB solution files (``.pos``, RTKLIB manual 2.4.2, Appendix B.1 "Solution
file format", llh form): ``%`` header lines, then per epoch GPST date and
time (``yyyy/mm/dd hh:mm:ss.sss``), latitude, longitude [deg], ellipsoidal
height [m], Q (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP), number of
satellites, sdn sde sdu sdne sdeu sdun [m], age, ratio and, when written,
vn ve vu [m/s] with their sigmas. A reference trajectory for scoring: keep
only the epochs of one quality (``quality=1``: fixed) and match them to
other epochs in time. Malformed lines are skipped and counted.
"""
from __future__ import annotations

import datetime as _dt
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

_GPS_EPOCH = _dt.datetime(1980, 1, 6)


@dataclass
class PosFile:
    t_gpst_s: np.ndarray          # continuous GPST seconds
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    alt_m: np.ndarray
    quality: np.ndarray
    n_sat: np.ndarray
    sigma_neu_m: np.ndarray       # (n, 3)
    vel_neu_mps: np.ndarray | None = None
    counts: Counter = field(default_factory=Counter)

    def select(self, mask) -> "PosFile":
        m = np.asarray(mask, bool)
        return PosFile(self.t_gpst_s[m], self.lat_rad[m], self.lon_rad[m], self.alt_m[m], self.quality[m],
                       self.n_sat[m], self.sigma_neu_m[m], None if self.vel_neu_mps is None else self.vel_neu_mps[m],
                       Counter(self.counts))

    def match(self, t_gpst_s, tol_s: float = 0.005) -> np.ndarray:
        """Index of the reference epoch within ``tol_s`` of each time (-1: none)."""
        t = np.asarray(t_gpst_s, float)
        if not len(self.t_gpst_s):
            return np.full(len(t), -1)
        k = np.clip(np.searchsorted(self.t_gpst_s, t), 1, len(self.t_gpst_s) - 1)
        k = np.where(np.abs(self.t_gpst_s[k - 1] - t) < np.abs(self.t_gpst_s[k] - t), k - 1, k)
        if len(self.t_gpst_s) == 1:
            k = np.zeros(len(t), int)
        return np.where(np.abs(self.t_gpst_s[k] - t) <= tol_s, k, -1)


def read_pos(path) -> PosFile:
    """Read an RTKLIB llh .pos file (see the module docstring)."""
    rows, vel, counts = [], [], Counter()
    for ln in Path(path).read_text(errors="replace").splitlines():
        if not ln.strip() or ln.startswith("%"):
            continue
        f = ln.split()
        try:
            d = _dt.datetime.strptime(f[0] + " " + f[1][:15], "%Y/%m/%d %H:%M:%S.%f") if "." in f[1] else \
                _dt.datetime.strptime(f[0] + " " + f[1], "%Y/%m/%d %H:%M:%S")
            dd = d - _GPS_EPOCH
            t = dd.days * 86400.0 + dd.seconds + dd.microseconds * 1e-6
            vals = [float(x) for x in f[2:]]
            rows.append([t] + vals[:9])
            vel.append(vals[13:16] if len(vals) >= 16 else [np.nan] * 3)     # after age (11) and ratio (12)
            counts["epochs"] += 1
        except (ValueError, IndexError):
            counts["malformed_lines"] += 1
    if not rows:
        raise ValueError(f"{path}: no solution epoch")
    a = np.array(rows, float)
    v = np.array(vel, float)
    q = a[:, 4].astype(int)
    for qq in np.unique(q):
        counts[f"quality_{qq}"] = int(np.count_nonzero(q == qq))
    return PosFile(a[:, 0], np.deg2rad(a[:, 1]), np.deg2rad(a[:, 2]), a[:, 3], q, a[:, 5].astype(int),
                   a[:, 6:9], None if np.all(np.isnan(v)) else v, counts)
