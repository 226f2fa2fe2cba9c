"""Point-mass boost-glide dynamics (boost_glide.py): flight mechanics of the
seed flights, exact IMU (finite differences, error-free mechanization)."""
import copy
import pathlib

import numpy as np
import pytest
import yaml

from hyper_nav_gnss import earth
from hyper_nav_filter.core import mechanization
from hyper_nav_filter.core.attitude import attitude_error_n_rad
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_sim.core.boost_glide import DynamicTrajectory
from hyper_nav_sim.core.boost_glide_config import parse_flight
from hyper_nav_sim.core.scenario import load_scenario, scenario_dirs
from hyper_nav_sim.core.trajectory import TruthSample

# the scenarios that fly a ``flight:`` block (the flights are written once, there)
FLIGHTS = sorted({p.stem for d in scenario_dirs() for p in d.glob("*.yaml")
                  if "flight:" in p.read_text()}, key=str)
# seed 003's flight read literally (no scenario flies it): the dynamics tests' own flight file
SEED003_LITERAL = pathlib.Path(__file__).with_name("seed003_glide_25km_flight.yaml")


def example_flight(scenario: str) -> dict:
    """A copy of a scenario's ``flight:`` block."""
    return copy.deepcopy(load_scenario(scenario).data["flight"])


@pytest.fixture(scope="module")
def s1():
    return DynamicTrajectory.from_config(example_flight("seed002_s1"))


@pytest.fixture(scope="module")
def s003():
    return DynamicTrajectory.from_config(yaml.safe_load(SEED003_LITERAL.read_text()))


@pytest.fixture(scope="module")
def launch():
    return DynamicTrajectory.from_config(example_flight("seed001"))


def fd_check(traj, t, h=1e-4, atol_w=1e-8, atol_f=1e-5):
    """omega_ib_b and f_b of the truth against finite differences of the truth."""
    tr = traj.truth([t - h, t, t + h])
    C0, C1, C2 = tr.C_b_n
    W = C1.T @ ((C2 - C0) / (2 * h))
    omega_nb_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    lat, alt, v = tr.lat_rad[1], tr.alt_m[1], tr.vel_enu_mps[1]
    w_ie, w_en = earth.omega_ie_n(lat), earth.omega_en_n(lat, alt, v)
    np.testing.assert_allclose(tr.omega_ib_b_radps[1], omega_nb_fd + C1.T @ (w_ie + w_en), atol=atol_w)
    vdot = (tr.vel_enu_mps[2] - tr.vel_enu_mps[0]) / (2 * h)
    f_n = vdot + np.cross(2 * w_ie + w_en, v) - earth.gravity_n(lat, alt)
    np.testing.assert_allclose(tr.f_b_mps2[1], C1.T @ f_n, atol=atol_f)
    # position is the integral of velocity
    rates = earth.geodetic_rates(lat, alt, v)
    assert (tr.alt_m[2] - tr.alt_m[0]) / (2 * h) == pytest.approx(rates[2], abs=1e-5)
    assert (tr.lat_rad[2] - tr.lat_rad[0]) / (2 * h) == pytest.approx(rates[0], rel=1e-6, abs=1e-11)


def test_interface_is_that_of_trajectory(s003):
    tr = s003.truth(np.array([0.0, 10.0]))
    assert isinstance(tr, TruthSample)
    assert s003.duration_s == 790.0
    dth, dv = s003.imu_increments(np.array([0.01, 0.02]), 0.01)
    assert dth.shape == dv.shape == (2, 3)


def test_seed002_scenario1_speed_decays_to_2000_in_a_glide_band(s1):
    assert s1.terminated_early                       # stopped at v_f = 2000 m/s
    t = np.arange(0.0, s1.duration_s, 5.0)
    f = s1.flight(t)
    assert f["V"][0] == pytest.approx(7010.0)
    assert s1.flight([s1.duration_s])["V"][0] == pytest.approx(2000.0, abs=0.5)
    assert np.all(np.diff(f["V"]) < 0.0)             # unpowered glide: always slowing
    h = s1.state(t)[2]
    assert np.all((h > 20e3) & (h < 60.5e3)), (h.min(), h.max())
    glide = t > 200.0
    assert np.all(np.abs(np.rad2deg(f["gamma"][glide])) < 3.0)   # no skips: quasi-equilibrium glide
    # measured: 7010 -> 2000 m/s in 1028 s, 60 -> ~41 km before the turn, 21 km at the end


