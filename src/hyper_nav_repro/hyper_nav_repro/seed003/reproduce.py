"""Reproduce seed 003 (Chen et al. 2020) Table 3 and Figs. 6-9, with the PCRB.

    ros2run hyper_nav_repro repro_seed003 [--seeds 20] [--out results/seed003]
    make seed003

Pure INS (barometric height only) from 0 to 420 s, then each algorithm
(MAGCOM, ICCP, SIMAN of the paper, and our EKF pseudo-fix) from 420 to
790 s, at the map-error levels 0.1, 1, 5 and 10 nT, over N random seeds,
on the offline fusion core with the node's aiding core in the loop
(``aided_flight``). Every parameter comes from the scenario
(``seed003.yaml``: ``geomag:`` and ``geomag.reproduction:``).

Per cell: absolute mean latitude and longitude error over 420-790 s (the
paper's metric; median and 5-95 % over seeds), the same split along and
across the field gradient (RMS), the aiding's computation time, fixes
accepted/gated, and the share of seeds where the aided error ends above the
pure-INS error ("diverged"); beside the paper's single-run values and the
PCRB (``bound``; lat/lon as the mean |error| of a Gaussian with the
bound's sigma, along/across as RMS; ours / bound ratios on the RMS). Writes
``table3.json``, ``series.npz`` (error curves) and ``fig_<level>nT.png``
(the paper's Figs. 6-9: latitude and longitude error against time).

The map's epoch is checked against the flight's date
(``magnetometer.epoch_decimal_year``; ``core.map_epoch``, issue 27): beyond
``geomag.map_epoch_tolerance_nT`` the run is refused (exit 2, the error
names both fields and the implied nT); within it the implied bias is
printed and written to ``table3.json`` (``map_epoch``); with
``geomag.map_bring_forward`` the map is brought to the flight's date first.

``--short``: a 60 s flight (pure INS to 30 s, then matching), one level,
two seeds, a coarse map of the first degree of the flight: a few seconds,
run by the test suite.
"""
from __future__ import annotations

import os

# one BLAS thread: the work is many small matrices (15-21 states, a growing
# triangular solve in the bound), where OpenBLAS threads cost more than they
# give: 8.2 ms vs 0.38 ms per 200 x 200 triangular solve on the 2-core
# machine under load (measured); set before numpy loads (the command line)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import copy
import json
import pathlib
import sys
import time
from dataclasses import dataclass, replace

import numpy as np

from hyper_nav_filter.core.config import FilterConfig

from hyper_nav_aiding.geomag.core.geomag_aiding import GeomagAiding
from hyper_nav_aiding.geomag.core.geomag_config import GeomagConfig
from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap, cached_map_path, get_or_build, load_map
from hyper_nav_aiding.geomag.core.map_epoch import bring_forward, check as check_map_epoch
from .bound import FlightBound
from .aided_flight import AidedFlight, baro_measurements, imu_streams, mag_total, position_errors
from .table import format_table, plot, summarize

SHORT = {"duration_s": 60.0, "start_s": 30.0, "levels_nT": [1.0], "seeds": 2, "imu_decimate": 10,
         "map": {"lat_min_deg": 40.0, "lat_max_deg": 42.0, "lon_min_deg": 111.0, "lon_max_deg": 112.0,
                 "grid_step_deg": 0.05, "refine_factor": 40}}


