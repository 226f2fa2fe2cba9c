"""The filter-configuration gaps a real data set shows, lifted as block and
engine declarations: per-axis noise, other units, initial sigmas decoupled
from the steady-state ones, Gauss-Markov scale factors, the gate switched
off, initial bias and scale values, an explicit initial state."""
import math

import numpy as np
import pytest

from hyper_nav_filter.core import units
from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.initial_state import INIT_PARAMS, from_block, initial_state, state_values
from hyper_nav_filter.core.measurements import GnssPosition, ModelContext
from hyper_nav_filter.core.nav_state import ImuSample, NavState
from hyper_nav_filter.core.params import ConfigError, check_all
from hyper_nav_filter.core.system_model import system_model

SF = ("att", "vel", "pos", "bg", "ba", "sg", "sa")


def test_per_axis_noise_and_one_number_for_every_axis():
    c = FilterConfig.from_dict({"gyro_arw_deg_per_sqrt_hr": [0.01, 0.02, 0.04], "accel_vrw_ug_per_sqrt_hz": 50})
    assert c.accel_vrw_ug_per_sqrt_hz == (50.0, 50.0, 50.0)
    qc = system_model(c).qc
    cols = system_model(c).noise_columns
    assert qc[cols["w_g"]] == pytest.approx(units.deg_per_sqrt_hr([0.01, 0.02, 0.04]) ** 2, rel=1e-12)
    assert qc[cols["w_a"]] == pytest.approx(np.full(3, float(units.ug_per_sqrt_hz(50.0)) ** 2), rel=1e-12)


def test_noise_and_biases_in_other_units_are_the_same_configuration():
    a = FilterConfig.from_dict({"accel_vrw_mps_per_sqrt_hr": 0.06, "accel_bias_sigma_mgal": 30.0,
                                "gyro_arw_deg_per_hr_per_sqrt_hz": 0.6, "init_att_sigma_deg": 0.1})
    b = FilterConfig.from_dict({"accel_vrw_ug_per_sqrt_hz": 0.06 / 60.0 / 9.80665e-6,
                                "accel_bias_sigma_ug": 30e-5 / 9.80665e-6, "gyro_arw_deg_per_sqrt_hr": 0.01,
                                "init_att_sigma_arcmin": 6.0})
    for name in ("accel_vrw_ug_per_sqrt_hz", "accel_bias_sigma_ug", "gyro_arw_deg_per_sqrt_hr", "init_att_sigma_arcmin"):
        assert getattr(a, name) == pytest.approx(getattr(b, name), rel=1e-12), name
    with pytest.raises(ConfigError, match="accel_bias_sigma_mgal: the same quantity as accel_bias_sigma_ug"):
        FilterConfig.from_dict({"accel_bias_sigma_ug": 10.0, "accel_bias_sigma_mgal": 10.0})
    with pytest.raises(ConfigError, match="accel_vrw_mps_per_sqrt_hr: expected a number or a list of 3 numbers"):
        FilterConfig.from_dict({"accel_vrw_mps_per_sqrt_hr": "fast"})
    with pytest.raises(ConfigError, match="accel_vrw_mps_per_hr.*did you mean 'accel_vrw_mps_per_sqrt_hr'"):
        FilterConfig.from_dict({"accel_vrw_mps_per_hr": 0.03})


def test_initial_bias_and_scale_sigmas_are_decoupled_from_the_steady_state_ones():
    base = {"state_blocks": list(SF), "gyro_bias_sigma_deg_per_hr": 0.1, "accel_bias_sigma_ug": 100.0,
            "gyro_scale_factor_sigma_ppm": 300.0}
    tied = np.sqrt(np.diag(FilterConfig.from_dict(base).initial_covariance()))
    c = FilterConfig.from_dict({**base, "init_gyro_bias_sigma_deg_per_hr": [1.0, 2.0, 3.0],
                                "init_accel_bias_sigma_mgal": 50.0, "init_gyro_scale_factor_sigma_ppm": 1000.0})
    free = np.sqrt(np.diag(c.initial_covariance()))
    lay = c.layout
    assert tied[lay.sl("bg")] == pytest.approx(units.deg_per_hr(0.1) * np.ones(3))      # NaN (not set): steady state
    assert free[lay.sl("bg")] == pytest.approx(units.deg_per_hr([1.0, 2.0, 3.0]))
    assert free[lay.sl("ba")] == pytest.approx(np.full(3, 50e-5))
    assert free[lay.sl("sg")] == pytest.approx(np.full(3, 1e-3))
    # the driving noise still comes from the steady-state sigma: 2 sigma^2 / tau
    m = system_model(c)
    assert m.qc[m.noise_columns["w_bg"]] == pytest.approx(2 * units.deg_per_hr(0.1) ** 2 / 3600.0 * np.ones(3))


