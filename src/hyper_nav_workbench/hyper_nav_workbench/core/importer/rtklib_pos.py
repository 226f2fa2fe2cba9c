"""RTKLIB solution files (``.pos``, RTKLIB manual 2.4.2, Appendix B.1 "Solution
file format", llh form): ``%`` header lines, then per epoch GPST date and
time (``yyyy/mm/dd hh:mm:ss.sss``), latitude, longitude [deg], ellipsoidal
height [m], Q (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP), number of
satellites, sdn sde sdu sdne sdeu sdun [m], age, ratio and, when written,
vn ve vu [m/s] with their sigmas. A reference trajectory for scoring: keep
only the epochs of one quality (``quality=1``: fixed) and match them to
other epochs in time. Malformed lines are skipped and counted.

As the GNSS input of an import (``preset: rtklib``, ``fix_table``)::

    gnss:
      file: drive.pos
      quality: [1, 2]                       # Q values kept (default: all in the file)
      sigma_scale: {1: 1.0, 2: 3.0, 5: 10.0}   # per Q, multiplies sdn/sde/sdu (and velocity sigmas); default 1
      sigma_floor_m: 0.01                   # lower bound of the position sigmas (default 0)
      vel_sigma_floor_mps: 0.02             # lower bound of the velocity sigmas (default 0)
      time: {offset_s: 0.0}                 # added to the GPST stamps

Position sigmas are sdn/sde/sdu (N, E, U -> ENU), velocities vn/ve/vu and
their sigmas sdvn/sdve/sdvu when the file has them. Times are continuous GPST
seconds since 1980-01-06: an IMU on the same axis has them too (an RTKLIB
time-tag file, ``time_tags``, or GPST stamps). ``describe`` states what was
kept and with which weights.
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
    vel_sigma_neu_mps: np.ndarray | None = None

    def select(self, mask) -> "PosFile":
        m = np.asarray(mask, bool)
        return PosFile(self.t_gpst_s[m], self.lat_rad[m], self.lon_rad[m], self.alt_m[m], self.quality[m],
                       self.n_sat[m], self.sigma_neu_m[m], None if self.vel_neu_mps is None else self.vel_neu_mps[m],
                       Counter(self.counts), None if self.vel_sigma_neu_mps is None else self.vel_sigma_neu_mps[m])

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
    rows, vel, vsig, counts = [], [], [], Counter()
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
            vsig.append(vals[16:19] if len(vals) >= 19 else [np.nan] * 3)    # sdvn sdve sdvu
            counts["epochs"] += 1
        except (ValueError, IndexError):
            counts["malformed_lines"] += 1
    if not rows:
        raise ValueError(f"{path}: no solution epoch")
    a = np.array(rows, float)
    v = np.array(vel, float)
    vs = np.array(vsig, float)
    q = a[:, 4].astype(int)
    for qq in np.unique(q):
        counts[f"quality_{qq}"] = int(np.count_nonzero(q == qq))
    return PosFile(a[:, 0], np.deg2rad(a[:, 1]), np.deg2rad(a[:, 2]), a[:, 3], q, a[:, 5].astype(int),
                   a[:, 6:9], None if np.all(np.isnan(v)) else v, counts, None if np.all(np.isnan(vs)) else vs)


QUALITY_NAMES = {1: "fix", 2: "float", 3: "SBAS", 4: "DGPS", 5: "single", 6: "PPP"}
PRESET_FIELDS = {"file", "quality", "sigma_scale", "sigma_floor_m", "vel_sigma_floor_mps", "time"}


def _num(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)


def fix_table(spec: dict, base_dir, where: str = "gnss"):
    """A ``.pos`` file as the GNSS input of an import (module docstring):
    (``columns.FixTable`` in ENU, continuous GPST, the sentence stating what
    was kept and weighted)."""
    from hyper_nav_filter.core.params import ConfigError, number

    from hyper_nav_workbench.core.importer.columns import FixTable, check_fields
    check_fields(spec, PRESET_FIELDS, where)
    if "file" not in spec:
        raise ConfigError(f"{where}.file: required")
    path = Path(spec["file"])
    path = path if path.is_absolute() else Path(base_dir) / path
    if not path.exists():
        raise ConfigError(f"{where}.file: {path} not found")
    try:
        pos = read_pos(path)
    except ValueError as exc:
        raise ConfigError(f"{where}.file: {exc}") from None
    present = sorted(int(q) for q in np.unique(pos.quality))
    keep = spec.get("quality", present)
    if not isinstance(keep, (list, tuple)) or not all(isinstance(q, int) and q in QUALITY_NAMES for q in keep):
        raise ConfigError(f"{where}.quality: expected a list of RTKLIB Q values (1-6: "
                          f"{', '.join(f'{k} {v}' for k, v in QUALITY_NAMES.items())}), got {keep!r}")
    scale = spec.get("sigma_scale") or {}
    if not isinstance(scale, dict) or not all(int(q) in QUALITY_NAMES and _num(v) and v > 0 for q, v in scale.items()):
        raise ConfigError(f"{where}.sigma_scale: expected {{Q: factor > 0}}, got {scale!r}")
    scale = {int(q): float(v) for q, v in scale.items()}
    floors = {}
    for name in ("sigma_floor_m", "vel_sigma_floor_mps"):
        floors[name] = number(f"{where}.{name}", spec.get(name, 0.0), 0.0)
    t_spec = spec.get("time") or {}
    check_fields(t_spec, {"offset_s"}, f"{where}.time")
    off = number(f"{where}.time.offset_s", t_spec.get("offset_s", 0.0))
    sel = pos.select(np.isin(pos.quality, keep))
    if not len(sel.t_gpst_s):
        raise ConfigError(f"{where}.quality: no epoch of Q {keep} in {path} (present: {present})")
    k = np.array([scale.get(int(q), 1.0) for q in sel.quality])[:, None]
    neu_to_enu = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    sig = np.maximum(np.abs(sel.sigma_neu_m) * k, floors["sigma_floor_m"]) @ neu_to_enu.T
    vel = vsig = None
    if sel.vel_neu_mps is not None and not np.any(np.isnan(sel.vel_neu_mps)):
        vel = sel.vel_neu_mps @ neu_to_enu.T
        if sel.vel_sigma_neu_mps is not None and not np.any(np.isnan(sel.vel_sigma_neu_mps)):
            vsig = np.maximum(np.abs(sel.vel_sigma_neu_mps) * k, floors["vel_sigma_floor_mps"]) @ neu_to_enu.T
    if np.any(sig <= 0):
        raise ConfigError(f"{where}: {int(np.count_nonzero(np.any(sig <= 0, axis=1)))} epoch(s) with a zero position "
                          f"sigma in {path}: set {where}.sigma_floor_m")
    kept = ", ".join(f"Q={q} {QUALITY_NAMES[q]} {int(np.count_nonzero(sel.quality == q))} (sigma x "
                     f"{scale.get(q, 1.0):g})" for q in sorted(set(keep) & set(present)))
    dropped = ", ".join(f"Q={q} {QUALITY_NAMES.get(q, '?')} {int(np.count_nonzero(pos.quality == q))}"
                        for q in present if q not in keep)
    text = (f"{where}: RTKLIB .pos {path.name}: kept {kept}" + (f"; dropped {dropped}" if dropped else "")
            + f"; sigma floor {floors['sigma_floor_m']:g} m" + ("; velocities N-E-U" + (" with sigmas" if vsig is not None
                                                                                        else " without sigmas")
                                                                if vel is not None else "; no velocity columns")
            + (f"; {pos.counts['malformed_lines']} malformed line(s) skipped" if pos.counts["malformed_lines"] else ""))
    tab = FixTable(sel.t_gpst_s + float(off), sel.lat_rad, sel.lon_rad, sel.alt_m, sig, vel, vsig)
    return tab, text
