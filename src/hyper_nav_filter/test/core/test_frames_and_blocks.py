"""Every state block and every measurement model, in both mechanization
frames (issue 9, items 2-3):

* the composed transition matrix Phi (frame core + block declarations)
  follows the filter's own nonlinear mechanization: propagate the truth and a
  perturbed copy through the same IMU data, the difference must be Phi dx0;
* each measurement model (written once, ENU convention) has, once mapped into
  the filter's own error state, the Jacobian of its residual (numerical
  central differences through the filter's own injection);
* injection undoes a known error; a block's declarations are complete.
"""
import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_filter.core.attitude import euler_to_C_b_n
from hyper_nav_filter.core.blocks import REGISTRY
from hyper_nav_filter.core.blocks.lever_arm import modal_model
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.measurements import BaroHeight, GnssPosition, GnssVelocity, HorizontalFix, ModelContext
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_filter.core.tightly_coupled import C_MPS, Pseudoranges, sagnac_rotate
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.core.trajectory import Maneuver, Start, Trajectory

LAYOUTS = {
    "15": ("att", "vel", "pos", "bg", "ba"),
    "21_scale_factors": ("att", "vel", "pos", "bg", "ba", "sg", "sa"),
    "17_clock": ("att", "vel", "pos", "bg", "ba", "clk"),
    "24_elastic": ("att", "vel", "pos", "bg", "gm", "ba", "lev"),
}
# random-constant biases: the nominal biases are constants, so the error-state
# decay of a Gauss-Markov model would not be seen by the mechanization; the
# layouts as listed (range_errors white: no range-bias states added to 17_clock)
CFG_KW = dict(gyro_bias_tau_s=1e12, accel_bias_tau_s=1e12, gyro_markov_tau_s=50.0,
              lever_arm_r0_b_m=(4.0, 0.0, 0.0), range_errors="white")


def vertical_launch():
    start = Start(np.deg2rad(40.0), np.deg2rad(100.0), 100.0, 50.0, np.deg2rad(88.0), np.deg2rad(60.0), 0.0, 0.0)
    return Trajectory(start, [Maneuver("pitch", 2.0, 10.0, np.deg2rad(4.0)), Maneuver("accelerate", 0.0, 40.0, 1200.0),
                              Maneuver("climb", 15.0, 25.0, -np.deg2rad(40.0))], 40.0)


def error_vector(lay, rng_seed=1):
    """A plausible initial error for every block of a layout."""
    scale = {"att": np.deg2rad(0.01), "vel": 0.2, "pos": 4.0, "bg": np.deg2rad(1.0) / 3600, "ba": 2e-3,
             "gm": np.deg2rad(0.5) / 3600, "sg": 300e-6, "sa": 300e-6, "clk": np.array([20.0, 0.3]),
             "lev": np.array([1e-4, 1e-4, 1e-4, 1e-3, 1e-3, 1e-3])}
    rng = np.random.default_rng(rng_seed)
    return np.concatenate([rng.choice([-1.0, 1.0], REGISTRY[n].size) * (0.5 + rng.random(REGISTRY[n].size))
                           * scale[n] for n in lay.names])


@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("frame, case", [("ENU", "cruise_turn"), ("LCI", "cruise_turn"), ("LCI", "vertical_launch")])
def test_transition_matrix_follows_the_mechanization(frame, layout, case):
    """2 s at 100 Hz of a 30 deg hypersonic turn (default scenario, t = 150 s)
    or, LCI only (the ENU attitude is singular there), through pitch 90 deg
    (vertical launch, t = 6 s)."""
    traj, t0 = (load_scenario("default").trajectory(), 150.0) if case == "cruise_turn" else (vertical_launch(), 6.0)
    cfg = FilterConfig(state_blocks=LAYOUTS[layout], mechanization_frame=frame, launch_azimuth_deg=30.0, **CFG_KW)
    lay = cfg.layout
    rate, n = 100.0, 200
    dt = 1.0 / rate
    t = t0 + np.arange(1, n + 1) * dt
    dth, dv = traj.imu_increments(t, dt)
    tr = traj.truth([t0])
    nav = NavState(t0, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0], tr.C_b_n[0],
                   extra={"clk": np.array([100.0, 2.0]), "gm": np.deg2rad([0.2, -0.1, 0.3]) / 3600,
                          "lev": np.array([2e-3, -5e-4, 1e-4, 0.0, 0.0, 0.0])})
    truth = ErrorStateKF(cfg, nav)
    est = ErrorStateKF(cfg, nav)
    dx0 = error_vector(lay)
    est.inject(-dx0)                               # estimate = truth + dx0
    np.testing.assert_allclose(est.error(est.snapshot(), truth.snapshot()), dx0, rtol=1e-6, atol=1e-9)
    Phi_total = np.eye(lay.dim)
    for k in range(n):
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        Phi_total = truth.linearize(imu).Phi @ Phi_total
        truth.predict(imu)
        est.predict(imu)
    actual = est.error(est.snapshot(), truth.snapshot())
    predicted = Phi_total @ dx0
    for name in lay.names:
        s = lay.sl(name)
        tol = 0.02 * np.abs(actual[s]).max() + 1e-3 * np.abs(dx0[s]).max()
        if name == "lev":     # neglected (documented): the modal input's error from the accelerometer bias
            gain = np.abs(modal_model(cfg).load_gain_kg_per_kg).max()
            du, w1 = gain * np.abs(dx0[lay.sl("ba")]).max(), min(cfg.lever_arm_natural_freq_radps)
            tol = tol + np.repeat([du / w1**2, du / w1], 3)         # bound of its q and q' response
        assert np.all(np.abs(predicted[s] - actual[s]) <= tol), (frame, layout, name, predicted[s], actual[s], tol)


