"""A scenario as a LinCov problem (``hyper_nav_filter.core.lincov``): the
reference trajectory from the scenario's truth source, the truth's error
sources from the *simulated world's* models (``imu_model.ImuErrors``, the
GNSS block), the filter from ``filter.config``, the GNSS schedule with its
outages. No rclpy.

What the world is, for the analysis (``draws``):
  * ``prior`` (default): as a Monte Carlo campaign draws it
    (``montecarlo.draw_overrides``): the turn-on IMU biases, the scale
    factors the filter carries and the initial navigation errors are
    N(0, the filter's prior sigma); noise from the scenario's own figures.
  * ``scenario``: the scenario's fixed values taken as 1-sigma (turn-on
    biases, scale factors, ``filter.initial_error``): the figures of a
    datasheet grade, whose sign is unknown.
Everything else is the world's model as the simulator draws it: white
noise (ARW, VRW), first-order Markov drifts, the bias-instability Markov
sum (``imu_model.markov_sum_components``: components slower than 20 flight
durations act as one random constant, those faster than the LinCov step as
white noise of PSD 2 sigma^2 tau; the rest are states), scale factors and
misalignments (unmodelled by a filter without ``sg``/``sa``: mismodelling).
Quantization is left out: the simulator carries the residual into the next
sample, so its integral is bounded by half a quantum.
"""
from __future__ import annotations

import math

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_filter.core.blocks import REGISTRY
from hyper_nav_filter.core.lincov import InsLinCov, LooseGnss, Reference, TruthModel, TruthSource
from hyper_nav_filter.core import units

from hyper_nav_sim.core.gnss_model import parse_outages
from hyper_nav_sim.core.imu_model import ImuErrors, markov_sum_components

DRAWS = ("prior", "scenario")
LOOSE_TYPES = {"imu", "gnss_fix", "gnss_vel"}


def reference(traj, duration_s: float, step_s: float) -> Reference:
    """The reference at t = 0, step, ..., duration: truth states and the exact
    interval-mean body rate and specific force (IMU increments / step)."""
    n = int(math.floor(duration_s / step_s + 1e-9))
    t = np.arange(n + 1) * step_s
    tr = traj.truth(t)
    dth, dv = traj.imu_increments(t[1:], step_s)
    w_in = earth.omega_ie_n(tr.lat_rad) + earth.omega_en_n(tr.lat_rad, tr.alt_m, tr.vel_enu_mps)
    omega_nb_b = tr.omega_ib_b_radps - np.einsum("kji,kj->ki", tr.C_b_n, w_in)
    return Reference(t, tr.lat_rad, tr.lon_rad, tr.alt_m, tr.vel_enu_mps, tr.C_b_n, omega_nb_b,
                     dth / step_s, dv / step_s)


def _bias_instability(sensor, B, band, duration_s, step_s, role):
    """The Markov-sum components of one sensor's bias instability as sources."""
    if B <= 0:
        return []
    sig, taus = markov_sum_components(B, band)
    out, slow, fast = [], 0.0, 0.0
    name = f"{sensor} bias instability"
    for k, (s, tau) in enumerate(zip(sig, taus)):
        if tau > 20.0 * duration_s:
            slow += s**2
        elif tau < step_s:
            fast += 2.0 * s**2 * tau
        else:
            out.append(TruthSource(f"{name} [{tau:.3g} s]", sensor, "bias", s, tau, role, group=name))
    if slow > 0:
        out.append(TruthSource(f"{name} [const]", sensor, "bias", math.sqrt(slow), math.inf, role, group=name))
    if fast > 0:
        out.append(TruthSource(f"{name} [white]", sensor, "white", math.sqrt(fast), group=name))
    return out


