"""Monte Carlo runs of a scenario through the fusion core, and the
campaign statistics (no ROS, no dask: ``mc_campaign`` distributes
``run_one`` over dask workers).

Run k of a campaign draws, from the scenario's own distributions:
  * ``noise``: every sensor noise stream, through the scenario seed
    (seed + k: ``Scenario.rng`` derives each sensor's stream from it);
  * ``biases``: the true IMU biases (and scale factors when the filter
    carries them) ~ N(0, the filter's prior sigma of that block,
    ``init_*_sigma`` or the steady-state sigma), per axis;
  * ``initial``: the initial position, velocity and attitude errors ~
    N(0, ``init_pos_sigma_m`` / ``init_vel_sigma_mps`` / ``init_att_sigma_arcmin``).
The draws of run k depend on (scenario seed, k) only, never on which worker
runs it: a campaign gives the same numbers on any number of workers.

Per epoch of the output grid (``grid_hz``) a run returns its errors
(estimate - truth, ENU), the filter's 1-sigma, NEES of position, velocity
and attitude (3 dof each), and per update kind the NIS sums of the updates
since the previous epoch (``eskf`` keeps them per kind). ``aggregate``
gives ANEES and ANIS with their 95 % chi-square bands, RMS and percentiles
over the runs, per epoch (Bar-Shalom, Li, Kirubarajan, sec. 5.4).
"""
from __future__ import annotations

import copy
import math
import pathlib
import tempfile
import time

import numpy as np
from scipy.stats import chi2

from hyper_nav_workbench.core import scoring

DRAWS = ("noise", "biases", "initial")
KIND_DOF = {"gnss_pos": 3, "gnss_vel": 3}
BAND = (0.025, 0.975)


def run_seed(base_seed: int, k: int) -> int:
    """The scenario seed of run k (independent streams per run)."""
    return int(np.random.SeedSequence([int(base_seed), int(k)]).generate_state(1)[0])


