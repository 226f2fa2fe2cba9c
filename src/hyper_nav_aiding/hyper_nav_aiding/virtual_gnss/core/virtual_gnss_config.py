"""Parameters of the virtual GNSS aiding (scenario block ``virtual_gnss:``),
one typed object validated at start; errors name the field.

    virtual_gnss:
      enabled: true
      topic: gnss/virtual             # output (GnssMeasurements, is_virtual set)
      position_source: fused          # fused (nav/state + IMU) | alpha_beta (receiver fixes)
      elevation_mask_deg: 7.5         # seed 004 Table 3
      pseudorange_sigma_m: elevation  # sigma written into the virtual epochs: 'elevation' (eq. 11) or metres
      pseudorange_rate_sigma_mps: 0.05
      add_noise: true                 # draw eq. 11's D_noise into the ranges (the paper); false: noise-free
      consistent_covariance: false    # add the source's position/clock 1-sigma to the written sigmas
      max_extrapolation_s: 600.0      # alpha_beta: nothing beyond this after the last fix
      max_state_age_s: 5.0            # fused: nav/state this old and no IMU to carry it -> nothing
      fused_state_delay_s: 1.1        # fused: use nav/state stamped <= t - this (filter output delay + 0.1 s)
      input_hold_s: 0.3               # an epoch is processed once the IMU is this far past it (inputs up to
                                      # this late are in: the output does not depend on their arrival order)
      alpha_beta_accel_sigma_mps2: 5.0
      alpha_beta_fix_sigma_m: 5.0
      clock_drift_rate_sigma_mps2: 0.2  # receiver clock tracker (TCXO: sqrt(2 pi^2 h-2) c = 0.19 m/s/sqrt(s))
      clock_sigma_m: 1.5              # its per-epoch measurement noise (the range error budget)
"""
from __future__ import annotations

from dataclasses import dataclass, fields

from hyper_nav_filter.core.params import BOOL, checked, number

POSITION_SOURCES = ("fused", "alpha_beta")


class VirtualGnssConfigError(ValueError):
    """A bad ``virtual_gnss`` field; the message names it."""


@dataclass(frozen=True)
class VirtualGnssConfig:
    enabled: bool = True
    topic: str = "gnss/virtual"
    position_source: str = "fused"
    elevation_mask_deg: float = 7.5
    pseudorange_sigma_m: object = "elevation"
    pseudorange_rate_sigma_mps: float = 0.05
    add_noise: bool = True
    consistent_covariance: bool = False
    max_extrapolation_s: float = 600.0
    max_state_age_s: float = 5.0
    fused_state_delay_s: float = 1.1
    input_hold_s: float = 0.3
    alpha_beta_accel_sigma_mps2: float = 5.0
    alpha_beta_fix_sigma_m: float = 5.0
    clock_drift_rate_sigma_mps2: float = 0.2
    clock_sigma_m: float = 1.5

    @classmethod
    def from_config(cls, d: dict | None, prefix: str = "virtual_gnss") -> "VirtualGnssConfig":
        d = {} if d is None else d
        if not isinstance(d, dict):
            raise VirtualGnssConfigError(f"{prefix}: expected a mapping, got {d!r}")
        known = {f.name for f in fields(cls)}
        for k in d:
            if k not in known:
                raise VirtualGnssConfigError(f"{prefix}.{k}: unknown field (known: {sorted(known)})")
        g = {**{f.name: f.default for f in fields(cls)}, **d}
        for k in ("enabled", "add_noise", "consistent_covariance"):
            checked(f"{prefix}.{k}", g[k], BOOL, error=VirtualGnssConfigError)
        if not isinstance(g["topic"], str) or not g["topic"]:
            raise VirtualGnssConfigError(f"{prefix}.topic: expected a topic name, got {g['topic']!r}")
        if g["position_source"] not in POSITION_SOURCES:
            raise VirtualGnssConfigError(f"{prefix}.position_source: expected one of {POSITION_SOURCES}, "
                                         f"got {g['position_source']!r}")
        if g["pseudorange_sigma_m"] != "elevation":
            g["pseudorange_sigma_m"] = _num(prefix, "pseudorange_sigma_m", g["pseudorange_sigma_m"], positive=True)
        g["elevation_mask_deg"] = _num(prefix, "elevation_mask_deg", g["elevation_mask_deg"], lo=-10.0, hi=60.0)
        g["fused_state_delay_s"] = _num(prefix, "fused_state_delay_s", g["fused_state_delay_s"], lo=0.0, hi=60.0)
        g["input_hold_s"] = _num(prefix, "input_hold_s", g["input_hold_s"], lo=0.0, hi=10.0)
        for k in ("pseudorange_rate_sigma_mps", "max_extrapolation_s", "max_state_age_s",
                  "alpha_beta_accel_sigma_mps2", "alpha_beta_fix_sigma_m", "clock_drift_rate_sigma_mps2",
                  "clock_sigma_m"):
            g[k] = _num(prefix, k, g[k], positive=True)
        return cls(**g)


def _num(prefix, name, v, positive=False, lo=None, hi=None) -> float:
    return number(f"{prefix}.{name}", v, 0.0 if positive else lo, hi, lo_open=positive, error=VirtualGnssConfigError)