# ---- measurement models in both frames ----------------------------------------------------------

LEVER = np.array([1.5, -0.3, 0.4])
OMEGA_NB = np.array([0.02, -0.05, 0.1])


def truth_nav():
    return NavState(100.0, np.deg2rad(26.5), np.deg2rad(119.0), 30000.0, np.array([1500.0, 1800.0, 20.0]),
                    euler_to_C_b_n(0.1, 0.05, 0.7), extra={"clk": np.array([1234.5, 12.3])})


def satellites(s: NavState, n=8, seed=3):
    rng = np.random.default_rng(seed)
    r_rx = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m)
    C = earth.C_n_e(s.lat_rad, s.lon_rad)
    az, el = rng.uniform(0, 2 * np.pi, n), rng.uniform(0.2, 1.4, n)
    dirs_n = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)], axis=1)
    return r_rx + (dirs_n @ C.T) * 2.2e7, rng.normal(0, 2000.0, (n, 3))


def exact_pseudoranges(s: NavState):
    """Measurements generated independently: iterate the transit time."""
    pos, vel = satellites(s)
    C = earth.C_n_e(s.lat_rad, s.lon_rad)
    r_a = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m) + C @ (s.C_b_n @ LEVER)
    tau = np.full(len(pos), 0.07)
    for _ in range(5):
        tau = np.linalg.norm(r_a - sagnac_rotate(pos, tau), axis=1) / C_MPS
    r_sat = sagnac_rotate(pos, tau)
    rho = np.linalg.norm(r_a - r_sat, axis=1) + s.extra["clk"][0]
    u = (r_a - r_sat) / np.linalg.norm(r_a - r_sat, axis=1)[:, None]
    rate = np.einsum("ij,ij->i", u, C @ s.vel_enu_mps - sagnac_rotate(vel, tau)) + s.extra["clk"][1]
    n = len(rho)
    return Pseudoranges(s.t_s, pos, vel, rho, np.full(n, 9.0), rate, np.full(n, 0.01))


def antenna_fix(s):
    r = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m) + earth.C_n_e(s.lat_rad, s.lon_rad) @ (s.C_b_n @ LEVER)
    return GnssPosition(s.t_s, *earth.ecef_to_geodetic(r), np.eye(3))


MODELS = {
    "pseudorange": exact_pseudoranges,
    "gnss_pos": antenna_fix,
    "gnss_vel": lambda s: GnssVelocity(s.t_s, s.vel_enu_mps + s.C_b_n @ np.cross(OMEGA_NB, LEVER), np.eye(3)),
    "baro": lambda s: BaroHeight(s.t_s, s.alt_m, 100.0),
    "horizontal_fix": lambda s: HorizontalFix(s.t_s, s.lat_rad, s.lon_rad, np.eye(2) * 50.0),
}


