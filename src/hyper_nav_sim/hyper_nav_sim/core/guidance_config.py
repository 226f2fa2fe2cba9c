"""The scenario's ``guidance:`` block (issue 36): the target, the guidance
law's gains, and the command loop's timing that the truth node and the
guidance node share. Validated like the other model blocks (unknown fields
refused with a did-you-mean, errors name the field).

Fields (units in the names; angles in degrees)::

    target: {lat_deg, lon_deg, alt_m 0}   the point to reach (required)
    period_s 0.1            guidance period = the flight's command step: a command is computed from
                            every navigation state stamped on this grid
    apply_delay_s 0.1       a command from the navigation stamp t_nav applies at step
                            ceil((t_nav + apply_delay_s) / period_s) (declared, never the arrival time);
                            must cover the navigation stream's own latency in flight time
                            (>= 1.0 s + one period on the 1 s delayed solution)
    t_start_s 0             first navigation stamp guidance acts on (the program flies before)
    command_topic "guidance/command"   where the truth node takes commands (remappable)
    nav_topic "nav/odom"    the navigation stream the guidance node flies on
    nav_type "odometry"     its type: "odometry" (nav_msgs/Odometry in the fusion node's map frame)
                            or "navstate" (hyper_nav_msgs/NavState: nav/state, truth/state)
    command_timeout_s 30    wall time the truth node waits for a due command before flying on the
                            last one (counted as missed on /diagnostics)
    navigation_constant 3.5 N of proportional navigation (both planes)
    terminal_range_m 60000  range-to-go at which the terminal (3-D PN) phase starts
    k_h_per_s 0.02, k_gamma_per_s 0.1, gamma_limit_deg 10   midcourse loop onto the glide slope
    n_vert_min_g 0.05       the least vertical load (push-overs by unloading, not inverted)
    bank_limit_deg 85       the guidance's bank limit; the truth refuses |sigma_cmd| above it
    miss_tolerance_m 100    the miss distance the law is held to on truth (tests)
"""
from __future__ import annotations

import math

from .boost_glide_config import _num  # one number validator for the flight and guidance blocks
from dataclasses import dataclass

from hyper_nav_filter.core.params import check_keys

_MISSING = object()
NAV_TYPES = ("odometry", "navstate")
FIELDS = {"target", "period_s", "apply_delay_s", "t_start_s", "command_topic", "command_timeout_s",
          "nav_topic", "nav_type",
          "navigation_constant", "terminal_range_m", "k_h_per_s", "k_gamma_per_s",
          "gamma_limit_deg", "n_vert_min_g", "bank_limit_deg", "miss_tolerance_m"}
TARGET_FIELDS = {"lat_deg", "lon_deg", "alt_m"}


@dataclass(frozen=True)
class GuidanceConfig:
    target_lat_rad: float
    target_lon_rad: float
    target_alt_m: float = 0.0
    period_s: float = 0.1
    apply_delay_s: float = 0.1
    t_start_s: float = 0.0
    command_topic: str = "guidance/command"
    command_timeout_s: float = 30.0
    nav_topic: str = "nav/odom"
    nav_type: str = "odometry"
    navigation_constant: float = 3.5
    terminal_range_m: float = 60000.0
    k_h_per_s: float = 0.02
    k_gamma_per_s: float = 0.1
    gamma_limit_rad: float = math.radians(10.0)
    n_vert_min_g: float = 0.05
    bank_limit_rad: float = math.radians(85.0)
    miss_tolerance_m: float = 100.0

    @classmethod
    def from_config(cls, d: dict) -> "GuidanceConfig":
        """Validate a ``guidance:`` block; ValueError naming the field."""
        if not isinstance(d, dict):
            raise ValueError(f"guidance: expected a mapping, got {d!r}")
        check_keys(d, FIELDS, "guidance.")
        if "target" not in d:
            raise ValueError("guidance.target: missing required field")
        tg = d["target"]
        if not isinstance(tg, dict):
            raise ValueError(f"guidance.target: expected a mapping, got {tg!r}")
        check_keys(tg, TARGET_FIELDS, "guidance.target.")
        lat = _num(tg, "lat_deg", "guidance.target.")
        if abs(lat) >= 90.0:
            raise ValueError(f"guidance.target.lat_deg: must be within (-90, 90), got {lat!r}")
        lon = _num(tg, "lon_deg", "guidance.target.")
        if not -180.0 <= lon <= 180.0:
            raise ValueError(f"guidance.target.lon_deg: must be within [-180, 180], got {lon!r}")
        p = "guidance."
        cfg = cls(math.radians(lat), math.radians(lon), _num(tg, "alt_m", "guidance.target.", 0.0),
                  period_s=_num(d, "period_s", p, 0.1, positive=True),
                  apply_delay_s=_num(d, "apply_delay_s", p, 0.1, nonneg=True),
                  t_start_s=_num(d, "t_start_s", p, 0.0, nonneg=True),
                  command_topic=_topic(d, "command_topic", "guidance/command"),
                  command_timeout_s=_num(d, "command_timeout_s", p, 30.0, positive=True),
                  nav_topic=_topic(d, "nav_topic", "nav/odom"), nav_type=d.get("nav_type", "odometry"),
                  navigation_constant=_num(d, "navigation_constant", p, 3.5, positive=True),
                  terminal_range_m=_num(d, "terminal_range_m", p, 60000.0, nonneg=True),
                  k_h_per_s=_num(d, "k_h_per_s", p, 0.02, positive=True),
                  k_gamma_per_s=_num(d, "k_gamma_per_s", p, 0.1, positive=True),
                  gamma_limit_rad=math.radians(_num(d, "gamma_limit_deg", p, 10.0, positive=True)),
                  n_vert_min_g=_num(d, "n_vert_min_g", p, 0.05, nonneg=True),
                  bank_limit_rad=math.radians(_num(d, "bank_limit_deg", p, 85.0, positive=True)),
                  miss_tolerance_m=_num(d, "miss_tolerance_m", p, 100.0, positive=True))
        if cfg.nav_type not in NAV_TYPES:
            raise ValueError(f"guidance.nav_type: expected one of {NAV_TYPES}, got {cfg.nav_type!r}")
        if cfg.bank_limit_rad > math.pi:
            raise ValueError("guidance.bank_limit_deg: must be <= 180")
        if cfg.apply_delay_s < cfg.period_s - 1e-9:
            raise ValueError(f"guidance.apply_delay_s: must be >= period_s ({cfg.period_s:g} s): a command "
                             f"cannot apply before the step after the state it was computed from")
        return cfg


def _topic(d, key, default):
    v = d.get(key, default)
    if not isinstance(v, str) or not v:
        raise ValueError(f"guidance.{key}: expected a topic name, got {v!r}")
    return v


