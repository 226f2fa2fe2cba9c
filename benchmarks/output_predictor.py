"""Current-time output (issue 35): the output predictor's rules measured.

On the default scenario (simulated world; seed 000 section IV.B flight) with
the IMU at ``--imu-hz`` and the GNSS fixes delivered ``--gnss-delay`` s after
their epoch (declared as the fusion horizon ``fusion_delay_s``), over
``--seeds`` random draws of IMU biases and initial errors, for

* the delayed stream (the released, arrival-order-independent solutions),
* the current-time stream, one state per IMU sample, with the output
  predictor's rules ``repropagate`` and ``complementary`` (tau 0.25 s), and
  with no fusion delay at all (the filter's own newest state; late fixes
  re-processed),

it prints: the per-sample cost of ``add_imu`` (mean, p99, max) and of the
predictor step alone, the jumps of the current-time stream (the step of its
position / velocity error from one sample to the next: p99, max), position
RMS (3D) of each stream, position and velocity NEES (mean over the run), and
the same through a 60 s GNSS outage (``--outage``) at the delayed stream's
stamps. Writes JSON (``--out``). Timings: wall clock of this process on a
shared machine; ratios within one run are what count.

    python benchmarks/output_predictor.py [--seeds 3] [--duration 120] [--imu-hz 200]
"""
from __future__ import annotations

import argparse
import json
import pathlib
import tempfile
import time

import numpy as np

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_workbench.core import scoring
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from hyper_nav_workbench.offline_fly import fly_current, nees_pos_vel


def scenario(seed: int, duration_s: float, imu_hz: float):
    base = load_scenario("default")
    cfg = base.filter_config()
    rng = np.random.default_rng(1000 + seed)
    ov = {"seed": 1000 + seed, "duration_s": duration_s, "imu.rate_hz": imu_hz,
          "imu.gyro_bias_deg_per_hr": (rng.standard_normal(3) * cfg.gyro_bias_sigma_deg_per_hr).tolist(),
          "imu.accel_bias_ug": (rng.standard_normal(3) * cfg.accel_bias_sigma_ug).tolist(),
          "filter.initial_error.pos_enu_m": (rng.standard_normal(3) * np.array(cfg.init_pos_sigma_m)).tolist(),
          "filter.initial_error.vel_enu_mps": (rng.standard_normal(3) * np.array(cfg.init_vel_sigma_mps)).tolist()}
    return apply_overrides(base, ov, pathlib.Path(tempfile.mkdtemp()))


def timed_predictor(eng) -> list:
    """Wrap the engine's predictor step to time it alone."""
    times, step = [], eng.predictor.step

    def wrapped(*a):
        t0 = time.perf_counter()
        out = step(*a)
        times.append(time.perf_counter() - t0)
        return out
    eng.predictor.step = wrapped
    return times


def one(sc, cfg, gnss_delay_s, duration_s, outage, t_from):
    import hyper_nav_workbench.offline_fly as of
    real = of.FusionEngine
    pred_times = []

    class Timed(real):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            pred_times.append(timed_predictor(self))
    of.FusionEngine = Timed
    try:
        cur, sols, eng, traj, wall = fly_current(sc, cfg, gnss_delay_s, duration_s, outage)
    finally:
        of.FusionEngine = real
    pt = np.array(pred_times[0]) if pred_times else np.array([])
    cur = [c for c in cur if c.t_s >= t_from]
    sols = [s for s in sols if s.t_s >= t_from]
    ec, es = scoring.solution_errors(cur, traj), scoring.solution_errors(sols, traj)
    dpos = np.linalg.norm(np.diff(ec["pos_enu_m"], axis=0), axis=1)
    dvel = np.linalg.norm(np.diff(ec["vel_enu_mps"], axis=0), axis=1)
    npc, nvc = nees_pos_vel(cur[::10], traj)
    nps, nvs = nees_pos_vel(sols, traj)
    # the current-time stream at the delayed stream's stamps
    tc = np.round(ec["t"] * 1e6)
    ts = np.round(es["t"] * 1e6)
    m = np.isin(tc, ts)
    out = {
        "add_imu_us": {"mean": 1e6 * wall.mean(), "p99": 1e6 * np.percentile(wall, 99), "max": 1e6 * wall.max()},
        "predictor_us": {"mean": 1e6 * pt.mean(), "p99": 1e6 * np.percentile(pt, 99), "max": 1e6 * pt.max()},
        "jump_pos_m": {"p99": float(np.percentile(dpos, 99)), "max": float(dpos.max())},
        "jump_vel_mps": {"p99": float(np.percentile(dvel, 99)), "max": float(dvel.max())},
        "pos_rms_current_m": float(np.sqrt(np.mean(np.sum(ec["pos_enu_m"] ** 2, axis=1)))),
        "pos_rms_current_at_delayed_stamps_m": float(np.sqrt(np.mean(np.sum(ec["pos_enu_m"][m] ** 2, axis=1)))),
        "pos_rms_delayed_m": float(np.sqrt(np.mean(np.sum(es["pos_enu_m"] ** 2, axis=1)))),
        "nees_pos_current": float(npc.mean()), "nees_vel_current": float(nvc.mean()),
        "nees_pos_delayed": float(nps.mean()), "nees_vel_delayed": float(nvs.mean()),
        "reanchors": eng.predictor.reanchors, "strapdown_steps": eng.predictor.steps,
        "epochs_reprocessed": eng.counters.get("epochs_reprocessed", 0),
    }
    return out


