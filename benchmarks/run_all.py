"""hyper-nav benchmarks (figures, not pass/fail): ``make bench``.

1. Cost per IMU epoch of predict and of each update type (mean over many calls).
2. Real-time factor of the fusion core fed with messages exactly as the node
   gets them (message -> conversions -> FusionEngine -> released solutions),
   at 100 Hz and 500 Hz IMU; DDS transport is not included (see README).
3. The same 15-state loosely coupled job with the covariance handled by
   filterpy's KalmanFilter (predict with our Phi/Q, Joseph-form update), as
   a baseline measured in the same run; ratios are ours / baseline.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from hyper_nav_filter.core import earth
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import BaroHeight, GnssPosition, GnssVelocity, ModelContext
from hyper_nav_filter.core.nav_state import ImuSample
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.graph import apply_overrides


def timeit(fn, n):
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - t0) / n


def per_call_costs(sc):
    cfg = sc.filter_config()
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    kf = ErrorStateKF(cfg, sc.filter_initial_state(), cfg.initial_covariance())
    samples = [ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k]) for k in range(2000)]
    it = iter(samples)
    t_pred = timeit(lambda: kf.predict(next(it)), 2000)
    s = kf.state
    ctx = ModelContext(np.zeros(3), np.zeros(3), 0.0)
    pos = GnssPosition(s.t_s, s.lat_rad, s.lon_rad, s.alt_m, np.eye(3) * 25.0)
    vel = GnssVelocity(s.t_s, s.vel_enu_mps.copy(), np.eye(3) * 0.01)
    baro = BaroHeight(s.t_s, s.alt_m, 100.0)
    out = {"predict (mechanization + F + Phi P Phi^T)": t_pred}
    for name, m in (("update gnss position", pos), ("update gnss velocity", vel), ("update baro height", baro)):
        out[name] = timeit(lambda m=m: kf.update(m.kind, s.t_s, *m.model(kf.state, cfg.layout, ctx)), 500)
    return out


def configuration_costs():
    """Predict per IMU epoch of the paper configurations, and the tightly
    coupled update (8 satellites, pseudoranges + rates)."""
    from hyper_nav_filter.core.fusion import make_filter
    from hyper_nav_filter.core.tightly_coupled import Pseudoranges
    out = {}
    for label, name in (("predict seed 004, ENU 17 states (clk)", "seed004_tight"),
                        ("predict seed 001, LCI 21 states (sg, sa)", "seed001"),
                        ("predict seed 000, ENU 24 states (gm, lev)", "seed000_elastic")):
        sc = load_scenario(name)
        cfg = sc.filter_config()
        traj = sc.trajectory()
        imu = simulate.imu_stream(sc, traj)
        kf = make_filter(cfg, sc.filter_initial_state())
        samples = [ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k]) for k in range(1000)]
        it = iter(samples)
        out[label] = timeit(lambda: kf.predict(next(it)), 1000)
        if cfg.layout.has("clk"):
            s = kf.state
            r_a = earth.geodetic_to_ecef(s.lat_rad, s.lon_rad, s.alt_m)
            az = np.deg2rad(np.arange(8) * 45.0)
            el = np.deg2rad([20.0, 60.0] * 4)
            C_n_e = earth.C_n_e(s.lat_rad, s.lon_rad)
            u = (C_n_e @ np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])).T
            sat = r_a + 2.2e7 * u
            pr = Pseudoranges(s.t_s, sat, np.zeros((8, 3)), np.linalg.norm(sat - r_a, axis=1), np.full(8, 9.0),
                              np.zeros(8), np.full(8, 0.01))
            ctx = ModelContext(np.zeros(3), np.zeros(3), 0.0)
            out["update pseudoranges + rates, 8 satellites"] = timeit(
                lambda: kf.update(pr.kind, s.t_s, *pr.model(kf.state, cfg.layout, ctx)), 300)
    return out


class FilterpyBaseline:
    """15-state loosely coupled ESKF whose covariance algebra is filterpy's."""

    def __init__(self, cfg, initial):
        from filterpy.kalman import KalmanFilter
        self.cfg = cfg
        self.kf = KalmanFilter(dim_x=cfg.layout.dim, dim_z=3)
        self.kf.P = cfg.initial_covariance()
        self.helper = ErrorStateKF(cfg, initial.copy(), cfg.initial_covariance())   # nominal state, Phi and Q

    def predict(self, imu):
        lin = self.helper.linearize(imu)
        self.helper.predict(imu)          # the nominal state (its own P is not used)
        self.kf.predict(F=lin.Phi, Q=lin.Q)

    def update(self, meas):
        z, H, R = meas.model(self.helper.state, self.cfg.layout, ModelContext(np.zeros(3), np.zeros(3), 0.0))
        self.kf.x = np.zeros((self.cfg.layout.dim, 1))
        self.kf.update(z.reshape(-1, 1), R=R, H=H)
        self.helper.inject(self.kf.x.ravel())


