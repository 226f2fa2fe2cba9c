"""A user's trajectory as the truth source (issue 39): a file of time,
position, velocity and attitude at any rate (e.g. 10 Hz from a 6-DOF
simulation), flown like the built-in flights (``trajectory.Trajectory``,
``boost_glide.DynamicTrajectory``): ``truth(t)`` and exact
``imu_increments`` by the same navigation equations
(``trajectory.inertial_rates``) and Gauss-Legendre quadrature.

Interpolation, consistent by construction between the samples:
  * position and velocity: a cubic Hermite spline of the ECEF position
    whose derivative is the file's velocity at every sample (C1; the
    acceleration is piecewise linear), so position and velocity agree with
    the file at its epochs and with each other everywhere;
  * attitude: scipy's ``RotationSpline`` of C_b_n (C2 in the rotation
    vector), whose derivative gives the body rate omega_nb_b.
The IMU increments of an interval that does not straddle a sample are
exact integrals of the interpolated motion; the interpolation error
against the motion the file sampled is ~h^2/12 of the fourth derivative of
the position for the specific force (h the sample interval).

Checks (each a ValueError naming the first epoch that fails): times
strictly increasing and values finite; the file's velocity against its
positions (central differences at the interior samples, allowed
``vel_tolerance_mps`` + the difference's own O(h^2) term from the file's
acceleration change); its attitude against its velocity: the angle between
the body x axis and the velocity (total angle of attack, for an
aerodynamic vehicle) at most ``max_flow_angle_deg`` while faster than
``min_speed_mps`` (a quaternion in w-x-y-z order read as x-y-z-w, or NED
read as ENU, fails here).

Scenario block (instead of ``maneuvers``/``flight``)::

    trajectory_file:
      path: my_flight.csv                 # relative to the scenario file
      columns: {t: time, lat: lat_deg, lon: lon_deg, alt: alt_m, ve: v_e, vn: v_n, vu: v_u,
                qx: qx, qy: qy, qz: qz, qw: qw}       # or roll, pitch, heading
      units: {t: s, angle: deg, alt: m}   # t: s|ms; angle (lat, lon, Euler): deg|rad; alt: m|ft
      vel_tolerance_mps: 0.5
      max_flow_angle_deg: 45.0

or a bag (``bag:`` instead of ``path:``): the project's ``truth/state``
(``hyper_nav_msgs/NavState``: geodetic position, ENU velocity, q_b_enu), or
``nav_msgs/Odometry`` whose pose is in a local ENU frame at ``origin``
({lat_deg, lon_deg, alt_m}) and whose twist is in the body frame (REP 105)::

    trajectory_file: {bag: run_bag, topic: /truth/state}
    trajectory_file: {bag: vehicle_bag, topic: /odom, origin: {lat_deg: 30.0, lon_deg: 120.0, alt_m: 0.0}}
"""
from __future__ import annotations

import csv
import math
import pathlib

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation, RotationSpline

from hyper_nav_gnss import earth

from hyper_nav_filter.core.params import check_keys, unknown_field
from .trajectory import TruthSample, gauss_legendre_increments, inertial_rates

POS_VEL = ("t", "lat", "lon", "alt", "ve", "vn", "vu")
QUAT = ("qx", "qy", "qz", "qw")
EULER = ("roll", "pitch", "heading")
TOP_FIELDS = ("path", "bag", "topic", "origin", "columns", "units", "vel_tolerance_mps", "max_flow_angle_deg",
              "min_speed_mps")
ORIGIN_FIELDS = ("lat_deg", "lon_deg", "alt_m")
UNIT_CHOICES = {"t": {"s": 1.0, "ms": 1e-3}, "angle": {"deg": math.pi / 180.0, "rad": 1.0},
                "alt": {"m": 1.0, "ft": 0.3048}}


