"""The scenario's ``world:`` block: how far the simulated truth is from the
models the filter and the receiver use (STYLE pattern 16).

    world:
      model: realistic            # realistic (default) | perfect (unit tests)
      ionosphere:                 # realistic only: core.gnss.world.TrueIonosphere
        klobuchar_error_rms: 0.5  #   truth / broadcast Klobuchar - 1, RMS (Klobuchar 1987: ~50 %)
        correlation_length_km: 1000.0
        correlation_time_s: 1800.0
        shell_height_km: 350.0
      troposphere:                # realistic only: core.gnss.world.TrueTroposphere
        surface_pressure_hpa: 1013.25
        surface_pressure_sigma_hpa: 8.0
        surface_temperature_k: 288.15
        surface_temperature_sigma_k: 8.0
        relative_humidity: 0.6
        relative_humidity_sigma: 0.2
        correlation_length_km: 500.0
        correlation_time_s: 10800.0
        water_vapour_scale_height_m: 2000.0
      orbits:                     # realistic only: core.gnss.world.OrbitClockErrors
        scale: 1.0                #   x the measured broadcast orbit/clock error sizes
        include_phase_centre_offset: false
      lever_arm:
        integrator: rk4           # rk4 (realistic default) | zoh (the filter's discretisation; perfect default)
        step_s: 0.002             # rk4 step [s]

``perfect``: the truth is the receiver's broadcast models and records, and
the lever-arm modes are integrated with the filter's own discretisation;
the other sub-blocks are then ignored (except an explicit
``lever_arm.integrator``). Every field is optional; errors name the field.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.core.params import BOOL, checked, number

WORLD_MODELS = ("realistic", "perfect")
# field -> (default, lower bound, upper bound) ; bounds inclusive, None = open
_IONO = {"klobuchar_error_rms": (0.5, 0.0, 5.0), "correlation_length_km": (1000.0, 1.0, 2e4),
         "correlation_time_s": (1800.0, 1.0, 1e6), "shell_height_km": (350.0, 100.0, 2000.0)}
_TROPO = {"surface_pressure_hpa": (1013.25, 500.0, 1100.0), "surface_pressure_sigma_hpa": (8.0, 0.0, 100.0),
          "surface_temperature_k": (288.15, 180.0, 340.0), "surface_temperature_sigma_k": (8.0, 0.0, 50.0),
          "relative_humidity": (0.6, 0.0, 1.0), "relative_humidity_sigma": (0.2, 0.0, 1.0),
          "correlation_length_km": (500.0, 1.0, 2e4), "correlation_time_s": (10800.0, 1.0, 1e7),
          "water_vapour_scale_height_m": (2000.0, 100.0, 20000.0)}
_ORBITS = {"scale": (1.0, 0.0, 100.0)}
_ORBIT_BOOLS = {"include_phase_centre_offset": False}
LEVER_ARM_INTEGRATORS = ("rk4", "zoh")


def _number(name, v, lo, hi):
    """A finite number in [lo, hi]; out of range is worded '<v> outside [lo, hi]' (asserted by test_world;
    the type check is params.number's)."""
    x = number(name, v, error=ValueError)
    if (lo is not None and x < lo) or (hi is not None and x > hi):
        raise ValueError(f"{name}: {v} outside [{lo}, {hi}]")
    return x


def _block(prefix, d, numbers, bools=None):
    bools = bools or {}
    if d is None:
        d = {}
    if not isinstance(d, dict):
        raise ValueError(f"{prefix}: expected a mapping, got {d!r}")
    unknown = sorted(set(d) - set(numbers) - set(bools))
    if unknown:
        raise ValueError(f"{prefix}.{unknown[0]}: unknown field (known: {sorted(set(numbers) | set(bools))})")
    out = {k: _number(f"{prefix}.{k}", d.get(k, dv), lo, hi) for k, (dv, lo, hi) in numbers.items()}
    for k, dv in bools.items():
        out[k] = checked(f"{prefix}.{k}", d.get(k, dv), BOOL, error=ValueError)
    return out


@dataclass(frozen=True)
class WorldConfig:
    model: str = "realistic"
    ionosphere: dict = field(default_factory=lambda: {k: v[0] for k, v in _IONO.items()})
    troposphere: dict = field(default_factory=lambda: {k: v[0] for k, v in _TROPO.items()})
    orbits: dict = field(default_factory=lambda: {**{k: v[0] for k, v in _ORBITS.items()}, **_ORBIT_BOOLS})
    lever_arm_integrator: str = "rk4"
    lever_arm_step_s: float = 0.002

    @property
    def realistic(self) -> bool:
        return self.model == "realistic"

    @classmethod
    def from_config(cls, d: dict | None, prefix: str = "world") -> "WorldConfig":
        """From the scenario's ``world:`` block (None: realistic with defaults);
        ValueError names a bad field."""
        d = {} if d is None else d
        if not isinstance(d, dict):
            raise ValueError(f"{prefix}: expected a mapping, got {d!r}")
        unknown = sorted(set(d) - {"model", "ionosphere", "troposphere", "orbits", "lever_arm"})
        if unknown:
            raise ValueError(f"{prefix}.{unknown[0]}: unknown field (known: model, ionosphere, troposphere, "
                             f"orbits, lever_arm)")
        model = d.get("model", "realistic")
        if model not in WORLD_MODELS:
            raise ValueError(f"{prefix}.model: expected one of {WORLD_MODELS}, got {model!r}")
        la = d.get("lever_arm") or {}
        if not isinstance(la, dict):
            raise ValueError(f"{prefix}.lever_arm: expected a mapping, got {la!r}")
        bad = sorted(set(la) - {"integrator", "step_s"})
        if bad:
            raise ValueError(f"{prefix}.lever_arm.{bad[0]}: unknown field (known: integrator, step_s)")
        integ = la.get("integrator", "rk4" if model == "realistic" else "zoh")
        if integ not in LEVER_ARM_INTEGRATORS:
            raise ValueError(f"{prefix}.lever_arm.integrator: expected one of {LEVER_ARM_INTEGRATORS}, got {integ!r}")
        step = _number(f"{prefix}.lever_arm.step_s", la.get("step_s", 0.002), 1e-5, 0.1)
        if step <= 0.0:
            raise ValueError(f"{prefix}.lever_arm.step_s: must be > 0")
        return cls(model, _block(f"{prefix}.ionosphere", d.get("ionosphere"), _IONO),
                   _block(f"{prefix}.troposphere", d.get("troposphere"), _TROPO),
                   _block(f"{prefix}.orbits", d.get("orbits"), _ORBITS, _ORBIT_BOOLS), integ, step)