def realtime_factor(sc, rate_hz, duration_s=30.0, baseline=False):
    import tempfile
    import pathlib
    sc = apply_overrides(sc, {"imu.rate_hz": rate_hz, "duration_s": duration_s},
                         pathlib.Path(tempfile.mkdtemp(prefix="bench_")))
    traj = sc.trajectory()
    imu, g = simulate.imu_stream(sc, traj), simulate.gnss_stream(sc, traj)
    meas = []
    for i in range(len(g.t_s)):
        meas.append(GnssPosition(g.t_s[i], g.lat_rad[i], g.lon_rad[i], g.alt_m[i], np.diag(g.pos_sigma_enu_m**2)))
        meas.append(GnssVelocity(g.t_s[i], g.vel_enu_mps[i], np.diag(g.vel_sigma_enu_mps**2)))
    t0 = time.perf_counter()
    if baseline:
        b = FilterpyBaseline(sc.filter_config(), sc.filter_initial_state())
        j = 0
        for k in range(len(imu.t_s)):
            b.predict(ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k]))
            while j < len(meas) and meas[j].t_s <= imu.t_s[k] + 1e-9:
                b.update(meas[j])
                j += 1
        state = b.helper.state
    else:
        eng = FusionEngine(sc.filter_config(), sc.filter_initial_state())
        j = 0
        for k in range(len(imu.t_s)):
            eng.add_imu(imu.t_s[k], imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
            while j < len(meas) and meas[j].t_s <= imu.t_s[k] + 1e-9:
                eng.add_measurement(meas[j])
                j += 1
            eng.release()
        state = eng.kf.state
    wall = time.perf_counter() - t0
    tr = traj.truth([state.t_s])
    err = np.linalg.norm(earth.position_error_enu_m(state.lat_rad, state.lon_rad, state.alt_m,
                                                    tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0]))
    return duration_s / wall, wall, err


def main() -> int:
    sc = load_scenario("default")
    print("== cost per call (default scenario, 15 states, 50 Hz IMU) ==")
    for name, t in per_call_costs(sc).items():
        print(f"  {name:45s} {t * 1e6:8.1f} us")
    print("== cost per call, paper configurations ==")
    for name, t in configuration_costs().items():
        print(f"  {name:45s} {t * 1e6:8.1f} us")
    print("== real-time factor of the fusion core (30 s flight, GNSS 10 Hz pos+vel) ==")
    print(f"  {'IMU rate':>8s} {'hyper-nav RTF':>14s} {'filterpy RTF':>13s} {'ratio':>7s}"
          f" {'final pos err ours/filterpy [m]':>32s}")
    for rate in (100.0, 500.0):
        ours, _, e1 = realtime_factor(sc, rate)
        base, _, e2 = realtime_factor(sc, rate, baseline=True)
        print(f"  {rate:8.0f} {ours:14.1f} {base:13.1f} {ours / base:7.2f} {e1:15.3f} / {e2:.3f}")
    print("  (hyper-nav includes the reorder buffer, snapshots and fixed-lag release; "
          "filterpy applies updates as they come)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
