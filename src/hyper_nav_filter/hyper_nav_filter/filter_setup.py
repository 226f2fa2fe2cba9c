"""A filter run without a simulated scenario: the ``filter:`` block of a
scenario file on its own (configuration, declared sources, an explicit
initial state) plus ``report.skip_s``. ``import_data`` writes one beside an
imported bag (``filter.yaml``); ``replay_filter`` takes it. Validated by the
same declarations as everything else (errors name the field). No rclpy.

    filter:
      config: {state_blocks: [att, vel, pos, bg, ba], accel_vrw_mps_per_sqrt_hr: 0.03, ...}
      sources: {...}                  # optional, default: IMU + loosely coupled GNSS
      initial_state: {t_s: 456300.0, lat_deg: 30.44, lon_deg: 114.47, alt_m: 20.9,
                      vel_ned_mps: [0, 0, 0], roll_pitch_heading_deg: [0.85, -2.03, 185.7]}
    report: {skip_s: 0.0}
"""
from __future__ import annotations

import pathlib
from dataclasses import dataclass

import yaml

from .core.config import FilterConfig
from .core.initial_state import from_block
from .core.nav_state import NavState
from .core.params import ConfigError, suggest
from .sources import DEFAULT_TABLE, make_sources, parse_sources


@dataclass
class FilterSetup:
    config: FilterConfig
    sources: dict
    initial: NavState
    skip_s: float = 0.0
    data: dict | None = None

    @classmethod
    def from_dict(cls, data: dict, where: str = "") -> "FilterSetup":
        if not isinstance(data, dict) or not isinstance(data.get("filter"), dict):
            raise ConfigError(f"{where}filter: required (a mapping with config, initial_state)")
        f = data["filter"]
        unknown = sorted(set(f) - {"config", "sources", "initial_state"})
        if unknown:
            raise ConfigError(f"{where}filter.{unknown[0]}: unknown field"
                              f"{suggest(str(unknown[0]), ('config', 'sources', 'initial_state'))}")
        unknown = sorted(set(data) - {"filter", "report"})
        if unknown:
            raise ConfigError(f"{where}{unknown[0]}: unknown field{suggest(str(unknown[0]), ('filter', 'report'))}")
        unknown = sorted(set(data.get("report") or {}) - {"skip_s"})
        if unknown:
            raise ConfigError(f"{where}report.{unknown[0]}: unknown field{suggest(str(unknown[0]), ('skip_s',))}")
        cfg = FilterConfig.from_dict(f.get("config") or {})
        table = f.get("sources") or DEFAULT_TABLE
        make_sources(parse_sources(table), cfg)
        initial = from_block(f.get("initial_state"), None, f"{where}filter.initial_state.")
        skip = float((data.get("report") or {}).get("skip_s", 0.0))
        return cls(cfg, table, initial, skip, data)

    @classmethod
    def load(cls, path) -> "FilterSetup":
        path = pathlib.Path(path)
        try:
            data = yaml.safe_load(path.read_text())
        except (OSError, yaml.YAMLError) as exc:
            raise ConfigError(f"{path}: cannot read ({exc})") from None
        return cls.from_dict(data, f"{path}: ")