def C_n_e(lat_rad, lon_rad) -> np.ndarray:
    """(N, 3, 3) ENU -> ECEF rotations (``earth.C_n_e``, vectorised)."""
    sl, cl, so, co = np.sin(lat_rad), np.cos(lat_rad), np.sin(lon_rad), np.cos(lon_rad)
    z = np.zeros_like(sl)
    return np.stack([np.stack([-so, -sl * co, cl * co], -1), np.stack([co, -sl * so, cl * so], -1),
                     np.stack([z, cl, sl], -1)], -2)


def C_b_n_from_euler(roll, pitch, heading) -> np.ndarray:
    """Body FLU -> ENU from roll, pitch, heading (clockwise from north), as the built-in flights."""
    return Rotation.from_euler("ZYX", np.stack([np.pi / 2 - heading, -pitch, roll], -1)).as_matrix()


class _TopicArrays:
    """One topic of a bag as arrays by field path (``tp["pose.pose.position.x"]``), its header stamps and type.

    Read with ``rosbags`` (its AnyReader takes the message definitions the bag carries, ours included): a
    trajectory is a few thousand messages, so the workbench's columnar bag reader is not needed here and the
    simulator does not depend on the workbench."""

    def __init__(self, msgtype: str, msgs: list):
        self.msgtype, self._msgs = msgtype, msgs
        self.stamp_s = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in msgs], float)

    def __getitem__(self, path: str) -> np.ndarray:
        out = []
        for m in self._msgs:
            for name in path.split("."):
                m = getattr(m, name)
            out.append(m)
        return np.asarray(out, float)

    @classmethod
    def read(cls, path, topic: str) -> "_TopicArrays":
        from rosbags.highlevel import AnyReader
        path = pathlib.Path(path)
        with AnyReader([path]) as reader:
            cons = [c for c in reader.connections if c.topic == topic]
            if not cons:
                raise ValueError(f"{path}: no topic {topic!r} in the bag")
            msgs = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=cons)]
        return cls(cons[0].msgtype, msgs)


