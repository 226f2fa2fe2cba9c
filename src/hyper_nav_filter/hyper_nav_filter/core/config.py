"""Typed, validated filter configuration (one object per node, STYLE 7).

Noise and initial uncertainty are given in datasheet units, named with the
unit, and converted to SI here once.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from . import units
from .elastic_lever_arm import TABLE2_FREQ_RADPS, free_free_beam_mode_shapes
from .state_layout import StateLayout

_MODE_SHAPE_IMU = tuple(float(x) for x in free_free_beam_mode_shapes(0.30))
_LOAD_PARTICIPATION = tuple(float(x) for x in free_free_beam_mode_shapes(0.55))


class ConfigError(ValueError):
    """A configuration field is missing or invalid; the message names it."""


# string-valued fields and their allowed values
_STRING_FIELDS = {"mechanization_frame": ("ENU", "LCI"), "lci_gravity": ("j2", "normal")}


@dataclass(frozen=True)
class FilterConfig:
    state_blocks: tuple[str, ...] = ("att", "vel", "pos", "bg", "ba")
    # IMU noise model assumed by the filter
    gyro_arw_deg_per_sqrt_hr: float = 0.01
    accel_vrw_ug_per_sqrt_hz: float = 100.0
    gyro_bias_sigma_deg_per_hr: float = 0.1
    gyro_bias_tau_s: float = 3600.0
    accel_bias_sigma_ug: float = 1000.0
    accel_bias_tau_s: float = 3600.0
    # first-order Markov gyro drift (block "gm", seed 000 eqs. 14-15)
    gyro_markov_sigma_deg_per_hr: float = 0.05
    gyro_markov_tau_s: float = 300.0
    # scale-factor blocks sg / sa: random constants, initial sigma (ppm)
    gyro_scale_factor_sigma_ppm: float = 100.0
    accel_scale_factor_sigma_ppm: float = 100.0
    # elastic lever arm (block "lev" = modal q, q', seed 000 eqs. 9-13, 17-23): the
    # filter's structural model (defaults: uniform free-free beam, IMU at x/l 0.30,
    # centre of pressure at 0.55, Table 2 frequencies; see core.elastic_lever_arm)
    lever_arm_r0_b_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    lever_arm_natural_freq_radps: tuple[float, float, float] = TABLE2_FREQ_RADPS
    lever_arm_damping_ratio: tuple[float, float, float] = (0.02, 0.02, 0.02)
    lever_arm_mode_shape_at_imu: tuple[float, float, float] = _MODE_SHAPE_IMU
    lever_arm_deflection_axis_b: tuple[float, float, float] = (0.0, 0.0, 1.0)
    lever_arm_load_participation: tuple[float, float, float] = _LOAD_PARTICIPATION
    lever_arm_generalized_mass_kg: tuple[float, float, float] = (1000.0, 1000.0, 1000.0)
    lever_arm_vehicle_mass_kg: float = 1000.0
    # initial sigmas of q, q' and the PSD of the modal noise w_q on q'' ((m/s^2)^2/Hz):
    # the nominal modal state is driven by the measured load, so these are small
    # (seed 000, 10 Hz GNSS: 10x larger values let velocity noise leak into the
    # modes and raise the vertical velocity error by 40 %)
    lever_arm_q_sigma_m: float = 1e-3
    lever_arm_qdot_sigma_mps: float = 1e-2
    lever_arm_modal_psd: float = 1e-6
    # receiver clock (block "clk"): initial sigmas and random-walk PSDs
    clock_bias_sigma_m: float = 100.0
    clock_drift_sigma_mps: float = 1.0
    clock_bias_psd_m2ps: float = 0.1
    clock_drift_psd_m2ps3: float = 0.01
    # initial uncertainty (1 sigma)
    init_att_sigma_arcmin: tuple[float, float, float] = (1.0, 1.0, 1.0)
    init_vel_sigma_mps: tuple[float, float, float] = (0.2, 0.2, 0.2)
    init_pos_sigma_m: tuple[float, float, float] = (5.0, 5.0, 10.0)
    # GNSS antenna position in body axes relative to the IMU (FLU, m)
    antenna_lever_arm_b_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # measurement handling
    gate_probability: float = 0.9999
    reprocess_window_s: float = 3.0
    output_delay_s: float = 1.0
    output_rate_hz: float = 50.0
    # mechanization frame of the filter's nominal state (make_filter picks the class):
    # "ENU" local-level geodetic (core.eskf.ErrorStateKF) or "LCI" launch-centred
    # inertial (core.lci.filter.LciErrorStateKF, seed 001); outputs are ENU for both
    mechanization_frame: str = "ENU"
    # LCI only: launch azimuth A0 (deg clockwise from north; x_a axis) and the
    # gravitation model of the LCI mechanization ("j2" seed 001 eqs. 7-10, or
    # "normal" = WGS-84 normal gravity as the simulator's truth uses)
    launch_azimuth_deg: float = 0.0
    lci_gravity: str = "j2"
    layout: StateLayout = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for f in fields(self):
            if f.name in ("layout", "state_blocks") or f.name in _STRING_FIELDS:
                continue
            val = getattr(self, f.name)
            arr = np.asarray(val, dtype=object)
            flat = arr.ravel().tolist() if arr.ndim else [val]
            if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in flat):
                raise ConfigError(f"filter config field '{f.name}' must be numeric, got {val!r}")
            if not all(np.isfinite(float(x)) for x in flat):
                raise ConfigError(f"filter config field '{f.name}' must be finite, got {val!r}")
            if isinstance(f.default, tuple) and len(flat) != len(f.default):
                raise ConfigError(f"filter config field '{f.name}' needs {len(f.default)} values, got {val!r}")
        for name in ("gyro_bias_tau_s", "accel_bias_tau_s", "gyro_markov_tau_s", "output_rate_hz",
                     "reprocess_window_s"):
            if getattr(self, name) <= 0:
                raise ConfigError(f"filter config field '{name}' must be > 0")
        for name in ("lever_arm_natural_freq_radps", "lever_arm_generalized_mass_kg", "lever_arm_vehicle_mass_kg"):
            if np.any(np.asarray(getattr(self, name), float) <= 0):
                raise ConfigError(f"filter config field '{name}' must be > 0")
        if np.any(np.asarray(self.lever_arm_damping_ratio, float) < 0) or \
                np.any(np.asarray(self.lever_arm_damping_ratio, float) >= 1):
            raise ConfigError("filter config field 'lever_arm_damping_ratio' must be in [0, 1) (under-damped modes)")
        if np.linalg.norm(np.asarray(self.lever_arm_deflection_axis_b, float)) == 0:
            raise ConfigError("filter config field 'lever_arm_deflection_axis_b' must be non-zero")
        for name, allowed in _STRING_FIELDS.items():
            if getattr(self, name) not in allowed:
                raise ConfigError(f"filter config field '{name}' must be one of {allowed}, "
                                  f"got {getattr(self, name)!r}")
        if not 0.5 < self.gate_probability < 1.0:
            raise ConfigError("filter config field 'gate_probability' must be in (0.5, 1)")
        if self.output_delay_s < 0 or self.output_delay_s >= self.reprocess_window_s:
            raise ConfigError("filter config field 'output_delay_s' must be in [0, reprocess_window_s)")
        try:
            object.__setattr__(self, "layout", StateLayout(tuple(self.state_blocks)))
        except ValueError as exc:
            raise ConfigError(f"filter config field 'state_blocks': {exc}") from None

    @classmethod
    def from_dict(cls, d: dict) -> "FilterConfig":
        known = {f.name for f in fields(cls) if f.init}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ConfigError(f"unknown filter config field(s) {unknown}")
        conv = {k: tuple(v) if isinstance(v, (list, tuple)) else v for k, v in d.items()}
        return cls(**conv)

    def noise_psd(self, layout: StateLayout | None = None) -> dict:
        """Continuous noise PSDs (SI) for a layout: {"psd": diag of Qc,
        "columns": {noise name: slice}}, white gyro/accel noise first, then
        the driving noise of each random block in layout order."""
        layout = layout or self.layout
        arw = units.deg_per_sqrt_hr(self.gyro_arw_deg_per_sqrt_hr)
        vrw = units.ug_per_sqrt_hz(self.accel_vrw_ug_per_sqrt_hz)
        driving = {
            "bg": np.full(3, 2 * units.deg_per_hr(self.gyro_bias_sigma_deg_per_hr) ** 2 / self.gyro_bias_tau_s),
            "ba": np.full(3, 2 * units.ug(self.accel_bias_sigma_ug) ** 2 / self.accel_bias_tau_s),
            "gm": np.full(3, 2 * units.deg_per_hr(self.gyro_markov_sigma_deg_per_hr) ** 2 / self.gyro_markov_tau_s),
            "clk": np.array([self.clock_bias_psd_m2ps, self.clock_drift_psd_m2ps3]),
            "lev": np.full(3, self.lever_arm_modal_psd),
        }
        parts = [("w_g", np.full(3, arw**2)), ("w_a", np.full(3, vrw**2))]
        parts += [(name, driving[name]) for name in layout.names if name in driving]
        columns, start = {}, 0
        for name, psd in parts:
            columns[name] = slice(start, start + len(psd))
            start += len(psd)
        return {"psd": np.concatenate([p for _, p in parts]), "columns": columns}

    def initial_covariance(self) -> np.ndarray:
        lay = self.layout
        P = np.zeros((lay.dim, lay.dim))
        diag = {"att": units.arcmin(self.init_att_sigma_arcmin),
                "vel": np.asarray(self.init_vel_sigma_mps, float),
                "pos": np.asarray(self.init_pos_sigma_m, float),
                "bg": np.full(3, units.deg_per_hr(self.gyro_bias_sigma_deg_per_hr)),
                "ba": np.full(3, units.ug(self.accel_bias_sigma_ug)),
                "gm": np.full(3, units.deg_per_hr(self.gyro_markov_sigma_deg_per_hr)),
                "clk": np.array([self.clock_bias_sigma_m, self.clock_drift_sigma_mps]),
                "sg": np.full(3, self.gyro_scale_factor_sigma_ppm * 1e-6),
                "sa": np.full(3, self.accel_scale_factor_sigma_ppm * 1e-6),
                "lev": np.concatenate([np.full(3, self.lever_arm_q_sigma_m), np.full(3, self.lever_arm_qdot_sigma_mps)])}
        for name in lay.names:
            s = lay.sl(name)
            P[s, s] = np.diag(diag[name] ** 2)
        return P