@dataclass
class ReproConfig:
    levels_nT: list
    level_reading: str
    attitude_reading: str
    attitude_errors_arcsec: list
    draw_truth_from_prior: bool
    seeds: int
    algorithms: list
    state_blocks: dict
    imu_decimate: int

    @classmethod
    def from_dict(cls, d: dict) -> "ReproConfig":
        try:
            rc = cls(**{k: d[k] for k in cls.__dataclass_fields__})
        except KeyError as exc:
            raise ValueError(f"geomag.reproduction: missing field {exc}") from None
        if rc.level_reading not in ("correlated", "white_uniform"):
            raise ValueError("geomag.reproduction.level_reading: 'correlated' or 'white_uniform', "
                             f"got {rc.level_reading!r}")
        if rc.attitude_reading not in ("enu", "body"):
            raise ValueError(f"geomag.reproduction.attitude_reading: 'enu' or 'body', got {rc.attitude_reading!r}")
        for a in rc.algorithms:
            alg, *opts = a.split("-")
            if alg not in rc.state_blocks or any(o not in VARIANTS for o in opts):
                raise ValueError(f"geomag.reproduction.algorithms: '{a}' is not one of {sorted(rc.state_blocks)} "
                                 f"with optional variants {sorted(VARIANTS)}")
        return rc

    def attitude_sigma_enu_arcsec(self) -> np.ndarray:
        """Table 1 lists roll, yaw, pitch = a[0], a[1], a[2]. 'enu': on E, N, U
        in that order; 'body' at heading 0 (north): roll about N, pitch about
        E, yaw about U."""
        a = np.asarray(self.attitude_errors_arcsec, float)
        return a.copy() if self.attitude_reading == "enu" else np.array([a[2], a[0], a[1]])

    def map_error_rms(self, level_nT: float) -> float:
        return level_nT if self.level_reading == "correlated" else level_nT / np.sqrt(3.0)


# ---- scenario per seed -------------------------------------------------------------
def _set(data: dict, dotted: str, value) -> None:
    cur = data
    parts = dotted.split(".")
    for p in parts[:-1]:
        cur = cur.setdefault(p, {})
    cur[parts[-1]] = value


def derived_scenario(sc, overrides: dict):
    """A validated copy of the scenario with dotted overrides; the
    trajectory is shared when the flight is unchanged."""
    from hyper_nav_sim.core.scenario import Scenario, validate
    data = copy.deepcopy(sc.data)
    for k, v in overrides.items():
        _set(data, k, v)
    out = Scenario(sc.path, validate(data, str(sc.path)))
    if not any(k.startswith(("flight", "duration_s", "maneuvers", "start")) for k in overrides):
        out._traj = sc._traj
    return out


def truth_overrides(sc, rc: ReproConfig, seed: int) -> dict:
    """The seed's scenario fields: its random streams, and (with
    draw_truth_from_prior) initial errors and IMU constant errors drawn from
    the Gaussian prior with Table 1's magnitudes as sigmas."""
    o = {"seed": int(seed), "magnetometer.map_error_seed": int(seed)}
    att = rc.attitude_sigma_enu_arcsec() / 60.0
    if not rc.draw_truth_from_prior:
        o["filter.initial_error.att_enu_arcmin"] = att.tolist()
        return o
    rng = np.random.default_rng([int(seed), 3003])
    fc = sc.data["filter"]["config"]
    imu = sc.data["imu"]

    def draw(sigma):
        return (np.abs(np.asarray(sigma, float)) * rng.standard_normal(3)).tolist()
    o["filter.initial_error.att_enu_arcmin"] = draw(att)
    o["filter.initial_error.vel_enu_mps"] = draw(fc["init_vel_sigma_mps"])
    o["filter.initial_error.pos_enu_m"] = draw(fc["init_pos_sigma_m"])
    for k in ("gyro_bias_deg_per_hr", "accel_bias_ug", "gyro_scale_factor_ppm", "accel_scale_factor_ppm"):
        o[f"imu.{k}"] = draw(np.broadcast_to(np.abs(np.asarray(imu[k], float)), (3,)))
    return o


def filter_config(sc, rc: ReproConfig, blocks) -> FilterConfig:
    """The scenario's filter, with the algorithm's state blocks and the
    attitude prior of the reading."""
    d = dict(sc.data["filter"]["config"])
    d["state_blocks"] = list(blocks)
    d["init_att_sigma_arcmin"] = (rc.attitude_sigma_enu_arcsec() / 60.0).tolist()
    return FilterConfig.from_dict(d)


