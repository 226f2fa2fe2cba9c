"""Tracking loops: closed forms (Kaplan & Hegarty 2nd ed. sec. 5.6), the 1 kHz
simulation against them, aided vs unaided under jerk, kernel vs its Python twin,
bad inputs."""
from __future__ import annotations

import numpy as np
import pytest

from hyper_nav_gnss.receiver import tracking as tr
from hyper_nav_gnss.receiver.tracking import (
    ChannelBank, LoopConfig, aiding_doppler_error_hz, dll_thermal_sigma_chips, fll_dynamic_stress_hz,
    fll_thermal_sigma_hz, pll_dynamic_stress_deg, pll_holds, pll_thermal_sigma_deg, pll_threshold_dbhz,
)

LAMBDA_L1_M = 299792458.0 / 1575.42e6
G = 9.80665


def test_closed_forms_by_hand():
    # 30 dB-Hz, 15 Hz, 1 ms: sqrt(15/1000 (1 + 1/2)) = 0.15 rad
    assert pll_thermal_sigma_deg(30.0, 15.0, 1e-3) == pytest.approx(np.rad2deg(0.15), rel=1e-12)
    # theta_e3 = 0.4828 R'''/B_n^3 and theta_e2 = 0.2809 R''/B_n^2 (K&H)
    assert pll_dynamic_stress_deg(1e5, 15.0, 3) == pytest.approx(0.4828 * 1e5 / 15.0 ** 3, rel=1e-3)
    assert pll_dynamic_stress_deg(1e3, 10.0, 2) == pytest.approx(0.2809 * 1e3 / 10.0 ** 2, rel=1e-3)
    # FLL: 1/(2 pi T) sqrt(4 F Bn/c (1 + 1/(T c))), 30 dB-Hz, 2 Hz, 1 ms, F = 1 -> 159.15 * sqrt(0.016)
    assert fll_thermal_sigma_hz(30.0, 2.0, 1e-3) == pytest.approx(np.sqrt(0.016) / (2 * np.pi * 1e-3), rel=1e-12)
    assert fll_dynamic_stress_hz(360.0 * 100.0, 0.53) == pytest.approx(100.0, rel=1e-12)
    # DLL: sqrt(1 * 0.5/(2 * 1000) (1 + 2/(0.001 * 1000 * 1.5)))
    assert dll_thermal_sigma_chips(30.0, 1.0, 1e-3, 0.5) == pytest.approx(np.sqrt(0.5 / 2000 * (1 + 2 / 1.5)))
    # rule of thumb: thresholds solve 3 sigma + theta_e = 45 deg
    thr = pll_threshold_dbhz(15.0, 1e-3)
    assert 3 * pll_thermal_sigma_deg(thr, 15.0, 1e-3) == pytest.approx(45.0, abs=1e-6)
    assert thr == pytest.approx(26.6, abs=0.05)
    assert pll_threshold_dbhz(3.0, 0.02) == pytest.approx(17.9, abs=0.05)
    assert not pll_holds(30.0, 15.0, 1e-3, dyn_stress_deg=30.0) and pll_holds(30.0, 15.0, 1e-3, dyn_stress_deg=15.0)


@pytest.mark.parametrize("cfg", [LoopConfig(), LoopConfig.aided_default()], ids=["unaided", "aided"])
@pytest.mark.parametrize("cn0", [45.0, 35.0])
def test_static_receiver_jitter_matches_closed_form(cfg, cn0):
    """12 channels x 10 s at constant C/N0, seeded. Phase-error samples are
    correlated over ~1/(4 B_n); >= 1000 independent samples -> the std estimate
    is within ~3 %; tolerance 12 % (the closed form is the linear-loop result)."""
    n_ch, n = 12, 10000
    bank = ChannelBank(cfg, n_ch, 0.0)
    out = bank.run(np.zeros((n, n_ch)), np.full((n, n_ch), cn0), np.random.default_rng(11))
    assert np.all(out.mode == tr.MODE_PLL)
    ph = out.phase_err_rad[1000:]
    assert np.rad2deg(ph.std()) == pytest.approx(pll_thermal_sigma_deg(cn0, cfg.bn_pll_hz, cfg.t_coh_s), rel=0.12)
    assert out.code_err_chips[1000:].std() == pytest.approx(
        dll_thermal_sigma_chips(cn0, cfg.bn_dll_hz, cfg.t_coh_s, cfg.d_chips), rel=0.15 if cfg.t_coh_s > 1e-3 else 0.12)
    assert np.median(out.cn0_est_dbhz[-1]) == pytest.approx(cn0, abs=0.5)


