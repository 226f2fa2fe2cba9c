"""Declared fusion sources: converters from ROS messages to the core's
measurements, IMU samples and model updates, registered by type name
(``base`` explains the table). Types: imu, gnss_fix, gnss_vel, gnss_raw,
baro_height, horizontal_fix, position_fix, model_update, zupt, nhc (land vehicles, ``land``); other packages add
theirs through the entry-point group ``hyper_nav.sources`` (``load_plugins``)."""
from __future__ import annotations

from . import aiding, gnss, imu, land  # noqa: F401  (registration)
from .base import (REGISTRY, SourceInput, SourceSpec, SourceType, load_plugins, make_sources, parse_sources,
                   spec_to_params, table_from_params)

# The table when a scenario declares none: IMU and loosely coupled GNSS.
DEFAULT_TABLE = {
    "imu": {"type": "imu", "topic": "imu/data_raw"},
    "gnss_fix": {"type": "gnss_fix", "topic": "gnss/fix"},
    "gnss_vel": {"type": "gnss_vel", "topic": "gnss/vel"},
}

__all__ = ["REGISTRY", "DEFAULT_TABLE", "SourceInput", "SourceSpec", "SourceType", "load_plugins", "make_sources",
           "parse_sources", "spec_to_params", "table_from_params"]
