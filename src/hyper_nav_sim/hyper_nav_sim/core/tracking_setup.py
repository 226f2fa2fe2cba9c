"""Scenario -> target tracker: the tracker's configuration (the scenario's
``tracker:`` block, with the radar noise of its ``radar:`` block), the
tracker node's ROS parameters, and the truth/radar track of the scenario's
flight for offline runs."""
from __future__ import annotations

import numpy as np

from hyper_nav_filter.core.tracking.config import TrackerConfig

from .imu_model import imu_epochs
from .radar import EarlyWarningRadar
from .scenario import Scenario
from .tracking_data import Track, truth_track


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