def test_code_error_correlation_between_epochs_is_the_first_order_loops():
    """The aided DLL (0.1 Hz) at constant C/N0: the simulated code error's
    correlation over 1 s is exp(-4 B_n 1 s) = 0.67 within 0.08 (12 channels x
    60 s, seeded), so the receiver's reported sigma grows by
    tracking.epoch_correlation_factor (2.25) for 1 Hz epochs; the factor by
    its formula, and 1 for a wide loop."""
    cfg = LoopConfig.aided_default()
    n_ch, n = 12, 60000
    bank = ChannelBank(cfg, n_ch, 0.0)
    out = bank.run(np.zeros((n, n_ch)), np.full((n, n_ch), 40.0), np.random.default_rng(5))
    e = out.code_err_chips[5000:]
    lag = 1000                                               # 1 s of 1 ms steps
    rho = np.sum(e[:-lag] * e[lag:]) / np.sum(e * e) * len(e) / (len(e) - lag)
    assert rho == pytest.approx(np.exp(-4.0 * cfg.bn_dll_hz), abs=0.08)
    r = np.exp(-0.4)
    assert tr.epoch_correlation_factor(0.1, 1.0) == pytest.approx(np.sqrt((1 + r) / (1 - r)), rel=1e-12)
    assert tr.epoch_correlation_factor(0.1, 1.0) == pytest.approx(2.25, abs=0.01)
    assert tr.epoch_correlation_factor(5.0, 1.0) == pytest.approx(1.0, abs=1e-8)


def _jerk_doppler_hz(jerk_mps3, n_ms, t_on=1.0, t_off=3.0):
    t = np.arange(1, n_ms + 1) * 1e-3
    J = jerk_mps3 / LAMBDA_L1_M
    tj = np.clip(t - t_on, 0.0, t_off - t_on)
    return np.where(t < t_off, 0.5 * J * tj ** 2, 0.5 * J * (t_off - t_on) ** 2 + J * (t_off - t_on) * (t - t_off))


def test_dynamic_stress_of_the_simulated_loop():
    """5 g/s line-of-sight jerk at 45 dB-Hz: mean phase error over the last
    second of the jerk equals theta_e3 = 13.3 deg within 10 %."""
    n_ch, n = 12, 3500
    f = np.repeat(_jerk_doppler_hz(5 * G, n)[:, None], n_ch, 1)
    out = ChannelBank(LoopConfig(), n_ch, 0.0).run(f, np.full((n, n_ch), 45.0), np.random.default_rng(2))
    expect = pll_dynamic_stress_deg(5 * G / LAMBDA_L1_M * 360.0, 15.0, 3)
    assert expect == pytest.approx(13.3, abs=0.1)
    assert np.rad2deg(out.phase_err_rad[2000:3000].mean()) == pytest.approx(expect, rel=0.10)