@pytest.mark.parametrize("frame", ["ENU", "LCI"])
@pytest.mark.parametrize("model", list(MODELS))
def test_every_model_in_both_frames_against_a_numerical_jacobian(frame, model):
    cfg = FilterConfig(state_blocks=LAYOUTS["17_clock"], mechanization_frame=frame, launch_azimuth_deg=20.0)
    lay = cfg.layout
    s = truth_nav()
    kf = ErrorStateKF(cfg, s)
    ctx = ModelContext(LEVER, OMEGA_NB, 0.0)
    meas = MODELS[model](kf.state)
    res0, H, _ = kf.model(meas, ctx)
    assert np.all(np.abs(res0) < 2e-3), res0                 # metre-level models: mm at the truth
    base = kf.snapshot()
    for i in range(lay.dim):
        if model == "gnss_vel" and lay.sl("bg").start <= i < lay.sl("bg").stop:
            continue           # acts through the context's corrected body rate (checked analytically below)
        h = 1e-5 if i < 3 else (1e-6 if i < lay.sl("ba").stop and i >= lay.sl("bg").start else 1e-2)
        col = []
        for sign in (1.0, -1.0):
            kf.restore(base)
            d = np.zeros(lay.dim)
            d[i] = sign * h
            kf.inject(-d)                                      # estimate = truth + d
            col.append(kf.model(meas, ctx)[0])
        num = (col[0] - col[1]) / (2 * h)
        np.testing.assert_allclose(num, H[:, i], atol=5e-4 * max(1.0, np.abs(H[:, i]).max()),
                                   err_msg=f"{frame} {model} state {i}")


def test_gnss_velocity_bias_column_is_the_lever_arm_rate():
    cfg = FilterConfig(state_blocks=LAYOUTS["15"])
    kf = ErrorStateKF(cfg, truth_nav())
    meas = MODELS["gnss_vel"](kf.state)
    _, H, _ = kf.model(meas, ModelContext(LEVER, OMEGA_NB, 0.0))
    # omega_nb = omega_meas - bg - ...: d residual / d bg = C_b_n [l x]
    from hyper_nav_filter.core.attitude import skew
    np.testing.assert_allclose(H[:, cfg.layout.sl("bg")], kf.state.C_b_n @ skew(LEVER), atol=1e-12)


@pytest.mark.parametrize("frame", ["ENU", "LCI"])
def test_inject_undoes_a_known_error_and_the_enu_covariance_round_trips(frame):
    cfg = FilterConfig(state_blocks=LAYOUTS["24_elastic"], mechanization_frame=frame, launch_azimuth_deg=75.0)
    s = truth_nav()
    s.extra["lev"] = np.array([1e-3, -2e-4, 5e-5, 1e-2, 0.0, -3e-3])
    truth = ErrorStateKF(cfg, s)
    est = ErrorStateKF(cfg, s)
    dx = error_vector(cfg.layout, 7)
    est.inject(-dx)
    est.inject(dx)
    np.testing.assert_allclose(est.error(est.snapshot(), truth.snapshot()), 0.0, atol=1e-5)   # m, rad: 2nd order
    # the ENU-convention covariance given at construction is what P_enu() returns
    np.testing.assert_allclose(truth.P_enu(), cfg.initial_covariance(), rtol=1e-9, atol=1e-15)


def test_block_declarations_are_complete():
    """Every registered block has a size, a description with units, a prior of
    its size, and couplings/noises whose matrices fit it."""
    cfg = FilterConfig()
    for name, b in REGISTRY.items():
        assert b.size > 0 and b.description, name
        assert b.prior_sigma(cfg).shape == (b.size,), name
        for c in b.couplings(cfg):
            assert c.target in ("att", "vel") and c.terms(), name
            for _, K in c.terms():
                assert K.shape == (3, b.size), name
        for w in b.noise(cfg):
            assert w.M.shape[1] == len(w.psd), name
            assert w.M.shape[0] == (b.size if w.target == "self" else 3), name


def test_tightly_coupled_update_with_eight_satellites_corrects_position_and_clock():
    s = truth_nav()
    meas = exact_pseudoranges(s)
    cfg = FilterConfig(state_blocks=LAYOUTS["17_clock"], init_pos_sigma_m=(50.0, 50.0, 50.0),
                       clock_bias_sigma_m=100.0)
    lay = cfg.layout
    truth = ErrorStateKF(cfg, s)
    kf = ErrorStateKF(cfg, s)
    dx = np.zeros(lay.dim)
    dx[lay.sl("pos")], dx[lay.sl("clk")] = [30.0, -20.0, 15.0], [50.0, 0.5]
    kf.inject(-dx)                                           # 40 m and 50 m of clock off
    res = kf.update("pseudorange", s.t_s, *kf.model(meas, ModelContext(LEVER, np.zeros(3), 0.0)))
    assert res.accepted
    err = kf.error(kf.snapshot(), truth.snapshot())
    assert np.linalg.norm(err[lay.sl("pos")]) < 3.0          # with 3 m code noise sigma
    assert abs(err[lay.sl("clk")][0]) < 3.0
