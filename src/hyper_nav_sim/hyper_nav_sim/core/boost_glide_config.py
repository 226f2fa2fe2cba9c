"""Configuration layer of ``DynamicTrajectory``: plain dicts (a scenario
YAML's ``flight:`` section) -> its typed constructor arguments (``Vehicle``,
``FlightStart``, ``Boost``, ``Guidance``, ``FlightManeuver``). The flights
themselves are written once, in the scenario files' ``flight:`` blocks.

Fields (units in the names; angles in degrees)::

    duration_s            max flight time (required, > 0)
    end_speed_mps         stop when the speed falls to this (optional; seed 002 Table 1 v_f)
    end_alt_m             stop when the altitude falls below this (default 0)
    start: {lat_deg, lon_deg, alt_m, speed_mps, gamma_deg, psi_deg}   (required;
                          psi clockwise from north; a vertical launch has
                          gamma_deg 90, psi_deg = launch azimuth, speed_mps > 0 at rail exit)
    mass_kg, s_ref_m2, cd0, k_induced                                  (required, > 0)
    cl_alpha_per_rad      linear lift-curve slope, alpha = C_L / cl_alpha (default 1.6)
    c_l_program           nominal normalized lift coefficient of the equilibrium glide:
                          a number or a list of [t_s, c_l] (linear in between) (default 1.0)
    c_l_min, c_l_max      limits of the commanded c_l (default 0, 3)
    bank_rate_max_deg_s, bank_time_constant_s     bank-angle rate limit / lag (default 30, 1)
    c_l_rate_max_per_s, c_l_time_constant_s       c_l rate limit / lag (default 1, 1)
    engine_isp_s, engine_thrust_max_n             speed-hold engine (default 1200, 1e5)
    altitude_mode         "equilibrium_glide" (seed 002 eq. 13 reference) or "hold"
    guidance: {k_gamma_per_s 0.03, k_h_per_s 0.015, gamma_limit_deg 10,
               n_vert_min_g 0.05, k_speed_per_s 0.05}                  (optional)
    boost: {thrust_n, burn_time_s, mass_flow_kgps, vertical_s 5, pitch_over_s 10,
            pitch_kick_deg 3, tail_off_s 3, blend_s 20}                (optional)
    maneuvers: list of {type, t_start_s, t_end_s (default duration_s), ...}:
        lateral_ca  load_g (signed, + right), ramp_s 5     constant lateral acceleration
        square_wave load_g, period_s 100, ramp_s 5         +-load_g alternating
        evasive     load_g, period_s 60, ramp_s 10         large alternating weave
        s_turn      load_g, period_s 100, ramp_s 5         sinusoidal weave
        turn_left / turn_right  load_g (> 0), ramp_s 5
        climb       delta_alt_m (reference altitude change over the window)
        dive        gamma_deg (< 0), ramp_s 10             flight-path angle override
        pull_up     load_g (> 0), ramp_s 1                 vertical load added to the guidance's
        glide       (no parameters: equilibrium glide, the default mode; for timetables)
        accelerate  delta_speed_mps, ramp_s 5              speed-hold engine, speed ramps
        cruise      ramp_s 5                               speed-hold engine at the reference
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.params import check_keys, number

_MISSING = object()


@dataclass(frozen=True)
class Vehicle:
    mass_kg: float
    s_ref_m2: float
    cd0: float
    k_induced: float
    cl_alpha_per_rad: float = 1.6
    c_l_min: float = 0.0
    c_l_max: float = 3.0
    bank_rate_max_radps: float = np.deg2rad(30.0)
    bank_time_constant_s: float = 1.0
    c_l_rate_max_per_s: float = 1.0
    c_l_time_constant_s: float = 1.0
    engine_isp_s: float = 1200.0
    engine_thrust_max_n: float = 1.0e5

    @property
    def cl_star(self):
        return float(np.sqrt(self.cd0 / self.k_induced))

    @property
    def cd_star(self):
        return 2.0 * self.cd0

    @property
    def e_star(self):
        return 1.0 / (2.0 * np.sqrt(self.cd0 * self.k_induced))


@dataclass(frozen=True)
class FlightStart:
    lat_rad: float
    lon_rad: float
    alt_m: float
    speed_mps: float
    gamma_rad: float
    psi_rad: float


@dataclass(frozen=True)
class Boost:
    thrust_n: float
    burn_time_s: float
    mass_flow_kgps: float
    vertical_s: float = 5.0
    pitch_over_s: float = 10.0
    pitch_kick_rad: float = np.deg2rad(3.0)
    tail_off_s: float = 3.0
    blend_s: float = 20.0


@dataclass(frozen=True)
class Guidance:
    altitude_mode: str = "equilibrium_glide"
    k_gamma_per_s: float = 0.03
    k_h_per_s: float = 0.015
    gamma_limit_rad: float = np.deg2rad(10.0)
    n_vert_min_g: float = 0.05
    k_speed_per_s: float = 0.05


@dataclass(frozen=True)
class FlightManeuver:
    type: str
    t_start_s: float
    t_end_s: float
    load_g: float = 0.0
    period_s: float = 100.0
    ramp_s: float = 5.0
    delta_alt_m: float = 0.0
    gamma_rad: float = 0.0
    delta_speed_mps: float = 0.0


def _num(d, key, path, default=_MISSING, positive=False, nonneg=False):
    if key not in d:
        if default is _MISSING:
            raise ValueError(f"{path}{key}: missing required field")
        return default
    return number(f"{path}{key}", d[key], 0.0 if positive or nonneg else None, lo_open=positive, error=ValueError)


def _check_keys(d, allowed, path):
    if not isinstance(d, dict):
        raise ValueError(f"{path.rstrip('.') or 'flight'}: expected a mapping, got {d!r}")
    check_keys(d, allowed, path)


_TOP = {"duration_s", "end_speed_mps", "end_alt_m", "start", "mass_kg", "s_ref_m2", "cd0", "k_induced",
        "cl_alpha_per_rad", "c_l_program", "c_l_min", "c_l_max", "bank_rate_max_deg_s",
        "bank_time_constant_s", "c_l_rate_max_per_s", "c_l_time_constant_s", "engine_isp_s",
        "engine_thrust_max_n", "altitude_mode", "guidance", "boost", "maneuvers", "name", "description"}
_MAN_DEFAULTS = {  # type -> allowed parameter defaults
    "lateral_ca": {"load_g": _MISSING, "ramp_s": 5.0},
    "square_wave": {"load_g": _MISSING, "period_s": 100.0, "ramp_s": 5.0},
    "evasive": {"load_g": _MISSING, "period_s": 60.0, "ramp_s": 10.0},
    "s_turn": {"load_g": _MISSING, "period_s": 100.0, "ramp_s": 5.0},
    "turn_left": {"load_g": _MISSING, "ramp_s": 5.0},
    "turn_right": {"load_g": _MISSING, "ramp_s": 5.0},
    "climb": {"delta_alt_m": _MISSING, "ramp_s": 5.0},
    "dive": {"gamma_deg": _MISSING, "ramp_s": 10.0},
    "pull_up": {"load_g": _MISSING, "ramp_s": 1.0},
    "glide": {"ramp_s": 5.0},
    "accelerate": {"delta_speed_mps": _MISSING, "ramp_s": 5.0},
    "cruise": {"ramp_s": 5.0},
}


def parse_flight(d: dict) -> dict:
    """Validate a flight dict and return ``DynamicTrajectory`` keyword arguments."""
    _check_keys(d, _TOP, "flight.")
    p = "flight."
    duration = _num(d, "duration_s", p, positive=True)
    if "start" not in d:
        raise ValueError("flight.start: missing required field")
    st = d["start"]
    _check_keys(st, {"lat_deg", "lon_deg", "alt_m", "speed_mps", "gamma_deg", "psi_deg"}, "flight.start.")
    ps = "flight.start."
    lat = _num(st, "lat_deg", ps)
    if abs(lat) >= 90.0:
        raise ValueError(f"flight.start.lat_deg: must be within (-90, 90), got {lat!r}")
    lon = _num(st, "lon_deg", ps)
    if not -180.0 <= lon <= 180.0:
        raise ValueError(f"flight.start.lon_deg: must be within [-180, 180], got {lon!r}")
    start = FlightStart(np.deg2rad(lat), np.deg2rad(lon), _num(st, "alt_m", ps),
                        _num(st, "speed_mps", ps, positive=True), np.deg2rad(_num(st, "gamma_deg", ps)),
                        np.deg2rad(_num(st, "psi_deg", ps)))
    veh = Vehicle(
        mass_kg=_num(d, "mass_kg", p, positive=True), s_ref_m2=_num(d, "s_ref_m2", p, positive=True),
        cd0=_num(d, "cd0", p, positive=True), k_induced=_num(d, "k_induced", p, positive=True),
        cl_alpha_per_rad=_num(d, "cl_alpha_per_rad", p, 1.6, positive=True),
        c_l_min=_num(d, "c_l_min", p, 0.0), c_l_max=_num(d, "c_l_max", p, 3.0, positive=True),
        bank_rate_max_radps=np.deg2rad(_num(d, "bank_rate_max_deg_s", p, 30.0, positive=True)),
        bank_time_constant_s=_num(d, "bank_time_constant_s", p, 1.0, positive=True),
        c_l_rate_max_per_s=_num(d, "c_l_rate_max_per_s", p, 1.0, positive=True),
        c_l_time_constant_s=_num(d, "c_l_time_constant_s", p, 1.0, positive=True),
        engine_isp_s=_num(d, "engine_isp_s", p, 1200.0, positive=True),
        engine_thrust_max_n=_num(d, "engine_thrust_max_n", p, 1.0e5, positive=True))
    if veh.c_l_min >= veh.c_l_max:
        raise ValueError("flight.c_l_min: must be below c_l_max")
    clp = d.get("c_l_program", 1.0)
    if isinstance(clp, (int, float)) and not isinstance(clp, bool):
        if not (np.isfinite(clp) and clp > 0):
            raise ValueError(f"flight.c_l_program: must be a positive number, got {clp!r}")
        clp = float(clp)
    else:
        ok = isinstance(clp, list) and len(clp) > 0 and all(
            isinstance(r, (list, tuple)) and len(r) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in r)
            for r in clp)
        if not ok or any(r[1] <= 0 for r in clp) or np.any(np.diff([r[0] for r in clp]) <= 0):
            raise ValueError(f"flight.c_l_program: expected a positive number or a list of [t_s, c_l] "
                             f"with increasing t_s and c_l > 0, got {clp!r}")
        clp = [[float(a), float(b)] for a, b in clp]
    mode = d.get("altitude_mode", "equilibrium_glide")
    if mode not in ("equilibrium_glide", "hold"):
        raise ValueError(f"flight.altitude_mode: expected 'equilibrium_glide' or 'hold', got {mode!r}")
    g = d.get("guidance", {})
    _check_keys(g, {"k_gamma_per_s", "k_h_per_s", "gamma_limit_deg", "n_vert_min_g", "k_speed_per_s"},
                "flight.guidance.")
    pg = "flight.guidance."
    guid = Guidance(mode, _num(g, "k_gamma_per_s", pg, 0.03, positive=True),
                    _num(g, "k_h_per_s", pg, 0.015, positive=True),
                    np.deg2rad(_num(g, "gamma_limit_deg", pg, 10.0, positive=True)),
                    _num(g, "n_vert_min_g", pg, 0.05, positive=True),
                    _num(g, "k_speed_per_s", pg, 0.05, positive=True))
    boost = None
    if d.get("boost") is not None:
        b = d["boost"]
        pb = "flight.boost."
        _check_keys(b, {"thrust_n", "burn_time_s", "mass_flow_kgps", "vertical_s", "pitch_over_s",
                        "pitch_kick_deg", "tail_off_s", "blend_s"}, pb)
        boost = Boost(_num(b, "thrust_n", pb, positive=True), _num(b, "burn_time_s", pb, positive=True),
                      _num(b, "mass_flow_kgps", pb, nonneg=True), _num(b, "vertical_s", pb, 5.0, positive=True),
                      _num(b, "pitch_over_s", pb, 10.0, positive=True),
                      np.deg2rad(_num(b, "pitch_kick_deg", pb, 3.0)), _num(b, "tail_off_s", pb, 3.0, positive=True),
                      _num(b, "blend_s", pb, 20.0, positive=True))
        if boost.vertical_s + boost.pitch_over_s >= boost.burn_time_s:
            raise ValueError("flight.boost.pitch_over_s: vertical rise + pitch-over must end before burnout")
        if boost.mass_flow_kgps * boost.burn_time_s >= veh.mass_kg:
            raise ValueError("flight.boost.mass_flow_kgps: burns more than the vehicle's mass")
    mans = []
    raw = d.get("maneuvers", [])
    if not isinstance(raw, list):
        raise ValueError(f"flight.maneuvers: expected a list, got {raw!r}")
    for i, m in enumerate(raw):
        pm = f"flight.maneuvers[{i}]."
        if not isinstance(m, dict) or "type" not in m:
            raise ValueError(f"{pm}type: missing required field")
        typ = m["type"]
        if typ not in _MAN_DEFAULTS:
            raise ValueError(f"{pm}type: unknown maneuver type {typ!r} (known: {sorted(_MAN_DEFAULTS)})")
        spec = _MAN_DEFAULTS[typ]
        _check_keys(m, {"type", "t_start_s", "t_end_s", *spec}, pm)
        t0 = _num(m, "t_start_s", pm)
        t1 = _num(m, "t_end_s", pm, duration)
        if not t1 > t0:
            raise ValueError(f"{pm}t_end_s: must be after t_start_s ({t1} <= {t0})")
        kw = {k: _num(m, k, pm, v) for k, v in spec.items()}
        if "period_s" in kw and kw["period_s"] <= 0:
            raise ValueError(f"{pm}period_s: must be > 0")
        if kw.get("ramp_s", 1.0) <= 0:
            raise ValueError(f"{pm}ramp_s: must be > 0")
        if typ in ("turn_left", "turn_right", "pull_up") and kw["load_g"] <= 0:
            raise ValueError(f"{pm}load_g: must be > 0 (the direction is in the type)")
        if typ == "dive" and kw["gamma_deg"] >= 0:
            raise ValueError(f"{pm}gamma_deg: a dive needs a negative flight-path angle")
        if "gamma_deg" in kw:
            kw["gamma_rad"] = np.deg2rad(kw.pop("gamma_deg"))
        mans.append(FlightManeuver(typ, t0, t1, **kw))
    end_speed = d.get("end_speed_mps")
    if end_speed is not None:
        end_speed = _num(d, "end_speed_mps", p, positive=True)
    end_alt = _num(d, "end_alt_m", p, 0.0) if d.get("end_alt_m", 0.0) is not None else None
    return dict(start=start, vehicle=veh, maneuvers=mans, duration_s=duration, c_l_program=clp,
                guidance=guid, boost=boost, end_speed_mps=end_speed, end_alt_m=end_alt)
