"""Scenario -> target tracker: the tracker's configuration (the scenario's
``tracker:`` block, with the radar noise of its ``radar:`` block), the
tracker node's ROS parameters, and the truth/radar track of the scenario's
flight for offline runs.

``truth_track(traj, t)`` gives the filter's state and input along a flight:
x = [alt, lon, lat, V, gamma, psi, 0] (geodetic, relative to the rotating
Earth: what the radar measures) and u = [lambda1, lambda2, T_chi] from the
flown c_l and bank angle (seed 002 eqs. 14, 17); the T_chi label is half the
period of a weave/square wave (the time between direction changes), else the
nominal T_chi.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking.config import TrackerConfig

from .imu_model import imu_epochs
from .radar import EarlyWarningRadar
from .scenario import Scenario

PERIODIC = ("square_wave", "evasive", "s_turn")


@dataclass
class Track:
    t_s: np.ndarray          # (N,) radar epochs
    x: np.ndarray            # (N, 7) physical truth state
    u: np.ndarray            # (N, 3) true inputs
    flight: dict


def t_chi_label(t_s, maneuvers, nominal_s: float) -> np.ndarray:
    out = np.full(np.shape(t_s), float(nominal_s))
    for m in maneuvers:
        if m["type"] in PERIODIC:
            inside = (t_s >= m["t_start_s"]) & (t_s <= m.get("t_end_s", np.inf))
            out[inside] = 0.5 * m["period_s"]
    return out


def truth_track(traj, t_s, maneuvers=(), nominal_t_chi_s: float = 100.0):
    """(x (N, 7), u (N, 3)) along a flight at the epochs t_s (see module doc)."""
    t_s = np.asarray(t_s, float)
    f = traj.flight(t_s)
    Y = traj.state(t_s)
    x = np.stack([Y[2], Y[1], Y[0], f["V"], f["gamma"], f["psi"], np.zeros_like(t_s)], axis=-1)
    u = gm.true_inputs(f["c_l"], f["sigma"], t_chi_label(t_s, maneuvers, nominal_t_chi_s))
    return x, u


def tracker_config(sc: Scenario, **overrides) -> TrackerConfig:
    """``TrackerConfig`` of a scenario: its ``tracker:`` block; the filter's R
    is the radar's datasheet noise (``radar:`` block)."""
    d = dict(sc.data.get("tracker") or {})
    radar = sc.data.get("radar") or {}
    for key in ("sigma_alt_m", "sigma_lon_rad", "sigma_lat_rad"):
        if key in radar:
            d.setdefault(f"radar_{key}", radar[key])
    d.update(overrides)
    return TrackerConfig.from_dict(d)


def radar_model(sc: Scenario) -> EarlyWarningRadar:
    return EarlyWarningRadar(**dict(sc.data["radar"]))


def radar_epochs(sc: Scenario) -> np.ndarray:
    """The radar node's epochs (``simulate.radar_stream``): 1/rate ... duration."""
    return imu_epochs(sc["duration_s"], radar_model(sc).rate_hz)


def initial_truth(sc: Scenario) -> np.ndarray:
    """True tracker state at t = 0 (the initial estimate's epoch)."""
    return truth_track(sc.trajectory(), np.array([0.0]))[0][0]


def scenario_track(sc: Scenario, nominal_t_chi_s: float | None = None) -> Track:
    """Truth state and inputs at the radar epochs of the scenario's flight."""
    cfg = tracker_config(sc)
    traj = sc.trajectory()
    t = radar_epochs(sc)
    man = (sc.data.get("flight") or {}).get("maneuvers", [])
    x, u = truth_track(traj, t, man, nominal_t_chi_s or cfg.nominal_t_chi_s)
    return Track(t, x, u, sc.data.get("flight", {}))


def tracker_parameters(sc: Scenario) -> dict:
    """The tracker node's ROS parameters, all derived from the scenario: the
    configuration (``tracker.*``) and the initial estimate (``init.*``: the true
    state at t = 0 plus ``tracker.init_error_*``, a track hand-over)."""
    cfg = tracker_config(sc)
    x0 = cfg.initial_estimate(initial_truth(sc))
    params = cfg.as_parameters()
    params.update({"init.t_s": 0.0, "init.state": [float(v) for v in x0], "qos.depth": int(sc["graph.qos_depth"])})
    return params


def radar_measurements(sc: Scenario, rng: np.random.Generator) -> np.ndarray:
    """(N, 3) radar z = [alt_m, lon_rad, lat_rad] at ``radar_epochs`` with a
    given noise draw; ``sc.rng("radar")`` gives the radar node's stream."""
    return radar_model(sc).measure(sc.trajectory(), radar_epochs(sc), rng).as_array()

