"""The fusion core flown over a simulated scenario without ROS (tests,
studies): the scenario's IMU and loosely coupled GNSS streams, in time order,
through ``hyper_nav_filter.core.fusion.FusionEngine``, and the per-axis
errors of the released solutions against the truth."""
from __future__ import annotations

import time

import numpy as np

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.stream_runner import Stamped, StreamRunner
from hyper_nav_sim.core import simulate
from hyper_nav_workbench.core import scoring


def fly(sc, cfg, decimate: int = 1, duration_s: float | None = None, release_every: int = 10):
    """Run the engine over the scenario; returns (solutions, engine, trajectory,
    wall seconds). ``decimate`` sums consecutive IMU increments (exactly the
    integral over the longer interval; only the coning/sculling resolution
    changes)."""
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    n = len(imu.t_s) if duration_s is None else int(round(duration_s / imu.dt_s))
    n -= n % decimate
    t = imu.t_s[decimate - 1:n:decimate]
    dth = imu.dtheta_b_rad[:n].reshape(-1, decimate, 3).sum(axis=1)
    dv = imu.dvel_b_mps[:n].reshape(-1, decimate, 3).sum(axis=1)
    meas = simulate.gnss_measurements(sc, traj)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    t0 = time.perf_counter()
    sols = StreamRunner(eng, [Stamped(meas)], release_every).run(t, dth, dv)
    return sols, eng, traj, time.perf_counter() - t0


def per_axis_errors(sols, traj, t_from: float = 0.0):
    """ENU per-axis errors (estimate - truth, ``core.scoring``) of the released
    solutions from t_from on: (times, {"att": deg, "vel": m/s, "pos": m}, each (N, 3))."""
    e = scoring.solution_errors([s for s in sols if s.t_s >= t_from - 1e-9], traj)
    return e["t"], {"att": e["att_enu_deg"], "vel": e["vel_enu_mps"], "pos": e["pos_enu_m"]}


def fly_current(sc, cfg, delivery_delay_s: float = 0.0, duration_s: float | None = None,
                outage: tuple[float, float] | None = None, keep_every: int = 1):
    """Run the engine over the scenario with the GNSS fixes delivered
    ``delivery_delay_s`` after their epoch (a receiver's latency) and none
    inside ``outage`` (t0, t1); returns (current-time states, one per IMU
    sample (every ``keep_every``-th), released solutions, engine, trajectory,
    per-sample wall seconds of ``add_imu``)."""
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    n = len(imu.t_s) if duration_s is None else min(len(imu.t_s), int(round(duration_s / imu.dt_s)))
    meas = [m for m in simulate.gnss_measurements(sc, traj)
            if outage is None or not (outage[0] <= m.t_s < outage[1])]
    eng = FusionEngine(cfg, sc.filter_initial_state())
    cur, wall = [], np.empty(n)
    run = StreamRunner(eng, [Stamped(meas, delivery_delay_s)])

    def current(k, t):
        if k % keep_every == 0:
            cur.append(eng.current)
    sols = run.run(imu.t_s, imu.dtheta_b_rad, imu.dvel_b_mps, n, on_sample=current, imu_wall_s=wall)
    return cur, sols, eng, traj, wall


def nees_pos_vel(sols, traj) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity NEES (3 dof each) of solutions against the truth
    at their own stamps, with their own ENU covariance."""
    e = scoring.solution_errors(sols, traj)
    lay = None
    out_p, out_v = np.empty(len(sols)), np.empty(len(sols))
    for i, s in enumerate(sols):
        P = s.P
        if lay is None:
            lay = s._src[0].layout
        pp, vv = P[lay.sl("pos"), lay.sl("pos")], P[lay.sl("vel"), lay.sl("vel")]
        ep, ev = e["pos_enu_m"][i], e["vel_enu_mps"][i]
        out_p[i] = ep @ np.linalg.solve(pp, ep)
        out_v[i] = ev @ np.linalg.solve(vv, ev)
    return out_p, out_v
