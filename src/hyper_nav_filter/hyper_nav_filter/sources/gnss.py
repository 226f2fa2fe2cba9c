"""GNSS sources.

* ``gnss_fix``: sensor_msgs/NavSatFix (antenna position, ENU covariance, REP-145)
  -> ``GnssPosition``; fixes with status NO_FIX or without a known
  covariance (unless ``default_sigma_enu_m`` is set) are rejected.
* ``gnss_vel``: geometry_msgs/TwistWithCovarianceStamped (ENU velocity w.r.t.
  Earth, linear block of the covariance) -> ``GnssVelocity``.
* ``gnss_raw``: hyper_nav_msgs/GnssMeasurements (pseudoranges, rates, lock)
  plus broadcast ephemerides (hyper_nav_msgs/GnssEphemeris on
  ``ephemeris_topic``, latched) -> pseudorange updates, corrected by the
  receiver models (``core.gnss.raw_to_pseudoranges``). ``channels`` selects
  tracked, virtual (``is_virtual``, reconstructed under lock loss) or all
  channels, and ``sigma_scale`` scales their sigmas, so virtual
  pseudoranges come in through their own declared source with their own noise.
  Real receivers (``signals`` set: a signal plan per system, e.g.
  ``["G:1C+2W,1C", "E:1X+7X", "C:2I+6I"]``): the real-signal receiver model
  (``core.gnss.receiver_model``: group delays, ionosphere-free pairs,
  Galileo, ``error_model`` weights, elevation mask) and the Klobuchar sets the
  ephemeris messages carry; ``per_satellite`` makes each satellite its own
  update, so the innovation gate excludes faulty satellites one by one.
  Range-error states (``rb``/``rb32``, ``isb`` in the layout) are used when
  the layout has them (``core.blocks.range_bias``).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import conversions
from hyper_nav_gnss.corrections.propagation import KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT
from hyper_nav_gnss.observations import MalformedGnssInput, check_raw_epoch
from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections, TightGnssInput
from ..core.params import BOOL, FLOAT, FLOATS, STR, STRS, ConfigError, ParamSpec, nonneg, positive
from .base import SourceType, navsatfix_check, register


def real_receiver_model(p: dict, corr: ReceiverCorrections):
    """The real-signal receiver model of a gnss_raw source's parameters
    (``signals``, ``error_model``, ``elevation_mask_deg``, Klobuchar /
    troposphere settings); errors name the field."""
    from hyper_nav_gnss.corrections.combinations import parse_plan
    from hyper_nav_gnss.corrections.receiver_model import ReceiverModel
    from hyper_nav_gnss.corrections.weighting import ErrorModel
    plan = {}
    for entry in p["signals"]:
        sysc, _, choices = str(entry).partition(":")
        if not sysc or not choices:
            raise ConfigError(f"signals: {entry!r} is not 'S:code[+code],...' (e.g. 'G:1C+2W,1C')")
        plan[sysc.strip()] = [c.strip() for c in choices.split(",") if c.strip()]
    try:
        plan = parse_plan(plan)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    errors = None if p["error_model"] == "message" else ErrorModel(weighting=p["error_model"])
    kb = None if corr.klobuchar is None else {"G": corr.klobuchar["G"]}
    return ReceiverModel(plan, errors, kb, corr.troposphere, np.deg2rad(p["elevation_mask_deg"]))


@register
class GnssFixSource(SourceType):
    TYPE = "gnss_fix"
    MSG_TYPES = ("sensor_msgs/msg/NavSatFix",)
    DESCRIPTION = "GNSS antenna position fix (loosely coupled)"
    PARAMS = (ParamSpec("default_sigma_enu_m", FLOATS, (0.0, 0.0, 0.0),
                        "1-sigma (m, E/N/U) used when a fix carries no covariance; 0 = reject such fixes",
                        lo=0.0, length=3),)

    def convert(self, role, msg, engine):
        sig = np.asarray(self.p["default_sigma_enu_m"], float)
        reason = navsatfix_check(msg, allow_no_covariance=bool(np.all(sig > 0)))
        if reason is not None:
            return reason
        meas = conversions.gnss_position(msg)
        if int(msg.position_covariance_type) == 0:
            meas = type(meas)(meas.t_s, meas.lat_rad, meas.lon_rad, meas.alt_m, np.diag(sig**2))
        return self._queued(engine.add_measurement(meas))

    def prepare_rows(self, role, fields, n):
        """``convert`` over a topic's arrays (``conversions.gnss_positions``)."""
        sig = np.asarray(self.p["default_sigma_enu_m"], float)
        allow = bool(np.all(sig > 0))
        meas = conversions.gnss_positions(fields)
        status = fields["status.status"]
        cov_type = fields["position_covariance_type"]
        out = []
        for r, m in enumerate(meas):
            if status[r] < 0:
                out.append("no_fix")
            elif cov_type[r] == 0:
                out.append(type(m)(m.t_s, m.lat_rad, m.lon_rad, m.alt_m, np.diag(sig**2)) if allow else "no_covariance")
            else:
                out.append(m)
        return out


