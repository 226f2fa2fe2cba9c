"""Typed, validated parameters of the geomagnetic aiding (one object, STYLE 7).

Filled from the scenario's ``geomag:`` block (offline) or from the node's
ROS parameters (the same fields, flattened as ``geomag.<group>.<field>``,
written from the scenario by ``run_graph``). Every field carries its
description and range; errors name the field
(``geomag.magcom.sequence_length: expected an integer in [2, 1000], got 1``).
Defaults are seed 003 Table 2 where the paper gives a value; the rest are
ours and say so.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field


from hyper_nav_aiding.geomag.core.geomag_map import MapError, MapSpec
from hyper_nav_filter.core.params import FLOATS, ConfigError, ParamSpec, kind_of

ALGORITHMS = ("MAGCOM", "ICCP", "SIMAN", "EKF")
FIX_COVARIANCES = ("isotropic", "geometry")


class GeomagConfigError(ValueError):
    """A geomag parameter is missing or invalid; the message names it."""


def _f(default, desc, lo=None, hi=None, choices=None):
    return field(default=default, metadata={"desc": desc, "min": lo, "max": hi, "choices": choices})


@dataclass(frozen=True)
class MagcomParams:
    """MAGCOM (seed 003 section 2.2, eqs. 2-6; Table 2)."""
    sequence_length: int = _f(10, "matching sequence length L (samples), Table 2", 2, 1000)
    area_cells: int = _f(25, "matching area P x Q (refined grid cells, odd), Table 2", 3, 2001)
    rotation_max_deg: float = _f(10.0, "rotation range [-theta, theta] (deg), Table 2", 0.0, 90.0)
    rotation_step_deg: float = _f(1.0, "rotation step (deg), Table 2", 0.01, 90.0)


@dataclass(frozen=True)
class IccpParams:
    """ICCP (seed 003 section 2.3; Table 2)."""
    sequence_length: int = _f(5, "matching sequence length L (samples), Table 2", 2, 1000)
    area_cells: int = _f(300, "matching area (refined grid cells per side), Table 2", 3, 4001)
    max_iterations: int = _f(20, "maximum iteration number, Table 2", 1, 1000)
    critical_distance_m: float = _f(200.0, "critical distance (m): stop when J = sum d^2 < d^2, Table 2",
                                    0.0, 1e6)


@dataclass(frozen=True)
class SimanParams:
    """SIMAN (seed 003 section 2.4, eqs. 7-12; Table 2)."""
    x0_m: tuple = _f((0.0, 0.0), "initial state [dN, dE] (m), Table 2 (zero)")
    p0_m2: tuple = _f((1.0e6, 1.0e6), "initial covariance diag [N, E] (m^2); Table 2's I read as km^2", 0.0, 1e12)
    q_m2_per_s: float = _f(1.0, "random-walk process noise of the position error (m^2/s), ours", 0.0, 1e8)
    plane_fit_cells: int = _f(1, "nine-point plane fit node spacing (refined cells), eq. 12", 1, 100)


@dataclass(frozen=True)
class EkfParams:
    """Ours: every sample as one scalar update of the fusion filter,
    published as an along-gradient pseudo-fix (see ``core.ekf_intensity``)."""
    map_error_corr_length_m: float = _f(0.0, "correlation length of the map error (m) for measurement "
                                        "differencing (time constant sqrt(pi/2) L / speed); 0 = white", 0.0, 1e7)
    across_sigma_m: float = _f(1.0e5, "1-sigma of the unobserved across-gradient direction (m)", 1.0, 1e8)
    vertical: bool = _f(True, "3-D pseudo-fix along the 3-D gradient (the field falls ~30 nT/km with height, "
                        "so the altitude error enters the measurement); needs a 3-D position source in the "
                        "fusion filter. false: horizontal fix, altitude error as extra noise")


@dataclass(frozen=True)
class GeomagConfig:
    algorithm: str = _f("SIMAN", "matching algorithm", choices=ALGORITHMS)
    start_s: float = _f(420.0, "matching starts at this sim time (s); seed 003: pure INS before 420 s", 0.0, 1e9)
    field_sigma_nT: float = _f(1.0, "1-sigma map error (true field - map) the matcher assumes (nT)", 1e-6, 1e6)
    sensor_sigma_nT: float = _f(0.01, "1-sigma white magnetometer noise the matcher assumes (nT)", 0.0, 1e6)
    fix_covariance: str = _f("isotropic", "fix covariance: 'isotropic' (isotropic_sigma_m, as a 2-D fix "
                             "in seed 003 eqs. 20-26) or 'geometry' (along/across the field gradient)",
                             choices=FIX_COVARIANCES)
    isotropic_sigma_m: float = _f(100.0, "1-sigma of an isotropic fix (m), ours (the paper gives none)", 0.1, 1e6)
    max_nav_gap_s: float = _f(0.5, "largest gap between the nav/state samples that bracket a magnetometer "
                              "stamp (s)", 0.0, 100.0)
    max_nav_prediction_s: float = _f(2.0, "a reference solution is carried forward to the magnetometer stamp "
                                     "if it is at most this old (s)", 0.0, 100.0)
    nav_reference_lag_s: float = _f(2.0, "a magnetometer sample at t is matched against the newest nav/state "
                                    "stamped at or before t - lag, carried to t (core.nav_reference; chosen by "
                                    "stamps, not by arrival); run_graph sets it to filter.config.output_delay_s "
                                    "+ 1 s, so that solution is out before the sample comes and the fix is made "
                                    "at once; 0 = interpolate at t (waits for that solution)", 0.0, 100.0)
    map_file: str = _f("", "map file (.npz); empty: the cache (map_cache_dir) for the map spec")
    map_cache_dir: str = _f("", "map cache directory; empty: ~/.cache/hyper_nav/geomag")
    map_epoch_tolerance_nT: float = _f(0.1, "largest |F at the flight's date - F of the map| over the map (nT) "
                                       "that the map's epoch may imply (secular variation, core.map_epoch); "
                                       "beyond it the map is refused; 0.1 nT = seed 003's smallest map-error level",
                                       0.0, 1e6)
    map_bring_forward: bool = _f(False, "bring the map from its epoch to the flight's date with the WMM's "
                                 "secular-variation coefficients (core.map_epoch.bring_forward)")
    map: MapSpec = field(default_factory=MapSpec, metadata={"desc": "the map (model, epoch, altitude, grid)"})
    magcom: MagcomParams = field(default_factory=MagcomParams, metadata={"desc": "MAGCOM"})
    iccp: IccpParams = field(default_factory=IccpParams, metadata={"desc": "ICCP"})
    siman: SimanParams = field(default_factory=SimanParams, metadata={"desc": "SIMAN"})
    ekf: EkfParams = field(default_factory=EkfParams, metadata={"desc": "EKF pseudo-fix"})

    @classmethod
    def from_dict(cls, d: dict | None, prefix: str = "geomag") -> "GeomagConfig":
        """From the scenario's ``geomag:`` block (nested mappings). Keys not
        of this object (``reproduction``) are ignored."""
        d = {} if d is None else d
        if not isinstance(d, dict):
            raise GeomagConfigError(f"{prefix}: expected a mapping, got {d!r}")
        kw = {}
        for f in dataclasses.fields(cls):
            if f.name not in d:
                continue
            v = d[f.name]
            if f.name == "map":
                try:
                    kw["map"] = MapSpec.from_dict(v, prefix=f"{prefix}.map")
                except MapError as exc:
                    raise GeomagConfigError(str(exc)) from None
            elif dataclasses.is_dataclass(f.default_factory if f.default_factory is not dataclasses.MISSING
                                          else None):
                sub = f.default_factory
                if not isinstance(v, dict):
                    raise GeomagConfigError(f"{prefix}.{f.name}: expected a mapping, got {v!r}")
                unknown = sorted(set(v) - {g.name for g in dataclasses.fields(sub)})
                if unknown:
                    raise GeomagConfigError(f"{prefix}.{f.name}: unknown field(s) {unknown}")
                kw[f.name] = sub(**{k: _check(f"{prefix}.{f.name}.{k}", g, v[k])
                                    for g in dataclasses.fields(sub) for k in [g.name] if k in v})
            else:
                kw[f.name] = _check(f"{prefix}.{f.name}", f, v)
        known = {f.name for f in dataclasses.fields(cls)} | {"reproduction"}
        unknown = sorted(set(d) - known)
        if unknown:
            raise GeomagConfigError(f"{prefix}: unknown field(s) {unknown} (known: {sorted(known)})")
        return cls(**kw)

    # ---- ROS parameters: flat names, descriptors ----------------------------------
    def flat(self, prefix: str = "geomag") -> dict:
        """{'geomag.magcom.sequence_length': 10, ...}: the node's parameters."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if dataclasses.is_dataclass(v):
                for g in dataclasses.fields(v):
                    out[f"{prefix}.{f.name}.{g.name}"] = _ros_value(getattr(v, g.name), g.default)
            else:
                out[f"{prefix}.{f.name}"] = _ros_value(v, f.default)
        return out

    @classmethod
    def describe(cls, prefix: str = "geomag") -> dict:
        """{flat name: (default, description, min, max, choices)} for the node's descriptors."""
        out = {}
        default = cls()
        for f in dataclasses.fields(cls):
            v = getattr(default, f.name)
            if dataclasses.is_dataclass(v):
                for g in dataclasses.fields(v):
                    md = g.metadata
                    out[f"{prefix}.{f.name}.{g.name}"] = (_ros_value(getattr(v, g.name)), md.get("desc", g.name),
                                                         md.get("min"), md.get("max"), md.get("choices"))
            else:
                md = f.metadata
                out[f"{prefix}.{f.name}"] = (_ros_value(v), md["desc"], md.get("min"), md.get("max"),
                                             md.get("choices"))
        return out

    @classmethod
    def from_flat(cls, flat: dict, prefix: str = "geomag") -> "GeomagConfig":
        """Inverse of ``flat`` (the node's parameter values)."""
        nested: dict = {}
        for name, value in flat.items():
            parts = name[len(prefix) + 1:].split(".")
            cur = nested
            for p in parts[:-1]:
                cur = cur.setdefault(p, {})
            cur[parts[-1]] = list(value) if isinstance(value, (list, tuple)) else value
        return cls.from_dict(nested, prefix)


def _ros_value(v, default=None):
    """A value as the ROS parameter of the field's type (floats stay floats
    when YAML wrote an integer: a declared double rejects an integer)."""
    if isinstance(v, tuple):
        return [float(x) for x in v]
    if isinstance(default, float) and isinstance(v, int) and not isinstance(v, bool):
        return float(v)
    return v


def _check(name: str, f, v):
    """One leaf value checked by the ParamSpec its field declares (``hyper_nav_filter.core.params``, the
    project's one validation rule): the type of its default, its range as an interval, its choices."""
    md, default = f.metadata, f.default
    kind = kind_of(default)
    if kind is None:
        raise GeomagConfigError(f"{name}: unsupported field type")  # pragma: no cover
    spec = ParamSpec(name, kind, default, md.get("desc", ""), lo=md.get("min"), hi=md.get("max"),
                     choices=tuple(md["choices"]) if md.get("choices") else None,
                     length=len(default) if kind == FLOATS else None, broadcast=False, interval=True)
    try:
        return spec.check(v)
    except ConfigError as exc:
        raise GeomagConfigError(str(exc)) from None
