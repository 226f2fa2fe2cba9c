"""Strapdown mechanization in the launch-centred inertial (LCI, 'a') frame.

Navigation equations (seed 001 eq. 6), a being inertial:
    dC_b_a/dt = C_b_a [omega_ib_b x],   dv_a/dt = C_b_a f_b + g_a(r_a),   dr_a/dt = v_a
No Earth-rate or transport-rate terms and no Euler angles: the attitude is a
DCM updated by a rotation vector, so a vertical launch (pitch 90 deg) is
regular.

Discrete update over (t_{m-1}, t_m], T = t_m - t_{m-1} (section 3):
    C_b_a(m) = C_b_a(m-1) exp([phi x])                                    (16, 29)
    v_a(m)   = v_a(m-1) + C_b_a(m-1) dv_sf_b + g_a(mid) T                  (34-38)
    r_a(m)   = r_a(m-1) + v_a(m-1) T + C_b_a(m-1) dR_sf_b + g_a(mid) T^2/2  (54-62)
with g_a evaluated at the position extrapolated to mid-interval,
r_a(m-1) + v_a(m-1) T/2 (eq. 38 uses extrapolation as well).

Two-sample model (eqs. 12-15): omega(t) = a + b t, f(t) = c + d t over the
update interval; the coefficients are solved from two angle/velocity
increments (eq. 26, 52) and the body-frame integrals are then exact for
that model to first order in the rotation angle (plus the exact
constant-rate second-order rotation terms):

    phi     = dth + a x b T^3/12                                   coning (27, 28)
    dv_sf_b = dv + 1/2 dth x dv + 1/6 dth x (dth x dv)              rotation (49)
              + (a x d - b x c) T^3/12                              sculling (50-53)
    dR_sf_b = S_v + 1/6 (S_th x dv + dth x S_v) + T/24 dth x (dth x dv)   rotation (63)
              + dR_scrl                                              scrolling (64)
    S_v = c T^2/2 + d T^3/6,  S_th = a T^2/2 + b T^3/6   (second integrals, eq. 62)
    dR_scrl = [a x c T^3/6 + a x d T^4/12 + b x c T^4/24 + b x d T^5/40]
              - 1/6 (S_th x dv + dth x S_v)   (exact double integral minus rotation)
The paper's own formulas for (62)-(64) were lost in extraction; the split
above reproduces its structure (rotation + scrolling) and reduces to the
classical forms, which the tests check:
  * two samples inside the interval (paper, T = 2h):
        phi = dth1 + dth2 + 2/3 dth1 x dth2,
        sculling = 2/3 (dth1 x dv2 + dv1 x dth2)  (Savage, Strapdown Analytics 7.2.2.2)
  * current + previous interval (update at the IMU rate, as the project's
    ENU mechanization and PSINS "one-plus-previous"):
        phi = dth + 1/12 dth_prev x dth,
        sculling = 1/12 (dth_prev x dv + dv_prev x dth).

``propagate`` is the one-plus-previous form (one update per IMU sample, for
the ESKF); ``propagate_two_sample`` the paper's two-samples-per-update form.
``Corrections`` switches the coning, sculling and scrolling terms off for
the demonstration of their effect. With scrolling off the position uses the
single-sample constant-rate form dR_sf_b = T/2 dv + T/6 dth x dv.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..attitude import cross3 as _cross3
from ..attitude import orthonormalize, rotvec_to_C
from ..nav_state import ImuSample, remove_imu_errors


@dataclass
class LciState:
    """Nominal strapdown state in LCI: r_a_m relative to the LCI origin (the
    launch point at t0), v_a_mps inertial velocity, C_b_a body(FLU) -> LCI."""
    t_s: float
    r_a_m: np.ndarray
    v_a_mps: np.ndarray
    C_b_a: np.ndarray
    gyro_bias_b_radps: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_bias_b_mps2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # nominal scale factors of the optional blocks {"sg": ..., "sa": ...} (dimensionless)
    extra: dict = field(default_factory=dict)

    def copy(self) -> "LciState":
        return replace(self, r_a_m=self.r_a_m.copy(), v_a_mps=self.v_a_mps.copy(), C_b_a=self.C_b_a.copy(),
                       gyro_bias_b_radps=self.gyro_bias_b_radps.copy(),
                       accel_bias_b_mps2=self.accel_bias_b_mps2.copy(),
                       extra={k: v.copy() for k, v in self.extra.items()})


@dataclass(frozen=True)
class Corrections:
    """Which high-rate corrections the update applies (all on by default)."""
    coning: bool = True
    sculling: bool = True
    scrolling: bool = True


ALL_ON = Corrections()
ALL_OFF = Corrections(False, False, False)


@dataclass(frozen=True)
class BodyIncrements:
    """Body-frame quantities of one update interval (all in frame b(t_{m-1}))."""
    T_s: float
    phi_b_rad: np.ndarray        # rotation vector b(m-1) -> b(m)
    dv_sf_b_mps: np.ndarray      # integral of C_b(m-1)_b(t) f_b dt
    dr_sf_b_m: np.ndarray        # double integral of the same


def compensate(imu: ImuSample, state: LciState) -> tuple[np.ndarray, np.ndarray]:
    """Remove the estimated biases, then the scale factors, from the increments
    (``nav_state.remove_imu_errors``; the LCI state has no Markov drift)."""
    return remove_imu_errors(imu.dtheta_b_rad, imu.dvel_b_mps, imu.dt_s, state.gyro_bias_b_radps,
                             state.accel_bias_b_mps2, state.extra)


def _cross_rows(u, v):
    """Row-wise cross product of (N, 3) arrays."""
    return np.cross(u, v)


def linear_model_increments(a, b, c, d, T, corr: Corrections = ALL_ON) -> BodyIncrements:
    """Body increments for omega = a + b t, f = c + d t over [0, T] (see module
    doc). a, b, c, d are 3-vectors, or (N, 3) arrays for a batch of intervals."""
    cross3 = _cross_rows if np.ndim(a) == 2 else _cross3
    dth = a * T + b * (T * T / 2.0)
    dv = c * T + d * (T * T / 2.0)
    T3 = T**3
    phi = dth + (cross3(a, b) * (T3 / 12.0) if corr.coning else 0.0)
    th_x_dv = cross3(dth, dv)
    th_x_th_x_dv = cross3(dth, th_x_dv)
    dv_sf = dv + 0.5 * th_x_dv + th_x_th_x_dv / 6.0
    if corr.sculling:
        dv_sf = dv_sf + (cross3(a, d) - cross3(b, c)) * (T3 / 12.0)
    if corr.scrolling:
        S_v = c * (T * T / 2.0) + d * (T3 / 6.0)
        S_th = a * (T * T / 2.0) + b * (T3 / 6.0)
        rot = (cross3(S_th, dv) + cross3(dth, S_v)) / 6.0
        exact = (cross3(a, c) * (T3 / 6.0) + cross3(a, d) * (T3 * T / 12.0)
                 + cross3(b, c) * (T3 * T / 24.0) + cross3(b, d) * (T3 * T * T / 40.0))
        scroll = exact - rot
        dr_sf = S_v + rot + scroll + th_x_th_x_dv * (T / 24.0)
    else:
        dr_sf = dv * (T / 2.0) + th_x_dv * (T / 6.0) + th_x_th_x_dv * (T / 24.0)
    return BodyIncrements(T, phi, dv_sf, dr_sf)


def increments_one_plus_previous(dth, dv, dth_prev, dv_prev, T, corr: Corrections = ALL_ON) -> BodyIncrements:
    """Linear model through the previous interval (-T, 0] and the current (0, T]
    (coefficients as eq. 26/52 with the previous sample as the first one);
    dth_prev = None means a constant-rate model (first step). Batch form:
    (N, 3) arrays of consecutive intervals, dth_prev the row-shifted arrays."""
    if dth_prev is None:
        z = np.zeros_like(dth)
        return linear_model_increments(dth / T, z, dv / T, z, T, corr)
    a = (dth_prev + dth) / (2.0 * T)
    b = (dth - dth_prev) / (T * T)
    c = (dv_prev + dv) / (2.0 * T)
    d = (dv - dv_prev) / (T * T)
    return linear_model_increments(a, b, c, d, T, corr)


def increments_two_sample(dth1, dv1, dth2, dv2, h, corr: Corrections = ALL_ON) -> BodyIncrements:
    """Paper form (eqs. 14, 26, 52): two equal sub-intervals of length h inside
    the update interval T = 2h."""
    a = (3.0 * dth1 - dth2) / (2.0 * h)
    b = (dth2 - dth1) / (h * h)
    c = (3.0 * dv1 - dv2) / (2.0 * h)
    d = (dv2 - dv1) / (h * h)
    return linear_model_increments(a, b, c, d, 2.0 * h, corr)


def apply_increments(state: LciState, inc: BodyIncrements, gravity) -> LciState:
    """Attitude, velocity and position update of eq. 6 from body increments;
    ``gravity(r_a_m, t_s) -> g_a`` is evaluated at the mid-interval
    extrapolated position r + v T/2 and time t + T/2."""
    T = inc.T_s
    C0, v0, r0 = state.C_b_a, state.v_a_mps, state.r_a_m
    g_mid = gravity(r0 + 0.5 * T * v0, state.t_s + 0.5 * T)
    v1 = v0 + C0 @ inc.dv_sf_b_mps + g_mid * T
    r1 = r0 + v0 * T + C0 @ inc.dr_sf_b_m + g_mid * (0.5 * T * T)
    C1 = orthonormalize(C0 @ rotvec_to_C(inc.phi_b_rad))
    return LciState(state.t_s + T, r1, v1, C1, state.gyro_bias_b_radps, state.accel_bias_b_mps2, state.extra)


def propagate(state: LciState, imu: ImuSample, imu_prev: ImuSample | None, gravity,
              corrections: Corrections = ALL_ON) -> LciState:
    """One update per IMU sample from ``state`` (epoch imu.t_s - dt) to imu.t_s,
    one-plus-previous two-sample corrections (``imu_prev`` None at the first
    step). ``gravity`` from :func:`gravity.make_gravity`."""
    dth, dv = compensate(imu, state)
    if imu_prev is None:
        dth_p = dv_p = None
    else:
        dth_p, dv_p = compensate(imu_prev, state)
    inc = increments_one_plus_previous(dth, dv, dth_p, dv_p, imu.dt_s, corrections)
    out = apply_increments(state, inc, gravity)
    out.t_s = imu.t_s
    return out


def propagate_two_sample(state: LciState, imu1: ImuSample, imu2: ImuSample, gravity,
                         corrections: Corrections = ALL_ON) -> LciState:
    """One update over two consecutive IMU samples (paper form, section 3),
    from ``state`` (epoch imu1.t_s - dt) to imu2.t_s."""
    dth1, dv1 = compensate(imu1, state)
    dth2, dv2 = compensate(imu2, state)
    inc = increments_two_sample(dth1, dv1, dth2, dv2, imu1.dt_s, corrections)
    out = apply_increments(state, inc, gravity)
    out.t_s = imu2.t_s
    return out


def propagate_batch(state: LciState, t_s, dt_s: float, dtheta_b_rad, dvel_b_mps, gravity,
                    corrections: Corrections = ALL_ON, imu_prev: ImuSample | None = None,
                    every: int = 1):
    """Free-inertial propagation over many IMU samples, identical to calling
    :func:`propagate` per sample with a constant bias estimate, but with the
    body-frame increments (coning/sculling/scrolling) computed vectorised.

    t_s (N,), dtheta_b_rad/dvel_b_mps (N, 3) over (t - dt, t]. Returns the final
    state and, if every > 0, the list of states at every ``every``-th sample."""
    dth, dv = compensate(ImuSample(float(t_s[-1]), dt_s, np.asarray(dtheta_b_rad, float),
                                   np.asarray(dvel_b_mps, float)), state)     # row-wise broadcast
    dth_p, dv_p = np.empty_like(dth), np.empty_like(dv)
    dth_p[1:], dv_p[1:] = dth[:-1], dv[:-1]
    if imu_prev is None:
        dth_p[0], dv_p[0] = dth[0], dv[0]        # constant-rate model at the first step
    else:
        dth_p[0], dv_p[0] = compensate(imu_prev, state)
    inc = increments_one_plus_previous(dth, dv, dth_p, dv_p, dt_s, corrections)
    out = []
    st = state
    for k in range(len(dth)):
        st = apply_increments(st, BodyIncrements(dt_s, inc.phi_b_rad[k], inc.dv_sf_b_mps[k], inc.dr_sf_b_m[k]),
                              gravity)
        st.t_s = float(t_s[k])
        if every > 0 and (k + 1) % every == 0:
            out.append(st)
    return st, out
