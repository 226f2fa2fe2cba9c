"""Issue 23 reproduction beside seed 004: navigation through a plasma blackout
with an unaided receiver, an INS-aided receiver (aided by the filter's own
state), the paper's virtual pseudoranges, INS coasting, and no loss (a), over
``--seeds`` seeds (``repro_aided_blackout``; cases in :mod:`.blackout_cases`).

Data: simulated world (seed004_virtual flight, realistic-world receiver
errors), the sheath profile ``--blackout`` (default 50 dB: ramp in 90-130 s,
hold to 150 s, ramp out to 190 s). The tightly coupled filter is flown with
``--filter after`` (default: the range-bias states and thermal weighting that
``tc_consistency`` found consistent) or ``before`` (the scenario's filter
before issue 37 item 5: white pseudorange errors, ``tc_consistency.BEFORE``).

Reported per case: horizontal error 5 s after the sheath's end (goal: within
2x case (a)), the share of the blackout-and-after epochs where the seed-mean
horizontal error is below INS coasting's, horizontal/vertical position and
velocity error during the blackout and after it, position ANEES over the seeds
during and after with the 95 % band, receiver reacquisition: per satellite,
the time from its C/N0 (truth) rising back above the aided PLL rule
threshold (17.9 dB-Hz) to the first 1-Hz epoch with the channel's code
(PR valid) and carrier (CP valid) lock. JSON + PNGs in ``--out``.
``--short``: 40 s flight, 40 dB sheath over 10-30 s, one seed (the unit test).

``--pullup``: the pull-up flight instead (``PULLUP``): seed 004's vehicle with
a lift that answers in 0.1 s, a 2 g pull-up command (lift-limited to 2.2 g,
jerk up to 66 m/s^3 at its ends) inside a 15 dB sheath; reported besides, per
receiver, the channels that keep code and carrier lock through it and how
long carrier stays lost, and per case the error and ANEES in the pull-up's
window.

``--aiding``: ``current`` (default, issue 35) the aided receiver takes the
filter's current-time state (``FusionEngine.current``, the live ``nav/state``)
with the scenario's default filter settings: at most one IMU interval old at
the receiver's epoch (the mean age used is reported, ``mean_age_s``);
``delayed`` the released record (``nav/delayed/state``) with the filter's
output delay set to ``--aiding-delay`` s (default 0.1: the aiding 0.1-0.2 s
old, the aided loops see the pull-up's jerk through that much extrapolation;
the study's setting before issue 35, kept for comparison).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np

from .blackout_cases import AIDING, CASE_NAMES, CASES, pullup_flight, run_seed

SHORT = {"duration_s": 40.0, "blackout": (10.0, 4.0, 8.0, 40.0), "seeds": 1}
# the pull-up flight (--pullup): seed 004's vehicle with a lift that answers in 0.1 s (10 c_l per s;
# the scenario's 1 s / 1 per s give jerks below 10 m/s^3), a 2 g pull-up command over 245-249 s with
# 0.2 s ramps (lift-limited to 2.2 g, jerk up to 66 m/s^3 at its ends), inside a 15 dB sheath
# (C/N0 about 28.6 dB-Hz, 230-260 s, 5 s ramps): weak signal and dynamics at once
PULLUP = {"duration_s": 275.0, "blackout": (225.0, 5.0, 30.0, 15.0),
          "pullup": {"t_start_s": 245.0, "load_g": 2.0, "ramp_s": 0.2, "length_s": 4.0, "lift_tau_s": 0.1,
                     "lift_rate_per_s": 10.0}}
SHORT_PULLUP = {"duration_s": 40.0, "blackout": (10.0, 4.0, 8.0, 40.0), "seeds": 1,
                "pullup": {**PULLUP["pullup"], "t_start_s": 30.0}}
AIDED_RULE_DBHZ = 17.9           # pll_threshold_dbhz(3 Hz, 20 ms): asserted in test_acquisition


def _filter_overrides(name, aiding_delay_s=None):
    """The filter of ``--filter``; with ``aiding_delay_s`` (the delayed aiding)
    its solutions released that far behind the IMU (the aiding's age is that
    to one IMU interval more); None: the scenario's output delay."""
    d = {} if aiding_delay_s is None else {
        "filter.config.output_delay_s": float(aiding_delay_s),
        "filter.sources.gnss_raw.ephemeris_wait_s": min(0.05, 0.5 * aiding_delay_s),
        "filter.sources.gnss_virtual.ephemeris_wait_s": min(0.05, 0.5 * aiding_delay_s)}
    from hyper_nav_repro.seed004.tc_consistency import AFTER, BEFORE
    return {**(BEFORE if name == "before" else AFTER), **d}