class FileTrajectory:
    def __init__(self, t_s, lat_rad, lon_rad, alt_m, vel_enu_mps, C_b_n, vel_tolerance_mps: float = 0.5,
                 max_flow_angle_deg: float = 45.0, min_speed_mps: float = 30.0, source: str = "trajectory"):
        t = np.asarray(t_s, float)
        self.source = source
        arrays = dict(t=t, lat=np.asarray(lat_rad, float), lon=np.asarray(lon_rad, float),
                      alt=np.asarray(alt_m, float), vel=np.asarray(vel_enu_mps, float), C=np.asarray(C_b_n, float))
        if len(t) < 4:
            raise ValueError(f"{source}: {len(t)} samples; need at least 4")
        for name, a in arrays.items():
            bad = ~np.isfinite(a.reshape(len(t), -1)).all(axis=1)
            if bad.any():
                raise ValueError(f"{source}: non-finite {name} at t = {t[np.argmax(bad)]:.3f} s")
        dt = np.diff(t)
        if np.any(dt <= 0):
            i = int(np.argmax(dt <= 0))
            raise ValueError(f"{source}: time not strictly increasing at t = {t[i + 1]:.3f} s (after {t[i]:.3f} s)")
        self.t0, self.t1 = float(t[0]), float(t[-1])
        r_e = earth.geodetic_to_ecef(arrays["lat"], arrays["lon"], arrays["alt"])
        Cne = C_n_e(arrays["lat"], arrays["lon"])
        v_e = np.einsum("kij,kj->ki", Cne, arrays["vel"])
        self._check_velocity(t, r_e, v_e, vel_tolerance_mps)
        self._check_flow_angle(t, arrays["vel"], arrays["C"], max_flow_angle_deg, min_speed_mps)
        self._pos = CubicHermiteSpline(t, r_e, v_e)
        self._vel = self._pos.derivative(1)
        self._acc = self._pos.derivative(2)
        self._att = RotationSpline(t, Rotation.from_matrix(arrays["C"]))

    @property
    def duration_s(self) -> float:
        return self.t1

    def _check_velocity(self, t, r_e, v_e, tol):
        """Central differences of the positions against the mean of the file's
        velocities (trapezoid: exact to O(h^2) jerk terms, bounded here by
        the file's own velocity changes)."""
        h = np.diff(t)[:, None]
        dr = np.diff(r_e, axis=0) / h                       # mean velocity over each interval
        trap = 0.5 * (v_e[1:] + v_e[:-1])
        dv = np.linalg.norm(np.diff(v_e, axis=0), axis=1)
        allowed = tol + dv / 6.0                            # trapezoid error of a steadily changing acceleration
        err = np.linalg.norm(dr - trap, axis=1)
        bad = err > allowed
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"{self.source}: position and velocity disagree between t = {t[i]:.3f} s and "
                             f"{t[i + 1]:.3f} s: the positions move at {np.linalg.norm(dr[i]):.2f} m/s, the "
                             f"velocities average {np.linalg.norm(trap[i]):.2f} m/s (difference {err[i]:.2f} m/s > "
                             f"{allowed[i]:.2f} m/s allowed)")

    def _check_flow_angle(self, t, vel_enu, C, max_deg, min_speed):
        speed = np.linalg.norm(vel_enu, axis=1)
        x_n = C[:, :, 0]
        cosang = np.einsum("ki,ki->k", x_n, vel_enu) / np.maximum(speed, 1e-12)
        ang = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
        bad = (speed > min_speed) & (ang > max_deg)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"{self.source}: attitude and velocity disagree at t = {t[i]:.3f} s: the body x axis is "
                             f"{ang[i]:.1f} deg from the velocity (> max_flow_angle_deg {max_deg:g}); check the "
                             "quaternion order (x, y, z, w) and the frames (body FLU, navigation ENU)")

    def truth(self, t) -> TruthSample:
        t = np.atleast_1d(np.asarray(t, float))
        if t.min() < self.t0 - 1e-9 or t.max() > self.t1 + 1e-9:
            raise ValueError(f"{self.source}: t outside the file's [{self.t0:g}, {self.t1:g}] s")
        r_e, v_e, a_e = self._pos(t), self._vel(t), self._acc(t)
        lat, lon, alt = earth.ecef_to_geodetic(r_e)
        Cen = np.transpose(C_n_e(lat, lon), (0, 2, 1))
        vel = np.einsum("kij,kj->ki", Cen, v_e)
        w_en = earth.omega_en_n(lat, alt, vel)
        vdot = np.einsum("kij,kj->ki", Cen, a_e) - np.cross(w_en, vel)
        rot = self._att(t)
        C = rot.as_matrix()
        # RotationSpline's first derivative is the rotation vector rate of the interpolant: in body axes here
        # (checked in the round-trip test against the built-in flight's omega_nb_b)
        omega_nb_b = self._att(t, 1)
        omega_ib_b, f_b = inertial_rates(lat, alt, vel, vdot, C, omega_nb_b)
        ypr = rot.as_euler("ZYX")
        return TruthSample(t, lat, lon, alt, vel, C, omega_ib_b, f_b, ypr[:, 2], -ypr[:, 1],
                           np.mod(np.pi / 2 - ypr[:, 0], 2 * np.pi))

    def imu_increments(self, t_end_s, dt_s):
        return gauss_legendre_increments(self.truth, t_end_s, dt_s)

    # ---- files ------------------------------------------------------------------------
    @classmethod
    def from_bag(cls, path, topic: str, origin: dict | None = None, **kw) -> "FileTrajectory":
        """From a bag's ``hyper_nav_msgs/NavState`` or ``nav_msgs/Odometry`` topic (module docstring)."""
        tp = _TopicArrays.read(path, topic)
        t = np.asarray(tp.stamp_s, float)
        src = f"{path} {topic}"
        if tp.msgtype == "hyper_nav_msgs/msg/NavState":
            q = np.stack([tp[f"q_b_enu.{c}"] for c in "xyzw"], -1)
            return cls(t, tp["lat_rad"], tp["lon_rad"], tp["alt_m"], tp["vel_enu_mps"], Rotation.from_quat(q).as_matrix(),
                       source=src, **kw)
        if tp.msgtype == "nav_msgs/msg/Odometry":
            if not origin:
                raise ValueError(f"trajectory_file.origin: needed for {tp.msgtype} (its pose is local ENU metres)")
            lat0, lon0 = math.radians(origin["lat_deg"]), math.radians(origin["lon_deg"])
            p = np.stack([tp[f"pose.pose.position.{c}"] for c in "xyz"], -1)
            r_e = earth.geodetic_to_ecef(lat0, lon0, float(origin["alt_m"])) + p @ C_n_e(np.array([lat0]),
                                                                                     np.array([lon0]))[0].T
            lat, lon, alt = earth.ecef_to_geodetic(r_e)
            q = np.stack([tp[f"pose.pose.orientation.{c}"] for c in "xyzw"], -1)
            C = Rotation.from_quat(q).as_matrix()                # body -> the local ENU frame at the origin
            v_b = np.stack([tp[f"twist.twist.linear.{c}"] for c in "xyz"], -1)
            v_loc = np.einsum("kij,kj->ki", C, v_b)
            # the local frame at the origin -> the ENU frame at each position
            R = np.einsum("kji,jl->kil", C_n_e(lat, lon), C_n_e(np.array([lat0]), np.array([lon0]))[0])
            return cls(t, lat, lon, alt, np.einsum("kij,kj->ki", R, v_loc), np.einsum("kij,kjl->kil", R, C),
                       source=src, **kw)
        raise ValueError(f"{src}: type {tp.msgtype} not flown (hyper_nav_msgs/msg/NavState or nav_msgs/msg/Odometry)")

    @classmethod
    def from_config(cls, cfg: dict, base_dir=None) -> "FileTrajectory":
        """From a scenario's ``trajectory_file`` block (module docstring)."""
        check_config(cfg)
        kw = {f: float(cfg[f]) for f in ("vel_tolerance_mps", "max_flow_angle_deg", "min_speed_mps") if f in cfg}
        if "bag" in cfg:
            bag = pathlib.Path(cfg["bag"])
            if not bag.is_absolute() and base_dir is not None:
                bag = pathlib.Path(base_dir) / bag
            return cls.from_bag(bag, cfg.get("topic", "/truth/state"), cfg.get("origin"), **kw)
        path = pathlib.Path(cfg["path"])
        if not path.is_absolute() and base_dir is not None:
            path = pathlib.Path(base_dir) / path
        cols = dict(cfg.get("columns") or {})
        units = {"t": "s", "angle": "deg", "alt": "m", **(cfg.get("units") or {})}
        data = read_csv(path, cols)
        k = {u: UNIT_CHOICES[u][units[u]] for u in UNIT_CHOICES}
        t = data["t"] * k["t"]
        lat, lon, alt = data["lat"] * k["angle"], data["lon"] * k["angle"], data["alt"] * k["alt"]
        vel = np.stack([data["ve"], data["vn"], data["vu"]], -1)
        if all(q in data for q in QUAT):
            q = np.stack([data[q] for q in QUAT], -1)
            n = np.linalg.norm(q, axis=1)
            bad = np.abs(n - 1.0) > 1e-3
            if bad.any():
                raise ValueError(f"{path}: quaternion not unit at t = {t[np.argmax(bad)]:.3f} s (norm "
                                 f"{n[np.argmax(bad)]:.4f})")
            C = Rotation.from_quat(q).as_matrix()
        else:
            C = C_b_n_from_euler(data["roll"] * k["angle"], data["pitch"] * k["angle"], data["heading"] * k["angle"])
        return cls(t, lat, lon, alt, vel, C, source=str(path), **kw)


