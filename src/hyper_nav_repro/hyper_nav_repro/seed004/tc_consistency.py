"""tc_consistency: is the tightly coupled filter's covariance honest in the
realistic world? Position NEES of seed 004's case (a) (no lock loss) over
the whole flight, and of a lock loss from 120 s (INS coasting after it),
flown through the fusion core exactly as ``repro_seed004`` flies them
(``seed004.cases``), for two filter configurations:

* ``before``: the scenario's filter before issue 37 item 5 (``BEFORE``: 17
  states, ``filter.config.range_errors: white``, pseudoranges weighted with
  the receiver's thermal sigma x ``sigma_scale`` 8);
* ``after``: the range errors the receiver's corrections leave modelled as
  per-satellite first-order Gauss-Markov range-bias states (``AFTER``: ``rb``,
  16 slots, ``core.blocks.range_bias``; sigma and correlation time measured on
  the simulated world by ``--measure``), the pseudoranges weighted with the
  thermal sigma alone (``sigma_scale`` 1): the configuration measured first;
* ``defaults``: the scenario as it is, nothing set: since issue 37 item 5 the
  filter's defaults (``range_errors: states``, which adds the ``rb32`` block
  with ``range_bias_sigma_m`` / ``range_bias_tau_s`` at their declared
  defaults, the values ``after`` measured) and the scenario's ``sigma_scale`` 1.

ANEES over N runs (seeds) per epoch, with the two-sided 95 % chi-square band
of 3N degrees of freedom divided by N; printed: the flight mean of ANEES,
the share of epochs inside the band, each seed's mean NEES, the horizontal /
vertical position RMS. ``--measure`` first prints the statistics of the range
errors left after the receiver's corrections on the seed 004 flight
(noise-free receiver, common mode removed: the clock takes it): RMS and the
structure function, i.e. what sigma and tau of a Gauss-Markov model fit.

    ros2run hyper_nav_repro tc_consistency --seeds 5 --measure --out results/tc_consistency
    ros2run hyper_nav_repro tc_consistency --seeds 3 --variants a --configs before,defaults --duration 60   # short
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import tempfile
import time
from dataclasses import replace

import numpy as np
from scipy.stats import chi2

from hyper_nav_workbench.graph import apply_overrides

from hyper_nav_aiding.virtual_gnss.offline import prepare

from .cases import run_case

BEFORE = {"filter.config.range_errors": "white", "filter.sources.gnss_raw.sigma_scale": 8.0}
AFTER = {"filter.config.state_blocks": ["att", "vel", "pos", "bg", "ba", "clk", "rb"],
         "filter.config.range_bias_sigma_m": 2.2, "filter.config.range_bias_tau_s": 1500.0,
         "filter.sources.gnss_raw.sigma_scale": 1.0}
CONFIGS = {"before": BEFORE, "after": AFTER, "defaults": {}}
VARIANTS = {"a": ("a", None), "loss_120s": ("d", 120.0)}


def anees_band(n_runs: int, dof: int = 3, p: float = 0.95) -> tuple[float, float]:
    a = (1.0 - p) / 2.0
    return float(chi2.ppf(a, dof * n_runs) / n_runs), float(chi2.ppf(1.0 - a, dof * n_runs) / n_runs)


def measure_range_errors(seeds, t_step_s: float = 5.0, duration_s: float = 500.0, log=print) -> dict:
    """Range errors the receiver's broadcast corrections leave on the seed 004
    flight (noise-free receiver at the true antenna and clock), per satellite,
    common mode per epoch removed: RMS and sqrt(E[(x(t+L) - x(t))^2]) at lags L."""
    from hyper_nav_gnss.orbits.ephemeris import C_MPS
    from hyper_nav_gnss.geometry import rot3
    from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections, corrected_pseudoranges
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import load_scenario
    lags = (5, 30, 60, 120, 240, 400)
    out = {"per_seed": []}
    pooled = {"x2": [], **{f"d{L}": [] for L in lags}}
    for seed in seeds:
        sc = load_scenario("seed004_virtual")
        sc.data["world"] = {"model": "realistic"}
        sc.data["seed"] = int(seed)
        rx = simulate.gnss_receiver(sc)
        corr = ReceiverCorrections.from_params("klobuchar", rx.cfg.klobuchar_alpha, rx.cfg.klobuchar_beta, "hopfield")
        t = np.arange(0.0, duration_s, t_step_s)
        series: dict = {}
        for e in rx.simulate(sc.trajectory(), t, None):
            p = corrected_pseudoranges(e.raw(), np.arange(len(e.sat_ids)), tuple(e.ephemerides), e.antenna_r_e_m,
                                       corr, e.clock_bias_m)
            tau = np.linalg.norm(p.sat_pos_e_m - e.antenna_r_e_m, axis=1) / C_MPS
            R = rot3(tau * 7.2921151467e-5)[0]
            rng = np.linalg.norm(np.einsum("kij,kj->ki", R, p.sat_pos_e_m) - e.antenna_r_e_m, axis=1)
            err = p.pseudorange_m - rng - e.clock_bias_m
            err = err - err.mean()
            for sid, x in zip(e.sat_ids, err):
                series.setdefault(sid, {})[round(float(e.t_s), 6)] = float(x)
        x2 = [x ** 2 for s in series.values() for x in s.values()]
        row = {"seed": int(seed), "satellites": len(series), "rms_m": float(np.sqrt(np.mean(x2)))}
        pooled["x2"] += x2
        for L in lags:
            d = [s[round(tt + L, 6)] - x for s in series.values() for tt, x in s.items() if round(tt + L, 6) in s]
            row[f"rms_change_{L}s_m"] = float(np.sqrt(np.mean(np.square(d)))) if d else float("nan")
            pooled[f"d{L}"] += list(np.square(d))
        out["per_seed"].append(row)
        log(f"[measure] seed {seed}: {row}")
    var = float(np.mean(pooled["x2"]))
    out["pooled_rms_m"] = float(np.sqrt(var))
    # Gauss-Markov: E[(x(t+L)-x(t))^2] = 2 sigma^2 (1 - exp(-L / tau)) -> tau per lag
    out["tau_s_by_lag"] = {L: float(-L / np.log(max(1e-9, 1.0 - np.mean(pooled[f"d{L}"]) / (2.0 * var))))
                           for L in lags if pooled[f"d{L}"]}
    log(f"[measure] pooled: RMS {out['pooled_rms_m']:.2f} m; Gauss-Markov tau fitted per lag "
        f"{ {k: round(v) for k, v in out['tau_s_by_lag'].items()} } s")
    return out


def run(seeds, configs=CONFIGS, variants=VARIANTS, duration_s=None, log=print) -> dict:
    res = {c: {v: [] for v in variants} for c in configs}
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="tc_consistency_"))
    for seed in seeds:
        for vname, (case, t_loss) in variants.items():
            over = {} if t_loss is None else {"gnss.raw.lock.outages": [[t_loss, 1.0e4]]}
            t0 = time.perf_counter()
            fl = prepare(seed, "realistic", duration_s, overrides=over)
            log(f"[seed {seed}] {vname}: flight simulated in {time.perf_counter() - t0:.0f} s")
            for cname, cover in configs.items():
                sc = apply_overrides(fl.sc, cover, tmp) if cover else fl.sc
                r = run_case(replace(fl, sc=sc), case)
                h = np.hypot(r.pos_err_enu_m[:, 0], r.pos_err_enu_m[:, 1])
                res[cname][vname].append({"t_s": r.t_s, "nees": r.nees_pos, "h": h, "v": np.abs(r.pos_err_enu_m[:, 2]),
                                          "sigma": r.pos_sigma_m, "wall_s": r.wall_s, "gate": {k: [int(x[0]), int(x[1])]
                                                                           for k, x in r.stats.items()}})
                log(f"  {cname:6s} {r.wall_s:5.0f} s: mean NEES {np.mean(r.nees_pos):9.2f}, pos RMS H "
                    f"{np.sqrt(np.mean(h ** 2)):.2f} V {np.sqrt(np.mean(r.pos_err_enu_m[:, 2] ** 2)):.2f} m, "
                    f"gate {res[cname][vname][-1]['gate']}")
    return res


def summarize(res: dict) -> dict:
    out = {}
    for cname, by_v in res.items():
        out[cname] = {}
        for vname, runs in by_v.items():
            n = min(len(r["nees"]) for r in runs)
            N = np.array([r["nees"][:n] for r in runs])
            anees = N.mean(0)
            lo, hi = anees_band(len(runs))
            out[cname][vname] = {
                "runs": len(runs), "epochs": int(n), "anees_flight_mean": float(anees.mean()),
                "anees_band_95": [lo, hi], "share_of_epochs_in_band": float(np.mean((anees >= lo) & (anees <= hi))),
                "share_above_band": float(np.mean(anees > hi)), "share_below_band": float(np.mean(anees < lo)),
                "anees_median": float(np.median(anees)),
                "mean_nees_per_seed": [float(np.mean(r["nees"])) for r in runs],
                "mean_nees_over_seeds": float(np.mean([np.mean(r["nees"]) for r in runs])),
                "std_nees_over_seeds": float(np.std([np.mean(r["nees"]) for r in runs], ddof=1)) if len(runs) > 1
                else 0.0,
                "pos_rms_h_m_per_seed": [float(np.sqrt(np.mean(r["h"] ** 2))) for r in runs],
                "pos_rms_v_m_per_seed": [float(np.sqrt(np.mean(r["v"] ** 2))) for r in runs],
                "wall_s_per_seed": [float(r["wall_s"]) for r in runs],
                "pos_rms_h_m": float(np.sqrt(np.mean([np.mean(r["h"] ** 2) for r in runs]))),
                "pos_rms_v_m": float(np.sqrt(np.mean([np.mean(r["v"] ** 2) for r in runs]))),
                "mean_sigma_m": float(np.mean([np.mean(r["sigma"]) for r in runs]))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=None, help="flight duration (s; default the scenario's 500 s)")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--configs", default=",".join(CONFIGS), help="filter configurations to fly (default all: "
                    + ", ".join(CONFIGS) + ")")
    ap.add_argument("--measure", action="store_true", help="first measure the range-error statistics")
    ap.add_argument("--out", default="results/tc_consistency")
    a = ap.parse_args(argv)
    seeds = list(range(1, a.seeds + 1))
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for opt, given, known in (("--configs", a.configs, CONFIGS), ("--variants", a.variants, VARIANTS)):
        bad = [k for k in given.split(",") if k not in known]
        if bad:
            ap.error(f"{opt}: unknown {bad[0]!r} (known: {', '.join(known)})")
    configs = {k: CONFIGS[k] for k in a.configs.split(",")}
    doc = {"seeds": seeds, "configs": configs}
    if a.measure:
        doc["range_errors"] = measure_range_errors(seeds)
    variants = {k: VARIANTS[k] for k in a.variants.split(",")}
    res = run(seeds, configs, variants, a.duration)
    doc["summary"] = summarize(res)
    for c, by_v in doc["summary"].items():
        for v, s in by_v.items():
            print(f"{c:6s} {v:10s}: ANEES flight mean {s['anees_flight_mean']:8.2f} (band {s['anees_band_95'][0]:.2f}-"
                  f"{s['anees_band_95'][1]:.2f} for {s['runs']} runs), median {s['anees_median']:.2f}, epochs in band "
                  f"{100 * s['share_of_epochs_in_band']:.0f} % (above {100 * s['share_above_band']:.0f} %), per seed "
                  f"{[round(x, 2) for x in s['mean_nees_per_seed']]} (mean {s['mean_nees_over_seeds']:.2f}, std "
                  f"{s['std_nees_over_seeds']:.2f}); pos RMS H {s['pos_rms_h_m']:.2f} "
                  f"V {s['pos_rms_v_m']:.2f} m, mean sigma {s['mean_sigma_m']:.2f} m")
    (out / "tc_consistency.json").write_text(json.dumps(doc, indent=1))
    print(f"wrote {out / 'tc_consistency.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
