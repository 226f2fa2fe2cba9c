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

from hyper_nav_filter.core.atmosphere import pressure_Pa as us76_pressure_pa   # US Standard Atmosphere 1976

from hyper_nav_filter.core.params import number, unknown_field

CONFIG_FIELDS = frozenset({"pressure_noise_rel_ppm", "pressure_noise_pa", "pressure_bias_pa", "max_alt_m"})


def default_pressure_fn():
    """``pressure_pa_at(alt_m)``: US76 static pressure (``atmosphere.py``)."""
    return us76_pressure_pa


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
        for k in d:
            if k not in CONFIG_FIELDS | {"rate_hz"}:
                raise ValueError(unknown_field(f"{prefix}.", k, CONFIG_FIELDS | {"rate_hz"}))
        out = {}
        for k, default, nonneg in (("pressure_noise_rel_ppm", 0.0, True), ("pressure_noise_pa", 0.0, True),
                                   ("pressure_bias_pa", 0.0, False), ("max_alt_m", 60000.0, True)):
            out[k] = number(f"{prefix}.{k}", d.get(k, default), 0.0 if nonneg else None, error=ValueError)
        return cls(out["pressure_noise_rel_ppm"] * 1e-6, out["pressure_noise_pa"], out["pressure_bias_pa"],
                   out["max_alt_m"])

    def pressure_variance_pa2(self, p_pa):
        """Variance (Pa^2) of a pressure reading p_pa: relative and absolute white noise."""
        return (self.pressure_noise_rel * np.asarray(p_pa, float)) ** 2 + self.pressure_noise_pa**2

    def pressure_sigma_pa(self, p_pa):
        return np.sqrt(self.pressure_variance_pa2(p_pa))


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
