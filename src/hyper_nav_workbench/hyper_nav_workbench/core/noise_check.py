"""The IMU's measured noise against the configured densities (pure numpy).

A data sheet gives the sensor's own white noise (ARW, VRW) on a quiet
bench; on a vehicle with its engine running the raw rates also carry
vibration, often tens of times the sensor noise. The filter's process noise
must cover what the data show, else its covariance is optimistic and the
innovation gate refuses correct fixes (``hyper_nav_filter.core.lockout``).

Measured on static intervals (the alignment window, and any interval where
the GNSS speed stays below ``static_speed_mps``, at least ``min_static_s``
long), per axis, with each interval's mean and linear trend removed:

* ``raw``: the sample standard deviation of the rates x sqrt(dt), the white
  density that would give that scatter (an upper bound when vibration,
  which averages out over longer times, dominates);
* ``allan``: where an interval holds at least ``ALLAN_MIN_S`` of data, the
  white-noise term N of the overlapping Allan variance fitted as
  3 Q^2/tau^2 + N^2/tau over TAU_MIN_S <= tau <= interval / 10
  (``allan.fit_noise_terms(quantization=True, bias_instability=False)``): vibration well above
  1/tau integrates to a bounded angle (velocity) of sigma s, whose Allan
  variance is 3 s^2/tau^2 (the Q term), so it no longer reads as white
  noise (TAU_MIN_S = 0.1 s: vibration above 10 Hz);
  pooled over the intervals (the mean of the N^2, weighted by length);
* the *measured* density is ``allan`` where available, else ``raw``.

Suggested configuration (the rule, stated in ``Check.describe``): per axis
max(configured, measured) for ``gyro_arw_deg_per_sqrt_hr`` and
``accel_vrw_ug_per_sqrt_hz``; the configuration is flagged when the
measured density exceeds the configured one by more than ``RATIO_WARN``
(3x: an optimistic model). ``--noise from-data`` (import_data) adopts the
suggestion.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.core import units

from hyper_nav_workbench.core import allan

RATIO_WARN = 3.0
ALLAN_MIN_S = 10.0
TAU_MIN_S = 0.1


@dataclass
class Check:
    intervals_s: list                  # [(t0, t1)] static intervals used
    gyro_measured: np.ndarray          # deg/sqrt(h) per axis
    accel_measured: np.ndarray         # ug/sqrt(Hz) per axis
    gyro_raw: np.ndarray
    accel_raw: np.ndarray
    method: str                        # "allan" or "raw"
    gyro_configured: np.ndarray
    accel_configured: np.ndarray
    notes: list = field(default_factory=list)

    @property
    def gyro_ratio(self) -> np.ndarray:
        return self.gyro_measured / np.maximum(self.gyro_configured, 1e-300)

    @property
    def accel_ratio(self) -> np.ndarray:
        return self.accel_measured / np.maximum(self.accel_configured, 1e-300)

    @property
    def optimistic(self) -> bool:
        return bool(np.any(self.gyro_ratio > RATIO_WARN) or np.any(self.accel_ratio > RATIO_WARN))

    def suggested(self) -> dict:
        """Filter config fields: per axis max(configured, measured)."""
        return {"gyro_arw_deg_per_sqrt_hr": [float(x) for x in np.maximum(self.gyro_configured, self.gyro_measured)],
                "accel_vrw_ug_per_sqrt_hz": [float(x) for x in np.maximum(self.accel_configured,
                                                                          self.accel_measured)]}

    def describe(self) -> str:
        span = sum(b - a for a, b in self.intervals_s)
        f = (lambda v: "/".join(f"{x:.3g}" for x in v))
        lines = [f"IMU noise on {len(self.intervals_s)} static interval(s), {span:.1f} s "
                 f"({'Allan deviation, white-noise reading' if self.method == 'allan' else 'sample std x sqrt(dt)'}):",
                 f"  gyro  measured {f(self.gyro_measured)} deg/sqrt(h) (raw scatter {f(self.gyro_raw)}), configured "
                 f"{f(self.gyro_configured)}: x {f(self.gyro_ratio)}",
                 f"  accel measured {f(self.accel_measured)} ug/sqrt(Hz) (raw scatter {f(self.accel_raw)}), configured "
                 f"{f(self.accel_configured)}: x {f(self.accel_ratio)}"]
        s = self.suggested()
        verdict = (f"  OPTIMISTIC: measured above {RATIO_WARN:g}x the configured densities (vibration or a bench data "
                   f"sheet); the gate will refuse correct fixes" if self.optimistic else "  consistent (within "
                   f"{RATIO_WARN:g}x) or pessimistic")
        lines.append(verdict)
        lines.append(f"  suggested (rule: per axis max(configured, measured); --noise from-data adopts it): "
                     f"gyro_arw_deg_per_sqrt_hr: [{', '.join(f'{x:.4g}' for x in s['gyro_arw_deg_per_sqrt_hr'])}], "
                     f"accel_vrw_ug_per_sqrt_hz: [{', '.join(f'{x:.4g}' for x in s['accel_vrw_ug_per_sqrt_hz'])}]")
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])

    def as_dict(self) -> dict:
        return {"intervals_s": [list(map(float, iv)) for iv in self.intervals_s], "method": self.method,
                "gyro_measured_deg_per_sqrt_hr": self.gyro_measured.tolist(),
                "accel_measured_ug_per_sqrt_hz": self.accel_measured.tolist(),
                "gyro_raw_deg_per_sqrt_hr": self.gyro_raw.tolist(), "accel_raw_ug_per_sqrt_hz": self.accel_raw.tolist(),
                "gyro_configured_deg_per_sqrt_hr": self.gyro_configured.tolist(),
                "accel_configured_ug_per_sqrt_hz": self.accel_configured.tolist(),
                "optimistic": self.optimistic, "suggested": self.suggested(), "notes": list(self.notes)}


def static_intervals(t_s, window_s: float, gnss_t_s=None, gnss_vel_enu_mps=None, static_speed_mps: float = 0.3,
                     min_static_s: float = 2.0) -> list:
    """[(t0, t1)]: the first ``window_s`` of the IMU when no GNSS speed in it
    reaches ``static_speed_mps`` (no GNSS there: static, as the alignment
    assumes), and every GNSS-static run of at least ``min_static_s``."""
    t = np.asarray(t_s, float)
    out = []
    if gnss_t_s is None or gnss_vel_enu_mps is None or not len(gnss_t_s):
        return [(float(t[0]), float(min(t[-1], t[0] + window_s)))]
    gt = np.asarray(gnss_t_s, float)
    speed = np.linalg.norm(np.asarray(gnss_vel_enu_mps, float)[:, :2], axis=1)
    in_win = (gt >= t[0]) & (gt <= t[0] + window_s)
    if not np.any(speed[in_win] >= static_speed_mps):
        out.append((float(t[0]), float(min(t[-1], t[0] + window_s))))
    still = speed < static_speed_mps
    k = 0
    while k < len(gt):
        if still[k]:
            j = k
            while j + 1 < len(gt) and still[j + 1]:
                j += 1
            a, b = max(gt[k], t[0]), min(gt[j], t[-1])
            if b - a >= min_static_s:
                out.append((float(a), float(b)))
            k = j + 1
        else:
            k += 1
    out.sort()
    merged = []
    for a, b in out:                                          # the window and a static run may overlap
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def _detrended(t, y):
    A = np.column_stack([np.ones_like(t), t - t.mean()])
    c, *_ = np.linalg.lstsq(A, y, rcond=None)
    return y - A @ c


def measure(t_s, omega_b_radps, f_b_mps2, intervals) -> tuple:
    """(gyro N rad/sqrt(s), accel N m/s^2 sqrt(s), raw gyro, raw accel, method) per axis over the intervals."""
    t = np.asarray(t_s, float)
    w, f = np.asarray(omega_b_radps, float), np.asarray(f_b_mps2, float)
    raw_g, raw_a, wts, av_g, av_a, av_w = [], [], [], [], [], []
    for a, b in intervals:
        m = (t >= a) & (t <= b)
        if m.sum() < 10:
            continue
        tt = t[m]
        dt = float(np.median(np.diff(tt)))
        g, acc = _detrended(tt, w[m]), _detrended(tt, f[m])
        raw_g.append(np.std(g, axis=0) * math.sqrt(dt))
        raw_a.append(np.std(acc, axis=0) * math.sqrt(dt))
        wts.append(len(tt))
        span = tt[-1] - tt[0]
        if span >= ALLAN_MIN_S:
            taus = allan.log_taus(len(tt), dt, max_fraction=0.1)
            taus = taus[taus >= TAU_MIN_S - 1e-12]
            if len(taus) >= 4:
                tg, ag, _ = allan.overlapping_adev(g, dt, taus)
                ta, aa, _ = allan.overlapping_adev(acc, dt, taus)
                rel = allan.adev_relative_sigma(tg, len(tt), dt)
                av_g.append([allan.fit_noise_terms(tg, ag[:, i], rel, quantization=True, bias_instability=False)["N"] ** 2
                             for i in range(3)])
                av_a.append([allan.fit_noise_terms(ta, aa[:, i], rel, quantization=True, bias_instability=False)["N"] ** 2
                             for i in range(3)])
                av_w.append(span)
    if not wts:
        return None
    wts = np.asarray(wts, float)[:, None]
    rg = np.sqrt(np.sum(np.square(raw_g) * wts, axis=0) / wts.sum())
    ra = np.sqrt(np.sum(np.square(raw_a) * wts, axis=0) / wts.sum())
    if av_g:
        aw = np.asarray(av_w, float)[:, None]
        return (np.sqrt(np.sum(np.asarray(av_g) * aw, axis=0) / aw.sum()),
                np.sqrt(np.sum(np.asarray(av_a) * aw, axis=0) / aw.sum()), rg, ra, "allan")
    return rg, ra, rg, ra, "raw"


def check(t_s, omega_b_radps, f_b_mps2, config, intervals) -> Check | None:
    """The measured densities against ``config`` (a FilterConfig); None when
    no interval holds 10 samples."""
    r = measure(t_s, omega_b_radps, f_b_mps2, intervals)
    if r is None:
        return None
    ng, na, rg, ra, method = r
    to_g = 1.0 / float(units.deg_per_sqrt_hr(1.0))        # rad/sqrt(s) -> deg/sqrt(h)
    to_a = 1.0 / float(units.ug_per_sqrt_hz(1.0))         # m/s^2 sqrt(s) -> ug/sqrt(Hz)
    gc = np.asarray(config.gyro_arw_deg_per_sqrt_hr, float)
    ac = np.asarray(config.accel_vrw_ug_per_sqrt_hz, float)
    notes = []
    if method == "raw":
        notes.append(f"static data shorter than {ALLAN_MIN_S:g} s: the raw scatter is the measure (an upper bound "
                     f"under vibration)")
    return Check(list(intervals), ng * to_g, na * to_a, rg * to_g, ra * to_a, method, np.broadcast_to(gc, 3).copy(),
                 np.broadcast_to(ac, 3).copy(), notes)


def report_saved(path, out) -> dict | None:
    """The noise check an import saved (``import_data``: ``noise_check.yaml``
    beside the bag's filter.yaml), as the replay shows it: a summary line
    and, when the measured densities exceed the configured ones by more than
    RATIO_WARN, a warning on ``out`` (a ``run_check.Outcome``) naming the
    suggestion. None when there is no such file."""
    import pathlib

    import yaml
    p = pathlib.Path(path)
    if not p.exists():
        return None
    d = yaml.safe_load(p.read_text()) or {}
    f = (lambda v: "/".join(f"{x:.3g}" for x in v))
    gm, gc = d.get("gyro_measured_deg_per_sqrt_hr", []), d.get("gyro_configured_deg_per_sqrt_hr", [])
    am, ac = d.get("accel_measured_ug_per_sqrt_hz", []), d.get("accel_configured_ug_per_sqrt_hz", [])
    print(f"IMU noise measured at import ({d.get('method')}): gyro {f(gm)} deg/sqrt(h) (configured {f(gc)}), "
          f"accel {f(am)} ug/sqrt(Hz) (configured {f(ac)})")
    if d.get("optimistic"):
        s = d.get("suggested", {})
        out.warnings.append(f"imu noise: measured densities above {RATIO_WARN:g}x the configured ones (gyro {f(gm)} vs "
                            f"{f(gc)} deg/sqrt(h), accel {f(am)} vs {f(ac)} ug/sqrt(Hz)); suggested "
                            f"gyro_arw_deg_per_sqrt_hr {s.get('gyro_arw_deg_per_sqrt_hr')}, accel_vrw_ug_per_sqrt_hz "
                            f"{s.get('accel_vrw_ug_per_sqrt_hz')} (import_data --noise from-data)")
    return d