def bound_config(sc, rc: ReproConfig) -> FilterConfig:
    """The truth's error model for the PCRB: 21 states, Table 1 sigmas,
    the IMU's white noise."""
    imu = sc.data["imu"]
    fc = sc.data["filter"]["config"]
    return FilterConfig(
        state_blocks=("att", "vel", "pos", "bg", "ba", "sg", "sa"),
        gyro_arw_deg_per_sqrt_hr=float(imu["gyro_arw_deg_per_sqrt_hr"]),
        accel_vrw_ug_per_sqrt_hz=float(imu["accel_vrw_ug_per_sqrt_hz"]),
        gyro_bias_sigma_deg_per_hr=float(np.max(np.abs(imu["gyro_bias_deg_per_hr"]))),
        accel_bias_sigma_ug=float(np.max(np.abs(imu["accel_bias_ug"]))),
        gyro_scale_factor_sigma_ppm=float(np.max(np.abs(imu["gyro_scale_factor_ppm"]))),
        accel_scale_factor_sigma_ppm=float(np.max(np.abs(imu["accel_scale_factor_ppm"]))),
        init_att_sigma_arcmin=tuple(rc.attitude_sigma_enu_arcsec() / 60.0),
        init_vel_sigma_mps=tuple(fc["init_vel_sigma_mps"]), init_pos_sigma_m=tuple(fc["init_pos_sigma_m"]))


VARIANTS = {"geometry": "fix covariance along/across the gradient instead of isotropic",
            "2d": "EKF horizontal pseudo-fix (altitude error as noise)",
            "15": "the paper's 15-state fusion filter"}


def base_algorithm(name: str) -> str:
    """'ICCP-geometry' -> 'ICCP' (variants: ``VARIANTS``)."""
    return name.split("-")[0]


def cell_geomag_config(gcfg: GeomagConfig, rc: ReproConfig, sc, level: float, name: str) -> GeomagConfig:
    """The node's configuration for one cell: the algorithm (and variant),
    and the map error it assumes = the simulated one (the paper's algorithms
    know the level they run at)."""
    alg, *opts = name.split("-")
    for o in opts:
        if o not in VARIANTS:
            raise ValueError(f"algorithm variant '{o}' of '{name}' unknown (known: {sorted(VARIANTS)})")
    corr = float(sc["magnetometer.map_error_corr_length_m"]) if rc.level_reading == "correlated" else 0.0
    return replace(gcfg, algorithm=alg, field_sigma_nT=rc.map_error_rms(level),
                   sensor_sigma_nT=float(sc["magnetometer.noise_nT"]),
                   fix_covariance="geometry" if "geometry" in opts else gcfg.fix_covariance,
                   ekf=replace(gcfg.ekf, map_error_corr_length_m=corr, vertical=gcfg.ekf.vertical and "2d" not in opts))


def state_blocks_of(rc: ReproConfig, sc, name: str) -> tuple:
    if "15" in name.split("-")[1:]:
        return tuple(sc.data["filter"]["config"]["state_blocks"])
    return tuple(rc.state_blocks[base_algorithm(name)])


# ---- one seed ----------------------------------------------------------------------
@dataclass
class SeedJob:
    scenario_path: str
    overrides: dict
    rc: ReproConfig
    gcfg: GeomagConfig
    map_path: str
    seed: int


