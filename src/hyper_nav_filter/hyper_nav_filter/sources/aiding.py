"""Non-GNSS aiding sources.

* ``baro_height``: sensor_msgs/FluidPressure (static pressure, Pa, and its
  variance) -> ``BaroHeight``: the altimeter's height is the US76 pressure
  altitude (``core.atmosphere.pressure_altitude_m``, the receiver-side model),
  its variance the pressure variance over (dp/dz)^2 (hydrostatic), at least
  ``min_sigma_m``. Readings above ``max_alt_m`` (where a pressure altimeter
  is no longer an aid, seed 003 section 3.2.2) are rejected.
* ``horizontal_fix``: sensor_msgs/NavSatFix -> ``HorizontalFix`` (latitude,
  longitude and the east/north 2 x 2 block of the ENU covariance): position
  fixes of map-matching aids (geomagnetic matching, seed 003 eqs. 20-26).
* ``model_update``: hyper_nav_msgs/ModelUpdate -> a time-stamped model update
  of the filter (``core.model_update``), e.g. re-estimated lever-arm modes.
"""
from __future__ import annotations

import numpy as np

from ..conversions import stamp_to_s
from ..core.atmosphere import pressure_altitude_m, pressure_height_gradient_pa_per_m
from ..core.measurements import BaroHeight, HorizontalFix
from ..core.model_update import ModelUpdate
from ..core.params import FLOAT, ConfigError, nonneg, positive
from .base import SourceType, navsatfix_check, register


@register
class BaroHeightSource(SourceType):
    TYPE = "baro_height"
    MSG_TYPES = ("sensor_msgs/msg/FluidPressure",)
    DESCRIPTION = "barometric altitude (US76 pressure altitude)"
    PARAMS = (
        nonneg("min_sigma_m", FLOAT, 0.5, "floor of the altitude 1-sigma (m)"),
        positive("max_alt_m", FLOAT, 60000.0, "reject pressure altitudes above this (m)"),
        nonneg("default_sigma_pa", FLOAT, 0.0, "pressure 1-sigma (Pa) when the message has no variance; "
               "0 = reject such messages"),
    )

    def convert(self, role, msg, engine):
        p = float(msg.fluid_pressure)
        if not (np.isfinite(p) and p > 0.0):
            return "bad_pressure"
        var_pa2 = float(msg.variance)
        if not var_pa2 > 0.0:
            if self.p["default_sigma_pa"] <= 0.0:
                return "no_variance"
            var_pa2 = self.p["default_sigma_pa"] ** 2
        alt = float(pressure_altitude_m(p))
        if alt > self.p["max_alt_m"]:
            return "above_max_alt"
        var_m2 = max(var_pa2 / float(pressure_height_gradient_pa_per_m(alt)) ** 2, self.p["min_sigma_m"] ** 2)
        return self._queued(engine.add_measurement(BaroHeight(stamp_to_s(msg.header.stamp), alt, var_m2)))


@register
class HorizontalFixSource(SourceType):
    TYPE = "horizontal_fix"
    MSG_TYPES = ("sensor_msgs/msg/NavSatFix",)
    DESCRIPTION = "horizontal position fix (map matching), east/north covariance"
    PARAMS = (nonneg("min_sigma_m", FLOAT, 0.0, "floor of the horizontal 1-sigma per axis (m)"),)

    def convert(self, role, msg, engine):
        reason = navsatfix_check(msg)
        if reason is not None:
            return reason
        cov = np.asarray(msg.position_covariance, float).reshape(3, 3)[:2, :2]
        floor = self.p["min_sigma_m"] ** 2
        cov = cov + np.diag(np.maximum(0.0, floor - np.diag(cov)))
        if not (np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(0.5 * (cov + cov.T)) > 0)):
            return "bad_covariance"
        meas = HorizontalFix(stamp_to_s(msg.header.stamp), np.deg2rad(msg.latitude), np.deg2rad(msg.longitude), cov)
        return self._queued(engine.add_measurement(meas))


@register
class ModelUpdateSource(SourceType):
    TYPE = "model_update"
    MSG_TYPES = ("hyper_nav_msgs/msg/ModelUpdate",)
    DESCRIPTION = "time-stamped update of a filter model (e.g. lever-arm natural frequencies)"

    def convert(self, role, msg, engine):
        try:
            upd = ModelUpdate.from_arrays(stamp_to_s(msg.header.stamp), msg.model, msg.names, msg.values,
                                          msg.origin, msg.note)
        except ConfigError as exc:
            return f"invalid: {exc}"
        return self._queued(engine.add_model_update(upd))
