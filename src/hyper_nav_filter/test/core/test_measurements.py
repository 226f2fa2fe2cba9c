"""Measurement models: zero residual at the truth, and Jacobians equal to
numerical derivatives of the residual w.r.t. the error state."""
import numpy as np
import pytest

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.attitude import euler_to_C_b_n, rotvec_to_C
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.measurements import BaroHeight, GnssPosition, GnssVelocity, HorizontalFix, ModelContext
from hyper_nav_filter.core.nav_state import NavState
from hyper_nav_filter.core.tightly_coupled import C_MPS, Pseudoranges, sagnac_rotate

CFG = FilterConfig(state_blocks=("att", "vel", "pos", "bg", "ba", "clk"))
LAY = CFG.layout
LEVER = np.array([1.5, -0.3, 0.4])
CTX = ModelContext(LEVER, np.array([0.02, -0.05, 0.1]), 0.0)


def truth_state():
    return NavState(0.0, np.deg2rad(26.5), np.deg2rad(119.0), 30000.0, np.array([1500.0, 1800.0, 20.0]),
                    euler_to_C_b_n(0.1, 0.05, 0.7), extra={"clk": np.array([1234.5, 12.3])})


def apply_error(s: NavState, dx):
    """Estimate = truth + error, in the filter's conventions."""
    e = s.copy()
    e.C_b_n = rotvec_to_C(-dx[LAY.sl("att")]) @ s.C_b_n
    e.vel_enu_mps = s.vel_enu_mps + dx[LAY.sl("vel")]
    d = dx[LAY.sl("pos")]
    r_m, r_n = earth.radii(s.lat_rad)
    e.lat_rad += d[1] / (r_m + s.alt_m)
    e.lon_rad += d[0] / ((r_n + s.alt_m) * np.cos(s.lat_rad))
    e.alt_m += d[2]
    e.extra["clk"] = s.extra["clk"] + dx[LAY.sl("clk")]
    return e


def satellites(s: NavState, n=8, seed=3):
    rng = np.random.default_rng(seed)
    r_rx = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m)
    C = earth.C_n_e(s.lat_rad, s.lon_rad)
    az, el = rng.uniform(0, 2 * np.pi, n), rng.uniform(0.2, 1.4, n)
    dirs_n = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    pos = r_rx + (dirs_n @ C.T) * 2.2e7
    vel = rng.normal(0, 2000.0, (n, 3))
    return pos, vel


def exact_pseudoranges(s: NavState):
    """Measurements generated independently: iterate the transit time."""
    pos, vel = satellites(s)
    C = earth.C_n_e(s.lat_rad, s.lon_rad)
    r_a = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m) + C @ (s.C_b_n @ LEVER)
    tau = np.full(len(pos), 0.07)
    for _ in range(5):
        r_sat = sagnac_rotate(pos, tau)
        tau = np.linalg.norm(r_a - r_sat, axis=1) / C_MPS
    r_sat = sagnac_rotate(pos, tau)
    rho = np.linalg.norm(r_a - r_sat, axis=1) + s.extra["clk"][0]
    u = (r_a - r_sat) / np.linalg.norm(r_a - r_sat, axis=1)[:, None]
    rate = np.einsum("ij,ij->i", u, C @ s.vel_enu_mps - sagnac_rotate(vel, tau)) + s.extra["clk"][1]
    n = len(rho)
    return Pseudoranges(0.0, pos, vel, rho, np.full(n, 9.0), rate, np.full(n, 0.01))


@pytest.mark.parametrize("meas_factory", [
    lambda s: exact_pseudoranges(s),
    lambda s: GnssPosition(0.0, *earth.ecef_to_geodetic(
        earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m)
        + earth.C_n_e(s.lat_rad, s.lon_rad) @ (s.C_b_n @ LEVER)), np.eye(3)),
    lambda s: BaroHeight(0.0, s.alt_m, 100.0),
    lambda s: HorizontalFix(0.0, s.lat_rad, s.lon_rad, np.eye(2) * 50.0),
])
def test_residual_zero_at_truth_and_jacobian_matches(meas_factory):
    s = truth_state()
    meas = meas_factory(s)
    res0, H, R = meas.model(s, LAY, CTX)
    assert np.all(np.abs(res0) < 2e-3), res0            # metre-level models: mm at truth
    dx = np.zeros(LAY.dim)
    for i in range(LAY.dim):
        if i in range(*LAY.sl("bg").indices(LAY.dim)) or i in range(*LAY.sl("ba").indices(LAY.dim)):
            continue
        h = 1e-4 if i < 3 else 1e-2
        dx[:] = 0.0
        dx[i] = h
        num = (meas.model(apply_error(s, dx), LAY, CTX)[0] - meas.model(apply_error(s, -dx), LAY, CTX)[0]) / (2 * h)
        np.testing.assert_allclose(num, H[:, i], atol=5e-4 * max(1.0, np.abs(H[:, i]).max()), err_msg=f"state {i}")


def test_velocity_model_with_lever_arm_is_zero_at_truth():
    s = truth_state()
    omega_nb = CTX.omega_nb_b_radps
    v_ant = s.vel_enu_mps + s.C_b_n @ np.cross(omega_nb, LEVER)
    res, H, _ = GnssVelocity(0.0, v_ant, np.eye(3)).model(s, LAY, CTX)
    np.testing.assert_allclose(res, 0.0, atol=1e-12)


def test_tightly_coupled_update_with_six_satellites_corrects_position_and_clock():
    s = truth_state()
    meas = exact_pseudoranges(s)
    est = apply_error(s, np.concatenate([np.zeros(6), [30.0, -20.0, 15.0], np.zeros(6), [50.0, 0.5]]))
    cfg = FilterConfig(state_blocks=LAY.names, init_pos_sigma_m=(50.0, 50.0, 50.0), clock_bias_sigma_m=100.0)
    kf = ErrorStateKF(cfg, est, cfg.initial_covariance())
    res = kf.update("pseudorange", 0.0, *meas.model(kf.state, LAY, ModelContext(LEVER, np.zeros(3), 0.0)))
    assert res.accepted
    d = earth.position_error_enu_m(kf.state.lat_rad, kf.state.lon_rad, kf.state.alt_m, s.lat_rad, s.lon_rad, s.alt_m)
    assert np.linalg.norm(d) < 3.0            # from 40 m, with 3 m code noise sigma
    assert abs(kf.state.extra["clk"][0] - s.extra["clk"][0]) < 3.0
