"""Configuration layer of ``DynamicTrajectory``: plain dicts (a scenario
YAML's ``flight:`` section) -> constructor arguments, and example flights
from the seed papers.

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
        glide       (no parameters: equilibrium glide, the default mode; for timetables)
        accelerate  delta_speed_mps, ramp_s 5              speed-hold engine, speed ramps
        cruise      ramp_s 5                               speed-hold engine at the reference
"""
from __future__ import annotations

import copy

import numpy as np

from .fields import check_keys

_MISSING = object()


def _num(d, key, path, default=_MISSING, positive=False, nonneg=False):
    if key not in d:
        if default is _MISSING:
            raise ValueError(f"{path}{key}: missing required field")
        return default
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ValueError(f"{path}{key}: expected a number, got {v!r}")
    if positive and not v > 0:
        raise ValueError(f"{path}{key}: must be > 0, got {v!r}")
    if nonneg and v < 0:
        raise ValueError(f"{path}{key}: must be >= 0, got {v!r}")
    return float(v)


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
    "glide": {"ramp_s": 5.0},
    "accelerate": {"delta_speed_mps": _MISSING, "ramp_s": 5.0},
    "cruise": {"ramp_s": 5.0},
}


def parse_flight(d: dict) -> dict:
    """Validate a flight dict and return ``DynamicTrajectory`` keyword arguments."""
    from .boost_glide import Boost, FlightManeuver, FlightStart, Guidance, Vehicle
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
        if typ in ("turn_left", "turn_right") and kw["load_g"] <= 0:
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


# ---------------------------------------------------------------------------
# Example flights. Vehicle: CAV-H, the data set seed 002 trains on (its ref.
# [24]): 907 kg, S_ref 0.4839 m^2 (public CAV-H numbers). C_D0 = 0.045 and
# K = 0.62 are our choice (the paper gives none): C_L* = 0.269, E* = 2.99,
# a typical maximum L/D of a hypersonic glider. cl_alpha 1.6 /rad puts
# alpha* (c_l = 1) at 9.6 deg; c_l_max = 3.5 is alpha = 34 deg (upper end of
# a linear lift curve, needed for the paper's 3-5 g lateral loads).
CAV_H = {"mass_kg": 907.0, "s_ref_m2": 0.4839, "cd0": 0.045, "k_induced": 0.62,
         "cl_alpha_per_rad": 1.6, "c_l_max": 3.5}

# Seed 002 Table 1 initial conditions; v_f = 2000 m/s is the terminal speed.
# Physics note: the paper's sustained 3 g / 5 g lateral loads cost drag
# D = L/(L/D) >= 1 g with L/D <= E* = 3, i.e. >= 10 m/s^2 of deceleration,
# so the flights reach v_f = 2000 m/s before the end of the paper's maneuver
# windows (the flight then ends: ``duration_s`` is the time at v_f).
# Nominal c_l well below 1 (glide below the max-L/D altitude, at 3-4 times
# the dynamic pressure) is our choice so that the 3 g and 5 g loads fit under
# c_l_max: in an equilibrium glide the lift is only (1 - V^2/(g r)) g, so a
# lateral load of n g needs c_l ~ c_l_nom n / (1 - V^2/(g r)).
_SEED002_START = {"lat_deg": 0.0, "lon_deg": 0.0, "alt_m": 60000.0, "speed_mps": 7010.0,
                  "gamma_deg": -1.0, "psi_deg": 90.0}
SEED002_SCENARIO1 = {
    "name": "seed002_scenario1",
    "description": "QEG with varying c_l; lateral 3 g CA maneuver 701-1300 s",
    **CAV_H, "duration_s": 2500.0, "end_speed_mps": 2000.0, "start": dict(_SEED002_START),
    # "varying normalized lift coefficient": our program, 0.35 -> 0.2
    # (the lower c_l, the denser the glide air and the more lift margin
    # for the 3 g turn under c_l_max; see the note above)
    "c_l_program": [[0.0, 0.35], [600.0, 0.2]],
    "maneuvers": [{"type": "lateral_ca", "t_start_s": 701.0, "t_end_s": 1300.0, "load_g": 3.0}],
}
SEED002_SCENARIO2 = {
    "name": "seed002_scenario2",
    "description": "QEG with constant c_l; 1 g square wave 0-1200 s, 5 g evasive 1201-1800 s",
    **CAV_H, "duration_s": 2500.0, "end_speed_mps": 2000.0, "start": dict(_SEED002_START),
    "c_l_program": 0.3,
    # square-wave period not in the paper: 200 s (100 s per side, a heading
    # swing of a few degrees at these speeds); the evasive weave: 60 s period
    "maneuvers": [{"type": "square_wave", "t_start_s": 0.0, "t_end_s": 1200.0, "load_g": 1.0,
                   "period_s": 200.0},
                  {"type": "evasive", "t_start_s": 1201.0, "t_end_s": 1800.0, "load_g": 5.0,
                   "period_s": 60.0}],
}
SEED002_SCENARIO3 = {
    "name": "seed002_scenario3",
    "description": "QEG with varying c_l; 3 g CA 401-800 s, 5 g evasive after 1501 s",
    **CAV_H, "duration_s": 2500.0, "end_speed_mps": 2000.0, "start": dict(_SEED002_START),
    "c_l_program": [[0.0, 0.35], [350.0, 0.2]],
    "maneuvers": [{"type": "lateral_ca", "t_start_s": 401.0, "t_end_s": 800.0, "load_g": 3.0},
                  {"type": "evasive", "t_start_s": 1501.0, "load_g": 5.0, "period_s": 60.0}],
}