def test_seed002_scenario1_lateral_load_is_3g(s1):
    t = np.arange(720.0, s1.duration_s, 1.0)           # after the 5 s onset ramp
    f = s1.flight(t)
    np.testing.assert_allclose(f["n_lat_g"], 3.0, rtol=0.02)      # measured 2.99 ... 3.015
    before = s1.flight(np.arange(0.0, 695.0, 5.0))
    assert np.max(np.abs(before["n_lat_g"])) < 1e-6
    # the bank angle is smooth: rate-limited, continuous
    tt = np.arange(695.0, 720.0, 0.01)
    ff = s1.flight(tt)
    assert np.max(np.abs(ff["sigma_dot"])) <= np.deg2rad(30.0) + 1e-12
    assert np.max(np.abs(np.diff(ff["sigma_dot"]))) < np.deg2rad(0.5)
    assert np.rad2deg(ff["sigma"][-1]) > 60.0


def test_vertical_launch_passes_pitch_90_without_nan(launch):
    t = np.arange(0.0, launch.duration_s, 0.05)
    tr = launch.truth(t)
    for k in ("lat_rad", "lon_rad", "alt_m", "vel_enu_mps", "C_b_n", "omega_ib_b_radps", "f_b_mps2",
              "roll_rad", "pitch_rad", "heading_rad"):
        assert np.all(np.isfinite(getattr(tr, k))), k
    assert np.rad2deg(tr.pitch_rad[0]) == pytest.approx(90.0, abs=1e-9)
    assert np.all(np.rad2deg(tr.pitch_rad[t < 4.0]) > 89.9)
    np.testing.assert_allclose(np.einsum("kji,kjl->kil", tr.C_b_n, tr.C_b_n), np.broadcast_to(np.eye(3), tr.C_b_n.shape),
                               atol=1e-12)
    # boost -> short coast (apogee ~43 km) -> pull-up -> weaving glide at 33-43 km
    h = tr.alt_m
    assert launch.flight([75.0])["V"][0] > 4000.0
    assert 40e3 < h.max() < 50e3
    assert np.all((h[(t > 300) & (t < 460)] > 30e3) & (h[(t > 300) & (t < 460)] < 40e3))
    heading = np.unwrap(tr.heading_rad[(t > 200) & (t < 460)])
    assert np.ptp(heading) > np.deg2rad(5.0)                   # the S-turn weave


@pytest.mark.parametrize("t", [0.5, 3.0, 10.0, 30.0, 74.0, 90.0, 330.0])
def test_launch_rates_match_finite_differences(launch, t):
    fd_check(launch, t, atol_f=1e-4)


@pytest.mark.parametrize("t", [100.0, 460.0, 500.0, 700.0])
def test_seed003_rates_match_finite_differences(s003, t):
    fd_check(s003, t)


@pytest.mark.parametrize("t", [300.0, 705.0, 900.0])
def test_seed002_rates_match_finite_differences(s1, t):
    fd_check(s1, t)


@pytest.fixture(scope="module")
def pull_up():
    """Seed 002 scenario 1's glide with a 1.5 g pull-up over 300-306 s (0.3 s ramps)."""
    d = example_flight("seed002_s1")
    d["maneuvers"] = [{"type": "pull_up", "t_start_s": 300.0, "t_end_s": 306.0, "load_g": 1.5, "ramp_s": 0.3}]
    return DynamicTrajectory.from_config(d)


def test_pull_up_adds_its_vertical_load(s1, pull_up):
    """The commanded vertical load rises by load_g over the window; the
    flown load follows within the lift's 1 s lag, and the flight before the
    window is the glide's."""
    before = np.arange(100.0, 299.0, 7.0)
    np.testing.assert_allclose(pull_up.flight(before)["n_vert_g"], s1.flight(before)["n_vert_g"], atol=1e-9)
    t = np.arange(301.0, 305.5, 0.5)
    f, f0 = pull_up.flight(t), s1.flight(t)
    assert np.all(f["n_vert_cmd_g"] - f0["n_vert_cmd_g"] > 1.3)
    flown = f["n_vert_g"] - f0["n_vert_g"]
    assert flown[-1] > 1.2 and np.all(flown > 0.0), flown
    fd_check(pull_up, 300.2)
    fd_check(pull_up, 306.1)


