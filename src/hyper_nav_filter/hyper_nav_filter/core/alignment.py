"""Initial alignment from the data: the filter's starting attitude, velocity,
gyro bias and their 1-sigma, with no truth to start from. No rclpy.

Frames as everywhere (README "Frames"): body FLU, navigation ENU, ``C_b_n``
body -> ENU. Inputs are mean rates over the IMU intervals (omega_ib_b in
rad/s, f_ib_b in m/s^2; increments / interval).

Method (which one is used is reported in ``Alignment.method``):

1. **Levelling** over a static (or constant-velocity) window at the start
   of the data: roll and pitch from the mean specific force, which is then
   the reaction to gravity (Groves 2nd ed. eq. 5.101, written for FLU):

       roll = atan2(f_y, f_z),   pitch = atan2(f_x, sqrt(f_y^2 + f_z^2)).

2. **Heading**, either
   * ``gyrocompass`` (static window only): the horizontal Earth rate in the
     levelled frame h (heading 0), omega_h = Rz(heading) (0, W cos L, .),
     gives heading = atan2(-omega_h,x, omega_h,y) (Groves eq. 5.103;
     Titterton & Weston 2nd ed. sec. 10.3). Used only when the IMU grade
     allows it: the predicted heading sigma
     sqrt(sigma_bg^2 + sigma_mean^2) / (W cos L) (+ tan L x tilt sigma,
     Titterton eq. 10.16) must be below ``max_gyrocompass_sigma_deg``; a
     navigation-grade unit (0.01 deg/h) gets ~0.05 deg, a MEMS unit
     (0.2 deg/s = 720 deg/h bias) could not find north at all.
   * ``gnss_velocity`` otherwise: the attitude of the levelled frame is
     carried on the gyros (their static-window mean removed as the bias
     estimate) from the end of the window to the first GNSS velocity whose
     horizontal speed exceeds ``speed_threshold_mps``; there the body x axis
     is taken along the course, heading = atan2(v_E, v_N) minus the body's
     heading in the carried frame (the body moves forward: a vehicle, or a
     handheld unit pointed where the walker goes; ``course_sigma_deg`` is
     the declared spread of that assumption). The filter starts there, at
     that IMU epoch, with the GNSS velocity. A window in motion is levelled
     to the direction of the specific force the GNSS velocities predict,
     dv/dt + (2 w_ie + w_en) x v - g (Groves eq. 5.54), not to the vertical:
     at 1700 m/s the Coriolis and transport terms tilt it by ~0.1 deg and
     any acceleration by a / g.

Initial 1-sigma from the alignment's own residuals: the standard error of
each mean is taken from the scatter of ``n_blocks`` block means (vibration
and coloured noise included, unlike sigma / sqrt(n)), added in quadrature
to what the data cannot show: the accelerometer bias (tilt: b_a / g) and
the gyro bias (heading: b_g / (W cos L)), from the declared IMU grade.
The tilt sigma is given on the east and north axes alike (the larger of
roll and pitch), the heading sigma on the up axis: ``init_att_sigma_deg``.
Carried attitude adds the gyro-bias residual x elapsed time and the ARW.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_gnss import earth
from .attitude import C_b_n_to_euler, C_to_quat_xyzw, euler_to_C_b_n, rotvec_to_C

__all__ = ["ImuGrade", "Alignment", "AlignmentError", "level", "gyrocompass_heading", "sigma_of_mean", "align"]


class AlignmentError(ValueError):
    """The data do not allow an alignment (the message says why)."""


@dataclass(frozen=True)
class ImuGrade:
    """What the IMU can do, in SI: turn-on bias 1-sigma per axis and the
    white-noise densities (rad/s/sqrt(Hz) = rad/sqrt(s); m/s^2/sqrt(Hz))."""
    accel_bias_sigma_mps2: float
    gyro_bias_sigma_radps: float
    gyro_arw_radps_per_sqrt_hz: float = 0.0
    accel_vrw_mps2_per_sqrt_hz: float = 0.0


@dataclass
class Alignment:
    """The result: state at ``t_s`` (an IMU stamp) and its 1-sigma."""
    t_s: float
    C_b_n: np.ndarray
    vel_enu_mps: np.ndarray
    att_sigma_enu_rad: np.ndarray          # (tilt E, tilt N, heading U)
    vel_sigma_enu_mps: np.ndarray
    gyro_bias_b_radps: np.ndarray
    gyro_bias_sigma_radps: np.ndarray
    method: str                            # gyrocompass | gnss_velocity
    static: bool
    window_s: tuple
    info: dict = field(default_factory=dict)

    @property
    def roll_pitch_heading_rad(self) -> tuple:
        return C_b_n_to_euler(self.C_b_n)

    def initial_state_fields(self) -> dict:
        """``filter.initial_state`` fields (core.initial_state units)."""
        return {"t_s": float(self.t_s), "q_b_enu_xyzw": [float(x) for x in C_to_quat_xyzw(self.C_b_n)],
                "vel_enu_mps": [float(x) for x in self.vel_enu_mps],
                "gyro_bias_deg_per_hr": [float(x) for x in np.degrees(self.gyro_bias_b_radps) * 3600.0]}

    def config_fields(self) -> dict:
        """``filter.config`` prior sigmas from the alignment (core.blocks units)."""
        return {"init_att_sigma_arcmin": [float(x) for x in np.degrees(self.att_sigma_enu_rad) * 60.0],
                "init_vel_sigma_mps": [float(max(x, 1e-3)) for x in self.vel_sigma_enu_mps],
                "init_gyro_bias_sigma_deg_per_hr": [float(x) for x in np.degrees(self.gyro_bias_sigma_radps) * 3600]}


def level(f_b_mps2) -> tuple[float, float]:
    """Roll and pitch (rad) of body FLU from the mean specific force (Groves eq. 5.101, FLU form)."""
    fx, fy, fz = (float(x) for x in f_b_mps2)
    return math.atan2(fy, fz), math.atan2(fx, math.hypot(fy, fz))


def gyrocompass_heading(C_b_h, omega_b_radps) -> float:
    """Heading (rad, clockwise from north) from the Earth rate seen by a
    static IMU; ``C_b_h`` is the levelled attitude at heading 0 (Groves eq. 5.103)."""
    w_h = np.asarray(C_b_h) @ np.asarray(omega_b_radps, float)
    return math.atan2(-w_h[0], w_h[1]) % (2 * math.pi)


def sigma_of_mean(x, n_blocks: int = 10) -> np.ndarray:
    """Standard error of the column means of ``x`` (n, k) from the scatter of
    ``n_blocks`` block means: std(block means) / sqrt(n_blocks). Coloured
    noise and vibration show up in it, which sigma / sqrt(n) would miss."""
    x = np.asarray(x, float)
    nb = max(2, min(n_blocks, len(x) // 2))
    m = np.array([b.mean(axis=0) for b in np.array_split(x, nb)])
    return m.std(axis=0, ddof=1) / math.sqrt(nb)


def _heading_in(C_b_h) -> float:
    """Heading of the body x axis in a levelled frame taken as ENU."""
    x = np.asarray(C_b_h)[:, 0]
    return math.atan2(x[0], x[1])


def _rotation_between(a, b) -> np.ndarray:
    """The smallest rotation taking unit vector a to unit vector b (Rodrigues)."""
    v = np.cross(a, b)
    s, c = float(np.linalg.norm(v)), float(a @ b)
    if s < 1e-15:
        return np.eye(3)
    return rotvec_to_C(v / s * math.atan2(s, c))


def _Rz_heading(dpsi_rad: float) -> np.ndarray:
    """Rotation of ENU about up that adds ``dpsi_rad`` to every heading (clockwise)."""
    c, s = math.cos(dpsi_rad), math.sin(dpsi_rad)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def align(t_s, omega_b_radps, f_b_mps2, lat_rad: float, alt_m: float, grade: ImuGrade,
          gnss_t_s=None, gnss_vel_enu_mps=None, gnss_vel_sigma_mps=None, window_s: float = 5.0,
          speed_threshold_mps: float = 1.0, static_speed_mps: float = 0.3, max_gyrocompass_sigma_deg: float = 3.0,
          course_sigma_deg: float = 0.0, n_blocks: int = 10) -> Alignment:
    """Align on the IMU samples ``t_s`` (n,) with mean rates over the
    intervals ending there (``omega_b_radps``, ``f_b_mps2``, (n, 3)) and,
    when given, GNSS velocities (``gnss_t_s`` (m,), ENU m/s (m, 3), 1-sigma
    per axis (m,) or (m, 3)). See the module docstring for the method. The
    window is [t_s[0], t_s[0] + window_s]; it counts as static when every
    GNSS speed in it is below ``static_speed_mps`` (no GNSS in it: static)."""
    t = np.asarray(t_s, float)
    w = np.asarray(omega_b_radps, float)
    f = np.asarray(f_b_mps2, float)
    if len(t) < 2 * n_blocks:
        raise AlignmentError(f"alignment: {len(t)} IMU samples, need at least {2 * n_blocks}")
    m = t <= t[0] + window_s + 1e-9
    if m.sum() < 2 * n_blocks:
        raise AlignmentError(f"alignment: {int(m.sum())} IMU samples in the {window_s:g} s window, need "
                             f"{2 * n_blocks}")
    k_end = int(np.flatnonzero(m)[-1])
    f_mean, w_mean = f[m].mean(axis=0), w[m].mean(axis=0)
    f_sem, w_sem = sigma_of_mean(f[m], n_blocks), sigma_of_mean(w[m], n_blocks)
    g_mps2 = float(np.linalg.norm(f_mean))
    if not 0.5 * earth.G0_MPS2 < g_mps2 < 1.5 * earth.G0_MPS2:
        raise AlignmentError(f"alignment: mean specific force {g_mps2:.3f} m/s^2 over the first {window_s:g} s "
                             "is not gravity: check the accelerometer unit and the window")
    roll, pitch = level(f_mean)
    # tilt 1-sigma: pitch from the x axis, roll from the y axis (near level), accelerometer bias beside the noise
    s_pitch = math.hypot(f_sem[0], grade.accel_bias_sigma_mps2) / g_mps2
    s_roll = math.hypot(f_sem[1], grade.accel_bias_sigma_mps2) / g_mps2
    s_tilt = max(s_pitch, s_roll)
    C_b_h = euler_to_C_b_n(roll, pitch, 0.0)

    gv = None if gnss_t_s is None else np.asarray(gnss_t_s, float)
    static = True
    if gv is not None and len(gv):
        vel = np.asarray(gnss_vel_enu_mps, float)
        in_win = (gv >= t[0] - 1e-9) & (gv <= t[k_end] + 1e-9)
        static = bool(np.all(np.linalg.norm(vel[in_win, :2], axis=1) < static_speed_mps)) if in_win.any() else True

    W_cosL = earth.OMEGA_IE_RADPS * math.cos(lat_rad)
    s_w_h = math.hypot(float(np.hypot(w_sem[0], w_sem[1])) / math.sqrt(2.0), grade.gyro_bias_sigma_radps)
    s_heading_gc = math.hypot(s_w_h / W_cosL, math.tan(lat_rad) * s_tilt)
    info = {"f_mean_b_mps2": f_mean.tolist(), "omega_mean_b_radps": w_mean.tolist(), "f_sem_b_mps2": f_sem.tolist(),
            "omega_sem_b_radps": w_sem.tolist(), "gyrocompass_sigma_deg": math.degrees(s_heading_gc),
            "n_window": int(m.sum())}
    if static and math.degrees(s_heading_gc) < max_gyrocompass_sigma_deg:
        heading = gyrocompass_heading(C_b_h, w_mean)
        C_b_n = euler_to_C_b_n(roll, pitch, heading)
        return Alignment(float(t[k_end]), C_b_n, np.zeros(3), np.array([s_tilt, s_tilt, s_heading_gc]),
                         np.full(3, 0.01), np.zeros(3), np.full(3, grade.gyro_bias_sigma_radps), "gyrocompass",
                         True, (float(t[0]), float(t[k_end])), info)

    # heading from the first GNSS velocity above the threshold; carry the levelled frame on the gyros
    if gv is None or not len(gv):
        raise AlignmentError("alignment: the IMU cannot gyrocompass (predicted heading sigma "
                             f"{math.degrees(s_heading_gc):.1f} deg) and no GNSS velocity was given")
    vel = np.asarray(gnss_vel_enu_mps, float)
    sig = np.asarray(0.1 if gnss_vel_sigma_mps is None else gnss_vel_sigma_mps, float)
    vs = np.full((len(gv), 3), float(sig)) if sig.ndim == 0 else (
        np.repeat(sig[:, None], 3, axis=1) if sig.ndim == 1 else sig)
    speed = np.linalg.norm(vel[:, :2], axis=1)
    cand = np.flatnonzero((speed > speed_threshold_mps) & (gv >= t[k_end]) & (gv <= t[-1]))
    if not len(cand):
        raise AlignmentError(f"alignment: no GNSS velocity above {speed_threshold_mps:g} m/s after the "
                             f"{window_s:g} s window: heading unknown")
    j = int(cand[0])
    k_g = int(np.searchsorted(t, gv[j], side="right") - 1)
    # gyro bias estimate: the static window's mean rate minus the Earth rate's vertical part (heading-free);
    # its horizontal part (W cos L) stays in the sigma
    if static:
        up_b = C_b_h.T @ np.array([0.0, 0.0, earth.OMEGA_IE_RADPS * math.sin(lat_rad)])
        bg = w_mean - up_b
        s_bg = np.sqrt(w_sem**2 + W_cosL**2)
    else:
        bg, s_bg = np.zeros(3), np.full(3, grade.gyro_bias_sigma_radps)
    C = C_b_h.copy()
    dt = np.diff(t[k_end:k_g + 1])
    for kk, h in enumerate(dt):
        C = C @ rotvec_to_C((w[k_end + 1 + kk] - bg) * h)
    carried_s = float(t[k_g] - t[k_end])
    # in motion the mean specific force is not the reaction to gravity alone: f_n = dv/dt + (2 w_ie + w_en) x v - g
    # (Groves eq. 5.54 with the GNSS velocities of the window); level to its direction instead of the vertical
    tilt_fix, s_acc = None, 0.0
    in_win = (gv >= t[0] - 1e-9) & (gv <= t[k_end] + 1e-9)
    if not static and in_win.sum() >= 2:
        tw, vw = gv[in_win], vel[in_win]
        a_n = (vw[-1] - vw[0]) / (tw[-1] - tw[0])
        v_m = vw.mean(axis=0)
        f_n = a_n + np.cross(2 * earth.omega_ie_n(lat_rad) + earth.omega_en_n(lat_rad, alt_m, v_m), v_m) \
            - earth.gravity_n(lat_rad, alt_m)
        tilt_fix = _rotation_between(np.array([0.0, 0.0, 1.0]), f_n / np.linalg.norm(f_n))
        s_acc = math.sqrt(2.0) * float(np.max(vs[in_win, :2])) / (tw[-1] - tw[0])
        info["window_f_n_mps2"] = f_n.tolist()
    s_carry = math.hypot(float(np.max(s_bg)) * carried_s, grade.gyro_arw_radps_per_sqrt_hz * math.sqrt(carried_s))
    course = math.atan2(vel[j, 0], vel[j, 1])
    heading_h = _heading_in(C)
    C_b_n = _Rz_heading(course - heading_h) @ C
    if tilt_fix is not None:
        C_b_n = tilt_fix @ C_b_n
        C_b_n = _Rz_heading(course - _heading_in(C_b_n)) @ C_b_n     # the tilt moved the heading a little
    s_course = float(np.hypot(vs[j, 0], vs[j, 1])) / math.sqrt(2.0) / speed[j]
    s_heading = math.sqrt(s_course**2 + math.radians(course_sigma_deg) ** 2 + s_carry**2)
    s_tilt_g = math.sqrt(s_tilt**2 + s_carry**2 + (s_acc / g_mps2) ** 2)
    info.update({"gnss_epoch_s": float(gv[j]), "speed_mps": float(speed[j]), "carried_s": carried_s,
                 "course_deg": math.degrees(course) % 360})
    return Alignment(float(t[k_g]), C_b_n, vel[j].copy(), np.array([s_tilt_g, s_tilt_g, s_heading]),
                     vs[j].copy(), bg, s_bg, "gnss_velocity", static, (float(t[0]), float(t[k_end])), info)