def pullup_locks(epochs, t0_s, t1_s):
    """Channels of one receiver around a pull-up over [t0, t1]: code and
    carrier locks at the last epoch before it, their minimum over [t0, t1 +
    5 s], the satellites that lost carrier lock there and how long each
    stayed without it (s, 1 s epochs; None: not back by the window's end)."""
    before = [e for e in epochs if e.t_s < t0_s]
    during = [e for e in epochs if t0_s <= e.t_s <= t1_s + 5.0]
    if not before or not during:
        return None
    b = before[-1]
    cp = lambda e, i: bool(e.tracking_flags[i] & 2)       # noqa: E731
    had = [s for i, s in enumerate(b.sat_ids) if cp(b, i)]
    lost = {}
    for s in had:
        out = [e.t_s for e in during if s not in e.sat_ids or not cp(e, e.sat_ids.index(s))]
        if out:
            back = next((e.t_s for e in during if e.t_s > out[0] and s in e.sat_ids and cp(e, e.sat_ids.index(s))),
                        None)
            lost[s] = None if back is None else float(back - out[0])
    return {"code_before": int(sum(bool(x) for x in b.locked)), "carrier_before": len(had),
            "code_min": int(min(sum(bool(x) for x in e.locked) for e in during)),
            "carrier_min": int(min(sum(cp(e, i) for i in range(len(e.sat_ids))) for e in during)),
            "carrier_lost": len(lost), "carrier_outage_s": sorted(lost.values(), key=lambda v: (v is None, v))}


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


def _paired_text(p):
    if p is None:
        return "one seed"
    return (f"below by > {p['z']:g} SE on {100 * p['share_below']:.0f} %, above on {100 * p['share_above']:.0f} %, "
            f"undecided {100 * p['share_undecided']:.0f} %")