def test_scale_factors_random_constant_or_gauss_markov():
    const = system_model(FilterConfig(state_blocks=SF))
    assert "w_sg" not in const.noise_columns and not const.A[const.layout.sl("sg"), const.layout.sl("sg")].any()
    gm = system_model(FilterConfig.from_dict({"state_blocks": list(SF), "gyro_scale_factor_tau_s": 14400,
                                              "accel_scale_factor_tau_s": 3600, "accel_scale_factor_sigma_ppm": 200}))
    s, a = gm.layout.sl("sg"), gm.layout.sl("sa")
    assert np.diag(gm.A[s, s]) == pytest.approx(np.full(3, -1 / 14400.0))
    assert np.diag(gm.A[a, a]) == pytest.approx(np.full(3, -1 / 3600.0))
    assert gm.qc[gm.noise_columns["w_sa"]] == pytest.approx(np.full(3, 2 * (200e-6) ** 2 / 3600.0))
    # a stationary Gauss-Markov scale factor keeps its variance over a long propagation without aiding
    c = FilterConfig.from_dict({"state_blocks": list(SF), "gyro_scale_factor_tau_s": 100.0,
                                "init_gyro_scale_factor_sigma_ppm": 10.0})
    kf = ErrorStateKF(c, NavState(0.0, 0.5, 2.0, 1000.0, np.zeros(3), np.eye(3)))
    for k in range(1, 2001):
        kf.predict(ImuSample(k * 0.5, 0.5, np.zeros(3), np.array([0.0, 0.0, 9.79]) * 0.5))
    assert math.sqrt(kf.P[c.layout.sl("sg"), c.layout.sl("sg")][0, 0]) == pytest.approx(100e-6, rel=0.02)


def test_the_gate_switched_off_accepts_an_outlier():
    s = NavState(0.0, 0.5, 2.0, 1000.0, np.zeros(3), np.eye(3))
    outlier = GnssPosition(0.0, s.lat_rad + 300.0 / 6.4e6, s.lon_rad, s.alt_m, np.eye(3))   # ~300 m off, sigma 1 m
    out = {}
    for p in (0.9999, 1.0):
        kf = ErrorStateKF(FilterConfig(gate_probability=p), s)
        ctx = ModelContext.at(kf, ImuSample(0.0, 0.01, np.zeros(3), np.zeros(3)), (0.0, 0.0, 0.0))
        out[p] = kf.update(outlier.kind, 0.0, *kf.model(outlier, ctx))
    assert not out[0.9999].accepted and out[1.0].accepted and out[1.0].nis > 1000
    with pytest.raises(ConfigError, match="gate_probability: must be <= 1"):
        FilterConfig(gate_probability=1.5)


def test_initial_state_with_bias_and_scale_values_from_one_declaration():
    values = check_all(INIT_PARAMS, {"lat_deg": 30.0, "lon_deg": 114.0, "alt_m": 20.0, "vel_ned_mps": [1.0, 2.0, 3.0],
                                     "roll_pitch_heading_deg": [1.0, -2.0, 185.0], "gyro_bias_deg_per_hr": [3, -3, 3],
                                     "accel_bias_mgal": 100.0, "gyro_scale_factor_ppm": [100, 200, 300]})
    nav = initial_state(values)
    assert nav.vel_enu_mps == pytest.approx([2.0, 1.0, -3.0])
    assert nav.accel_bias_b_mps2 == pytest.approx(np.full(3, 1e-3))
    kf = ErrorStateKF(FilterConfig(state_blocks=SF), nav)
    lay = kf.layout
    assert kf.values[lay.value_sl("bg")] == pytest.approx(units.deg_per_hr([3, -3, 3]))
    assert kf.values[lay.value_sl("sg")] == pytest.approx([1e-4, 2e-4, 3e-4])
    back = state_values(nav)
    assert back["gyro_scale_factor_ppm"] == pytest.approx([100, 200, 300])
    from hyper_nav_filter.core.initial_state import euler_deg
    assert euler_deg(nav) == pytest.approx((1.0, -2.0, 185.0))
    # over a base (a simulated truth plus error): only the given fields change
    over = from_block({"accel_bias_ug": [10.0, 20.0, 30.0]}, nav)
    assert over.lat_rad == pytest.approx(nav.lat_rad) and over.accel_bias_b_mps2 == pytest.approx(
        units.ug([10.0, 20.0, 30.0]))
    with pytest.raises(ConfigError, match="initial_state.lat_deg: required"):
        from_block({"lon_deg": 1.0, "alt_m": 0.0})
    with pytest.raises(ConfigError, match="initial_state.lat_deg: must be <= 90"):
        from_block({"lat_deg": 95.0, "lon_deg": 1.0, "alt_m": 0.0})


def test_scenario_initial_state_block_over_truth_plus_error(tmp_path):
    from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, load_scenario
    base = load_scenario("default")
    sc = apply_overrides(base, {"filter.initial_state": {"gyro_bias_deg_per_hr": [0.1, -0.1, 0.1],
                                                         "alt_m": 30500.0}}, tmp_path)
    a, b = base.filter_initial_state(), sc.filter_initial_state()
    assert b.alt_m == 30500.0 and b.lat_rad == a.lat_rad
    assert b.gyro_bias_b_radps == pytest.approx(units.deg_per_hr([0.1, -0.1, 0.1]))
    with pytest.raises(ScenarioError, match="filter.initial_state.gyro_bias_deg_per_hr: expected 3 numbers"):
        apply_overrides(base, {"filter.initial_state": {"gyro_bias_deg_per_hr": [1.0, 2.0]}}, tmp_path)
