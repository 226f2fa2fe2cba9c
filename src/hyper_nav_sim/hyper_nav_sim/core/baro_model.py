"""Barometric altimeter: static pressure at the true altitude, with noise and
bias, and the pressure-to-altitude inversion used on the filter side.

Seed 003 (Wang et al., section 3.2.2) adds a barometric altimeter to the
altitude channel of the inertial/geomagnetic filter. The atmosphere is
injected as ``pressure_pa_at(alt_m)`` (vectorised, geometric altitude); the
default is the project's US Standard Atmosphere 1976 (``.atmosphere``,
another module) when it can be imported, otherwise the minimal US76 below
(geopotential layers 0-86 km, hydrostatic, valid here to 60 km and more).

Measurement::

    p_meas = p(h) + b + sqrt((rel p(h))^2 + abs^2) w,   w ~ N(0, 1)

with ``pressure_noise_rel`` (fraction of reading, given in ppm),
``pressure_noise_pa`` (absolute) and ``pressure_bias_pa``.

Altitude-equivalent error: dp/dh = -rho g = -p / H (H = R T / (g M), the
scale height, 6.3-8.4 km below 60 km), so

    sigma_h = sigma_p / |dp/dh| = sqrt(rel^2 H^2 + (abs H / p)^2).

The relative term maps to a nearly constant rel * H; the absolute term
grows like 1/p, i.e. about exp(h / H): from 10 km (p = 26.5 kPa) to 30 km
(1.2 kPa) x 20, to 60 km (22 Pa) x 1000 or so. A pressure altimeter is
therefore an altitude aid that degrades strongly in near space; the model is
stated valid to ``max_alt_m`` (60 km).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# ---- minimal US Standard Atmosphere 1976 (fallback) ----------------------------
_R0_M = 6356766.0                 # US76 effective Earth radius for geopotential height
_G0 = 9.80665
_M_AIR = 0.0289644                # kg/mol
_R_STAR = 8.31432                 # J/(mol K), US76 value
_H_B = np.array([0.0, 11000.0, 20000.0, 32000.0, 47000.0, 51000.0, 71000.0, 84852.0])   # geopotential m
_L_B = np.array([-0.0065, 0.0, 0.0010, 0.0028, 0.0, -0.0028, -0.0020])                  # K/m
_T_B = np.empty(8)
_P_B = np.empty(8)
_T_B[0], _P_B[0] = 288.15, 101325.0
for _i in range(7):
    _dh = _H_B[_i + 1] - _H_B[_i]
    _T_B[_i + 1] = _T_B[_i] + _L_B[_i] * _dh
    if _L_B[_i] == 0.0:
        _P_B[_i + 1] = _P_B[_i] * np.exp(-_G0 * _M_AIR * _dh / (_R_STAR * _T_B[_i]))
    else:
        _P_B[_i + 1] = _P_B[_i] * (_T_B[_i] / _T_B[_i + 1]) ** (_G0 * _M_AIR / (_R_STAR * _L_B[_i]))


def us76_pressure_pa(alt_m):
    """US76 static pressure [Pa] at geometric altitude alt_m (0-86 km; below
    0 the first layer is extrapolated)."""
    z = np.asarray(alt_m, float)
    h = _R0_M * z / (_R0_M + z)                         # geopotential altitude
    i = np.clip(np.searchsorted(_H_B, h, side="right") - 1, 0, 6)
    tb, lb, pb, hb = _T_B[i], _L_B[i], _P_B[i], _H_B[i]
    lb_safe = np.where(lb == 0.0, 1.0, lb)
    iso = pb * np.exp(-_G0 * _M_AIR * (h - hb) / (_R_STAR * tb))
    grad = pb * (tb / (tb + lb_safe * (h - hb))) ** (_G0 * _M_AIR / (_R_STAR * lb_safe))
    return np.where(lb == 0.0, iso, grad)


def default_pressure_fn():
    """``pressure_pa_at(alt_m)``: the project's ``atmosphere.us76`` if it is
    importable and returns a pressure (a number/array, or an object/dict with
    ``pressure_pa``), else ``us76_pressure_pa``."""
    try:
        from .atmosphere import us76        # written by another module owner
    except Exception:                       # noqa: BLE001 - absent or broken: use the fallback
        return us76_pressure_pa

    def p(alt_m):
        r = us76(alt_m)
        if hasattr(r, "pressure_pa"):
            return np.asarray(r.pressure_pa, float)
        if isinstance(r, dict) and "pressure_pa" in r:
            return np.asarray(r["pressure_pa"], float)
        return np.asarray(r, float)

    try:
        if not 2.0e4 < float(np.ravel(p(np.array([1000.0])))[0]) < 1.0e5:
            return us76_pressure_pa
    except Exception:                       # noqa: BLE001 - unexpected API: use the fallback
        return us76_pressure_pa
    return p


@dataclass(frozen=True)
class BaroErrors:
    pressure_noise_rel: float = 0.0     # fraction of reading (1 sigma)
    pressure_noise_pa: float = 0.0      # absolute (1 sigma)
    pressure_bias_pa: float = 0.0
    max_alt_m: float = 60000.0

    @classmethod
    def from_config(cls, d: dict | None, prefix: str = "baro") -> "BaroErrors":
        """Fields (optional): pressure_noise_rel_ppm, pressure_noise_pa,
        pressure_bias_pa, max_alt_m; rate_hz allowed and ignored."""
        d = {} if d is None else d
        if not isinstance(d, dict):
            raise ValueError(f"{prefix}: expected a mapping, got {d!r}")
        known = {"pressure_noise_rel_ppm", "pressure_noise_pa", "pressure_bias_pa", "max_alt_m"}
        for k in d:
            if k not in known | {"rate_hz"}:
                raise ValueError(f"{prefix}.{k}: unknown field (known: {sorted(known)})")
        out = {}
        for k, default, nonneg in (("pressure_noise_rel_ppm", 0.0, True), ("pressure_noise_pa", 0.0, True),
                                   ("pressure_bias_pa", 0.0, False), ("max_alt_m", 60000.0, True)):
            v = d.get(k, default)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)):
                raise ValueError(f"{prefix}.{k}: expected a number, got {v!r}")
            if nonneg and v < 0:
                raise ValueError(f"{prefix}.{k}: must be >= 0, got {v}")
            out[k] = float(v)
        return cls(out["pressure_noise_rel_ppm"] * 1e-6, out["pressure_noise_pa"], out["pressure_bias_pa"],
                   out["max_alt_m"])

    def pressure_sigma_pa(self, p_pa):
        return np.sqrt((self.pressure_noise_rel * np.asarray(p_pa, float)) ** 2 + self.pressure_noise_pa**2)


def simulate_baro_pa(alt_m, errors: BaroErrors, rng: np.random.Generator, pressure_pa_at=None):
    """Measured static pressure [Pa] at true geometric altitudes alt_m."""
    alt = np.asarray(alt_m, float)
    if np.any(alt > errors.max_alt_m):
        raise ValueError(f"baro: altitude {alt.max():.0f} m above the model's max_alt_m {errors.max_alt_m:.0f} m")
    f = pressure_pa_at or default_pressure_fn()
    p = np.asarray(f(alt), float)
    return p + errors.pressure_bias_pa + errors.pressure_sigma_pa(p) * rng.standard_normal(p.shape)


def altitude_from_pressure_m(p_pa, pressure_pa_at=None, alt_lo_m: float = -1000.0, alt_hi_m: float = 86000.0,
                             tol_m: float = 1e-6):
    """Invert the (monotone decreasing) pressure profile by bisection on
    log p, vectorised; pressures outside [p(hi), p(lo)] clip to the bounds."""
    f = pressure_pa_at or default_pressure_fn()
    lp = np.log(np.asarray(p_pa, float))
    lo = np.full(lp.shape, alt_lo_m)
    hi = np.full(lp.shape, alt_hi_m)
    n_iter = int(np.ceil(np.log2((alt_hi_m - alt_lo_m) / tol_m))) + 1
    for _ in range(n_iter):
        mid = 0.5 * (lo + hi)
        above = np.log(np.asarray(f(mid), float)) < lp      # p(mid) < p: mid is too high
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return 0.5 * (lo + hi)


def altitude_sigma_m(alt_m, errors: BaroErrors, pressure_pa_at=None, dh_m: float = 1.0):
    """Altitude-equivalent 1-sigma of the pressure noise: sigma_p / |dp/dh|
    (central difference of the profile)."""
    f = pressure_pa_at or default_pressure_fn()
    h = np.asarray(alt_m, float)
    dpdh = (np.asarray(f(h + dh_m), float) - np.asarray(f(h - dh_m), float)) / (2.0 * dh_m)
    return errors.pressure_sigma_pa(f(h)) / np.abs(dpdh)
