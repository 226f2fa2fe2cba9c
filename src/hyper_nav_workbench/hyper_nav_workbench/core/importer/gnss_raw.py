"""Real GNSS receiver data (a u-blox UBX log, or RINEX 3 observation +
navigation files) -> ``gnss/raw`` (hyper_nav_msgs/GnssMeasurements) and
``gnss/ephemeris`` (hyper_nav_msgs/GnssEphemeris) messages for a bag, the
``ubx`` and ``rinex`` presets of ``import_data``. No rclpy.

The import file's ``gnss`` block::

    gnss:
      file: gnss_1730.ubx            # ubx: the raw log; rinex: the observation file (.rnx, .crx, .gz)
      nav: BRDC00IGS_R_..._MN.rnx.gz # rinex: the navigation file (required); ubx: optional, added to the log's records
      signals: {G: [1C, 2W], E: [1X, 7X], C: [2I, 6I]}   # rinex: observation codes to keep (default: all)
      time_axis: gpst_unix           # header.stamp = GPST as seconds since 1970-01-01 (default, the walk's IMU
                                     # time); gpst = seconds since 1980-01-06; gpst_week = seconds of the first week
      ephemeris: at_start            # at_start (default): every record of the file published at the first epoch
                                     # (post-processing, as RTKLIB uses a navigation file); when_decoded: each UBX
                                     # record at the epoch its subframes were complete (what a real-time receiver has)
      start_s / end_s                # optional window on the time axis

Each receiver epoch becomes one GnssMeasurements (one channel per signal,
``signal`` = RINEX code, carrier phase, Doppler, C/N0, lock time, tracking
flags; ``elevation_rad`` / ``azimuth_rad`` left empty: a raw log does not
report them). Channels of systems the message cannot carry (SBAS, NavIC)
are dropped and counted. Each broadcast record becomes one GnssEphemeris;
the Klobuchar set of its system (UBX: GPS LNAV page 18 / BDS D1 subframe 1;
RINEX: the header) rides on every record of that system.
"""
from __future__ import annotations

import pathlib
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_gnss.orbits.ephemeris import SECONDS_PER_WEEK
from hyper_nav_gnss.signals import MSG_SYSTEM
from hyper_nav_filter.core.params import ConfigError, suggest, unknown_field
from hyper_nav_gnss.formats.registry import RECEIVER_FORMATS, receiver_format

from hyper_nav_workbench.core.bag import typestore

GPST_UNIX_OFFSET_S = 315964800.0          # 1980-01-06 - 1970-01-01 (GPS time, no leap seconds)
TIME_AXES = ("gpst_unix", "gpst", "gpst_week")
KNOWN = {"file", "nav", "signals", "time_axis", "ephemeris", "start_s", "end_s", "pseudorange_sigma_m"}


@dataclass
class GnssImport:
    """What the reader gave: epochs (RawGnssEpoch, t_s = continuous GPST),
    records [(t_gpst_s available, BroadcastEphemeris)], Klobuchar sets
    {system: (alpha, beta)}, counts, errors, the time offset (stamp = GPST +
    offset) and the reading wall time."""
    epochs: list
    ephemerides: list
    iono: dict
    counts: Counter = field(default_factory=Counter)
    errors: list = field(default_factory=list)
    offset_s: float = GPST_UNIX_OFFSET_S
    read_wall_s: float = 0.0
    source: str = ""
    header: dict = field(default_factory=dict)

    def stamp_s(self, t_gpst_s: float) -> float:
        return float(t_gpst_s) + self.offset_s


def _path(spec: dict, key: str, base_dir, where: str) -> pathlib.Path:
    if key not in spec:
        raise ConfigError(f"{where}.{key}: required")
    p = pathlib.Path(spec[key])
    p = p if p.is_absolute() else pathlib.Path(base_dir) / p
    if not p.exists():
        raise ConfigError(f"{where}.{key}: {p} not found")
    return p


def time_offset_s(axis: str, epochs) -> float:
    """stamp = continuous GPST + offset for a time axis (see the module docstring)."""
    if axis == "gpst_unix":
        return GPST_UNIX_OFFSET_S
    if axis == "gpst":
        return 0.0
    if axis == "gpst_week":
        if not epochs:
            return 0.0
        return -np.floor(epochs[0].t_rx_gpst_s / SECONDS_PER_WEEK) * SECONDS_PER_WEEK
    raise ConfigError(f"gnss.time_axis: unknown {axis!r} (known: {', '.join(TIME_AXES)})")