def check_config(cfg) -> None:
    """ValueError naming the field of a bad ``trajectory_file`` block."""
    if not isinstance(cfg, dict):
        raise ValueError(f"trajectory_file: expected a mapping, got {cfg!r}")
    check_keys(cfg, TOP_FIELDS, "trajectory_file.")
    if ("path" in cfg) == ("bag" in cfg):
        raise ValueError("trajectory_file: give either path (a CSV) or bag (a rosbag2 directory)")
    if "origin" in cfg:
        o = cfg["origin"]
        if not isinstance(o, dict):
            raise ValueError("trajectory_file.origin: expected {lat_deg, lon_deg, alt_m}")
        check_keys(o, ORIGIN_FIELDS, "trajectory_file.origin.")
        for f in ORIGIN_FIELDS:
            if not isinstance(o.get(f), (int, float)):
                raise ValueError(f"trajectory_file.origin.{f}: a number is required")
    cols = cfg.get("columns") or {}
    if not isinstance(cols, dict):
        raise ValueError("trajectory_file.columns: expected a mapping {quantity: column name}")
    for key in cols:
        if key not in POS_VEL + QUAT + EULER:
            raise ValueError(unknown_field("trajectory_file.columns.", key, POS_VEL + QUAT + EULER))
    units = cfg.get("units") or {}
    for key, v in units.items():
        if key not in UNIT_CHOICES:
            raise ValueError(unknown_field("trajectory_file.units.", key, UNIT_CHOICES))
        if v not in UNIT_CHOICES[key]:
            raise ValueError(f"trajectory_file.units.{key}: {v!r} not in {sorted(UNIT_CHOICES[key])}")


