"""Typed, validated filter configuration (one object per node, STYLE 7).

``FilterConfig`` is assembled from parameter declarations (``core.params``):
the engine's own (``CORE_PARAMS`` below) and each state block's
(``core.blocks``, ``Block.PARAMS``: a block brings its parameters with it).
Noise and initial uncertainty are given in datasheet units, named with the
unit, and converted to SI by the blocks. The same declarations validate
scenario files and declare the fusion node's ROS parameters with
descriptors. ``FilterConfig`` is frozen; a time-stamped model update
(``core.model_update``) makes a new one with ``with_updates``.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .blocks import REGISTRY
from .blocks.range_bias import RANGE_BIAS_BLOCKS
from .params import FLOAT, FLOATS, INT, STR, STRS, ConfigError, ParamSpec, check_all, nonneg, positive
from .state_layout import StateLayout

__all__ = ["FilterConfig", "ConfigError", "CORE_PARAMS", "ALL_PARAMS", "PARAM_BY_NAME"]

CORE_PARAMS = (
    ParamSpec("state_blocks", STRS, ("att", "vel", "pos", "bg", "ba"),
              "error-state blocks in order, att vel pos first (core.blocks)", choices=tuple(REGISTRY)),
    # issue 37 item 5: the corrected pseudoranges keep errors correlated over minutes (residual ionosphere and
    # troposphere, broadcast orbit/clock: 2.2 m RMS, tau ~1500 s on seed 004's realistic world); weighted as
    # white noise they are averaged away as if independent (position NEES 486.5 there, 3 seeds, 500 s; 2.36 as states)
    ParamSpec("range_errors", STR, "states", "tightly coupled (a layout with 'clk', ENU frame; the LCI frame, "
              "flown loosely coupled only, is left as listed): states = per-satellite "
              "range-bias states (block rb32, range_bias_sigma_m / range_bias_tau_s) are added to a layout that has "
              "no rb/rb32 block; white = the pseudorange sigmas alone (optimistic where the errors are correlated)",
              choices=("states", "white")),
    # mechanization frame of the nominal state; outputs are ENU/geodetic for both
    ParamSpec("mechanization_frame", STR, "ENU", "ENU (local-level, geodetic) or LCI (launch-centred inertial, "
              "seed 001)", choices=("ENU", "LCI")),
    ParamSpec("launch_azimuth_deg", FLOAT, 0.0, "LCI only: launch azimuth A0 (deg clockwise from north)",
              lo=-360.0, hi=360.0),
    ParamSpec("lci_gravity", STR, "j2", "LCI only: gravitation model (j2: seed 001 eqs. 7-10; normal: WGS-84)",
              choices=("j2", "normal")),
    ParamSpec("antenna_lever_arm_b_m", FLOATS, (0.0, 0.0, 0.0), "GNSS antenna position from the IMU, body FLU (m)",
              length=3),
    # 1.0 switches the gate off: chi2.ppf(1, dof) = inf, so every finite innovation is accepted
    # (a NaN one is still refused); KF-GINS, for one, does not gate
    ParamSpec("gate_probability", FLOAT, 0.9999, "chi-square gate probability of the innovation test; "
              "1 = no gate (every finite innovation accepted)", lo=0.5, hi=1.0, lo_open=True),
    # the gate's lock-out monitor (core.lockout; PX4 EKF2's innovation-consistency timeout)
    positive("lockout_timeout_s", FLOAT, 1.0, "a source refused by the gate for this long (s) without an accepted "
             "update, while it keeps arriving, is locked out and taken back (core.lockout)"),
    ParamSpec("lockout_min_rejections", INT, 5, "... and refused at least this many times in a row", lo=1),
    ParamSpec("lockout_recovery", STR, "inflate", "inflate: scale the covariance of the observed att/vel/pos "
              "states until the refused innovation fits; off: no recovery (a gated source may stay locked out)",
              choices=("inflate", "off")),
    positive("lockout_target_nis_per_dof", FLOAT, 1.0, "lock-out recovery: the inflation brings the refused "
             "innovation's NIS per dof to this value (1: its expected size; smaller: closer to a reset)"),
    positive("reprocess_window_s", FLOAT, 3.0, "how far back (s) a late measurement can still be applied exactly"),
    nonneg("output_delay_s", FLOAT, 1.0, "solutions are released this far (s) behind the newest IMU epoch"),
    positive("output_rate_hz", FLOAT, 50.0, "solution output rate (Hz)"),
    nonneg("fusion_delay_s", FLOAT, 0.0, "fusion time horizon (s): IMU samples are fused this far behind the newest "
           "one, so measurements delivered within it are never late (the largest declared source delay, "
           "filter.sources.<id>.delay_s, raises it); the current-time state is predicted over it"),
    ParamSpec("output_predictor", STR, "complementary", "how the current-time state follows a correction of the "
              "fusion horizon (core.output_predictor): repropagate (re-run the strapdown from the corrected state) "
              "or complementary (PX4 EKF2: fed back with time constants output_tau_*_s)",
              choices=("repropagate", "complementary")),
    positive("output_tau_att_s", FLOAT, 0.25, "complementary output predictor: attitude time constant (s)"),
    positive("output_tau_vel_s", FLOAT, 0.25, "complementary output predictor: velocity time constant (s) "
             "(PX4 EKF2_TAU_VEL)"),
    positive("output_tau_pos_s", FLOAT, 0.25, "complementary output predictor: position time constant (s) "
             "(PX4 EKF2_TAU_POS)"),
    positive("imu_gap_s", FLOAT, 0.25, "an IMU interval longer than this (s) is a gap: bridged, counted, reported"),
    nonneg("gap_accel_sigma_mps2", FLOAT, 2.0,
           "1-sigma deviation of the specific force from its interpolation across an IMU gap (m/s^2), inflates P"),
    nonneg("gap_rate_sigma_deg_per_s", FLOAT, 0.05,
           "1-sigma deviation of the angular rate from its interpolation across an IMU gap (deg/s), inflates P"),
)

# the range-bias block range_errors 'states' adds: 32 slots (GPS + Galileo + BeiDou receivers see 20-30 satellites)
RANGE_BIAS_DEFAULT_BLOCK = "rb32"

ALL_PARAMS: tuple[ParamSpec, ...] = CORE_PARAMS + tuple(p for b in REGISTRY.values() for p in b.PARAMS)
PARAM_BY_NAME = {p.name: p for p in ALL_PARAMS}
if len(PARAM_BY_NAME) != len(ALL_PARAMS):
    raise RuntimeError("a filter parameter is declared twice (core.config / core.blocks)")


def _post_init(self):
    for p in ALL_PARAMS:
        object.__setattr__(self, p.name, p.check(getattr(self, p.name), "filter config field "))
    if self.output_delay_s >= self.reprocess_window_s:
        raise ConfigError("filter config field 'output_delay_s': must be < reprocess_window_s "
                          f"({self.output_delay_s:g} >= {self.reprocess_window_s:g})")
    if self.fusion_delay_s > self.output_delay_s:
        raise ConfigError("filter config field 'fusion_delay_s': must be <= output_delay_s "
                          f"({self.fusion_delay_s:g} > {self.output_delay_s:g}): the record is released behind "
                          "the fusion horizon")
    blocks = tuple(self.state_blocks)
    if (self.range_errors == "states" and "clk" in blocks and not set(blocks) & set(RANGE_BIAS_BLOCKS)
            and self.mechanization_frame == "ENU"):
        object.__setattr__(self, "state_blocks", blocks + (RANGE_BIAS_DEFAULT_BLOCK,))
    if np.linalg.norm(np.asarray(self.lever_arm_deflection_axis_b, float)) == 0:
        raise ConfigError("filter config field 'lever_arm_deflection_axis_b': must be non-zero")
    try:
        object.__setattr__(self, "layout", StateLayout(tuple(self.state_blocks)))
    except ValueError as exc:
        raise ConfigError(f"filter config field 'state_blocks': {exc}") from None
    # hashed once: configurations key the caches of derived models (system model, modal model)
    object.__setattr__(self, "_hash", hash(tuple(getattr(self, p.name) for p in ALL_PARAMS)))


def _hash(self) -> int:
    return self._hash


@classmethod
def _from_dict(cls, d: dict) -> "FilterConfig":
    """From a scenario's ``filter.config`` mapping: unknown fields are refused
    (with a suggestion), integers are accepted where floats are declared."""
    return cls(**check_all(ALL_PARAMS, dict(d or {}), "filter config field "))


def _with_updates(self, values: dict) -> "FilterConfig":
    """A new configuration with some *updatable* fields changed (time-stamped
    model updates); ConfigError for a field that is not updatable."""
    for name in values:
        spec = PARAM_BY_NAME.get(name)
        if spec is None or not spec.updatable:
            updatable = [p.name for p in ALL_PARAMS if p.updatable]
            raise ConfigError(f"{name}: not an updatable filter field (updatable: {updatable})")
    return dataclasses.replace(self, **values)


def _initial_covariance(self) -> np.ndarray:
    """Diagonal prior from each block's prior sigma, in layout order."""
    return np.diag(np.concatenate([b.prior_sigma(self) for b in self.layout.blocks]) ** 2)


def _as_dict(self) -> dict:
    """{field: value} of every declared parameter (ROS-ready: tuples as lists)."""
    return {p.name: list(getattr(self, p.name)) if isinstance(getattr(self, p.name), tuple)
            else getattr(self, p.name) for p in ALL_PARAMS}


FilterConfig = dataclasses.make_dataclass(
    "FilterConfig",
    [(p.name, object, dataclasses.field(default=p.default)) for p in ALL_PARAMS]
    + [("layout", StateLayout, dataclasses.field(init=False, repr=False, compare=False)),
       ("_hash", int, dataclasses.field(init=False, repr=False, compare=False))],
    namespace={"__post_init__": _post_init, "__hash__": _hash, "from_dict": _from_dict, "with_updates": _with_updates,
               "initial_covariance": _initial_covariance, "as_dict": _as_dict,
               "__doc__": "Filter configuration; fields and meanings: ``config.ALL_PARAMS`` (core.params.ParamSpec)."},
    frozen=True)
FilterConfig.__module__ = __name__          # picklable (worker processes, dask)
