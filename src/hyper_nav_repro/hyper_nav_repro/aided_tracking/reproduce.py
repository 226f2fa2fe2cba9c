"""Issue 23: unaided vs INS-aided receiver tracking through a plasma blackout on
seed 004's boost-glide trajectory (``repro_aided_tracking``, ``make repro-aided-tracking``).

Flight: scenario ``seed004`` (boost-glide, GPS L1, nominal constellation,
elevation mask 7.5 deg), window ``--t0``..``--t1`` of the glide. Per satellite
and 10 Hz epoch the line-of-sight geometry (satellite orbits from the nominal
broadcast records, antenna truth), Doppler -(u . (v_sat - v_a))/lambda, and
C/N0 from :class:`hyper_nav_sim.core.gnss.signal_env.SignalEnvironment` (top-mounted
antenna with the truth attitude) minus a plasma-sheath attenuation profile
(scenario data, ``--blackout``: ramp up, hold, ramp down, dB vs time). Both
receivers run the same 1 kHz tracking simulation
(:mod:`hyper_nav_gnss.receiver.tracking`) on 12 channels or fewer:

* unaided: the loops track the true Doppler (wide PLL 15 Hz / 1 ms); after a
  loss the search covers the Doppler the receiver cannot predict (vehicle speed
  + 100 m/s clock drift over lambda) x the full code (FFT-parallel over code,
  500 Hz bins, 4 x 1 ms noncoherent dwells);
* aided: the loops track the residual after the navigation-predicted Doppler
  (narrow PLL 3 Hz / 20 ms); the prediction error is a Gauss-Markov velocity
  error with the covariance of an INS coasting through the blackout
  (sigma_v(t)^2 = sigma_v0^2 + (sigma_a (t - t_last_fix))^2, sigma_a from the
  seed-004 accelerometer bias 100 ug, plus clock drift); the search covers +-3
  sigma of predicted Doppler and code, all its cells in one 0.5 s dwell (the
  same 2046-cell FFT engine as unaided; 20 ms x 25 noncoherent).

Reported (over ``--seeds`` noise seeds): C/N0 (truth) at which each channel
loses phase lock and is dropped to search on the way into the blackout; time
from the C/N0 rising back above the aided threshold to phase lock again
(reacquisition), per receiver; time in track per satellite; and, before the
blackout, a synthetic vertical pull-up (``--pullup``: jerk up and down, added
to the line-of-sight Doppler; the aided loops do not see it, the INS measures
it): channels losing phase lock per receiver; JSON + PNGs.
This is the receiver alone; the loop closed through the filter (the aiding
taken from the filter's own state and covariance) is :mod:`.reproduce_blackout`.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import numpy as np
from scipy.interpolate import CubicSpline

from hyper_nav_gnss.constants import C_MPS
F_L1_HZ = 1575.42e6
LAMBDA_M = C_MPS / F_L1_HZ
G0 = 9.80665


def geometry(t_s, sc=None):
    """Per 10 Hz epoch: sat ids, elevation/azimuth [rad], Doppler [Hz], C_b_n,
    altitude, speed; satellites above the mask over the whole window."""
    from hyper_nav_gnss import earth
    from hyper_nav_gnss.orbits.ephemeris import satellite_position_ecef, system_time_s
    from hyper_nav_gnss.geometry import elevation_azimuth
    from hyper_nav_sim.core import simulate
    from hyper_nav_sim.core.scenario import load_scenario
    sc = sc or load_scenario("seed004")
    traj = sc.trajectory()
    rx = simulate.gnss_receiver(sc)
    t = np.asarray(t_s, float)
    eset = rx.ephemeris_set(float(t[0]))
    r_a, v_a, _ = rx.antenna_truth(traj, t)
    tg = rx.cfg.start_gpst_s + t
    h = 0.5
    r_s = np.stack([satellite_position_ecef(e, system_time_s(e.system, tg))[0] for e in eset])
    v_s = np.stack([(satellite_position_ecef(e, system_time_s(e.system, tg + h))[0] -
                     satellite_position_ecef(e, system_time_s(e.system, tg - h))[0]) / (2 * h) for e in eset])
    el = np.empty((t.size, len(eset)))
    az = np.empty_like(el)
    for k in range(t.size):
        el[k], az[k] = elevation_azimuth(r_a[k], r_s[:, k])
    keep = np.flatnonzero(np.all(el >= np.deg2rad(rx.cfg.elevation_mask_deg), axis=0))
    keep = keep[np.argsort(-el[0, keep])][:12]
    d = r_s[keep] - r_a[None]
    u = d / np.linalg.norm(d, axis=2, keepdims=True)
    dop = -np.einsum("skj,skj->sk", u, v_s[keep] - v_a[None]) / LAMBDA_M
    tr = traj.truth(t)
    Cne = np.stack([earth.C_n_e(a, b) for a, b in zip(tr.lat_rad, tr.lon_rad)])
    u_enu = np.einsum("kji,skj->ksi", Cne, u)
    return dict(t=t, sat_ids=[eset[i].sat_id for i in keep], el=el[:, keep], az=az[:, keep], doppler_hz=dop.T,
                u_enu=u_enu, C_b_n=tr.C_b_n, alt_m=tr.alt_m, speed_mps=np.linalg.norm(tr.vel_enu_mps, axis=1))


def blackout_profile(t_on, ramp_s, hold_s, depth_db):
    return {"mode": "table", "t_s": [t_on, t_on + ramp_s, t_on + ramp_s + hold_s, t_on + 2 * ramp_s + hold_s],
            "att_db": [0.0, depth_db, depth_db, 0.0]}


def pullup_velocity_mps(t_s, t_start, jerk_mps3, t_half_s):
    """Vertical velocity change [m/s] of a synthetic pull-up: acceleration rising
    at jerk_mps3 for t_half_s, falling back to 0 over t_half_s (peak
    jerk * t_half), integrated."""
    tau = np.clip(np.asarray(t_s, float) - t_start, 0.0, 2 * t_half_s)
    up = np.minimum(tau, t_half_s)
    dn = np.clip(tau - t_half_s, 0.0, t_half_s)
    return jerk_mps3 * (0.5 * up ** 2 + t_half_s * dn - 0.5 * dn ** 2)


def run_receiver(kind, geo, cn0_10hz, seed, t_black_on, sigma_v0_mps=0.05, sigma_a_mps2=1e-3,
                 clk_drift_sigma_mps=0.05, tau_aid_s=20.0, pullup=None):
    """One receiver over the window; returns per-ms (decimated to 100 Hz) mode,
    estimated C/N0 and per-ms truth C/N0 at 100 Hz."""
    from hyper_nav_gnss.receiver import acquisition as acq
    from hyper_nav_gnss.receiver.tracking import ChannelBank, LoopConfig, aiding_doppler_error_hz
    rng = np.random.default_rng(seed)
    t10 = geo["t"]
    n_ch = len(geo["sat_ids"])
    t_ms = np.arange(t10[0] + 1e-3, t10[-1] + 1e-9, 1e-3)
    f_true = CubicSpline(t10, geo["doppler_hz"], axis=0)(t_ms)
    if pullup is not None:      # synthetic vertical manoeuvre on the line of sight (the INS measures it: aided unaffected)
        u_up = np.stack([np.interp(t_ms, t10, geo["u_enu"][:, i, 2]) for i in range(n_ch)], axis=1)
        f_true = f_true + u_up * pullup_velocity_mps(t_ms, *pullup)[:, None] / LAMBDA_M
    cn0 = np.stack([np.interp(t_ms, t10, cn0_10hz[:, i]) for i in range(n_ch)], axis=1)
    if kind == "unaided":
        cfg = LoopConfig(acq_k_noncoh=4)
        f_in = f_true
        hw = acq.unaided_doppler_halfwidth_hz(float(geo["speed_mps"].max()), 100.0)
        q = acq.search_cells(hw, 511.5, cfg.acq_doppler_bin_hz, cfg.acq_code_bin_chips, n_parallel=2046)
        bank = ChannelBank(cfg, n_ch, f_true[0], (f_true[1] - f_true[0]) / 1e-3, q_cells=q)
    else:
        cfg = LoopConfig.aided_default()
        dt_coast = np.clip(t10 - t_black_on, 0.0, None)
        sig_v = np.sqrt(sigma_v0_mps ** 2 + (sigma_a_mps2 * dt_coast) ** 2)
        P = sig_v[:, None, None] ** 2 * np.eye(3)[None]
        err10 = aiding_doppler_error_hz(geo["u_enu"], P, t10, tau_aid_s, rng, clk_drift_sigma_mps=clk_drift_sigma_mps)
        f_in = -np.stack([np.interp(t_ms, t10, err10[:, i]) for i in range(n_ch)], axis=1)
        bank = ChannelBank(cfg, n_ch, f_in[0], 0.0)
    out_mode, out_cn0e = [], []
    for k0 in range(0, t_ms.size, 1000):
        if kind == "aided":     # search window from the current covariance (+-3 sigma, velocity and ~100 m range)
            k10 = min(int(np.searchsorted(t10, t_ms[k0])), t10.size - 1)
            sv = np.hypot(sig_v[k10], clk_drift_sigma_mps)
            fd, cc = acq.aided_halfwidths(sv, 30.0 + 0.5 * sigma_a_mps2 * dt_coast[k10] ** 2, 3.0)
            bank.set_search_cells(acq.search_cells(fd, cc, cfg.acq_doppler_bin_hz, cfg.acq_code_bin_chips,
                                                   n_parallel=2046))
        o = bank.run(f_in[k0:k0 + 1000], cn0[k0:k0 + 1000], rng)
        out_mode.append(o.mode[::10])
        out_cn0e.append(o.cn0_est_dbhz[::10])
    return dict(t=t_ms[::10], mode=np.concatenate(out_mode), cn0_est=np.concatenate(out_cn0e), cn0=cn0[::10],
                q=float(np.max(bank.state[:, 24])))


def events(res, t_on, t_off_ramp_start, thr_up_dbhz):
    """Per channel: truth C/N0 at the first loss of phase lock (mode < 2) and at
    the drop to search (mode 0) after t_on; reacquisition: time from the C/N0
    rising above thr_up_dbhz (after the hold) to phase lock (mode 2) again."""
    t, m, c = res["t"], res["mode"], res["cn0"]
    out = []
    for i in range(m.shape[1]):
        after = t >= t_on
        lost = np.flatnonzero(after & (m[:, i] < 2))
        drop = np.flatnonzero(after & (m[:, i] == 0))
        up = np.flatnonzero((t >= t_off_ramp_start) & (c[:, i] >= thr_up_dbhz))
        ev = {"cn0_at_phase_loss_dbhz": float(c[lost[0], i]) if lost.size else None,
              "cn0_at_drop_dbhz": float(c[drop[0], i]) if drop.size else None,
              "t_above_threshold_s": float(t[up[0]]) if up.size else None}
        reac = det = None
        if up.size:
            back = np.flatnonzero((t >= t[up[0]]) & (m[:, i] == 2))
            reac = float(t[back[0]] - t[up[0]]) if back.size else None
            found = np.flatnonzero((t >= t[up[0]]) & (m[:, i] >= 1))
            det = float(t[found[0]] - t[up[0]]) if found.size else None
        ev["reacquisition_s"] = reac
        ev["detection_s"] = det
        ev["time_in_phase_lock_frac"] = float(np.mean(m[:, i] == 2))
        ev["time_in_track_frac"] = float(np.mean(m[:, i] >= 1))
        out.append(ev)
    return out


def _med(v):
    v = [x for x in v if x is not None]
    return (float(np.median(v)), float(np.percentile(v, 10)), float(np.percentile(v, 90)), len(v)) if v else None


def plot(geo, runs, out_dir, summary):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    pngs = []
    fig, axs = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    r_u, r_a = runs["unaided"], runs["aided"]
    for i, s in enumerate(geo["sat_ids"]):
        axs[0].plot(r_u["t"], r_u["cn0"][:, i], lw=0.8, label=s)
    for thr, ls, name in ((summary["unaided"]["cn0_at_phase_loss_dbhz"], "--", "unaided loss"),
                          (summary["aided"]["cn0_at_phase_loss_dbhz"], ":", "aided loss")):
        if thr:
            axs[0].axhline(thr[0], color="k", ls=ls, lw=1, label=f"{name} (median) {thr[0]:.1f} dB-Hz")
    axs[0].set_ylabel("C/N0 truth [dB-Hz]")
    axs[0].legend(ncol=5, fontsize=7)
    for ax, r, name in ((axs[1], r_u, "unaided"), (axs[2], r_a, "INS-aided")):
        for i, s in enumerate(geo["sat_ids"]):
            ax.plot(r["t"], r["mode"][:, i] + 3.0 * i, lw=0.8, drawstyle="steps-post")
        ax.set_yticks([3 * i + 1 for i in range(len(geo["sat_ids"]))], geo["sat_ids"])
        ax.set_ylabel(f"{name}\nmode 0/1/2 per sat")
    axs[2].set_xlabel("scenario time [s]")
    fig.suptitle("seed 004 blackout: C/N0 and lock state per satellite (0 search, 1 FLL/code, 2 phase lock)")
    fig.tight_layout()
    p = out_dir / "aided_tracking_lock.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    pngs.append(p)
    fig, ax = plt.subplots(figsize=(7, 4))
    for name in ("unaided", "aided"):
        v = [e["reacquisition_s"] for e in summary[name]["events"] if e["reacquisition_s"] is not None]
        if v:
            ax.hist(v, bins=30, alpha=0.6, label=f"{name} (n={len(v)})")
    ax.set_xlabel("time from C/N0 above the aided threshold to phase lock [s]")
    ax.set_ylabel("channels x seeds")
    ax.legend()
    fig.tight_layout()
    p = out_dir / "aided_tracking_reacquisition.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    pngs.append(p)
    return pngs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--t0", type=float, default=60.0)
    ap.add_argument("--t1", type=float, default=240.0)
    ap.add_argument("--blackout", type=float, nargs=4, default=[90.0, 40.0, 20.0, 50.0],
                    metavar=("T_ON", "RAMP_S", "HOLD_S", "DEPTH_DB"))
    ap.add_argument("--pullup", type=float, nargs=3, default=[70.0, 20.0 * G0, 0.5],
                    metavar=("T_START", "JERK_MPS3", "T_HALF_S"),
                    help="synthetic vertical pull-up before the blackout (default 20 g/s for 0.5 s up and down: "
                         "peak 10 g)")
    ap.add_argument("--out", default="results/aided_tracking")
    a = ap.parse_args(argv)
    from hyper_nav_sim.core.gnss.signal_env import PlasmaSheath, SignalEnvironment
    from hyper_nav_gnss.receiver.tracking import pll_threshold_dbhz, LoopConfig
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    t_on, ramp, hold, depth = a.blackout
    c0 = time.process_time()
    geo = geometry(np.arange(a.t0, a.t1 + 1e-9, 0.1))
    env = SignalEnvironment(plasma=PlasmaSheath(**{k: tuple(v) if isinstance(v, list) else v
                                                   for k, v in blackout_profile(t_on, ramp, hold, depth).items()}))
    cn0 = np.stack([env.cn0_dbhz(t, geo["el"][k], geo["az"][k], geo["C_b_n"][k]) for k, t in enumerate(geo["t"])])
    print(f"[aided_tracking] {len(geo['sat_ids'])} satellites {geo['sat_ids']}, window {a.t0}-{a.t1} s, "
          f"blackout on {t_on} s ramp {ramp} s hold {hold} s depth {depth} dB; "
          f"geometry {time.process_time() - c0:.1f} s CPU",
          flush=True)
    t_up = t_on + ramp + hold
    all_ev = {"unaided": [], "aided": []}
    first = {}
    c1 = time.process_time()
    for seed in range(a.seeds):
        runs = {k: run_receiver(k, geo, cn0, 1000 * seed + j, t_on, pullup=tuple(a.pullup))
                for j, k in enumerate(("unaided", "aided"))}
        if seed == 0:
            first = runs
        for k in runs:
            all_ev[k].append(runs[k])
    cpu_track = time.process_time() - c1
    # thresholds measured on the way in; reacquisition measured against the aided threshold
    loss = {k: [e for r in all_ev[k] for e in events(r, t_on, t_up, 0.0)] for k in all_ev}
    thr_aided = _med([e["cn0_at_phase_loss_dbhz"] for e in loss["aided"]])
    thr_unaided = _med([e["cn0_at_phase_loss_dbhz"] for e in loss["unaided"]])
    x = thr_aided[0] if thr_aided else 20.0
    t_p0, t_p1 = a.pullup[0], a.pullup[0] + 2 * a.pullup[2] + 1.0
    pull = {}
    for k in all_ev:
        lost = [bool(np.any(r["mode"][(r["t"] >= t_p0) & (r["t"] < t_p1), i] < 2))
                for r in all_ev[k] for i in range(len(geo["sat_ids"]))]
        pull[k] = {"channels_losing_phase_lock": int(sum(lost)), "channels": len(lost)}
    rule = {"unaided": pll_threshold_dbhz(15.0, 1e-3), "aided": pll_threshold_dbhz(3.0, 0.02)}
    summary = {}
    for k in all_ev:
        ev = [e for r in all_ev[k] for e in events(r, t_on, t_up, x)]
        ev_rule = [e for r in all_ev[k] for e in events(r, t_on, t_up, rule["aided"])]
        for e, er in zip(ev, ev_rule):
            e["reacquisition_after_rule_threshold_s"] = er["reacquisition_s"]
        for j, e in enumerate(ev):
            e["sat_id"] = geo["sat_ids"][j % len(geo["sat_ids"])]
            e["seed"] = j // len(geo["sat_ids"])
        summary[k] = {"cn0_at_phase_loss_dbhz": _med([e["cn0_at_phase_loss_dbhz"] for e in ev]),
                      "cn0_at_drop_dbhz": _med([e["cn0_at_drop_dbhz"] for e in ev]),
                      "reacquisition_s": _med([e["reacquisition_s"] for e in ev]),
                      "detection_s": _med([e["detection_s"] for e in ev]),
                      "reacquisition_after_rule_threshold_s": _med([e["reacquisition_after_rule_threshold_s"]
                                                                    for e in ev]),
                      "not_reacquired": sum(e["reacquisition_s"] is None for e in ev),
                      "time_in_phase_lock_frac": _med([e["time_in_phase_lock_frac"] for e in ev]),
                      "time_in_track_frac": _med([e["time_in_track_frac"] for e in ev]),
                      "events": ev}
    margin = (summary["unaided"]["cn0_at_phase_loss_dbhz"][0] - summary["aided"]["cn0_at_phase_loss_dbhz"][0]
              if summary["unaided"]["cn0_at_phase_loss_dbhz"] and summary["aided"]["cn0_at_phase_loss_dbhz"] else None)
    doc = {"issue": 23, "scenario": "seed004", "window_s": [a.t0, a.t1], "satellites": geo["sat_ids"],
           "blackout": blackout_profile(t_on, ramp, hold, depth), "seeds": a.seeds,
           "stats_format": "[median, p10, p90, n]",
           "rule_of_thumb_pll_threshold_dbhz": rule,
           "aided_threshold_used_for_reacquisition_dbhz": x,
           "unaided_minus_aided_phase_loss_cn0_db": margin,
           "pullup": {"t_start_s": a.pullup[0], "jerk_mps3": a.pullup[1], "t_half_s": a.pullup[2],
                      "peak_accel_mps2": a.pullup[1] * a.pullup[2], "window_s": [t_p0, t_p1], "results": pull},
           "tracking_cpu_s": cpu_track, "simulated_channel_s": 2 * a.seeds * len(geo["sat_ids"]) * (a.t1 - a.t0),
           "results": summary}
    (out / "aided_tracking.json").write_text(json.dumps(doc, indent=1))
    pngs = plot(geo, first, out, summary)
    for k in ("unaided", "aided"):
        s = summary[k]
        f = (lambda v: "n/a" if v is None else f"{v[0]:.2f} [p10 {v[1]:.2f}, p90 {v[2]:.2f}, n={v[3]}]")
        print(f"{k:8s}: C/N0 at phase-lock loss {f(s['cn0_at_phase_loss_dbhz'])} dB-Hz; at drop to search "
              f"{f(s['cn0_at_drop_dbhz'])} dB-Hz; after C/N0 > {x:.1f} dB-Hz: detection {f(s['detection_s'])} s, "
              f"phase lock (reacquisition) {f(s['reacquisition_s'])} s "
              f"({s['not_reacquired']} not reacquired in the window); phase-lock time fraction "
              f"{f(s['time_in_phase_lock_frac'])}")
    print(f"rule-of-thumb PLL thresholds (no dynamics): unaided {rule['unaided']:.1f}, "
          f"aided {rule['aided']:.1f} dB-Hz; phase lock after C/N0 > the aided rule threshold: unaided "
          f"{summary['unaided']['reacquisition_after_rule_threshold_s'][0]:.2f} s, aided "
          f"{summary['aided']['reacquisition_after_rule_threshold_s'][0]:.2f} s (medians); "
          f"simulated unaided - aided phase-loss C/N0: {margin if margin is None else round(margin, 2)} dB")
    print(f"pull-up {a.pullup[1] / G0:.0f} g/s to {a.pullup[1] * a.pullup[2] / G0:.0f} g at {a.pullup[0]} s: channels "
          f"losing phase lock unaided {pull['unaided']['channels_losing_phase_lock']}/{pull['unaided']['channels']}, "
          f"aided {pull['aided']['channels_losing_phase_lock']}/{pull['aided']['channels']}")
    print(f"tracking CPU {cpu_track:.1f} s for {doc['simulated_channel_s']:.0f} channel-seconds at 1 kHz")
    print(f"wrote {out / 'aided_tracking.json'} and {', '.join(str(p) for p in pngs)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