@register
class GnssVelSource(SourceType):
    TYPE = "gnss_vel"
    MSG_TYPES = ("geometry_msgs/msg/TwistWithCovarianceStamped",)
    DESCRIPTION = "GNSS antenna velocity w.r.t. Earth, ENU (loosely coupled)"

    def convert(self, role, msg, engine):
        return self._queued(engine.add_measurement(conversions.gnss_velocity(msg)))

    def prepare_rows(self, role, fields, n):
        """``convert`` over a topic's arrays (``conversions.gnss_velocities``)."""
        return conversions.gnss_velocities(fields)


@register
class GnssRawSource(SourceType):
    TYPE = "gnss_raw"
    MSG_TYPES = ("hyper_nav_msgs/msg/GnssMeasurements",)
    DESCRIPTION = "GNSS pseudoranges and rates with broadcast ephemerides (tightly coupled)"
    PARAMS = (
        ParamSpec("ephemeris_topic", STR, "gnss/ephemeris", "topic of the broadcast ephemerides (latched)"),
        ParamSpec("ionosphere", STR, "klobuchar", "receiver ionosphere model", choices=("klobuchar", "off")),
        ParamSpec("klobuchar_alpha", FLOATS, tuple(KLOBUCHAR_ALPHA_DEFAULT), "broadcast Klobuchar alpha_0..3",
                  length=4),
        ParamSpec("klobuchar_beta", FLOATS, tuple(KLOBUCHAR_BETA_DEFAULT), "broadcast Klobuchar beta_0..3", length=4),
        ParamSpec("troposphere", STR, "hopfield", "receiver troposphere model", choices=("hopfield", "off")),
        ParamSpec("use_rates", BOOL, False, "use pseudorange rates (Doppler) as well as pseudoranges"),
        nonneg("ephemeris_wait_s", FLOAT, 0.5, "hold a raw epoch this long (filter time) for missing ephemerides"),
        ParamSpec("channels", STR, "tracked", "which channels: tracked (is_virtual false), virtual, or all",
                  choices=("tracked", "virtual", "all")),
        positive("sigma_scale", FLOAT, 1.0, "factor on the message's pseudorange and rate sigmas"),
        ParamSpec("signals", STRS, [], "real-signal plan per system, 'S:code[+code2],...' (e.g. 'G:1C+2W,1C'); "
                  "empty = the simulated receiver's legacy channels"),
        ParamSpec("error_model", STR, "message", "pseudorange weights of the real-signal model: the receiver's own "
                  "sigmas, or core.gnss.weighting's model", choices=("message", "elevation", "cn0", "elevation_cn0")),
        nonneg("elevation_mask_deg", FLOAT, 10.0, "elevation mask of the real-signal model (deg)"),
        ParamSpec("per_satellite", BOOL, False, "one update per satellite (the gate tests each satellite)"),
        positive("range_bias_release_s", FLOAT, 30.0, "an unseen satellite's range-bias slot (and bias state) "
                 "may go to another satellite after this long; until then, and while no other needs it, it is kept"),
    )
    EXTRA_INPUTS = {"ephemeris": ("ephemeris_topic", "hyper_nav_msgs/msg/GnssEphemeris", True)}

    def __init__(self, spec, cfg=None):
        super().__init__(spec, cfg)
        p = self.p
        corr = ReceiverCorrections.from_params(p["ionosphere"], p["klobuchar_alpha"], p["klobuchar_beta"],
                                               p["troposphere"])
        receiver = None
        if p["signals"]:
            try:
                receiver = real_receiver_model(p, corr)
            except ConfigError as exc:
                raise ConfigError(f"filter.sources.{self.id}.{exc}") from None
        self.tight = TightGnssInput(corr, p["use_rates"], p["ephemeris_wait_s"], receiver, p["per_satellite"],
                                    p["range_bias_release_s"], slot_owner=f"{self.id}:")

    def check(self, cfg) -> None:
        if cfg is not None and not cfg.layout.has("clk"):
            raise ConfigError(f"filter.sources.{self.id}: type 'gnss_raw' needs the receiver clock block 'clk' in "
                              f"filter.config.state_blocks, got {list(cfg.state_blocks)}")
        if cfg is not None and cfg.output_delay_s <= self.p["ephemeris_wait_s"]:
            raise ConfigError(f"filter.sources.{self.id}.ephemeris_wait_s: must be below filter.config.output_delay_s "
                              f"({cfg.output_delay_s:g} s) so released solutions do not depend on arrival order")

    def convert(self, role, msg, engine):
        try:
            if role == "ephemeris":
                self.tight.add_ephemeris(conversions.gnss_ephemeris(msg), conversions.stamp_to_s(msg.header.stamp))
                kb = conversions.gnss_ephemeris_klobuchar(msg)
                if kb is not None:
                    self.tight.add_klobuchar(*kb)
            else:
                raw = conversions.gnss_raw(msg)
                raw = self._select(raw, getattr(msg, "is_virtual", ()))
                if raw is None:                 # a valid epoch without a usable channel (e.g. lock lost)
                    self.tight.counters["epochs_without_selected_channel"] += 1
                    return None
                self.tight.add_raw(raw)
        except MalformedGnssInput as exc:
            return f"malformed: {exc}"
        self.tight.feed(engine)
        return None

    def _select(self, raw, is_virtual):
        """The raw epoch with only the configured channels marked usable and
        their sigmas scaled; None when no channel is left."""
        check_raw_epoch(raw)
        n = len(raw.system)
        virt = np.zeros(n, bool) if len(is_virtual) == 0 else np.asarray(list(is_virtual), bool)
        if len(virt) != n:
            raise MalformedGnssInput(f"gnss raw: is_virtual has {len(virt)} entries for {n} channels")
        keep = {"tracked": ~virt, "virtual": virt, "all": np.ones(n, bool)}[self.p["channels"]]
        locked = np.asarray(raw.locked, bool) & keep
        if not locked.any():
            return None
        k = self.p["sigma_scale"]
        return replace(raw, pseudorange_sigma_m=raw.pseudorange_sigma_m * k, rate_sigma_mps=raw.rate_sigma_mps * k,
                       locked=locked)

    def on_imu(self, engine) -> None:
        self.tight.feed(engine)

    def diagnostics(self) -> dict:
        d = super().diagnostics()
        d.update({f"{self.id} {k}": v for k, v in self.tight.counters.items()})
        d[f"{self.id} ephemerides"] = len(self.tight.ephemerides)
        return d