# Seed 003 section 4: glide at 25 km and 2000 m/s inside 40-48N 109-112E,
# 790 s: accelerate, climb, glide at constant speed, turn left, turn right.
# The paper gives no timetable, start point or heading: start at 41N 110.5E
# heading north (to stay inside the magnetic map), altitude hold with a
# speed-hold air-breathing engine (a 907 kg CAV-H loses ~3 m/s^2 to drag at
# 25 km / Mach 6.8, so "constant speed" needs thrust); +200 m/s, +3 km climb,
# 2 g turns of 100 s (about 33 deg each at ~2.2 km/s).
SEED003 = {
    "name": "seed003_glide_25km",
    "description": "25 km, 2000 m/s, 790 s: accelerate / climb / glide / turn left / turn right",
    **CAV_H, "duration_s": 790.0, "altitude_mode": "hold",
    "start": {"lat_deg": 41.0, "lon_deg": 110.5, "alt_m": 25000.0, "speed_mps": 2000.0,
              "gamma_deg": 0.0, "psi_deg": 0.0},
    "engine_thrust_max_n": 30000.0,
    "maneuvers": [
        # engine on over the whole flight (window edges outside [0, 790] s)
        {"type": "cruise", "t_start_s": -10.0, "t_end_s": 800.0},
        {"type": "accelerate", "t_start_s": 50.0, "t_end_s": 150.0, "delta_speed_mps": 200.0},
        {"type": "climb", "t_start_s": 200.0, "t_end_s": 300.0, "delta_alt_m": 3000.0},
        {"type": "glide", "t_start_s": 300.0, "t_end_s": 450.0},
        {"type": "turn_left", "t_start_s": 450.0, "t_end_s": 560.0, "load_g": 2.0, "ramp_s": 10.0},
        {"type": "turn_right", "t_start_s": 620.0, "t_end_s": 730.0, "load_g": 2.0, "ramp_s": 10.0},
    ],
}

# Seed 004: boost-glide from (26.5N, 119E), 500 s; the paper only gives the
# point-mass equations (its eq. 12) and the start point. Our choices: launch
# azimuth 60 deg (out to sea), a solid booster giving ~Mach 8 at burnout
# (the paper: glide "generally not below Ma 7"), no stage separation
# (the spent case stays on: mass after burnout 1400 kg), glide at c_l 0.8.
SEED004 = {
    "name": "seed004_boost_glide",
    "description": "boost-glide from 26.5N 119E, 500 s (vertical launch, pull-up, glide)",
    "mass_kg": 5000.0, "s_ref_m2": 0.8, "cd0": 0.045, "k_induced": 0.62, "cl_alpha_per_rad": 1.6,
    "c_l_max": 3.0, "duration_s": 500.0, "c_l_program": 0.8,
    "start": {"lat_deg": 26.5, "lon_deg": 119.0, "alt_m": 20.0, "speed_mps": 30.0,
              "gamma_deg": 90.0, "psi_deg": 60.0},
    "boost": {"thrust_n": 165000.0, "burn_time_s": 58.0, "mass_flow_kgps": 60.0, "vertical_s": 4.0,
              "pitch_over_s": 30.0, "pitch_kick_deg": 26.0, "tail_off_s": 3.0, "blend_s": 20.0},
}

# Seed 001 (Chen et al., LCI SINS/BDS) boost-glide HWIL trajectory: its
# Table 1 values are not in our copy of the text; launch site near Xi'an as in
# its vehicle test (34.2N 108.8E), azimuth 90 deg, 560 s. Booster sized for a
# ~Mach 13 burnout at 25 km (mass ratio 4, Isp ~ 280 s); a short coast to
# 43 km (specific force 0.15-0.4 g from 100 to 160 s), pull-up, glide from
# 43 to 33 km with a 1.5 g S-turn weave (period 90 s), terminal dive at 470 s. Depressed rather than lofted: the
# first version (pitch kick 30 deg) coasted to 83 km for 220 s at zero g,
# where tilt about the velocity and the roll-axis gyro bias are unobservable
# from position/velocity fixes (attitude error 0.1-0.3 deg until re-entry).
SEED001 = {
    "name": "seed001_vertical_launch",
    "description": "vertical launch, pitch-over, gravity turn, short coast, pull-up, weaving glide, dive",
    "mass_kg": 8000.0, "s_ref_m2": 1.0, "cd0": 0.045, "k_induced": 0.62, "cl_alpha_per_rad": 1.6,
    "c_l_max": 3.0, "duration_s": 560.0, "c_l_program": 0.8,
    "start": {"lat_deg": 34.2, "lon_deg": 108.8, "alt_m": 400.0, "speed_mps": 30.0,
              "gamma_deg": 90.0, "psi_deg": 90.0},
    "boost": {"thrust_n": 260000.0, "burn_time_s": 75.0, "mass_flow_kgps": 90.0, "vertical_s": 4.0,
              "pitch_over_s": 30.0, "pitch_kick_deg": 31.5, "tail_off_s": 3.0, "blend_s": 20.0},
    # terminal dive window ends beyond the flight: no recovery
    "maneuvers": [{"type": "s_turn", "t_start_s": 180.0, "t_end_s": 460.0, "load_g": 1.5, "period_s": 90.0},
                  {"type": "dive", "t_start_s": 470.0, "t_end_s": 700.0, "gamma_deg": -30.0}],
}

FLIGHTS = {f["name"]: f for f in (SEED002_SCENARIO1, SEED002_SCENARIO2, SEED002_SCENARIO3,
                                  SEED003, SEED004, SEED001)}


def example_flight(name: str) -> dict:
    """A deep copy of one of the example flight dicts (see ``FLIGHTS``)."""
    if name not in FLIGHTS:
        raise ValueError(f"unknown example flight {name!r} (known: {sorted(FLIGHTS)})")
    return copy.deepcopy(FLIGHTS[name])
