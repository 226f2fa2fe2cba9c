"""15-state error model of the LCI strapdown INS (seed 001 section 4.1) and the
loosely coupled BDS/GNSS measurements converted from ECEF (section 4.3).

Error state (block names of ``core.state_layout``, all estimate minus truth,
here in the LCI frame a):
  att  phi_a [rad],   C_b_a_est = (I - [phi x]) C_b_a_true
  vel  dv_a  [m/s],   pos  dr_a [m],   bg  [rad/s] body,   ba  [m/s^2] body.

Continuous dynamics (a is inertial, so no Earth/transport-rate terms; eqs.
79-86 with the symbols reconstructed, errors estimate minus truth):
    phi_dot = C_b_a d_bg - C_b_a w_g                      (79-81)
    dv_dot  = (C_b_a f_b) x phi - C_b_a d_ba + G_a dr + C_b_a w_a   (82-85)
    dr_dot  = dv                                           (86)
    d_bg_dot = -d_bg / tau_g + w_bg,  d_ba_dot = -d_ba / tau_a + w_ba
Optional scale-factor blocks (random constants, body axes; as the ENU model):
    phi_dot += C_b_a diag(omega_ib_b) d_sg,   dv_dot -= C_b_a diag(f_b) d_sa
G_a = dg_a/dr_a is the gravity gradient (central term, ``gravity.gravity_gradient_a``).
The paper models the biases as random constants; the first-order
Gauss-Markov form (tau -> inf gives the constant) keeps the interface of
the ENU ``core.error_model``. Noise order (w_g, w_a, w_bg, w_ba) as there.

Measurements (section 4.3): the receiver's ECEF fix is converted to LCI,
    r_a = C_t_a C_e_t(t) r_e - R0_a,   v_a = C_t_a C_e_t(t) (v_e + omega_ie x r_e)
and compared with the antenna position/velocity predicted by the INS,
    r_ant = r_a + C_b_a l_b,   v_ant = v_a + C_b_a (omega_ib_b x l_b)
(inertial velocity, so the lever-arm term uses omega_ib_b). With l_b = 0
the measurement matrix is the paper's H = [0 I 0 0 0; 0 0 I 0 0] blocks
(eq. 91). Each function returns (residual = predicted - measured, H, R),
the contract of ``core.eskf.ErrorStateKF.update``.
"""
from __future__ import annotations

import numpy as np

from ..attitude import rotvec_to_C, skew
from ..error_model import discretize  # noqa: F401  (same discretisation, re-exported)
from ..state_layout import INS_15, StateLayout
from .frames import LaunchFrame
from .gravity import gravity_gradient_a
from .mechanization import LciState


def system_matrices(state: LciState, f_b_mps2: np.ndarray, omega_ib_b_radps: np.ndarray,
                    frame: LaunchFrame, layout: StateLayout = INS_15,
                    gyro_bias_tau_s: float = np.inf, accel_bias_tau_s: float = np.inf):
    """Return F (n x n) and G (n x 12) of the LCI error model.

    f_b_mps2 / omega_ib_b_radps: bias-compensated specific force and angular
    rate (omega is unused: in the inertial frame the attitude error has no
    rate coupling except through the scale-factor block ``sg``)."""
    n = layout.dim
    F = np.zeros((n, n))
    G = np.zeros((n, 12))
    C = state.C_b_a
    f_a = C @ f_b_mps2
    a, vv, p = layout.sl("att"), layout.sl("vel"), layout.sl("pos")
    F[vv, a] = skew(f_a)
    F[vv, p] = gravity_gradient_a(state.r_a_m, frame)
    F[p, vv] = np.eye(3)
    G[a, 0:3] = -C
    G[vv, 3:6] = C
    if layout.has("bg"):
        bg = layout.sl("bg")
        F[a, bg] = C
        F[bg, bg] = -np.eye(3) / gyro_bias_tau_s
        G[bg, 6:9] = np.eye(3)
    if layout.has("ba"):
        ba = layout.sl("ba")
        F[vv, ba] = -C
        F[ba, ba] = -np.eye(3) / accel_bias_tau_s
        G[ba, 9:12] = np.eye(3)
    if layout.has("sg"):
        F[a, layout.sl("sg")] = C * omega_ib_b_radps          # C diag(omega)
    if layout.has("sa"):
        F[vv, layout.sl("sa")] = -C * f_b_mps2                # -C diag(f)
    return F, G


def gnss_position_ecef(state: LciState, layout: StateLayout, frame: LaunchFrame, t_s: float,
                       r_e_m, cov_e_m2, lever_arm_b_m=np.zeros(3), dt_to_meas_s: float = 0.0):
    """ECEF antenna position fix at epoch t_s (covariance in ECEF, m^2) as an
    LCI position measurement. dt_to_meas_s = t_s - state.t_s (small)."""
    z_a = frame.ecef_position_to_lci(r_e_m, t_s)
    l_a = state.C_b_a @ lever_arm_b_m
    residual = state.r_a_m + l_a + state.v_a_mps * dt_to_meas_s - z_a
    H = np.zeros((3, layout.dim))
    H[:, layout.sl("pos")] = np.eye(3)
    H[:, layout.sl("att")] = skew(l_a)
    return residual, H, frame.cov_ecef_to_lci(np.asarray(cov_e_m2, float), t_s)


def gnss_velocity_ecef(state: LciState, layout: StateLayout, frame: LaunchFrame, t_s: float,
                       r_e_m, v_e_mps, cov_e_m2ps2, omega_ib_b_radps=np.zeros(3),
                       lever_arm_b_m=np.zeros(3)):
    """ECEF antenna velocity (w.r.t. Earth) at epoch t_s, with its ECEF
    position r_e_m for the omega_ie x r term, as an LCI inertial-velocity
    measurement. The position error's contribution to the converted
    velocity (omega_ie x dr, ~7e-5 m/s per metre) is neglected in R."""
    _, z_a = frame.ecef_to_lci(r_e_m, v_e_mps, t_s)
    lever_b = np.cross(omega_ib_b_radps, lever_arm_b_m)
    lever_a = state.C_b_a @ lever_b
    residual = state.v_a_mps + lever_a - z_a
    H = np.zeros((3, layout.dim))
    H[:, layout.sl("vel")] = np.eye(3)
    H[:, layout.sl("att")] = skew(lever_a)
    if layout.has("bg"):
        H[:, layout.sl("bg")] = state.C_b_a @ skew(lever_arm_b_m)
    return residual, H, frame.cov_ecef_to_lci(np.asarray(cov_e_m2ps2, float), t_s)


def inject(state: LciState, dx: np.ndarray, layout: StateLayout = INS_15) -> LciState:
    """Correct a nominal LCI state with an error estimate (estimate - truth)."""
    s = state.copy()
    s.C_b_a = rotvec_to_C(dx[layout.sl("att")]) @ s.C_b_a     # C_true = (I + [phi x]) C_est
    s.v_a_mps = s.v_a_mps - dx[layout.sl("vel")]
    s.r_a_m = s.r_a_m - dx[layout.sl("pos")]
    if layout.has("bg"):
        s.gyro_bias_b_radps = s.gyro_bias_b_radps - dx[layout.sl("bg")]
    if layout.has("ba"):
        s.accel_bias_b_mps2 = s.accel_bias_b_mps2 - dx[layout.sl("ba")]
    for name in ("sg", "sa"):
        if layout.has(name):
            s.extra[name] = s.extra.get(name, np.zeros(3)) - dx[layout.sl(name)]
    return s