def micro(imu_hz: float, delay_s: float) -> dict:
    """In-process cost of the predictor step over a 20 s flight (the engine
    fed as in ``fly_current``): median and p90 of the calls with no
    correction and, for ``repropagate``, of the calls that re-run the horizon
    (medians: robust to a busy machine's preemptions)."""
    from hyper_nav_filter.core.fusion import FusionEngine
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.simulate import gnss_measurements
    sc = scenario(0, 20.0, imu_hz)
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj)
    meas = gnss_measurements(sc, traj)
    out = {}
    for rule in ("repropagate", "complementary"):
        cfg = FilterConfig.from_dict({**sc.filter_config().as_dict(), "fusion_delay_s": delay_s,
                                      "output_predictor": rule})
        eng = FusionEngine(cfg, sc.filter_initial_state())
        pr = eng.predictor
        step, plain, re = pr.step, [], []

        def timed(*a):
            n0 = pr.reanchors
            t0 = time.perf_counter()
            r = step(*a)
            dt = time.perf_counter() - t0
            (re if pr.reanchors != n0 else plain).append(dt)
            return r
        pr.step = timed
        j = 0
        for k in range(len(imu.t_s)):
            t = float(imu.t_s[k])
            while j < len(meas) and meas[j].t_s + delay_s <= t - 1e-9:
                eng.add_measurement(meas[j])
                j += 1
            eng.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        plain, re = np.array(plain[len(plain) // 10:]) * 1e6, np.array(re[1:]) * 1e6
        out[rule] = {"step_median_us": float(np.median(plain)), "step_p90_us": float(np.percentile(plain, 90)),
                     "n_steps": len(plain)}
        if len(re):
            out[rule].update({"repropagate_median_us": float(np.median(re)), "n_repropagations": len(re),
                              "horizon_samples": int(round(delay_s * imu_hz))})
    return out


VARIANTS = {
    "no fusion delay (late fixes re-processed)": {"fusion_delay_s": 0.0},
    "repropagate": {"output_predictor": "repropagate"},
    "complementary tau 0.25 s": {"output_predictor": "complementary"},
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--imu-hz", type=float, default=200.0)
    ap.add_argument("--gnss-delay", type=float, default=0.2)
    ap.add_argument("--outage", type=float, nargs=2, default=None, metavar=("T0", "T1"))
    ap.add_argument("--from", dest="t_from", type=float, default=10.0, help="score from this time on (s)")
    ap.add_argument("--out", default="results/output_predictor.json")
    ap.add_argument("--micro", action="store_true", help="only the in-process per-sample cost of the predictor")
    a = ap.parse_args(argv)
    if a.micro:
        for hz in (200.0, 1000.0):
            print(f"IMU {hz:g} Hz, horizon {a.gnss_delay:g} s: {micro(hz, a.gnss_delay)}")
        return
    results = {}
    for name, over in VARIANTS.items():
        runs = []
        for seed in range(a.seeds):
            sc = scenario(seed, a.duration, a.imu_hz)
            base = sc.filter_config()
            cfg = FilterConfig.from_dict({**base.as_dict(), "fusion_delay_s": a.gnss_delay, **over})
            runs.append(one(sc, cfg, a.gnss_delay, a.duration, tuple(a.outage) if a.outage else None, a.t_from))
        results[name] = runs
        print(f"\n== {name} ({a.seeds} seeds, {a.duration:g} s, IMU {a.imu_hz:g} Hz, GNSS delivered "
              f"{a.gnss_delay:g} s late{', outage %g-%g s' % tuple(a.outage) if a.outage else ''})")
        keys = [k for k in runs[0] if not isinstance(runs[0][k], dict)]
        for k in keys:
            v = np.array([r[k] for r in runs], float)
            print(f"  {k:40s} mean {v.mean():10.4g}  spread {v.std():8.3g}")
        for k in [k for k in runs[0] if isinstance(runs[0][k], dict)]:
            print(f"  {k:40s} " + "  ".join(f"{q} {np.mean([r[k][q] for r in runs]):8.4g}" for q in runs[0][k]))
    out = pathlib.Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"args": vars(a), "results": results}, indent=1, default=float))
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