def truth_model(sc, cfg, draws: str = "prior", step_s: float = 0.1, lever_arm_sigma_m=0.0) -> TruthModel:
    """The world's error sources (module docstring)."""
    if draws not in DRAWS:
        raise ValueError(f"draws: {draws!r} not in {DRAWS}")
    e = ImuErrors.from_scenario(sc)
    dur = float(sc["duration_s"])
    blocks = set(cfg.state_blocks)
    if draws == "prior":
        bg = REGISTRY["bg"].prior_sigma(cfg)
        ba = REGISTRY["ba"].prior_sigma(cfg)
        sg = REGISTRY["sg"].prior_sigma(cfg) if "sg" in blocks else np.abs(e.gyro_scale_factor)
        sa = REGISTRY["sa"].prior_sigma(cfg) if "sa" in blocks else np.abs(e.accel_scale_factor)
        att = units.arcmin(np.asarray(cfg.init_att_sigma_arcmin, float))
        init = np.concatenate([att, cfg.init_vel_sigma_mps, cfg.init_pos_sigma_m])
    else:
        bg, ba = np.abs(e.gyro_bias_b_radps), np.abs(e.accel_bias_b_mps2)
        sg, sa = np.abs(e.gyro_scale_factor), np.abs(e.accel_scale_factor)
        att = units.arcmin(np.abs(np.asarray(sc["filter.initial_error.att_enu_arcmin"], float)))
        init = np.concatenate([att, np.abs(sc["filter.initial_error.vel_enu_mps"]),
                               np.abs(sc["filter.initial_error.pos_enu_m"])])
    off = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]
    src = [
        TruthSource("gyro bias (turn-on)", "gyro", "bias", bg, math.inf, "gyro_bias"),
        TruthSource("accel bias (turn-on)", "accel", "bias", ba, math.inf, "accel_bias"),
        TruthSource("gyro Markov drift", "gyro", "bias", e.gyro_markov_sigma_radps, e.gyro_markov_tau_s, "gyro_bias",
                    prefer_block="gm"),
        TruthSource("accel Markov drift", "accel", "bias", e.accel_markov_sigma_mps2, e.accel_markov_tau_s,
                    "accel_bias"),
        *_bias_instability("gyro", e.gyro_bias_instability_radps, e.bias_instability_band_s, dur, step_s,
                           "gyro_bias"),
        *_bias_instability("accel", e.accel_bias_instability_mps2, e.bias_instability_band_s, dur, step_s,
                           "accel_bias"),
        TruthSource("gyro scale factor", "gyro", "scale", sg, math.inf, "gyro_scale"),
        TruthSource("accel scale factor", "accel", "scale", sa, math.inf, "accel_scale"),
        TruthSource("gyro misalignment", "gyro", "misalignment",
                    np.abs([e.gyro_misalignment_rad[i, j] for i, j in off])),
        TruthSource("accel misalignment", "accel", "misalignment",
                    np.abs([e.accel_misalignment_rad[i, j] for i, j in off])),
        TruthSource("gyro white noise (ARW)", "gyro", "white", e.gyro_arw_rad_per_sqrt_s),
        TruthSource("accel white noise (VRW)", "accel", "white", e.accel_vrw_mps_per_sqrt_s),
        TruthSource("GNSS lever arm", "gnss", "lever_arm", lever_arm_sigma_m),
    ]
    return TruthModel(tuple(src), init)


def measurements(sc, cfg, outages_s=()) -> list:
    """The scenario's GNSS as LinCov schedules (loosely coupled only)."""
    types = {s.type for s in sc.filter_source_specs()}
    other = types - LOOSE_TYPES
    if other:
        raise ValueError(f"LinCov: filter.sources of type {sorted(other)} are not modelled (loosely coupled GNSS "
                         "position/velocity only)")
    windows = tuple(parse_outages(sc.data["gnss"].get("outages_s"))) + tuple(outages_s)
    return [LooseGnss(float(sc["gnss.rate_hz"]), np.asarray(sc["gnss.pos_sigma_enu_m"], float),
                      np.asarray(sc["gnss.vel_sigma_enu_mps"], float),
                      np.asarray(cfg.antenna_lever_arm_b_m, float), windows,
                      use_pos="gnss_fix" in types, use_vel="gnss_vel" in types)]


def default_step_s(sc) -> float:
    """The LinCov step: 0.1 s, or the GNSS period when shorter (epochs on its grid)."""
    return min(0.1, 1.0 / float(sc["gnss.rate_hz"]))


def build(sc, draws: str = "prior", step_s: float | None = None, outages_s=(), lever_arm_sigma_m=0.0,
          cfg=None) -> InsLinCov:
    """The scenario's LinCov problem, ready to ``run()``."""
    cfg = sc.filter_config() if cfg is None else cfg
    step = default_step_s(sc) if step_s is None else float(step_s)
    ref = reference(sc.trajectory(), float(sc["duration_s"]), step)
    truth = truth_model(sc, cfg, draws, step, lever_arm_sigma_m)
    return InsLinCov(cfg, truth, ref, measurements(sc, cfg, outages_s))