def read_gnss(preset: str, spec: dict, base_dir, where: str = "gnss") -> GnssImport:
    """Read the ``gnss`` block of a receiver-format import (``preset``: a name of
    ``hyper_nav_gnss.formats.registry.RECEIVER_FORMATS``; module docstring)."""
    unknown = sorted(set(spec) - KNOWN)
    if unknown:
        raise ConfigError(unknown_field(f"{where}.", unknown[0], KNOWN))
    try:
        fmt = receiver_format(preset)
    except KeyError:
        raise ConfigError(f"preset: {preset!r} is not a GNSS receiver format{suggest(str(preset), RECEIVER_FORMATS)}"
                          ) from None
    t0 = time.perf_counter()
    path = _path(spec, "file", base_dir, where)
    log = fmt.read(path, signals=spec.get("signals"))
    imp = GnssImport(log.epochs, list(log.ephemerides), dict(log.iono), Counter(log.counts), list(log.errors),
                     source=str(path), header=log.header or {})
    if "nav" in spec or fmt.needs_nav:
        _add_nav(imp, _path(spec, "nav", base_dir, where), at_s=np.nan)
    imp.read_wall_s = time.perf_counter() - t0
    if not imp.epochs:
        raise ConfigError(f"{where}.file: {imp.source}: no receiver epoch read ({dict(imp.counts)})")
    imp.offset_s = time_offset_s(spec.get("time_axis", "gpst_unix"), imp.epochs)
    mode = spec.get("ephemeris", "at_start")
    if mode not in ("at_start", "when_decoded"):
        raise ConfigError(f"{where}.ephemeris: expected 'at_start' or 'when_decoded', got {mode!r}")
    t_first = imp.epochs[0].t_rx_gpst_s
    imp.ephemerides = [(t_first if (mode == "at_start" or not np.isfinite(t)) else max(t, t_first), e)
                       for t, e in imp.ephemerides]
    return imp


def _add_nav(imp: GnssImport, path, at_s: float) -> None:
    from hyper_nav_gnss.formats.rinex_nav import RINEX3_SYSTEMS, read_rinex3_nav_records
    nav = read_rinex3_nav_records(path, RINEX3_SYSTEMS)
    imp.ephemerides += [(at_s, e) for e in nav]
    for s, ab in nav.iono.items():
        imp.iono.setdefault(s, ab)
    imp.counts.update({f"nav_{k}": v for k, v in nav.counts.items()})
    imp.errors += nav.errors[:20]


def window(imp: GnssImport, start_s, end_s) -> GnssImport:
    """Epochs whose stamp lies in [start_s, end_s] (None: open)."""
    keep = [e for e in imp.epochs if (start_s is None or imp.stamp_s(e.t_rx_gpst_s) >= start_s - 1e-9)
            and (end_s is None or imp.stamp_s(e.t_rx_gpst_s) <= end_s + 1e-9)]
    if not keep:
        raise ConfigError(f"gnss: no receiver epoch in the window [{start_s}, {end_s}]")
    t0 = keep[0].t_rx_gpst_s
    ephs = [(max(t, t0), e) for t, e in imp.ephemerides]
    return GnssImport(keep, ephs, imp.iono, imp.counts, imp.errors, imp.offset_s, imp.read_wall_s, imp.source,
                      imp.header)


# ---------------------------------------------------------------- messages (rosbags types)
def _t(name):
    return typestore().types[name]


def _header(t_s: float, frame: str):
    sec, nsec = s_to_stamp_fields(t_s)
    return _t("std_msgs/msg/Header")(stamp=_t("builtin_interfaces/msg/Time")(sec=sec, nanosec=nsec), frame_id=frame)


def _ns(t_s: float) -> int:
    sec, nsec = s_to_stamp_fields(t_s)
    return sec * 1_000_000_000 + nsec


