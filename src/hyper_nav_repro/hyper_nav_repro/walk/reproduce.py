"""repro_walk: the walk_0827 recording (u-blox raw log + MEMS IMU, RTK
reference; ../shared/real-data/walk_0827, README there) through the filter,
scored against the RTK-fixed epochs.

    ros2run hyper_nav_repro repro_walk --out results/walk      # make repro-walk
    ros2run hyper_nav_repro repro_walk --out /tmp/w --end-s 40 # a short segment (seconds after the alignment)

Steps: ``import_data`` of ``real_data/walk_imu.yaml`` (IMU with its mounting,
alignment on the data, MEMS error model) -> ``<out>/bag`` + filter.yaml;
the bag's records through the fusion core tightly coupled (``gnss/raw``
pseudoranges, as ``replay_filter`` runs it); loosely coupled on this
project's own single-point fixes of the same receiver epochs
(``core.gnss.spp`` position + Doppler velocity, as NavSatFix / Twist
messages, their sigmas scaled by the tightly coupled source's
``sigma_scale``; the log holds no receiver PVT message); the single-point fixes
themselves. Against the 349 RTK-fixed epochs (Q = 1, cm-level) after the
alignment epoch: horizontal RMS and 95th percentile, vertical RMS of the
antenna (the IMU solution moved by the lever arm), position NEES (3 dof)
and the count of epochs inside its 95 % interval. GNSS outages cut into the
data (15 s and 30 s at three places, one run each): horizontal error at the
outage end and the fraction of RTK epochs inside the outage where both
horizontal errors lie within the filter's 3 sigma.
The tightly coupled filter runs three times: as the import file sets it up
with the filter's defaults (``tc_default``: since issue 37 item 5 the
range errors are per-satellite range-bias states, ``rb32`` with the declared
``range_bias_sigma_m`` / ``range_bias_tau_s``, the values measured on seed
004's realistic world), with white range errors (``tc``:
``range_errors: white``, the import file's filter before item 5) and with
the range-bias states of issue 21 (``tc_rb``, ``RANGE_BIAS_VARIANT``,
white-weighted base plus 1 m / 60 s states).
Writes ``walk.json``, ``errors.png`` (TC E/N/U error against RTK with
+/-3 sigma) and ``track.png``; prints the table. Exit 0, 2 on bad input.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import shutil
import sys
import time

import numpy as np
from scipy import stats

from hyper_nav_gnss import earth
from hyper_nav_filter.core.params import ConfigError

# outage starts (s after the alignment epoch) per length: the RTK-fixed epochs end 75 s after the alignment,
# so the three 30 s outages overlap (each is its own run)
OUTAGES_S = {15.0: (10.0, 30.0, 55.0), 30.0: (5.0, 25.0, 45.0)}
# ``tc_rb``: the tightly coupled filter of the import file with per-satellite range-bias states
# (``core.blocks.range_bias``, 32 slots for three constellations): the part of each pseudorange error that is
# correlated over tens of seconds (backyard multipath, residual ionosphere and orbits; our single-point errors
# are correlated over 9-22 s, docs/walk_imu.md) as a Gauss-Markov state instead of white noise. Sigma 1 m,
# tau 60 s (the first values tried, in a previous session); measured with 1 m / 300 s: NEES 2.61, 0.7 m /
# 300 s: 3.59, 1 m / 300 s with sigma_scale 1.5: 2.39 (docs/walk_imu.md)
RANGE_BIAS_VARIANT = {"add_block": "rb32", "range_bias_sigma_m": 1.0, "range_bias_tau_s": 60.0}
MODES = ("tc_default", "tc", "tc_rb", "lc")
TC_MODES = ("tc_default", "tc", "tc_rb")


def walk_yaml() -> pathlib.Path:
    from hyper_nav_workbench.spp import dataset_dirs
    for d in dataset_dirs():
        if (d / "walk_imu.yaml").exists():
            return d / "walk_imu.yaml"
    raise ConfigError("walk_imu.yaml: not found among the data set descriptions")


def reference(data_dir=None):
    """RTK-fixed epochs of the walk: (stamps on the GPST-unix axis, lat, lon, alt)."""
    from hyper_nav_workbench.core.importer import gnss_raw, rtklib_pos
    from hyper_nav_workbench.spp import default_data_dir
    pos = rtklib_pos.read_pos(pathlib.Path(data_dir or default_data_dir()) / "walk_0827" / "gnss_1730_sf.pos")
    pos = pos.select(pos.quality == 1)
    return pos.t_gpst_s + gnss_raw.GPST_UNIX_OFFSET_S, pos.lat_rad, pos.lon_rad, pos.alt_m


def lc_records(imu_records, fixes, outage=None, sigma_scale: float = 1.0):
    """IMU records + the single-point fixes as NavSatFix / Twist messages, stamp order;
    their sigmas times ``sigma_scale``."""
    from hyper_nav_workbench.core.importer import messages
    tab = fixes.fix_table()
    tab.pos_sigma_enu_m = tab.pos_sigma_enu_m * sigma_scale
    tab.vel_sigma_enu_mps = tab.vel_sigma_enu_mps * sigma_scale
    recs = [("/gnss/fix", m) for _, m in messages.fix_messages(tab)] + \
           [("/gnss/vel", m) for _, m in messages.vel_messages(tab)]
    recs = [r for r in recs if outage is None or not _in(_stamp(r[1]), outage)]
    return sorted(imu_records + recs, key=lambda r: _stamp(r[1]))


def _stamp(msg) -> float:
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _in(t, outage) -> bool:
    return outage[0] <= t < outage[1]


def run(records, cfg, initial, sources):
    from hyper_nav_filter.offline import run_offline
    sols, eng = run_offline(records, cfg, initial, sources, final=True)
    return sols, eng


def errors_at_reference(sols, layout, lever_b_m, ref):
    """Antenna position error (ENU m) and its covariance at each reference epoch inside the solution span:
    (t, e (n, 3), P (n, 3, 3))."""
    t_ref, lat_r, lon_r, alt_r = ref
    t = np.array([s.t_s for s in sols])
    lat0, lon0, alt0 = lat_r[0], lon_r[0], alt_r[0]
    st = [s.state for s in sols]
    p = earth.enu_offset_m(lat0, lon0, alt0, np.array([x.lat_rad for x in st]), np.array([x.lon_rad for x in st]),
                           np.array([x.alt_m for x in st]))
    p = p + np.einsum("kij,j->ki", np.array([x.C_b_n for x in st]), np.asarray(lever_b_m, float))
    m = (t_ref >= t[0]) & (t_ref <= t[-1])
    tr = t_ref[m]
    pi = np.column_stack([np.interp(tr, t, p[:, i]) for i in range(3)])
    pr = earth.enu_offset_m(lat0, lon0, alt0, lat_r[m], lon_r[m], alt_r[m])
    sl = layout.sl("pos")
    k = np.clip(np.searchsorted(t, tr), 0, len(t) - 1)
    P = np.array([sols[j].P[sl, sl] for j in k])
    return tr, pi - pr, P


def summary(e, P=None) -> dict:
    h = np.hypot(e[:, 0], e[:, 1])
    out = {"n": int(len(e)), "horizontal_rms_m": float(np.sqrt(np.mean(h**2))),
           "horizontal_p95_m": float(np.percentile(h, 95)), "vertical_rms_m": float(np.sqrt(np.mean(e[:, 2] ** 2))),
           "horizontal_max_m": float(h.max()), "mean_error_enu_m": e.mean(axis=0).tolist(),
           "std_error_enu_m": e.std(axis=0).tolist()}
    if P is not None:
        nees = np.einsum("ki,ki->k", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])
        lo, hi = stats.chi2.ppf([0.025, 0.975], 3)
        n = len(nees)
        lo_m, hi_m = stats.chi2.ppf([0.025, 0.975], 3 * n) / n
        out.update({"nees_mean": float(nees.mean()), "nees_mean_band95": [float(lo_m), float(hi_m)],
                    "nees_epochs_inside_95": int(np.count_nonzero((nees >= lo) & (nees <= hi))),
                    "nees_epochs_below_upper95": int(np.count_nonzero(nees <= hi)),
                    "nees_single_band95": [float(lo), float(hi)]})
    return out


def mean_sigma(e) -> np.ndarray:
    """1-sigma (per column) of the mean of a time-correlated series: the
    sample standard deviation over sqrt(n_eff), n_eff = n / (1 + 2 sum rho_k)
    with the autocorrelation summed up to its first negative lag (the
    initial-positive-sequence estimate; Geyer 1992)."""
    e = np.asarray(e, float)
    n = len(e)
    out = np.empty(e.shape[1])
    for i in range(e.shape[1]):
        x = e[:, i] - e[:, i].mean()
        ac = np.correlate(x, x, "full")[n - 1:] / max(float(x @ x), 1e-300)
        s = 1.0
        for k in range(1, n // 2):
            if ac[k] < 0.0:
                break
            s += 2.0 * ac[k]
        out[i] = x.std() / np.sqrt(n / s)
    return out


def outage_score(t, e, P, outage) -> dict:
    m = (t >= outage[0]) & (t < outage[1])
    if not m.any():
        return {"n": 0}
    s = np.sqrt(np.stack([P[:, 0, 0], P[:, 1, 1]], axis=1))
    inside = np.all(np.abs(e[m, :2]) <= 3 * s[m], axis=1)
    k_end = int(np.flatnonzero(m)[-1])
    return {"n": int(m.sum()), "end_horizontal_error_m": float(np.hypot(*e[k_end, :2])),
            "end_horizontal_3sigma_m": float(3 * np.hypot(*s[k_end])), "inside_3sigma": float(inside.mean()),
            "max_horizontal_error_m": float(np.hypot(e[m, 0], e[m, 1]).max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="repro_walk", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="results/walk")
    ap.add_argument("--data-dir", default=None, help="folder holding walk_0827 (default ../shared/real-data)")
    ap.add_argument("--end-s", type=float, default=None, help="stop this many seconds after the alignment epoch")
    ap.add_argument("--no-outages", action="store_true")
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args(argv)
    try:
        res = reproduce(pathlib.Path(args.out), args.data_dir, args.end_s, not args.no_outages, not args.no_plots)
    except (ConfigError, OSError, ValueError) as exc:
        print(f"repro_walk: error: {exc}", file=sys.stderr)
        return 2
    print_table(res)
    return 0


def reproduce(out: pathlib.Path, data_dir=None, end_s=None, outages=True, plots=True) -> dict:
    from hyper_nav_filter.filter_setup import FilterSetup
    from hyper_nav_filter.sources import DEFAULT_TABLE

    from hyper_nav_workbench import import_data
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    from hyper_nav_workbench.core.importer import gnss_raw
    wall0 = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    imported = import_data.load_import(walk_yaml(), data_dir)
    al = imported["alignment"]
    if end_s is not None:
        from hyper_nav_workbench.core.importer import columns
        imported["imu"] = columns.window(imported["imu"], None, al.t_s + end_s)
    bag = out / "bag"
    if bag.exists():
        shutil.rmtree(bag)
    counts = import_data.write(imported, bag)
    setup = FilterSetup.load(bag / "filter.yaml")
    cfg, init = setup.config, setup.initial
    records = [(r.topic, deserialize(r.raw, r.msgtype)) for r in read_bag(bag)]
    imu_records = [r for r in records if r[0] == "/imu/data_raw"]
    t_end = _stamp(imu_records[-1][1])
    ref = reference(data_dir)
    ref = tuple(x[(ref[0] > al.t_s) & (ref[0] <= t_end)] for x in ref)
    lever = np.asarray(cfg.antenna_lever_arm_b_m, float)

    fixes = gnss_raw.spp_fixes(imported["gnss_raw"], None, t_end)
    lc_cfg = type(cfg).from_dict({**{k: v for k, v in cfg.as_dict().items()},
                                  "state_blocks": ["att", "vel", "pos", "bg", "ba"]})
    rb = dict(RANGE_BIAS_VARIANT)
    from hyper_nav_filter.core.blocks.range_bias import RANGE_BIAS_BLOCKS
    white = {**cfg.as_dict(), "range_errors": "white",
             "state_blocks": [b for b in cfg.state_blocks if b not in RANGE_BIAS_BLOCKS]}
    mode_cfg = {"tc_default": cfg, "tc": type(cfg).from_dict(white),
                "tc_rb": type(cfg).from_dict({**white, "state_blocks": white["state_blocks"] + [rb.pop("add_block")],
                                              **rb})}
    lc_sources = dict(DEFAULT_TABLE)
    # the fixes come from the same pseudoranges and Dopplers: the same scale as the tightly coupled source's
    # (measured with 1: the gate refuses the Doppler velocity in the turns from 28 s to 45 s, 2.70 m H RMS)
    lc_scale = float(setup.sources.get("gnss", {}).get("sigma_scale", 1.0))
    res = {"alignment": {"method": al.method, "t_s": al.t_s, "static": al.static,
                         "roll_pitch_heading_deg": [float(np.degrees(a)) for a in al.roll_pitch_heading_rad],
                         "att_sigma_enu_deg": np.degrees(al.att_sigma_enu_rad).tolist(),
                         "gyro_bias_deg_per_s": np.degrees(al.gyro_bias_b_radps).tolist(), **al.info},
           "bag_counts": counts, "reference_epochs": int(len(ref[0])), "runs": {}, "outages": []}

    def one(mode, outage=None):
        t0 = time.perf_counter()
        if mode in TC_MODES:
            recs = [r for r in records if not (outage and r[0] == "/gnss/raw" and _in(_stamp(r[1]), outage))]
            c = mode_cfg[mode]
            sols, eng = run(recs, c, init, setup.sources)
            layout = c.layout
        else:
            sols, eng = run(lc_records(imu_records, fixes, outage, lc_scale), lc_cfg, init, lc_sources)
            layout = lc_cfg.layout
        t, e, P = errors_at_reference(sols, layout, lever, ref)
        return t, e, P, sols, time.perf_counter() - t0, dict(eng.counters)

    # the single-point fixes at the reference epochs; their mean error is the reference's datum offset
    # (docs/gnss_real_data.md: every single-point solution, RTKLIB's too, lies ~24 m below and ~6 m east of it)
    k = np.array([int(np.argmin(np.abs(fixes.t_s - tt))) for tt in ref[0]])
    ok = np.abs(fixes.t_s[k] - ref[0]) < 0.01
    lat0, lon0, alt0 = ref[1][0], ref[2][0], ref[3][0]
    e_spp = earth.enu_offset_m(lat0, lon0, alt0, fixes.lat_rad[k[ok]], fixes.lon_rad[k[ok]], fixes.alt_m[k[ok]]) \
        - earth.enu_offset_m(lat0, lon0, alt0, ref[1][ok], ref[2][ok], ref[3][ok])
    offset = e_spp.mean(axis=0)
    res["datum_offset_enu_m"] = offset.tolist()
    # the offset is itself an estimate (single-point errors correlated over ~10-20 s): its 1-sigma, which the
    # filter's P cannot hold, for a second NEES figure (P + its covariance)
    off_sigma = mean_sigma(e_spp)
    res["datum_offset_sigma_enu_m"] = off_sigma.tolist()
    res["runs"]["spp"] = {**summary(e_spp - offset), "raw": summary(e_spp)}
    series = {}
    res["range_bias_variant"] = RANGE_BIAS_VARIANT
    for mode in MODES:
        t, e, P, sols, wall, ctr = one(mode)
        series[mode] = (t, e - offset, P, sols)
        res["runs"][mode] = {**summary(e - offset, P), "raw": summary(e, P),
                             "with_datum_offset_sigma": summary(e - offset, P + np.diag(off_sigma ** 2)), "wall_s": wall,
                             "real_time_factor": (t_end - al.t_s) / wall, "counters": ctr}
    if outages:
        for L, starts in OUTAGES_S.items():
            for s0 in starts:
                o = (al.t_s + s0, al.t_s + s0 + L)
                if o[1] > t_end:
                    continue
                row = {"start_s_after_alignment": s0, "length_s": L}
                for mode in MODES:
                    t, e, P, *_ = one(mode, o)
                    row[mode] = outage_score(t, e - offset, P, o)
                res["outages"].append(row)
    res["wall_s"] = time.perf_counter() - wall0
    (out / "walk.json").write_text(json.dumps(res, indent=1, default=float))
    if plots:
        _plots(out, series, ref, fixes, al, offset)
    return res


def _plots(out, series, ref, fixes, al, offset):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t, e, P, _ = series["tc_default"]
    fig, axs = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for i, name in enumerate("ENU"):
        s = 3 * np.sqrt(P[:, i, i])
        axs[i].plot(t - al.t_s, e[:, i], ".", ms=3, label="tightly coupled (defaults) - RTK")
        axs[i].plot(t - al.t_s, s, "k--", lw=0.8, label="+/-3 sigma")
        axs[i].plot(t - al.t_s, -s, "k--", lw=0.8)
        tl, el, *_ = series["lc"]
        axs[i].plot(tl - al.t_s, el[:, i], ".", ms=2, alpha=0.5, label="loosely coupled (SPP) - RTK")
        if "tc" in series:
            tr, er, Pr, _ = series["tc"]
            sr = 3 * np.sqrt(Pr[:, i, i])
            axs[i].plot(tr - al.t_s, er[:, i], ".", ms=2, alpha=0.6, label="tightly coupled, white range errors - RTK")
            axs[i].plot(tr - al.t_s, sr, ":", color="tab:green", lw=0.8, label="+/-3 sigma (white range errors)")
            axs[i].plot(tr - al.t_s, -sr, ":", color="tab:green", lw=0.8)
        axs[i].set_ylabel(f"{name} error (m)")
        axs[i].grid(alpha=0.3)
    axs[0].legend(fontsize=8)
    axs[-1].set_xlabel("time after alignment (s)")
    fig.suptitle("walk_0827: antenna position error against the RTK-fixed epochs\n(reference datum offset "
                 f"{', '.join(f'{x:.1f}' for x in offset)} m E/N/U removed)")
    fig.tight_layout()
    fig.savefig(out / "errors.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(7, 7))
    lat0, lon0, alt0 = ref[1][0], ref[2][0], ref[3][0]
    pr = earth.enu_offset_m(lat0, lon0, alt0, ref[1], ref[2], ref[3])
    ax.plot(pr[:, 0], pr[:, 1], "k.", ms=4, label="RTK fixed")
    names = {"tc_default": "tightly coupled (defaults: range-bias states)", "tc": "tightly coupled, white range errors",
             "tc_rb": "tightly coupled + range-bias states 1 m / 60 s", "lc": "loosely coupled (SPP)"}
    for mode in (m for m in MODES if m in series):
        st = [s.state for s in series[mode][3]]
        p = earth.enu_offset_m(lat0, lon0, alt0, np.array([x.lat_rad for x in st]),
                               np.array([x.lon_rad for x in st]), np.array([x.alt_m for x in st])) - offset
        ax.plot(p[:, 0], p[:, 1], "-", lw=1, label=names[mode])
    ps = earth.enu_offset_m(lat0, lon0, alt0, fixes.lat_rad, fixes.lon_rad, fixes.alt_m) - offset
    ax.plot(ps[:, 0], ps[:, 1], "x", ms=3, alpha=0.5, label="single point")
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "track.png", dpi=110)
    plt.close(fig)


def print_table(res: dict) -> None:
    a = res["alignment"]
    print(f"alignment: {a['method']} at t = {a['t_s']:.3f}, roll/pitch/heading "
          f"{', '.join(f'{x:.2f}' for x in a['roll_pitch_heading_deg'])} deg, 1-sigma "
          f"{', '.join(f'{x:.2f}' for x in a['att_sigma_enu_deg'])} deg")
    print(f"against {res['reference_epochs']} RTK-fixed epochs after the alignment, the reference's datum offset "
          f"({', '.join(f'{x:+.2f}' for x in res['datum_offset_enu_m'])} m E/N/U, the mean single-point error) removed "
          f"(raw figures in walk.json):")
    print(f"{'':8s}{'h RMS m':>9s}{'h 95% m':>9s}{'v RMS m':>9s}{'NEES':>8s}{'in 95%':>9s}{'x RT':>7s}")
    if "datum_offset_sigma_enu_m" in res:
        print(f"datum offset 1-sigma {', '.join(f'{x:.2f}' for x in res['datum_offset_sigma_enu_m'])} m E/N/U; NEES "
              "with it added to P: " + ", ".join(f"{m} {res['runs'][m]['with_datum_offset_sigma']['nees_mean']:.2f}"
                                                 for m in MODES if m in res["runs"]))
    for mode in (*MODES, "spp"):
        if mode not in res["runs"]:
            continue
        r = res["runs"][mode]
        nees = f"{r['nees_mean']:8.2f}{r['nees_epochs_inside_95']:5d}/{r['n']:<3d}" if "nees_mean" in r else " " * 17
        rt = f"{r['real_time_factor']:7.1f}" if "real_time_factor" in r else ""
        print(f"{mode:8s}{r['horizontal_rms_m']:9.3f}{r['horizontal_p95_m']:9.3f}{r['vertical_rms_m']:9.3f}{nees}{rt}")
    for o in res["outages"]:
        if not all(o[m]["n"] for m in MODES if m in o):
            continue
        print(f"outage {o['length_s']:.0f} s at +{o['start_s_after_alignment']:.0f} s: " + "; ".join(
            f"{m} end error {o[m]['end_horizontal_error_m']:.2f} m (3 sigma {o[m]['end_horizontal_3sigma_m']:.2f} m), "
            f"inside 3 sigma {100 * o[m]['inside_3sigma']:.0f} % of {o[m]['n']}" for m in MODES if m in o and o[m]["n"]))
    print(f"wall {res['wall_s']:.1f} s")


if __name__ == "__main__":
    sys.exit(main())
