"""The filter's initial state, declared once (``core.params``).

The same declarations are the fusion node's ``init.*`` ROS parameters, a
scenario's optional ``filter.initial_state`` block and the ``initial_state``
of a setup file written for imported data (``hyper_nav_workbench.core.importer``).
Besides position, velocity and attitude they carry the initial *values* of
the IMU error blocks (biases, scale factors: a calibration, or the end of a
previous run); the initial *sigmas* are filter parameters
(``init_*_sigma*``, core.blocks). Attitude and velocity may be given the way
other tools write them (aliases): Euler angles roll/pitch/heading (deg, the
aerospace angles of README "Frames") and NED velocity.
No rclpy here.
"""
from __future__ import annotations

import math

import numpy as np

from . import units
from .attitude import C_b_n_to_euler, C_to_quat_xyzw, euler_to_C_b_n, quat_xyzw_to_C
from .nav_state import NavState
from .params import FLOAT, FLOATS, Alias, ConfigError, ParamSpec, check_all, with_aliases

_MGAL_IN_UG = 1e-5 / float(units.ug(1.0))


def _rph_to_q(rph_deg):
    r, p, h = np.deg2rad(rph_deg)
    return tuple(float(x) for x in C_to_quat_xyzw(euler_to_C_b_n(r, p, h)))


def _ned_to_enu(v):
    return (v[1], v[0], -v[2])


_VEL_NED = Alias(ParamSpec("vel_ned_mps", FLOATS, (0.0, 0.0, 0.0), "initial velocity, NED (m/s); alternative "
                           "to vel_enu_mps", length=3), _ned_to_enu)
_RPH = Alias(ParamSpec("roll_pitch_heading_deg", FLOATS, (0.0, 0.0, 0.0), "initial roll, pitch, heading (deg; "
                       "aerospace angles of body FRD w.r.t. NED, = README Frames); alternative to q_b_enu_xyzw",
                       length=3), _rph_to_q)

INIT_PARAMS = (
    ParamSpec("t_s", FLOAT, 0.0, "epoch of the initial state (the data's time scale, s)"),
    ParamSpec("lat_deg", FLOAT, 0.0, "initial latitude (deg)", lo=-90.0, hi=90.0),
    ParamSpec("lon_deg", FLOAT, 0.0, "initial longitude (deg)", lo=-360.0, hi=360.0),
    ParamSpec("alt_m", FLOAT, 0.0, "initial height above the WGS-84 ellipsoid (m)"),
    ParamSpec("vel_enu_mps", FLOATS, (0.0, 0.0, 0.0), "initial velocity w.r.t. Earth, ENU (m/s)", length=3,
              aliases=(_VEL_NED,)),
    ParamSpec("q_b_enu_xyzw", FLOATS, (0.0, 0.0, 0.0, 1.0), "initial attitude body(FLU) -> ENU, quaternion "
              "(x, y, z, w)", length=4, aliases=(_RPH,)),
    with_aliases(ParamSpec("gyro_bias_deg_per_hr", FLOATS, (0.0, 0.0, 0.0), "initial gyro bias estimate, body FLU "
                           "(deg/h)", length=3), ("gyro_bias_rad_per_s", 1.0 / float(units.deg_per_hr(1.0)), "rad/s")),
    with_aliases(ParamSpec("accel_bias_ug", FLOATS, (0.0, 0.0, 0.0), "initial accelerometer bias estimate, body FLU "
                           "(ug)", length=3), ("accel_bias_mgal", _MGAL_IN_UG, "mGal"),
                 ("accel_bias_mps2", 1.0 / float(units.ug(1.0)), "m/s^2")),
    ParamSpec("gyro_scale_factor_ppm", FLOATS, (0.0, 0.0, 0.0), "initial gyro scale-factor estimate, body FLU (ppm)",
              length=3),
    ParamSpec("accel_scale_factor_ppm", FLOATS, (0.0, 0.0, 0.0), "initial accelerometer scale-factor estimate, "
              "body FLU (ppm)", length=3),
    ParamSpec("clock_bias_m", FLOAT, 0.0, "initial receiver clock bias estimate (m; the clk block), e.g. from a "
              "single-point solution: a u-blox receiver's can be hundreds of km"),
    ParamSpec("clock_drift_mps", FLOAT, 0.0, "initial receiver clock drift estimate (m/s; the clk block)"),
    ParamSpec("isb_m", FLOATS, (0.0, 0.0, 0.0), "initial inter-system bias estimates Galileo, BeiDou, QZSS vs GPS "
              "(m; the isb block)", length=3),
)
INIT_BY_NAME = {p.name: p for p in INIT_PARAMS}
REQUIRED_WITHOUT_BASE = ("lat_deg", "lon_deg", "alt_m")