def test_pull_up_load_must_be_positive():
    d = example_flight("seed002_s1")
    d["maneuvers"] = [{"type": "pull_up", "t_start_s": 300.0, "t_end_s": 306.0, "load_g": -1.0}]
    with pytest.raises(ValueError, match=r"flight.maneuvers\[0\].load_g"):
        DynamicTrajectory.from_config(d)


def test_scalar_and_vectorised_dynamics_agree(s1, launch, s003, pull_up):
    rng = np.random.default_rng(0)
    for traj in (s1, launch, s003, pull_up):
        for t in rng.uniform(0.0, traj.duration_s, 20):
            y = traj.state([t])[:, 0]
            a, b = traj._rhs(t, y), traj._rhs_vectorised(t, y)
            np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-13)


@pytest.mark.slow
def test_seed003_error_free_imu_through_mechanization_drifts_under_1m(s003):
    """Issue requirement: < 1 m over the 790 s flight at 100 Hz."""
    dt = 0.01
    t = np.arange(1, int(round(s003.duration_s / dt)) + 1) * dt
    dth, dv = s003.imu_increments(t, dt)
    s0 = s003.truth([0.0])
    st = NavState(0.0, s0.lat_rad[0], s0.lon_rad[0], s0.alt_m[0], s0.vel_enu_mps[0], s0.C_b_n[0])
    prev, v_prev = None, None
    for k in range(len(t)):
        imu = ImuSample(t[k], dt, dth[k], dv[k])
        v_before = st.vel_enu_mps
        st = mechanization.propagate(st, imu, prev, v_prev)
        prev, v_prev = imu, v_before
    tr = s003.truth([t[-1]])
    pos = earth.position_error_enu_m(st.lat_rad, st.lon_rad, st.alt_m, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0])
    assert np.linalg.norm(pos) < 1.0, pos                      # measured 0.03 m
    assert np.linalg.norm(st.vel_enu_mps - tr.vel_enu_mps[0]) < 5e-3
    assert np.linalg.norm(attitude_error_n_rad(st.C_b_n, tr.C_b_n[0])) < np.deg2rad(1e-4)
    # the flight did what seed 003 says: +200 m/s, +3 km, a left and a right turn
    f = s003.flight([40.0, 190.0, 440.0, 600.0, 780.0])
    assert f["V"][1] - f["V"][0] == pytest.approx(200.0, abs=2.0)
    assert s003.state([440.0])[2, 0] == pytest.approx(28000.0, abs=400.0)
    psi = np.rad2deg(np.unwrap(f["psi"]))
    assert psi[3] - psi[2] < -30.0 and psi[4] - psi[3] > 30.0


def test_all_example_flights_parse():
    for name in FLIGHTS:
        kw = parse_flight(example_flight(name))
        assert kw["duration_s"] > 0


@pytest.mark.parametrize("patch, field", [
    ({"mass_kg": -1.0}, "flight.mass_kg"),
    ({"cd0": "x"}, "flight.cd0"),
    ({"c_l_program": [[0.0, 1.0], [0.0, 2.0]]}, "flight.c_l_program"),
    ({"altitude_mode": "skip"}, "flight.altitude_mode"),
    ({"maneuvers": [{"type": "loop", "t_start_s": 1.0}]}, r"flight.maneuvers\[0\].type"),
    ({"maneuvers": [{"type": "lateral_ca", "t_start_s": 10.0, "t_end_s": 5.0, "load_g": 3}]},
     r"flight.maneuvers\[0\].t_end_s"),
    ({"maneuvers": [{"type": "lateral_ca", "t_start_s": 10.0}]}, r"flight.maneuvers\[0\].load_g"),
    ({"maneuvers": [{"type": "turn_left", "t_start_s": 1.0, "load_g": 2, "gamma_deg": 3}]},
     r"flight.maneuvers\[0\].gamma_deg"),
    ({"bogus_field": 1}, "flight.bogus_field"),
])
def test_bad_config_names_the_field(patch, field):
    d = example_flight("seed002_s1")
    d.update(patch)
    with pytest.raises(ValueError, match=field):
        DynamicTrajectory.from_config(d)


def test_bad_start_names_the_field():
    d = example_flight("seed001")
    del d["start"]["psi_deg"]
    with pytest.raises(ValueError, match="flight.start.psi_deg"):
        DynamicTrajectory.from_config(d)
    d = example_flight("seed001")
    d["boost"]["burn_time_s"] = 0
    with pytest.raises(ValueError, match="flight.boost.burn_time_s"):
        DynamicTrajectory.from_config(d)