def test_aided_loop_keeps_lock_under_jerk_where_unaided_loses_it():
    """20 g/s jerk for 2 s at 35 dB-Hz: theta_e3 = 53 deg for the unaided
    15 Hz loop (rule: lost), while the aided loop sees only the aiding error
    (velocity sigma 0.1 m/s, 10 s correlation)."""
    n_ch, n = 12, 4000
    rng = np.random.default_rng(4)
    f_true = np.repeat(_jerk_doppler_hz(20 * G, n)[:, None], n_ch, 1)
    cn0 = np.full((n, n_ch), 35.0)
    un = ChannelBank(LoopConfig(), n_ch, 0.0).run(f_true, cn0, rng)
    t = np.arange(1, n + 1) * 1e-3
    u = rng.normal(size=(n_ch, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    f_aid_err = aiding_doppler_error_hz(u, np.eye(3) * 0.1 ** 2, t, 10.0, rng)
    ai = ChannelBank(LoopConfig.aided_default(), n_ch, 0.0).run(-f_aid_err, cn0, rng)
    assert not pll_holds(35.0, 15.0, 1e-3, pll_dynamic_stress_deg(20 * G / LAMBDA_L1_M * 360, 15.0, 3))
    slipped_un = (np.abs(un.phase_err_rad) > np.pi / 2).any(axis=0)
    slipped_ai = (np.abs(ai.phase_err_rad) > np.pi / 2).any(axis=0)
    assert slipped_un.sum() >= 10 and (un.mode[1000:3000] < tr.MODE_PLL).any(axis=0).sum() >= 10
    assert not slipped_ai.any() and np.all(ai.mode == tr.MODE_PLL)


def test_compiled_kernel_equals_python_reference():
    n_ch, n = 4, 1500
    rng = np.random.default_rng(9)
    noise, unif = rng.standard_normal((n, n_ch, 3)), rng.random((n, n_ch, 3))
    f = np.repeat(np.linspace(0, 30, n)[:, None], n_ch, 1)
    cn0 = np.repeat(np.linspace(40, 0, n)[:, None], n_ch, 1)        # drives channels through loss and search
    outs = []
    for compiled in (True, False):
        b = ChannelBank(LoopConfig(drop_hold_s=0.04, cn0_tau_s=0.05), n_ch, 0.0, q_cells=3, compiled=compiled)
        o = b.run(f, cn0, None, noise=noise, unif=unif)
        outs.append((o, b.state.copy()))
    (a, sa), (b_, sb) = outs
    assert (a.mode == 0).any()                                       # the search path ran
    for x, y in ((a.mode, b_.mode), (a.phase_err_rad, b_.phase_err_rad), (a.code_err_chips, b_.code_err_chips),
                 (a.cn0_est_dbhz, b_.cn0_est_dbhz), (sa, sb)):
        np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-9)


def test_bad_inputs_rejected():
    b = ChannelBank(LoopConfig(), 2, 0.0)
    rng = np.random.default_rng(0)
    cn0 = np.full((10, 2), 40.0)
    cn0[3, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite C/N0"):
        b.run(np.zeros((10, 2)), cn0, rng)
    with pytest.raises(ValueError, match="expected"):
        b.run(np.zeros((10, 3)), np.full((10, 3), 40.0), rng)
    with pytest.raises(ValueError, match="cn0_dbhz"):
        pll_thermal_sigma_deg(np.nan, 15.0, 1e-3)
    t = np.arange(5.0)
    bad = np.diag([1.0, -0.5, 1.0])
    with pytest.raises(ValueError, match="positive semidefinite"):
        aiding_doppler_error_hz(np.eye(3), bad, t, 10.0, rng)
    asym = np.eye(3)
    asym[0, 1] = 0.3
    with pytest.raises(ValueError, match="not symmetric"):
        aiding_doppler_error_hz(np.eye(3), asym, t, 10.0, rng)
    with pytest.raises(ValueError, match="finite"):
        aiding_doppler_error_hz(np.eye(3), np.full((3, 3), np.nan), t, 10.0, rng)
    with pytest.raises(ValueError, match="t_coh_s"):
        LoopConfig(t_coh_s=0.0015).validate()
    with pytest.raises(ValueError, match="too wide"):
        LoopConfig(t_coh_s=0.02, bn_pll_hz=15.0).validate()


def test_aiding_error_has_the_covariance_it_was_given():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 4000.0, 1.0)
    u = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    P = np.diag([0.04, 0.09, 0.25])
    e = aiding_doppler_error_hz(u, P, t, 5.0, rng)
    # sigma of u.dv / lambda: 0.5 / lambda (up), sqrt(0.36 * 0.04 + 0.64 * 0.09) / lambda;
    # 4000 s / 5 s correlation ~ 400 independent samples per channel -> std within ~7 % (2 sigma)
    assert e[:, 0].std() == pytest.approx(0.5 / LAMBDA_L1_M, rel=0.1)
    assert e[:, 1].std() == pytest.approx(np.sqrt(0.36 * 0.04 + 0.64 * 0.09) / LAMBDA_L1_M, rel=0.1)


def test_aided_nco_bound_inside_the_fll_range():
    with pytest.raises(ValueError, match="nco_limit_hz"):
        LoopConfig(t_coh_s=0.02, bn_pll_hz=3.0, bn_dll_hz=0.1, nco_limit_hz=15.0).validate()
    # 40 channels searching while C/N0 ramps 12 -> 37 dB-Hz over 20 s: with the default bound (3 Hz,
    # re-centred on the aiding when a channel out of phase lock runs to it) all end in phase lock
    n_ch, n = 40, 20000
    bank = ChannelBank(LoopConfig.aided_default(), n_ch, 0.0, q_cells=2)
    rng = np.random.default_rng(0)
    bank.start_search(rng)
    out = bank.run(np.zeros((n, n_ch)), np.repeat(np.linspace(12.0, 37.0, n)[:, None], n_ch, 1), rng)
    assert int((out.mode[-1] != tr.MODE_PLL).sum()) == 0