def initial_state(values: dict) -> NavState:
    """NavState from checked values ({name: value} of INIT_PARAMS, declared
    units); scale factors go to ``extra`` ("sg", "sa"), used when the layout
    has those blocks."""
    q = np.asarray(values["q_b_enu_xyzw"], float)
    n = float(np.linalg.norm(q))
    if not math.isfinite(n) or n < 1e-9:
        raise ConfigError(f"q_b_enu_xyzw: not a rotation quaternion: {list(q)}")
    nav = NavState(float(values["t_s"]), math.radians(values["lat_deg"]), math.radians(values["lon_deg"]),
                   float(values["alt_m"]), np.asarray(values["vel_enu_mps"], float), quat_xyzw_to_C(q / n),
                   gyro_bias_b_radps=units.deg_per_hr(values["gyro_bias_deg_per_hr"]),
                   accel_bias_b_mps2=units.ug(values["accel_bias_ug"]))
    nav.extra["sg"] = np.asarray(values["gyro_scale_factor_ppm"], float) * 1e-6
    nav.extra["sa"] = np.asarray(values["accel_scale_factor_ppm"], float) * 1e-6
    nav.extra["clk"] = np.array([float(values["clock_bias_m"]), float(values["clock_drift_mps"])])
    nav.extra["isb"] = np.asarray(values["isb_m"], float)
    return nav


def state_values(nav: NavState) -> dict:
    """The inverse of :func:`initial_state`: declared-unit values of a NavState
    (ROS-ready lists), e.g. to write the fusion node's ``init.*`` parameters."""
    zero = np.zeros(3)
    return {
        "t_s": float(nav.t_s), "lat_deg": math.degrees(nav.lat_rad), "lon_deg": math.degrees(nav.lon_rad),
        "alt_m": float(nav.alt_m), "vel_enu_mps": [float(x) for x in nav.vel_enu_mps],
        "q_b_enu_xyzw": [float(x) for x in C_to_quat_xyzw(nav.C_b_n)],
        "gyro_bias_deg_per_hr": [float(x) for x in np.asarray(nav.gyro_bias_b_radps) / units.deg_per_hr(1.0)],
        "accel_bias_ug": [float(x) for x in np.asarray(nav.accel_bias_b_mps2) / units.ug(1.0)],
        "gyro_scale_factor_ppm": [float(x) for x in np.asarray(nav.extra.get("sg", zero)) * 1e6],
        "accel_scale_factor_ppm": [float(x) for x in np.asarray(nav.extra.get("sa", zero)) * 1e6],
        "clock_bias_m": float(np.asarray(nav.extra.get("clk", np.zeros(2)))[0]),
        "clock_drift_mps": float(np.asarray(nav.extra.get("clk", np.zeros(2)))[1]),
        "isb_m": [float(x) for x in np.asarray(nav.extra.get("isb", zero))],
    }


def from_block(block: dict | None, base: NavState | None = None, where: str = "initial_state.") -> NavState:
    """The initial state of a ``filter.initial_state`` block: its fields over
    ``base`` (e.g. a simulated scenario's truth plus scripted error), or, with
    no base, the block alone (``lat_deg``, ``lon_deg``, ``alt_m`` required;
    velocity, attitude and IMU errors default to zero/identity)."""
    block = dict(block or {})
    if base is None:
        missing = [n for n in REQUIRED_WITHOUT_BASE if n not in block]
        if missing:
            raise ConfigError(f"{where}{missing[0]}: required (no simulated truth to start from)")
        values = check_all(INIT_PARAMS, block, where)
    else:
        given = check_all(INIT_PARAMS, block, where)
        explicit = set(block) | {s.name for s in INIT_PARAMS for a in s.aliases if a.name in block}
        values = {**state_values(base), **{k: v for k, v in given.items() if k in explicit}}
    return initial_state(values)


def euler_deg(nav: NavState) -> tuple[float, float, float]:
    """(roll, pitch, heading) in degrees of a NavState's attitude."""
    return tuple(float(math.degrees(a)) for a in C_b_n_to_euler(nav.C_b_n))
