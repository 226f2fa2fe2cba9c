"""Issue 23 reproduction beside seed 004: navigation through a plasma blackout
with an unaided receiver, an INS-aided receiver (aided by the filter's own
state), the paper's virtual pseudoranges, INS coasting, and no loss (a), over
``--seeds`` seeds (``repro_aided_blackout``; cases in :mod:`.blackout_cases`).

Data: simulated world (seed004_virtual flight, realistic-world receiver
errors), the sheath profile ``--blackout`` (default 50 dB: ramp in 90-130 s,
hold to 150 s, ramp out to 190 s). The tightly coupled filter is flown with
``--filter after`` (default: the range-bias states and thermal weighting that
``tc_consistency`` found consistent) or ``before`` (the scenario's own).

Reported per case: horizontal error 5 s after the sheath's end (goal: within
2x case (a)), the share of the blackout-and-after epochs where the seed-mean
horizontal error is below INS coasting's, horizontal/vertical position and
velocity error during the blackout and after it, position ANEES over the seeds
during and after with the 95 % band, receiver reacquisition: per satellite,
the time from its C/N0 (truth) rising back above the aided PLL rule
threshold (17.9 dB-Hz) to the first 1-Hz epoch with the channel's code
(PR valid) and carrier (CP valid) lock. JSON + PNGs in ``--out``.
``--short``: 40 s flight, 40 dB sheath over 10-30 s, one seed (the unit test).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np

from .blackout_cases import CASE_NAMES, CASES, run_seed

SHORT = {"duration_s": 40.0, "blackout": (10.0, 4.0, 8.0, 40.0), "seeds": 1}
AIDED_RULE_DBHZ = 17.9           # pll_threshold_dbhz(3 Hz, 20 ms): asserted in test_acquisition


def _filter_overrides(name):
    if name == "before":
        return {}
    from hyper_nav_repro.seed004.tc_consistency import AFTER
    return dict(AFTER)


def channel_reacq(epochs, t_hold_end_s, thr_dbhz=AIDED_RULE_DBHZ):
    """Per satellite seen after the hold: (t_thr, code-lock delay, carrier-lock delay) [s]."""
    out = []
    sats = sorted({s for e in epochs if e.t_s >= t_hold_end_s for s in e.sat_ids})
    for sat in sats:
        t_thr = next((e.t_s for e in epochs if e.t_s >= t_hold_end_s and sat in e.sat_ids
                      and e.cn0_true_dbhz is not None
                      and e.cn0_true_dbhz[e.sat_ids.index(sat)] >= thr_dbhz), None)
        if t_thr is None:
            continue

        def first(pred):
            t = next((e.t_s for e in epochs if e.t_s >= t_thr and sat in e.sat_ids and pred(e, e.sat_ids.index(sat))),
                     None)
            return None if t is None else float(t - t_thr)
        out.append((sat, float(t_thr), first(lambda e, i: bool(e.locked[i])),
                    first(lambda e, i: bool(e.tracking_flags[i] & 2))))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--duration", type=float, default=240.0)
    ap.add_argument("--blackout", type=float, nargs=4, default=[90.0, 40.0, 20.0, 50.0],
                    metavar=("T_ON", "RAMP_S", "HOLD_S", "DEPTH_DB"))
    ap.add_argument("--filter", choices=("after", "before"), default="after")
    ap.add_argument("--short", action="store_true")
    ap.add_argument("--out", default="results/aided_tracking")
    a = ap.parse_args(argv)
    from scipy.stats import chi2
    if a.short:
        a.duration, a.blackout, a.seeds = SHORT["duration_s"], list(SHORT["blackout"]), SHORT["seeds"]
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    t_on, ramp, hold, depth = a.blackout
    t_hold_end, t_end = t_on + ramp + hold, t_on + 2 * ramp + hold
    t5 = t_end + 5.0
    c0 = time.process_time()
    runs, reacq = [], {"unaided": [], "aided": []}
    aid_counts = []
    for seed in range(a.seeds):
        res, rx = run_seed(seed, a.duration, tuple(a.blackout), filter_overrides=_filter_overrides(a.filter))
        runs.append(res)
        for k in reacq:
            reacq[k] += [(seed,) + r for r in channel_reacq(rx[k], t_hold_end)]
        aid_counts.append(res["aided"].counters)
        h5 = {c: float(np.interp(t5, r.t_s, np.hypot(r.pos_err_enu_m[:, 0], r.pos_err_enu_m[:, 1])))
              for c, r in res.items()}
        print(f"[blackout] seed {seed}: horizontal error at {t5:.0f} s " +
              ", ".join(f"{c} {v:.2f} m" for c, v in h5.items()) + f" ({time.process_time() - c0:.0f} s CPU)",
              flush=True)
    cpu = time.process_time() - c0
    # common time grid (the solutions of every case are at the same output epochs)
    t = runs[0]["a"].t_s
    def curve(c, f):
        return np.stack([np.interp(t, r[c].t_s, f(r[c])) for r in runs])
    hpos = {c: curve(c, lambda r: np.hypot(r.pos_err_enu_m[:, 0], r.pos_err_enu_m[:, 1])) for c in CASES}
    vpos = {c: curve(c, lambda r: np.abs(r.pos_err_enu_m[:, 2])) for c in CASES}
    hvel = {c: curve(c, lambda r: np.hypot(r.vel_err_enu_mps[:, 0], r.vel_err_enu_mps[:, 1])) for c in CASES}
    vvel = {c: curve(c, lambda r: np.abs(r.vel_err_enu_mps[:, 2])) for c in CASES}
    nees = {c: curve(c, lambda r: r.nees_pos) for c in CASES}
    n = len(runs)
    band = (float(chi2.ppf(0.025, 3 * n) / n), float(chi2.ppf(0.975, 3 * n) / n))
    during = (t >= t_on) & (t <= t_end)
    after = t > t_end
    both = t >= t_on
    summary = {}
    for c in CASES:
        anees = nees[c].mean(axis=0)
        d = {"h_err_at_end_plus_5s_m": [float(np.interp(t5, t, x)) for x in hpos[c]]}
        d["h_err_at_end_plus_5s_median_m"] = float(np.median(d["h_err_at_end_plus_5s_m"]))
        for name, arr in (("pos_h_m", hpos[c]), ("pos_v_m", vpos[c]), ("vel_h_mps", hvel[c]), ("vel_v_mps", vvel[c])):
            for wname, w in (("during", during), ("after", after)):
                if w.any():
                    d[f"{name}_{wname}"] = {"mean": float(arr[:, w].mean()), "max": float(arr[:, w].max())}
        for wname, w in (("during", during), ("after", after)):
            if w.any():
                d[f"anees_pos_{wname}"] = {"mean": float(anees[w].mean()),
                                           "share_in_band": float(np.mean((anees[w] >= band[0]) & (anees[w] <= band[1])))}
        excess = hpos[c].mean(axis=0)[both] - hpos["coasting"].mean(axis=0)[both]
        d["share_below_coasting"] = float(np.mean(excess < 0.0))
        # where the case is not below coasting: by how much at most (seed means) and when
        k = int(np.argmax(excess))
        d["max_excess_over_coasting_m"] = {"value": float(excess[k]), "t_s": float(t[both][k])}
        summary[c] = d
    # the figure's curves on a 1 s grid: seed-mean horizontal error per case
    grid = np.arange(np.ceil(t[0]), t[-1] + 1e-9, 1.0)
    curves = {"t_s": grid.tolist(), **{c: np.interp(grid, t, hpos[c].mean(axis=0)).round(4).tolist() for c in CASES}}
    ha = summary["a"]["h_err_at_end_plus_5s_median_m"]
    for c in CASES:
        summary[c]["within_2x_a_at_end_plus_5s"] = summary[c]["h_err_at_end_plus_5s_median_m"] <= 2 * ha
    rq = {}
    for k, v in reacq.items():
        code = [x[3] for x in v if x[3] is not None]
        carr = [x[4] for x in v if x[4] is not None]
        rq[k] = {"channels": len(v), "code_lock_s_median": float(np.median(code)) if code else None,
                 "code_lock_s_p90": float(np.percentile(code, 90)) if code else None,
                 "carrier_lock_s_median": float(np.median(carr)) if carr else None,
                 "carrier_lock_s_p90": float(np.percentile(carr, 90)) if carr else None,
                 "not_reacquired_code": sum(x[3] is None for x in v),
                 "per_channel": [{"seed": s, "sat": sat, "t_above_threshold_s": tt, "code_lock_s": cl,
                                  "carrier_lock_s": pl} for s, sat, tt, cl, pl in v]}
    doc = {"issue": 23, "data": "simulated world (seed004_virtual flight, realistic-world receiver errors)",
           "scenario": "seed004_virtual", "filter": a.filter, "seeds": n, "duration_s": a.duration,
           "blackout": {"t_on_s": t_on, "ramp_s": ramp, "hold_s": hold, "depth_db": depth, "t_end_s": t_end},
           "cases": CASE_NAMES, "anees_band_95": band, "epoch_resolution_s": 1.0,
           "aided_threshold_dbhz": AIDED_RULE_DBHZ, "reacquisition": rq, "results": summary,
           "h_error_mean_over_seeds_m": curves,
           "aiding_counters": aid_counts, "cpu_s": cpu}
    (out / "blackout_cases.json").write_text(json.dumps(doc, indent=1))
    pngs = plot(t, hpos, nees, band, runs, reacq, a, out, n)
    print(f"ANEES 95 % band over {n} seeds: [{band[0]:.2f}, {band[1]:.2f}]")
    for c in CASES:
        s = summary[c]
        print(f"{CASE_NAMES[c]:44s}: h err {t5:.0f} s {s['h_err_at_end_plus_5s_median_m']:7.2f} m "
              f"(2x (a) {2 * ha:.2f}: {'met' if s['within_2x_a_at_end_plus_5s'] else 'NOT met'}); "
              f"h during mean {s.get('pos_h_m_during', {}).get('mean', float('nan')):7.2f} max "
              f"{s.get('pos_h_m_during', {}).get('max', float('nan')):7.2f} m; after mean "
              f"{s.get('pos_h_m_after', {}).get('mean', float('nan')):7.2f} m; vel h during "
              f"{s.get('vel_h_mps_during', {}).get('mean', float('nan')):.3f} m/s; below coasting "
              f"{100 * s['share_below_coasting']:.0f} % of epochs (at most {s['max_excess_over_coasting_m']['value']:+.3f} m "
              f"above, at {s['max_excess_over_coasting_m']['t_s']:.0f} s); ANEES during "
              f"{s.get('anees_pos_during', {}).get('mean', float('nan')):.2f} "
              f"({100 * s.get('anees_pos_during', {}).get('share_in_band', float('nan')):.0f} % in band), after "
              f"{s.get('anees_pos_after', {}).get('mean', float('nan')):.2f} "
              f"({100 * s.get('anees_pos_after', {}).get('share_in_band', float('nan')):.0f} % in band)")
    for k, v in rq.items():
        print(f"reacquisition {k}: {v['channels']} channels; code lock {v['code_lock_s_median']} s median "
              f"(p90 {v['code_lock_s_p90']}), carrier lock {v['carrier_lock_s_median']} s median "
              f"(p90 {v['carrier_lock_s_p90']}), {v['not_reacquired_code']} not reacquired; 1 s epochs")
    print(f"CPU {cpu:.0f} s; wrote {out / 'blackout_cases.json'} and {', '.join(str(p) for p in pngs)}")
    return 0


def plot(t, hpos, nees, band, runs, reacq, a, out, n):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t_on, ramp, hold, depth = a.blackout
    t_end = t_on + 2 * ramp + hold
    data = f"simulated world, seed004_virtual flight, {depth:g} dB sheath {t_on:g}-{t_end:g} s, {n} seeds"
    pngs = []
    fig, axs = plt.subplots(2, 1, figsize=(11, 8), sharex=True)
    for c in CASES:
        axs[0].plot(t, hpos[c].mean(axis=0), label=CASE_NAMES[c])
    r0 = runs[0]["aided"]
    from hyper_nav_sim.core import scoring  # noqa: F401  (keeps the import graph of the cases)
    axs[0].fill_between(r0.t_s, 0, 3 * r0.pos_sigma_m, color="C2", alpha=0.15, label="aided, seed 0: 3 sigma (trace)")
    axs[0].axvspan(t_on, t_end, color="grey", alpha=0.1)
    axs[0].set_yscale("log")
    axs[0].set_ylabel("horizontal position error [m]\n(mean over seeds)")
    axs[0].legend(fontsize=8)
    for c in CASES:
        axs[1].plot(t, nees[c].mean(axis=0), label=CASE_NAMES[c], lw=0.8)
    axs[1].axhspan(*band, color="k", alpha=0.1, label="95 % band")
    axs[1].axvspan(t_on, t_end, color="grey", alpha=0.1)
    axs[1].set_yscale("log")
    axs[1].set_ylabel("position ANEES (3 dof)")
    axs[1].set_xlabel("scenario time [s]")
    fig.suptitle(f"Navigation through a plasma blackout ({data})", fontsize=10)
    fig.tight_layout()
    p = out / "blackout_cases_error.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    pngs.append(p)
    fig, ax = plt.subplots(figsize=(7, 4))
    for k in ("unaided", "aided"):
        v = [x[3] for x in reacq[k] if x[3] is not None]
        if v:
            ax.hist(v, bins=np.arange(-0.5, max(v) + 1.5, 1.0), alpha=0.6, label=f"{k} receiver, code lock (n={len(v)})")
    ax.set_xlabel(f"time from C/N0 > {AIDED_RULE_DBHZ} dB-Hz to code lock [s] (1 s epochs)")
    ax.set_ylabel("channels x seeds")
    ax.set_title(f"Reacquisition ({data})", fontsize=8)
    ax.legend()
    fig.tight_layout()
    p = out / "blackout_cases_reacquisition.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    pngs.append(p)
    return pngs


if __name__ == "__main__":
    sys.exit(main())