def paired_vs_coasting(h_case, h_coast, z=2.0):
    """Per epoch, the seeds' paired difference d = h_case - h_coasting
    (seeds x epochs): the share of epochs where the case is below coasting
    beyond z standard errors of the mean difference (mean + z SE < 0), above
    it beyond them (mean - z SE > 0), and neither (the seeds cannot tell)."""
    d = np.asarray(h_case, float) - np.asarray(h_coast, float)
    n = d.shape[0]
    if n < 2:
        return None
    m, se = d.mean(axis=0), d.std(axis=0, ddof=1) / np.sqrt(n)
    below, above = m + z * se < 0.0, m - z * se > 0.0
    return {"z": z, "share_below": float(np.mean(below)), "share_above": float(np.mean(above)),
            "share_undecided": float(np.mean(~below & ~above))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--duration", type=float, default=240.0)
    ap.add_argument("--blackout", type=float, nargs=4, default=[90.0, 40.0, 20.0, 50.0],
                    metavar=("T_ON", "RAMP_S", "HOLD_S", "DEPTH_DB"))
    ap.add_argument("--filter", choices=("after", "before"), default="after")
    ap.add_argument("--pullup", action="store_true",
                    help="the pull-up flight instead (PULLUP: a 2 g pull-up with 0.2 s ramps inside a 15 dB sheath)")
    ap.add_argument("--aiding", choices=AIDING, default=None,
                    help="current: the filter's current-time state with its default settings (the default "
                         "without --aiding-delay); "
                         "delayed: the released record with the output delay --aiding-delay")
    ap.add_argument("--aiding-delay", type=float, default=None,
                    help="the delayed aiding's output delay, s (implies --aiding delayed; its default 0.1 s: "
                         "0.1-0.2 s old aiding)")
    ap.add_argument("--skip-case", action="append", default=[], choices=("virtual",),
                    help="leave a comparison case out (repeatable)")
    ap.add_argument("--short", action="store_true")
    ap.add_argument("--out", default=None, help="default results/aided_tracking (results/aided_tracking_pullup)")
    a = ap.parse_args(argv)
    a.cases = tuple(c for c in CASES if c not in a.skip_case)
    if a.aiding is None:
        a.aiding = "current" if a.aiding_delay is None else "delayed"
    if a.aiding == "current" and a.aiding_delay is not None:
        ap.error("--aiding-delay sets the delayed record's output delay: give it with --aiding delayed")
    if a.aiding == "delayed" and a.aiding_delay is None:
        a.aiding_delay = 0.1
    from scipy.stats import chi2
    pull = None
    if a.pullup:
        pre = SHORT_PULLUP if a.short else PULLUP
        pull = pre["pullup"]
        a.duration, a.blackout = pre["duration_s"], list(pre["blackout"])
        if a.short:
            a.seeds = pre["seeds"]
    elif a.short:
        a.duration, a.blackout, a.seeds = SHORT["duration_s"], list(SHORT["blackout"]), SHORT["seeds"]
    a.out = a.out or ("results/aided_tracking_pullup" if a.pullup else "results/aided_tracking")
    flight = None if pull is None else pullup_flight(pull["t_start_s"], pull["load_g"], pull["ramp_s"],
                                                     pull["length_s"], pull["lift_tau_s"], pull["lift_rate_per_s"])
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    t_on, ramp, hold, depth = a.blackout
    t_hold_end, t_end = t_on + ramp + hold, t_on + 2 * ramp + hold
    t5 = t_end + 5.0
    c0 = time.process_time()
    runs, reacq = [], {"unaided": [], "aided": []}
    aid_counts, pull_rx = [], {"unaided": [], "aided": []}
    for seed in range(a.seeds):
        res, rx = run_seed(seed, a.duration, tuple(a.blackout),
                           filter_overrides=_filter_overrides(a.filter, a.aiding_delay), flight_overrides=flight,
                           aiding=a.aiding, cases=a.cases)
        runs.append(res)
        if pull is not None:
            for k in pull_rx:
                pull_rx[k].append(pullup_locks(rx[k], pull["t_start_s"], pull["t_start_s"] + pull["length_s"]))
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
    hpos = {c: curve(c, lambda r: np.hypot(r.pos_err_enu_m[:, 0], r.pos_err_enu_m[:, 1])) for c in a.cases}
    vpos = {c: curve(c, lambda r: np.abs(r.pos_err_enu_m[:, 2])) for c in a.cases}
    hvel = {c: curve(c, lambda r: np.hypot(r.vel_err_enu_mps[:, 0], r.vel_err_enu_mps[:, 1])) for c in a.cases}
    vvel = {c: curve(c, lambda r: np.abs(r.vel_err_enu_mps[:, 2])) for c in a.cases}
    nees = {c: curve(c, lambda r: r.nees_pos) for c in a.cases}
    n = len(runs)
    band = (float(chi2.ppf(0.025, 3 * n) / n), float(chi2.ppf(0.975, 3 * n) / n))
    during = (t >= t_on) & (t <= t_end)
    after = t > t_end
    both = t >= t_on
    summary = {}
    for c in a.cases:
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
        d["vs_coasting_paired"] = paired_vs_coasting(hpos[c][:, both], hpos["coasting"][:, both])
        summary[c] = d
    # the figure's curves on a 1 s grid: seed-mean horizontal error per case
    grid = np.arange(np.ceil(t[0]), t[-1] + 1e-9, 1.0)
    curves = {"t_s": grid.tolist(), **{c: np.interp(grid, t, hpos[c].mean(axis=0)).round(4).tolist() for c in a.cases}}
    ha = summary["a"]["h_err_at_end_plus_5s_median_m"]
    for c in a.cases:
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
    if pull is not None:
        t_p0, t_p1 = pull["t_start_s"], pull["t_start_s"] + pull["length_s"] + 5.0
        wp = (t >= t_p0) & (t <= t_p1)
        pdoc = {**pull, "window_s": [t_p0, t_p1], "receivers": {}, "cases": {}}
        for k, v in pull_rx.items():
            v = [x for x in v if x is not None]
            outs = [o for x in v for o in x["carrier_outage_s"]]
            pdoc["receivers"][k] = {
                "carrier_before_mean": float(np.mean([x["carrier_before"] for x in v])),
                "carrier_min_mean": float(np.mean([x["carrier_min"] for x in v])),
                "code_min_mean": float(np.mean([x["code_min"] for x in v])),
                "channels_losing_carrier": int(sum(x["carrier_lost"] for x in v)),
                "channels_with_carrier_before": int(sum(x["carrier_before"] for x in v)),
                "carrier_outage_s_median": float(np.median([o for o in outs if o is not None])) if any(
                    o is not None for o in outs) else None,
                "carrier_not_back": sum(o is None for o in outs), "per_seed": v}
        for c in a.cases:
            pdoc["cases"][c] = {"pos_h_m_mean": float(hpos[c][:, wp].mean()), "pos_h_m_max": float(hpos[c][:, wp].max()),
                                "pos_v_m_mean": float(vpos[c][:, wp].mean()),
                                "anees_pos": float(nees[c].mean(axis=0)[wp].mean())}
    doc = {"issue": 23, "data": "simulated world (seed004_virtual flight, realistic-world receiver errors)"
           + ("; the pull-up flight (seed 004's vehicle, lift answering in 0.1 s, 2 g pull-up)" if pull else ""),
           "scenario": "seed004_virtual", "filter": a.filter, "aiding": a.aiding, "aiding_delay_s": a.aiding_delay,
           "aiding_mean_age_s": float(np.mean([c["mean_age_s"] for c in aid_counts])),
           "seeds": n, "duration_s": a.duration,
           "blackout": {"t_on_s": t_on, "ramp_s": ramp, "hold_s": hold, "depth_db": depth, "t_end_s": t_end},
           "cases": CASE_NAMES, "anees_band_95": band, "epoch_resolution_s": 1.0,
           "aided_threshold_dbhz": AIDED_RULE_DBHZ, "reacquisition": rq, "results": summary,
           "h_error_mean_over_seeds_m": curves,
           "aiding_counters": aid_counts, "cpu_s": cpu, **({"pullup": pdoc} if pull is not None else {})}
    (out / "blackout_cases.json").write_text(json.dumps(doc, indent=1))
    a.pull, a.mean_age_s = pull, doc["aiding_mean_age_s"]
    pngs = plot(t, hpos, nees, band, runs, reacq, a, out, n)
    print(f"ANEES 95 % band over {n} seeds: [{band[0]:.2f}, {band[1]:.2f}]")
    for c in a.cases:
        s = summary[c]
        print(f"{CASE_NAMES[c]:44s}: h err {t5:.0f} s {s['h_err_at_end_plus_5s_median_m']:7.2f} m "
              f"(2x (a) {2 * ha:.2f}: {'met' if s['within_2x_a_at_end_plus_5s'] else 'NOT met'}); "
              f"h during mean {s.get('pos_h_m_during', {}).get('mean', float('nan')):7.2f} max "
              f"{s.get('pos_h_m_during', {}).get('max', float('nan')):7.2f} m; after mean "
              f"{s.get('pos_h_m_after', {}).get('mean', float('nan')):7.2f} m; vel h during "
              f"{s.get('vel_h_mps_during', {}).get('mean', float('nan')):.3f} m/s; below coasting "
              f"{100 * s['share_below_coasting']:.0f} % of epochs (at most {s['max_excess_over_coasting_m']['value']:+.3f} m "
              f"above, at {s['max_excess_over_coasting_m']['t_s']:.0f} s; paired over seeds: "
              f"{_paired_text(s['vs_coasting_paired'])}); ANEES during "
              f"{s.get('anees_pos_during', {}).get('mean', float('nan')):.2f} "
              f"({100 * s.get('anees_pos_during', {}).get('share_in_band', float('nan')):.0f} % in band), after "
              f"{s.get('anees_pos_after', {}).get('mean', float('nan')):.2f} "
              f"({100 * s.get('anees_pos_after', {}).get('share_in_band', float('nan')):.0f} % in band)")
    for k, v in rq.items():
        print(f"reacquisition {k}: {v['channels']} channels; code lock {v['code_lock_s_median']} s median "
              f"(p90 {v['code_lock_s_p90']}), carrier lock {v['carrier_lock_s_median']} s median "
              f"(p90 {v['carrier_lock_s_p90']}), {v['not_reacquired_code']} not reacquired; 1 s epochs")
    if pull is not None:
        for k, v in pdoc["receivers"].items():
            print(f"pull-up {pdoc['window_s'][0]:g}-{pdoc['window_s'][1]:g} s, {k} receiver: carrier lock on "
                  f"{v['carrier_before_mean']:.1f} channels before (seed mean), at least {v['carrier_min_mean']:.1f} "
                  f"(code {v['code_min_mean']:.1f}) in the window; {v['channels_losing_carrier']} of "
                  f"{v['channels_with_carrier_before']} channels x seeds lost carrier (median outage "
                  f"{v['carrier_outage_s_median']} s, {v['carrier_not_back']} not back)")
        for c, v in pdoc["cases"].items():
            print(f"pull-up window, {CASE_NAMES[c]:44s}: h err mean {v['pos_h_m_mean']:.2f} max {v['pos_h_m_max']:.2f} m,"
                  f" v err mean {v['pos_v_m_mean']:.2f} m, position ANEES {v['anees_pos']:.2f}")
    print(f"aiding: {a.aiding} state, mean age at the aided epochs {1e3 * doc['aiding_mean_age_s']:.1f} ms"
          + ("" if a.aiding == "current" else f" (output delay {a.aiding_delay:g} s)"))
    print(f"CPU {cpu:.0f} s; wrote {out / 'blackout_cases.json'} and {', '.join(str(p) for p in pngs)}")
    return 0


def plot(t, hpos, nees, band, runs, reacq, a, out, n):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t_on, ramp, hold, depth = a.blackout
    t_end = t_on + 2 * ramp + hold
    data = f"simulated world, seed004_virtual flight, {depth:g} dB sheath {t_on:g}-{t_end:g} s, {n} seeds"
    if getattr(a, "pull", None):
        pu = a.pull
        data += (f", {pu['load_g']:g} g pull-up {pu['t_start_s']:g}-{pu['t_start_s'] + pu['length_s']:g} s "
                 f"(lift answering in {pu['lift_tau_s']:g} s)")
    data += (f", current-time aiding (mean age {a.mean_age_s * 1e3:.1f} ms)" if a.aiding == "current"
             else f", delayed aiding (output delay {a.aiding_delay:g} s)")
    pngs = []
    fig, axs = plt.subplots(2, 1, figsize=(11, 8), sharex=True)
    for c in a.cases:
        axs[0].plot(t, hpos[c].mean(axis=0), label=CASE_NAMES[c])
    r0 = runs[0]["aided"]
    from hyper_nav_workbench.core import scoring
    axs[0].fill_between(r0.t_s, 0, 3 * r0.pos_sigma_m, color="C2", alpha=0.15, label="aided, seed 0: 3 sigma (trace)")
    axs[0].axvspan(t_on, t_end, color="grey", alpha=0.1)
    axs[0].set_yscale("log")
    axs[0].set_ylabel("horizontal position error [m]\n(mean over seeds)")
    axs[0].legend(fontsize=8)
    for c in a.cases:
        axs[1].plot(t, nees[c].mean(axis=0), label=CASE_NAMES[c], lw=0.8)
    axs[1].axhspan(*band, color="k", alpha=0.1, label="95 % band")
    axs[1].axvspan(t_on, t_end, color="grey", alpha=0.1)
    axs[1].set_yscale("log")
    axs[1].set_ylabel("position ANEES (3 dof)")
    axs[1].set_xlabel("scenario time [s]")
    import textwrap
    fig.suptitle("\n".join(textwrap.wrap(
        f"Navigation through a {'pull-up in a plasma sheath' if a.pullup else 'plasma blackout'} ({data})", 110)),
        fontsize=9)
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
    ax.set_title("\n".join(textwrap.wrap(f"Reacquisition ({data})", 80)), fontsize=8)
    ax.legend()
    fig.tight_layout()
    p = out / "blackout_cases_reacquisition.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    pngs.append(p)
    return pngs


if __name__ == "__main__":
    sys.exit(main())