def read_csv(path, columns: dict) -> dict:
    """{quantity: array} from a CSV with a header; ``columns`` maps quantities
    to header names (default: the quantity's own name). Attitude: qx qy qz qw
    if present, else roll pitch heading. A row that cannot be read is an
    error naming its line (a trajectory with a hole is not flown)."""
    path = pathlib.Path(path)
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if len(rows) < 2:
        raise ValueError(f"{path}: no data rows")
    header = [h.strip() for h in rows[0]]
    name = {q: columns.get(q, q) for q in POS_VEL + QUAT + EULER}
    att = QUAT if all(name[q] in header for q in QUAT) else EULER
    need = POS_VEL + att
    missing = [f"{q} ({name[q]!r})" for q in need if name[q] not in header]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}; header: {header} (map names with columns:)")
    idx = {q: header.index(name[q]) for q in need}
    out = {q: np.empty(len(rows) - 1) for q in need}
    for j, r in enumerate(rows[1:]):
        try:
            for q in need:
                out[q][j] = float(r[idx[q]])
        except (ValueError, IndexError):
            raise ValueError(f"{path}: line {j + 2} cannot be read ({r!r})") from None
    return out


def write_csv(path, traj, t_s, quaternion: bool = True) -> None:
    """A trajectory's truth at ``t_s`` as a file this module reads (degrees)."""
    tr = traj.truth(t_s)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        att = list(QUAT) if quaternion else list(EULER)
        w.writerow(["t", "lat", "lon", "alt", "ve", "vn", "vu"] + att)
        q = Rotation.from_matrix(tr.C_b_n).as_quat()
        for i in range(len(tr.t_s)):
            a = list(q[i]) if quaternion else [math.degrees(tr.roll_rad[i]), math.degrees(tr.pitch_rad[i]),
                                               math.degrees(tr.heading_rad[i])]
            w.writerow([repr(float(tr.t_s[i])), repr(math.degrees(tr.lat_rad[i])), repr(math.degrees(tr.lon_rad[i])),
                        repr(float(tr.alt_m[i]))] + [repr(float(x)) for x in tr.vel_enu_mps[i]] + [repr(float(x)) for x in a])