def run_seed(job: SeedJob) -> dict:
    """Every (level, algorithm) cell of one seed, plus pure INS."""
    from hyper_nav_sim.core.scenario import load_scenario
    rc, gcfg = job.rc, job.gcfg
    base = derived_scenario(load_scenario(job.scenario_path), job.overrides)
    sc = derived_scenario(base, truth_overrides(base, rc, job.seed))
    traj = sc.trajectory()
    epoch = check_map_epoch(gcfg, float(sc["magnetometer.epoch_decimal_year"]))
    gmap = _at_flight_date(load_map(job.map_path, gcfg.map), epoch)
    end = float(sc["duration_s"])
    t_all = np.arange(0.0, np.floor(end) + 1e-9, 1.0)
    tr = traj.truth(t_all)
    grad = _truth_gradient(gmap, tr)
    imu_t, dth, dv = imu_streams(sc, traj, rc.imu_decimate)
    baro = baro_measurements(sc, traj)
    init = sc.filter_initial_state()
    starts = {}
    ins_blocks = tuple(sc.data["filter"]["config"]["state_blocks"])
    for blocks in {state_blocks_of(rc, sc, a) for a in rc.algorithms} | {ins_blocks}:
        fl = AidedFlight(filter_config(sc, rc, blocks), init, imu_t, dth, dv, baro)
        fl.run_until(gcfg.start_s - 1e-6)          # the epoch start_s and its sample belong to the aided part
        starts[blocks] = fl
    out = {"seed": job.seed, "truth": {k: v for k, v in truth_overrides(base, rc, job.seed).items()}, "cells": {}}
    fl = starts[ins_blocks].fork()
    fl.run_until(end)
    out["ins"] = _metrics(position_errors(fl.posterior, traj, t_all), t_all, grad, gcfg.start_s)
    for level in rc.levels_nT:
        sc_l = derived_scenario(sc, {"magnetometer.map_error_rms_nT": rc.map_error_rms(level),
                                     "magnetometer.map_error_model": rc.level_reading})
        mag_t, mag_nT = mag_total(sc_l, traj)
        for alg in rc.algorithms:
            cfg = cell_geomag_config(gcfg, rc, sc_l, level, alg)
            aiding = GeomagAiding(cfg, gmap, epoch=epoch)
            fl = starts[state_blocks_of(rc, sc, alg)].fork()
            fl.run_until(end, aiding, mag_t, mag_nT)
            m = _metrics(position_errors(fl.posterior, traj, t_all), t_all, grad, gcfg.start_s)
            acc, rej = (sum(fl.eng.kf.stats.get(k, (0, 0, 0.0))[i] for k in ("horizontal_fix", "position_fix"))
                        for i in (0, 1))
            m.update({"compute_time_s": aiding.compute_cpu_s, "compute_wall_s": aiding.compute_time_s,
                      "fixes_accepted": int(acc), "fixes_gated": int(rej),
                      "counters": dict(aiding.counters)})
            out["cells"][f"{level:g}/{alg}"] = m
    return out


def _at_flight_date(gmap: GeomagMap, epoch) -> GeomagMap:
    """The map brought to the flight's date when the scenario asks for it."""
    return bring_forward(gmap, epoch.measurement_epoch_decimal_year) if epoch.brought_forward else gmap


def _truth_gradient(gmap: GeomagMap, tr) -> np.ndarray:
    """Horizontal field gradient (E, N) at the true positions; outside the
    map the nearest point inside."""
    s = gmap.spec
    lat = np.clip(tr.lat_rad, np.deg2rad(s.lat_min_deg), np.deg2rad(s.lat_max_deg))
    lon = np.clip(tr.lon_rad, np.deg2rad(s.lon_min_deg), np.deg2rad(s.lon_max_deg))
    _, g = gmap.total_and_gradient(lat, lon, tr.alt_m)
    return g[:, :2]


def _metrics(err: np.ndarray, t: np.ndarray, grad_en: np.ndarray, start_s: float) -> dict:
    u = grad_en / np.linalg.norm(grad_en, axis=1, keepdims=True)
    along = np.sum(err[:, :2] * u, axis=1)
    across = u[:, 0] * err[:, 1] - u[:, 1] * err[:, 0]
    w = (t >= start_s - 1e-9) & np.all(np.isfinite(err), axis=1)
    last = np.flatnonzero(np.all(np.isfinite(err), axis=1))[-1]
    def mean_abs(x):
        return float(np.mean(np.abs(x[w])))

    def rms(x):
        return float(np.sqrt(np.mean(x[w] ** 2)))
    return {"lat_mean_abs_m": mean_abs(err[:, 1]), "lon_mean_abs_m": mean_abs(err[:, 0]),
            "along_rms_m": rms(along), "across_rms_m": rms(across),
            "along_mean_abs_m": mean_abs(along), "across_mean_abs_m": mean_abs(across),
            "final_lat_abs_m": float(abs(err[last, 1])), "final_lon_abs_m": float(abs(err[last, 0])),
            "series_en_m": err[:, :2].astype(np.float32)}