def draw_overrides(data: dict, cfg, k: int, draws=DRAWS) -> dict:
    """Scenario field overrides of run k (see the module docstring)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(data["seed"]), int(k), 1]))
    out = {"seed": run_seed(data["seed"], k)} if "noise" in draws else {}
    c = cfg.as_dict()

    def prior(init_name, steady_name):
        v = np.asarray(c.get(init_name, [math.nan] * 3), float)
        return np.asarray(c[steady_name], float) if np.all(np.isnan(v)) else v
    # always draw in the same order, so adding a draw kind never shifts the others
    z = rng.standard_normal((7, 3))
    if "biases" in draws:
        out["imu.gyro_bias_deg_per_hr"] = (z[0] * prior("init_gyro_bias_sigma_deg_per_hr",
                                                         "gyro_bias_sigma_deg_per_hr")).tolist()
        out["imu.accel_bias_ug"] = (z[1] * prior("init_accel_bias_sigma_ug", "accel_bias_sigma_ug")).tolist()
        if "sg" in cfg.state_blocks:
            out["imu.gyro_scale_factor_ppm"] = (z[2] * prior("init_gyro_scale_factor_sigma_ppm",
                                                             "gyro_scale_factor_sigma_ppm")).tolist()
        if "sa" in cfg.state_blocks:
            out["imu.accel_scale_factor_ppm"] = (z[3] * prior("init_accel_scale_factor_sigma_ppm",
                                                              "accel_scale_factor_sigma_ppm")).tolist()
    if "initial" in draws:
        out["filter.initial_error.pos_enu_m"] = (z[4] * np.asarray(c["init_pos_sigma_m"])).tolist()
        out["filter.initial_error.vel_enu_mps"] = (z[5] * np.asarray(c["init_vel_sigma_mps"])).tolist()
        out["filter.initial_error.att_enu_arcmin"] = (z[6] * np.asarray(c["init_att_sigma_arcmin"])).tolist()
    return out


def run_one(data: dict, k: int, draws=DRAWS, grid_hz: float = 1.0) -> dict:
    """One Monte Carlo run of the scenario ``data`` (a validated scenario
    mapping, so a remote worker needs no file); see the module docstring."""
    from hyper_nav_filter.core.fusion import FusionEngine
    from hyper_nav_filter.core.stream_runner import StreamRunner

    from hyper_nav_workbench.core import mc_sources
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import Scenario, set_fields, validate
    cpu0 = time.process_time()
    base = Scenario(pathlib.Path("campaign.yaml"), copy.deepcopy(data))
    cfg = base.filter_config()
    over = draw_overrides(data, cfg, k, draws)
    d = set_fields(copy.deepcopy(data), over)
    with tempfile.TemporaryDirectory(prefix="hyper_nav_mc_") as tmp:
        sc = Scenario(pathlib.Path(tmp) / "run.yaml", validate(d, f"run {k}"))
        traj = sc.trajectory()
        imu = simulate.imu_stream(sc, traj)
        feed = mc_sources.Feed(sc, traj, cfg)       # the declared sources: loose or tight GNSS, barometer
    eng = FusionEngine(cfg, sc.filter_initial_state())
    lay = cfg.layout
    nis_rows, next_grid = [], [1.0 / grid_hz]
    last = {}

    def nis_grid(i, t):
        if t >= next_grid[0] - 1e-9:
            nis_rows.append((next_grid[0], _nis_deltas(eng.kf.stats, last)))
            next_grid[0] += 1.0 / grid_hz
    run = StreamRunner(eng, [feed], keep=lambda s: _on_grid(s.t_s, grid_hz))
    sols = run.run(imu.t_s, imu.dtheta_b_rad, imu.dvel_b_mps, on_sample=nis_grid)
    e = scoring.solution_errors(sols, traj)
    out = {"k": k, "seed": over.get("seed", data["seed"]), "draws": over, "t_s": e["t"],
           "err": {"pos": e["pos_enu_m"], "vel": e["vel_enu_mps"], "att": np.deg2rad(e["att_enu_deg"])},
           "sigma": {}, "nees": {}}
    for b, e in out["err"].items():
        sl = lay.sl(b)
        P = np.array([s.P[sl, sl] for s in sols])
        out["sigma"][b] = np.sqrt(np.diagonal(P, axis1=1, axis2=2))
        out["nees"][b] = np.einsum("ni,ni->n", e, np.linalg.solve(P, e[..., None])[..., 0])
    kinds = sorted({kd for _, row in nis_rows for kd in row})
    out["nis_t_s"] = np.array([g for g, _ in nis_rows])
    out["nis"] = {kd: np.array([row.get(kd, (0, 0.0))[1] for _, row in nis_rows]) for kd in kinds}
    out["nis_n"] = {kd: np.array([row.get(kd, (0, 0.0))[0] for _, row in nis_rows]) for kd in kinds}
    out["gated"] = {kd: int(v[1]) for kd, v in eng.kf.stats.items()}
    out["accepted"] = {kd: int(v[0]) for kd, v in eng.kf.stats.items()}
    out["far"] = {kd: int(w.far) for kd, w in eng.kf.watch.items()}
    out["recoveries"] = {kd: int(w.recoveries) for kd, w in eng.kf.watch.items()}
    out["mean_nis_per_dof"] = {kd: v[2] / v[0] if v[0] else float("nan") for kd, v in eng.kf.stats.items()}
    out["aiding"] = [dict(f.counts) for f in feed.aiding]     # the aiding nodes' counters (their diagnostics)
    out["cpu_s"] = time.process_time() - cpu0            # for throughput figures only, never in the statistics
    return out


def _on_grid(t: float, grid_hz: float) -> bool:
    x = t * grid_hz
    return abs(x - round(x)) < 1e-6


def _nis_deltas(stats: dict, last: dict) -> dict:
    """{kind: (accepted updates, sum of their NIS)} since the previous call
    (``stats``: {kind: (accepted, gated, sum of NIS/dof)})."""
    out = {}
    for kind, (acc, _gated, nis_per_dof) in stats.items():
        a0, s0 = last.get(kind, (0, 0.0))
        dof = KIND_DOF.get(kind)
        if dof is not None and acc > a0:
            out[kind] = (acc - a0, (nis_per_dof - s0) * dof)
        last[kind] = (acc, nis_per_dof)
    return out


def band(n_runs: int, dof: int) -> tuple[float, float]:
    """95 % band of the average of n_runs chi-square(dof) variables."""
    lo, hi = chi2.ppf(BAND, n_runs * dof)
    return float(lo / n_runs), float(hi / n_runs)


def run_metrics(r: dict, skip_s: float) -> dict:
    """Scalar figures of one run after skip_s (RMS 3D, max 3D, largest |error| on
    any axis, mean NEES)."""
    m = r["t_s"] >= skip_s
    out = {"k": r["k"], "seed": r["seed"]}
    for b, scale in (("pos", 1.0), ("vel", 1.0), ("att", 180.0 / math.pi)):
        e = np.linalg.norm(r["err"][b][m], axis=1) * scale
        out[f"{b}_rms_3d"] = float(np.sqrt(np.mean(e**2))) if len(e) else math.nan
        out[f"{b}_max_3d"] = float(e.max()) if len(e) else math.nan
        out[f"{b}_max_axis"] = float(np.max(np.abs(r["err"][b][m])) * scale) if len(e) else math.nan
        out[f"{b}_mean_nees"] = float(np.mean(r["nees"][b][m])) if len(e) else math.nan
    out["gated"] = r["gated"]
    out["accepted"] = r.get("accepted", {})
    out["aiding"] = r.get("aiding", [])           # the aiding nodes' counters (e.g. geomag fixes published)
    return out


def aggregate(runs: list[dict], skip_s: float = 0.0) -> dict:
    """Campaign statistics per epoch: ANEES (pos, vel, att) and ANIS per
    update kind with 95 % bands, RMS over runs of the 3D errors, 50th and
    95th percentiles, and the filter's RMS 1-sigma (3D) for comparison."""
    runs = sorted(runs, key=lambda r: r["k"])
    n = len(runs)
    t = runs[0]["t_s"]
    if any(len(r["t_s"]) != len(t) for r in runs):
        raise ValueError("runs of different lengths")
    out = {"n_runs": n, "t_s": t.tolist(), "anees": {}, "anees_band": band(n, 3), "rms_3d": {}, "p50_3d": {},
           "p95_3d": {}, "sigma_3d": {}, "anis": {}, "anis_band": {}, "anis_t_s": runs[0]["nis_t_s"].tolist()}
    for b, scale in (("pos", 1.0), ("vel", 1.0), ("att", 180.0 / math.pi)):
        nees = np.array([r["nees"][b] for r in runs])
        e3 = np.array([np.linalg.norm(r["err"][b], axis=1) for r in runs]) * scale
        s3 = np.array([np.linalg.norm(r["sigma"][b], axis=1) for r in runs]) * scale
        out["anees"][b] = nees.mean(axis=0).tolist()
        out["rms_3d"][b] = np.sqrt(np.mean(e3**2, axis=0)).tolist()
        out["p50_3d"][b] = np.percentile(e3, 50, axis=0).tolist()
        out["p95_3d"][b] = np.percentile(e3, 95, axis=0).tolist()
        out["sigma_3d"][b] = np.sqrt(np.mean(s3**2, axis=0)).tolist()
    for kind, dof in KIND_DOF.items():
        if not all(kind in r["nis"] for r in runs):
            continue
        sums = np.sum([r["nis"][kind] for r in runs], axis=0)
        counts = np.sum([r["nis_n"][kind] for r in runs], axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            out["anis"][kind] = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan).tolist()
        lo, hi = zip(*[(chi2.ppf(BAND[0], dof * c) / c, chi2.ppf(BAND[1], dof * c) / c) if c > 0 else (np.nan, np.nan)
                       for c in counts])
        out["anis_band"][kind] = {"lo": list(lo), "hi": list(hi), "dof": dof}
    m = np.asarray(t) >= skip_s
    if not m.any():                      # a short campaign: summarize every epoch
        m[:] = True
        skip_s = 0.0
    out["skip_s"] = skip_s
    lo, hi = out["anees_band"]
    out["summary"] = {b: {"mean_anees": float(np.mean(np.asarray(out["anees"][b])[m])),
                          "share_in_band": float(np.mean((np.asarray(out["anees"][b])[m] > lo)
                                                         & (np.asarray(out["anees"][b])[m] < hi))),
                          "rms_3d": float(np.sqrt(np.mean(np.asarray(out["rms_3d"][b])[m] ** 2)))}
                      for b in ("pos", "vel", "att")}
    return out
