"""Typed, validated configuration of the target tracker (the scenario's
``tracker:`` block; one object for the node and the offline commands).

Units are in the field names (datasheet units at the edge); ``TrackerConfig``
converts them once into the scaled-unit matrices the filters use
(``Q``, ``R``, ``P0``, ``u_nominal``). Errors name the field
(``tracker.q_v_mps: expected a number, got 'x'``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from hyper_nav_filter.core.params import FLOAT, ConfigError, ParamSpec, kind_of, number, unknown_field
from hyper_nav_filter.core.target_tracking import glide_model as gm

FILTER_TYPES = ("EKF", "AEKF", "LEKF", "IMM")


class TrackerConfigError(ValueError):
    """A tracker configuration field is missing or invalid; the message names it."""


@dataclass(frozen=True)
class TrackerConfig:
    filter_type: str = "LEKF"
    # nominal input u_k of every filter (eq. 22): a quasi-equilibrium glide
    # without lateral maneuver at c_l = nominal_c_l (lambda1 = c_l, lambda2 = c_l + 1/c_l)
    nominal_c_l: float = 0.3
    nominal_t_chi_s: float = 100.0
    # radar noise assumed by the filter (R), seed 002 section 3.2
    radar_sigma_alt_m: float = 2000.0
    radar_sigma_lon_rad: float = 0.01
    radar_sigma_lat_rad: float = 0.01
    # process noise (white, per sqrt(s)) of eq. 22's omega
    q_h_m: float = 1.0
    q_lonlat_rad: float = 1.0e-7
    q_v_mps: float = 3.0
    q_gamma_rad: float = 3.0e-4
    q_psi_rad: float = 1.0e-3
    q_chi: float = 0.05
    # initial covariance (track hand-over) and the initial estimate's error w.r.t. the truth
    init_sigma_h_m: float = 1000.0
    init_sigma_lonlat_rad: float = 1.0e-3
    init_sigma_v_mps: float = 100.0
    init_sigma_gamma_deg: float = 0.5
    init_sigma_psi_deg: float = 2.0
    init_sigma_chi: float = 0.5
    init_error_h_m: float = 0.0
    init_error_lon_rad: float = 0.0
    init_error_lat_rad: float = 0.0
    init_error_v_mps: float = 0.0
    init_error_gamma_deg: float = 0.0
    init_error_psi_deg: float = 0.0
    # adaptive EKF: forgetting factor of the innovation-based process-noise estimate
    aekf_forgetting: float = 0.9
    # IMM: one mode per lateral c_l sin(sigma) hypothesis, process noise scaled per mode
    imm_lateral_c_l: tuple[float, ...] = (0.0, 1.0, 2.5)
    imm_q_scale: tuple[float, ...] = (1.0, 3.0, 10.0)
    imm_p_stay: float = 0.95
    # trained L-EKF parameter set (name in core/tracking/trained/)
    lekf_parameters: str = "lekf_seed002"
    model: gm.GlideModel = field(default_factory=gm.GlideModel)

    # ---- derived (scaled units) ---------------------------------------------------
    @property
    def u_nominal(self) -> np.ndarray:
        return gm.glide_inputs(self.nominal_c_l, self.nominal_t_chi_s)

    @property
    def R(self) -> np.ndarray:
        s = np.array([self.radar_sigma_alt_m, self.radar_sigma_lon_rad, self.radar_sigma_lat_rad])
        return np.diag((s / gm.STATE_SCALE[: gm.N_Z]) ** 2)

    @property
    def Q(self) -> np.ndarray:
        q = np.array([self.q_h_m, self.q_lonlat_rad, self.q_lonlat_rad, self.q_v_mps, self.q_gamma_rad,
                      self.q_psi_rad, self.q_chi])
        return np.diag((q / gm.STATE_SCALE) ** 2)

    @property
    def P0(self) -> np.ndarray:
        s = np.array([self.init_sigma_h_m, self.init_sigma_lonlat_rad, self.init_sigma_lonlat_rad,
                      self.init_sigma_v_mps, np.deg2rad(self.init_sigma_gamma_deg),
                      np.deg2rad(self.init_sigma_psi_deg), self.init_sigma_chi])
        return np.diag((s / gm.STATE_SCALE) ** 2)

    @property
    def init_error(self) -> np.ndarray:
        """Error of the initial estimate (physical units, chi 0)."""
        return np.array([self.init_error_h_m, self.init_error_lon_rad, self.init_error_lat_rad,
                         self.init_error_v_mps, np.deg2rad(self.init_error_gamma_deg),
                         np.deg2rad(self.init_error_psi_deg), 0.0])

    def initial_estimate(self, truth_x0_phys) -> np.ndarray:
        """Initial estimate (physical units): the true [h, theta, phi, v, gamma,
        psi] at the first epoch plus ``init_error``, chi = 0 (no lateral maneuver)."""
        x = np.zeros(gm.N_X)
        x[:6] = np.asarray(truth_x0_phys, float)[:6]
        return x + self.init_error

    # ---- construction ------------------------------------------------------------
    @classmethod
    def from_dict(cls, d: dict | None, prefix: str = "tracker.") -> "TrackerConfig":
        d = dict(d or {})
        kw = {}
        names = {f.name: f for f in fields(cls)}
        for key, value in d.items():
            if key not in names:
                raise TrackerConfigError(unknown_field(prefix, key, names))
            if key == "model":
                kw["model"] = _model_from_dict(value, f"{prefix}model.")
                continue
            default = getattr(cls, key) if key != "model" else None
            kw[key] = _check(f"{prefix}{key}", default, value)
        cfg = cls(**kw)
        cfg._validate(prefix)
        return cfg

    def _validate(self, prefix: str) -> None:
        if self.filter_type not in FILTER_TYPES:
            raise TrackerConfigError(f"{prefix}filter_type: expected one of {FILTER_TYPES}, got {self.filter_type!r}")
        positive = ["nominal_c_l", "nominal_t_chi_s", "radar_sigma_alt_m", "radar_sigma_lon_rad",
                    "radar_sigma_lat_rad", "q_h_m", "q_lonlat_rad", "q_v_mps", "q_gamma_rad", "q_psi_rad", "q_chi",
                    "init_sigma_h_m", "init_sigma_lonlat_rad", "init_sigma_v_mps", "init_sigma_gamma_deg",
                    "init_sigma_psi_deg", "init_sigma_chi"]
        for name in positive:
            number(f"{prefix}{name}", getattr(self, name), 0.0, lo_open=True, error=TrackerConfigError)
        for name in ("aekf_forgetting", "imm_p_stay"):
            number(f"{prefix}{name}", getattr(self, name), 0.0, 1.0, lo_open=True, hi_open=True, interval=True,
                   error=TrackerConfigError)
        if len(self.imm_lateral_c_l) != len(self.imm_q_scale) or len(self.imm_lateral_c_l) < 2:
            raise TrackerConfigError(f"{prefix}imm_q_scale: needs one entry per imm_lateral_c_l mode (>= 2 modes)")
        if any(c < 0 for c in self.imm_lateral_c_l) or any(q <= 0 for q in self.imm_q_scale):
            raise TrackerConfigError(f"{prefix}imm_lateral_c_l: entries must be >= 0 (and imm_q_scale > 0)")

    def as_parameters(self, prefix: str = "tracker.") -> dict:
        """Flat {dotted name: value} dict (ROS parameters of the tracker node)."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "model":
                for mf in fields(gm.GlideModel):
                    out[f"{prefix}model.{mf.name}"] = getattr(v, mf.name)
            else:
                out[prefix + f.name] = list(v) if isinstance(v, tuple) else v
        return out

    @classmethod
    def from_parameters(cls, params: dict, prefix: str = "tracker.") -> "TrackerConfig":
        """Inverse of ``as_parameters``."""
        d, model = {}, {}
        for k, v in params.items():
            if not k.startswith(prefix):
                continue
            name = k[len(prefix):]
            if name.startswith("model."):
                model[name[len("model."):]] = v
            else:
                d[name] = v
        if model:
            d["model"] = model
        return cls.from_dict(d, prefix)


def _model_from_dict(d, prefix: str) -> gm.GlideModel:
    if not isinstance(d, dict):
        raise TrackerConfigError(f"{prefix.rstrip('.')}: expected a mapping, got {d!r}")
    names = {f.name for f in fields(gm.GlideModel)}
    kw = {}
    for key, value in d.items():
        if key not in names:
            raise TrackerConfigError(unknown_field(prefix, key, names))
        kw[key] = _check(f"{prefix}{key}", getattr(gm.GlideModel, key), value, lo=0, lo_open=True)
    return gm.GlideModel(**kw)


def _check(name: str, default, value, **rng):
    """``value`` checked by a ParamSpec of the field's type (the type of its
    default: str, tuple of floats, int, float) and range ``rng``."""
    kind = kind_of(default) or FLOAT
    try:
        return ParamSpec(name, kind, default, "", **rng).check(value)
    except ConfigError as exc:
        raise TrackerConfigError(str(exc)) from None