def _seed_json(result: dict) -> dict:
    """One seed's figures for its per-run JSON (the error series stay in series.npz)."""
    def strip(m):
        return {k: v for k, v in m.items() if k != "series_en_m"}
    return {**result, "ins": strip(result["ins"]), "cells": {k: strip(c) for k, c in result["cells"].items()}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Reproduce seed 003 Table 3 / Figs. 6-9 with the PCRB.")
    ap.add_argument("--scenario", default="seed003")
    ap.add_argument("--out", default="results/seed003")
    ap.add_argument("--seeds", type=int, default=None, help="number of seeds (default: the scenario's)")
    ap.add_argument("--levels", default=None, help="comma-separated levels in nT")
    ap.add_argument("--algorithms", default=None, help="comma-separated, e.g. SIMAN,EKF")
    ap.add_argument("--level-reading", choices=("correlated", "white_uniform"), default=None)
    ap.add_argument("--attitude-reading", choices=("enu", "body"), default=None)
    ap.add_argument("--fixed-truth", action="store_true", help="fly the scenario's fixed initial/IMU errors")
    from hyper_nav_workbench import campaign
    campaign.add_arguments(ap)             # --workers, --scheduler, --max-workers: the seeds as a dask campaign
    ap.add_argument("--no-vector-bound", action="store_true")
    ap.add_argument("--short", action="store_true", help="60 s smoke run (tests)")
    args = ap.parse_args(argv)
    try:
        return _run(args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"repro_seed003: error: {exc}", file=sys.stderr)
        return 2


def _run(args) -> int:
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_sim.core.baro_model import BaroErrors, altitude_sigma_m
    t_start = time.perf_counter()
    sc0 = load_scenario(args.scenario)
    g = copy.deepcopy(sc0.data["geomag"])
    rdict = dict(g.get("reproduction", {}))
    overrides = {}
    if args.short:
        overrides = {"duration_s": SHORT["duration_s"], "flight.duration_s": SHORT["duration_s"]}
        g["start_s"] = SHORT["start_s"]
        g["map"].update(SHORT["map"])
        rdict.update({k: SHORT[k] for k in ("levels_nT", "seeds", "imu_decimate")})
    if args.seeds is not None:
        rdict["seeds"] = args.seeds
    if args.levels:
        rdict["levels_nT"] = [float(x) for x in args.levels.split(",")]
    if args.algorithms:
        rdict["algorithms"] = args.algorithms.split(",")
    if args.level_reading:
        rdict["level_reading"] = args.level_reading
    if args.attitude_reading:
        rdict["attitude_reading"] = args.attitude_reading
    if args.fixed_truth:
        rdict["draw_truth_from_prior"] = False
    rdict["levels_nT"] = [float(x) for x in rdict["levels_nT"]]
    rc = ReproConfig.from_dict(rdict)
    gcfg = GeomagConfig.from_dict(g)
    sc = derived_scenario(sc0, overrides)
    epoch = check_map_epoch(gcfg, float(sc["magnetometer.epoch_decimal_year"]))    # MapEpochError: exit 2
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = (lambda m: print(f"[repro_seed003] {m}", flush=True))
    log(f"map epoch: {epoch.describe()}, within geomag.map_epoch_tolerance_nT = {gcfg.map_epoch_tolerance_nT:g} nT")
    gmap = _at_flight_date(get_or_build(gcfg.map, gcfg.map_cache_dir or None,
                                        workers=max(1, args.workers or os.cpu_count() or 1), log=log), epoch)
    map_path = str(cached_map_path(gcfg.map, gcfg.map_cache_dir or None))

    # the bound: independent of the seed (same flight, prior, noise statistics)
    traj = sc.trajectory()
    end = float(sc["duration_s"])
    t_b = np.arange(0.0, np.floor(end) + 1e-9, 1.0)
    alt = traj.truth(t_b).alt_m
    baro_sigma = altitude_sigma_m(alt, BaroErrors.from_config(sc.data["barometer"], prefix="barometer"))
    t0 = time.perf_counter()
    fb = FlightBound.build(traj, t_b, gmap, bound_config(sc, rc), baro_sigma)
    bounds, bounds_t, vbounds = {}, {}, {}
    corr_L = float(sc["magnetometer.map_error_corr_length_m"])
    sensor = float(sc["magnetometer.noise_nT"])
    for level in rc.levels_nT:
        hb = fb.bound(gcfg.start_s, rc.map_error_rms(level), rc.level_reading, sensor, corr_L)
        bounds[level] = hb.window(gcfg.start_s, end).summary()
        bounds_t[level] = {k: getattr(hb, k).tolist() for k in ("t_s", "sigma_n_m", "sigma_e_m", "sigma_along_m",
                                                                  "sigma_across_m")}
        if not args.no_vector_bound:
            vb = fb.bound(gcfg.start_s, rc.map_error_rms(level), rc.level_reading, sensor, corr_L, components="vector")
            vbounds[level] = vb.window(gcfg.start_s, end).summary()
    log(f"PCRB for {len(rc.levels_nT)} levels in {time.perf_counter() - t0:.1f} s")

    jobs = [SeedJob(str(sc0.path), overrides, rc, gcfg, map_path, s) for s in range(1, rc.seeds + 1)]
    from hyper_nav_workbench import campaign
    log(f"{len(jobs)} seeds on {campaign.where(campaign.options(args))}")
    t0 = time.perf_counter()
    results = campaign.run("repro_seed003", run_seed, jobs, keys=[f"seed{j.seed:03d}" for j in jobs],
                           opts=campaign.options(args), out_dir=out / "runs", to_json=_seed_json,
                           warm_up=("hyper_nav_repro.seed003.reproduce",)).results
    wall = time.perf_counter() - t0
    table = summarize(results, rc, bounds, vbounds)
    table["wall_s"] = {"seeds": wall, "total": time.perf_counter() - t_start}
    table["map"] = {"file": map_path, **{k: getattr(gmap.spec, k) for k in gmap.spec.__dataclass_fields__}}
    table["map_epoch"] = {**epoch.summary(), "map_epoch_tolerance_nT": gcfg.map_epoch_tolerance_nT}
    text = format_table(table, len(results))
    print(text)
    series = {"INS": np.stack([r["ins"]["series_en_m"] for r in results])}
    for k in results[0]["cells"]:
        series[k] = np.stack([r["cells"][k]["series_en_m"] for r in results])
    for r in results:
        r["ins"].pop("series_en_m")
        for c in r["cells"].values():
            c.pop("series_en_m")
    table["per_seed"] = results
    table["bound_series"] = {f"{k:g}": v for k, v in bounds_t.items()}
    (out / "table3.json").write_text(json.dumps(table, indent=1, default=float))
    (out / "table3.txt").write_text(text + "\n")
    np.savez_compressed(out / "series.npz", t_s=t_b, **{k.replace("/", "_"): v for k, v in series.items()})
    figs = plot(series, bounds_t, t_b, out, rc.levels_nT, rc.algorithms)
    log(f"wrote {out / 'table3.json'}, {out / 'series.npz'}, {', '.join(f.name for f in figs)}; "
        f"{wall:.0f} s for {len(results)} seeds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