def raw_messages(imp: GnssImport, frame: str = "gnss_antenna", counts: Counter | None = None):
    """(t_ns, GnssMeasurements) of every epoch, stamped on the import's time axis."""
    Msg = _t("hyper_nav_msgs/msg/GnssMeasurements")
    counts = counts if counts is not None else Counter()
    f64 = (lambda a: np.asarray(a, np.float64))
    for ep in imp.epochs:
        keep = np.array([s in MSG_SYSTEM for s in ep.system], bool)
        for s in set(np.asarray(ep.system, object)[~keep]):
            counts[f"channels_dropped_system_{s}"] += int(np.count_nonzero(np.asarray(ep.system, object) == s))
        e = ep.subset(np.flatnonzero(keep))
        t = imp.stamp_s(ep.t_rx_gpst_s)
        week = int(ep.t_rx_gpst_s // SECONDS_PER_WEEK)
        n = len(e)
        opt = (lambda a, dtype=np.float64: np.asarray(a, dtype) if len(a) else np.zeros(0, dtype))
        yield _ns(t), Msg(
            header=_header(t, frame), rx_time_of_week_s=float(ep.t_rx_gpst_s - week * SECONDS_PER_WEEK),
            gps_week=week, system=np.array([MSG_SYSTEM[s] for s in e.system], np.uint8),
            prn=np.asarray(e.prn, np.uint16), pseudorange_m=f64(e.pseudorange_m),
            pseudorange_sigma_m=f64(e.pseudorange_sigma_m), pseudorange_rate_mps=f64(e.rate_mps),
            pseudorange_rate_sigma_mps=f64(e.rate_sigma_mps), doppler_hz=opt(e.doppler_hz),
            carrier_frequency_hz=opt(e.carrier_frequency_hz), cn0_dbhz=opt(e.cn0_dbhz),
            elevation_rad=np.zeros(0), azimuth_rad=np.zeros(0), locked=np.asarray(e.locked, bool),
            is_virtual=np.zeros(0, bool), signal=list(e.signal) if e.signal else [],
            carrier_phase_cycles=opt(e.carrier_phase_cycles), lock_time_s=opt(e.lock_time_s),
            tracking_flags=opt(e.tracking_flags, np.uint8))
        counts["gnss_raw_epochs"] += 1
        counts["gnss_raw_channels"] += n


def ephemeris_messages(imp: GnssImport, counts: Counter | None = None):
    """(t_ns, GnssEphemeris) of every record of a system the message carries,
    stamped when it is available (module docstring), in time order."""
    Msg = _t("hyper_nav_msgs/msg/GnssEphemeris")
    counts = counts if counts is not None else Counter()
    seen = set()
    for t_gpst, eph in sorted(imp.ephemerides, key=lambda x: x[0]):
        if eph.system not in ("G", "E", "C"):
            counts[f"ephemerides_dropped_system_{eph.system}"] += 1
            continue
        key = (eph.system, eph.prn, eph.week, eph.toe, eph.data_source)
        if key in seen:
            counts["ephemerides_duplicate"] += 1
            continue
        seen.add(key)
        kb = imp.iono.get(eph.system)
        t = imp.stamp_s(t_gpst)
        counts["gnss_ephemerides"] += 1
        yield _ns(t), Msg(
            header=_header(t, ""), system=MSG_SYSTEM[eph.system], prn=int(eph.prn), week=int(eph.week),
            toe_s=float(eph.toe), toc_s=float(eph.toc), sqrt_a_sqrtm=float(eph.sqrtA), e=float(eph.e),
            i0_rad=float(eph.i0), omega0_rad=float(eph.Omega0), omega_rad=float(eph.omega), m0_rad=float(eph.M0),
            delta_n_radps=float(eph.delta_n), idot_radps=float(eph.idot), omega_dot_radps=float(eph.OmegaDot),
            cuc_rad=float(eph.cuc), cus_rad=float(eph.cus), crc_m=float(eph.crc), crs_m=float(eph.crs),
            cic_rad=float(eph.cic), cis_rad=float(eph.cis), af0_s=float(eph.af0), af1_sps=float(eph.af1),
            af2_sps2=float(eph.af2), tgd_s=float(eph.tgd), tgd2_s=float(eph.tgd2), iode=int(eph.iode),
            health=min(int(eph.health), 255), data_source=int(eph.data_source),     # uint8: a 9-bit Galileo word stays non-zero
            accuracy_m=float(eph.accuracy_m) if np.isfinite(eph.accuracy_m) else 0.0,
            klobuchar_alpha=np.asarray(kb[0], float) if kb else np.zeros(0),
            klobuchar_beta=np.asarray(kb[1], float) if kb else np.zeros(0))


def initial_from_spp(imp: GnssImport, t_stamp_s: float, n_epochs: int = 5) -> dict:
    """``filter.initial_state`` fields from single-point positioning of the
    first receiver epochs at or after ``t_stamp_s`` (the IMU's first epoch):
    antenna position (lat/lon/alt of the mean of ``n_epochs`` solutions),
    receiver clock bias (at t_stamp_s) and drift (their slope), inter-system
    biases. The default signal plan and error model of
    ``hyper_nav_filter.core.gnss`` (combinations.DEFAULT_PLAN)."""
    from hyper_nav_gnss import earth
    from hyper_nav_gnss.positioning import spp
    store, cfg = _spp_setup(imp)
    eps = [e for e in imp.epochs if imp.stamp_s(e.t_rx_gpst_s) >= t_stamp_s - 1e-6]
    sols = [s for s in spp.solve(eps[: 4 * n_epochs], store, cfg) if s.valid][:n_epochs]
    if not sols:
        raise ConfigError("filter.initial_state: no single-point solution in the first receiver epochs; give "
                          "lat_deg, lon_deg, alt_m, clock_bias_m")
    r = np.mean([s.pos_ecef_m for s in sols], axis=0)
    lat, lon, alt = earth.ecef_to_geodetic(r)
    t = np.array([imp.stamp_s(s.t_rx_gpst_s) for s in sols])
    b = np.array([s.clock_bias_m for s in sols])
    drift = float(np.polyfit(t - t[0], b, 1)[0]) if len(sols) > 1 else 0.0
    isb = [float(np.mean([s.isb_m.get(k, 0.0) for s in sols])) for k in ("E", "C", "J")]
    return {"lat_deg": float(np.rad2deg(lat)), "lon_deg": float(np.rad2deg(lon)), "alt_m": float(alt),
            "clock_bias_m": float(b[0] + drift * (t_stamp_s - t[0])), "clock_drift_mps": drift, "isb_m": isb}


def _spp_setup(imp: "GnssImport"):
    """The import's broadcast ephemerides as a store (malformed ones left
    out, as the filter does) and the default single-point configuration
    with the import's Klobuchar coefficients."""
    from hyper_nav_gnss.positioning import spp
    from hyper_nav_gnss.observations import EphemerisStore, MalformedGnssInput
    from hyper_nav_gnss.corrections.receiver_model import ReceiverModel
    store = EphemerisStore()
    for _, e in imp.ephemerides:
        try:
            store.add(e)
        except MalformedGnssInput:
            pass
    return store, spp.SppConfig(ReceiverModel(klobuchar=imp.iono or None))


@dataclass
class SppFixes:
    """Single-point fixes of a receiver import (stamps on the import's time
    axis): antenna position and ENU covariance, Doppler velocity and its ENU
    covariance (NaN where no velocity solution), as ``columns.FixTable`` fields."""
    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    alt_m: np.ndarray
    pos_cov_enu_m2: np.ndarray
    vel_enu_mps: np.ndarray
    vel_cov_enu_m2ps2: np.ndarray
    clock_bias_m: np.ndarray
    clock_drift_mps: np.ndarray

    def fix_table(self):
        """The fixes as a ``columns.FixTable`` (sigmas: the covariance diagonals)."""
        from hyper_nav_workbench.core.importer.columns import FixTable
        return FixTable(self.t_s, self.lat_rad, self.lon_rad, self.alt_m,
                        np.sqrt(np.einsum("kii->ki", self.pos_cov_enu_m2)), self.vel_enu_mps,
                        np.sqrt(np.einsum("kii->ki", self.vel_cov_enu_m2ps2)))


def spp_fixes(imp: GnssImport, t_from_s: float | None = None, t_to_s: float | None = None) -> SppFixes:
    """Single-point position (``core.gnss.spp``, default signal plan and
    error model) and Doppler velocity (``spp.solve_velocity``) of every
    receiver epoch with a stamp in [t_from_s, t_to_s]; only epochs with a
    valid position and a velocity are kept."""
    from hyper_nav_gnss import earth
    from hyper_nav_gnss.positioning import spp
    store, cfg = _spp_setup(imp)
    eps = [e for e in imp.epochs if (t_from_s is None or imp.stamp_s(e.t_rx_gpst_s) >= t_from_s - 1e-6)
           and (t_to_s is None or imp.stamp_s(e.t_rx_gpst_s) <= t_to_s + 1e-6)]
    rows = []
    for raw, s in zip(eps, spp.solve(eps, store, cfg)):
        v = spp.solve_velocity(raw, store, cfg, s) if s.valid else None
        if v is None:
            continue
        lat, lon, alt = earth.ecef_to_geodetic(s.pos_ecef_m)
        R = earth.C_n_e(lat, lon).T
        rows.append((imp.stamp_s(s.t_rx_gpst_s), lat, lon, alt, R @ s.cov_ecef_m2 @ R.T, v.vel_enu_mps,
                     v.cov_enu_m2ps2, s.clock_bias_m, v.clock_drift_mps))
    if not rows:
        raise ConfigError("gnss: no single-point solution with a Doppler velocity in the window")
    cols = list(zip(*rows))
    return SppFixes(*(np.array(c, float) for c in cols))
