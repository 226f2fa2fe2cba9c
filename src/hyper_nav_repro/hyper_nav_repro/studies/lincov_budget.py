"""LinCov error budget of a scenario's filter along its flight (issue 39).

One linear covariance pass (``hyper_nav_filter.core.lincov``) gives the true
1-sigma of the navigation error of the configured filter against the
*simulated world's* error models (``hyper_nav_workbench.core.lincov_setup``: the
truth is the simulator's IMU and GNSS models, not the filter's), the
filter's own 1-sigma beside it, and the split of the final variance by
error source. Writes ``budget.json`` (table at the chosen epochs, the
series at 1 Hz) and ``budget.png`` (true vs filter sigma; stacked variance
shares by source over time).

    study_lincov --scenario default --blackout 120:240 --epochs 100,240,300
    study_lincov --scenario seed004 --blackout 100:220 --sweep imu --limit-pos-m 100
    study_lincov --scenario default --blackout 120:180 --sweep gnss

``--sweep imu``: every catalogue IMU grade (``core.sensor_catalogue``) in
the world and the filter tuned to it; ``--sweep gnss``: every catalogue GNSS
receiver grade's fixes (sigmas and rate) with the scenario's IMU. The table
says which grade keeps the 3-D position 1-sigma under ``--limit-pos-m``
through the blackout, and its 1-sigma at the end of the flight.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib

import numpy as np

from hyper_nav_workbench.core import lincov_setup
from hyper_nav_sim.core.scenario import apply_overrides, load_with_settings, set_fields
from hyper_nav_sim.core.sensor_catalogue import CATALOGUE, filter_tuning, grade_figures

BLOCKS = (("pos", "m", 1.0), ("vel", "m/s", 1.0), ("att", "deg", 180.0 / math.pi))


def parse_window(text: str) -> tuple[float, float]:
    a, _, b = text.partition(":")
    try:
        w = (float(a), float(b))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--blackout: expected T0:T1 in seconds, got {text!r}") from None
    if not 0 <= w[0] < w[1]:
        raise argparse.ArgumentTypeError(f"--blackout: need 0 <= T0 < T1, got {text!r}")
    return w


def budget_table(res, epochs) -> list[dict]:
    """Per epoch: true and filter 3-D sigma of pos/vel/att and each source's
    1-sigma contribution (sqrt of its variance share; they add in variance)."""
    rows = []
    for t in epochs:
        k = int(np.argmin(np.abs(res.t_s - t)))
        row = {"t_s": float(res.t_s[k])}
        for b, unit, scale in BLOCKS:
            sl = {"att": slice(0, 3), "vel": slice(3, 6), "pos": slice(6, 9)}[b]
            v = res.var[k][:, sl]
            row[f"{b}_sigma_3d_{unit}"] = float(math.sqrt(v.sum()) * scale)
            row[f"{b}_sigma_axes_{unit}"] = (np.sqrt(v.sum(axis=0)) * scale).tolist()
            row[f"{b}_filter_sigma_3d_{unit}"] = float(math.sqrt(res.filter_var[k][sl].sum()) * scale)
            row[f"{b}_by_source_{unit}"] = {g: float(math.sqrt(x) * scale) for g, x in zip(res.groups, v.sum(axis=1))
                                            if x > 0}
        rows.append(row)
    return rows


def print_table(rows, groups) -> None:
    for row in rows:
        print(f"\n t = {row['t_s']:.1f} s   position 3-D 1-sigma: true {row['pos_sigma_3d_m']:.2f} m, filter "
              f"{row['pos_filter_sigma_3d_m']:.2f} m | velocity true {row['vel_sigma_3d_m/s']:.3f} m/s | "
              f"attitude true {row['att_sigma_3d_deg']:.4f} deg")
        print(f"   {'source':34s} {'pos m':>10s} {'share':>7s} {'vel m/s':>10s} {'att deg':>10s}")
        tot = row["pos_sigma_3d_m"] ** 2
        for g in groups:
            p = row["pos_by_source_m"].get(g)
            if p is None and g not in row["vel_by_source_m/s"]:
                continue
            p = p or 0.0
            print(f"   {g:34s} {p:10.3f} {100 * p * p / tot if tot else 0:6.1f}% "
                  f"{row['vel_by_source_m/s'].get(g, 0.0):10.4f} {row['att_by_source_deg'].get(g, 0.0):10.5f}")


def plot(res, path, title, windows) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
    t = res.t_s
    pos_true = np.sqrt(res.total_var[:, 6:9].sum(axis=1))
    pos_filt = np.sqrt(res.filter_var[:, 6:9].sum(axis=1))
    ax[0].semilogy(t, pos_true, "k-", label="true 1-sigma (LinCov vs simulated world)")
    ax[0].semilogy(t, pos_filt, "r--", label="filter's own 1-sigma")
    ax[0].set_ylabel("3-D position 1-sigma (m)")
    ax[0].legend(loc="upper left")
    v = res.var[:, :, 6:9].sum(axis=2)                  # (T, G)
    tot = np.maximum(v.sum(axis=1, keepdims=True), 1e-300)
    used = [i for i in range(len(res.groups)) if np.max(v[:, i] / tot[:, 0]) > 0.005]
    ax[1].stackplot(t, *(v[:, i] / tot[:, 0] * 100 for i in used), labels=[res.groups[i] for i in used])
    ax[1].set_ylabel("share of position variance (%)")
    ax[1].set_xlabel("time (s)")
    ax[1].set_ylim(0, 100)
    ax[1].legend(loc="upper left", fontsize=7, ncol=2)
    for a in ax:
        for w0, w1 in windows:
            a.axvspan(w0, w1, color="grey", alpha=0.15)
    ax[0].set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sweep(rows, windows, limit_pos_m, path, name, kind: str = "imu") -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(10, 5))
    for r in rows:
        t, pos = r["_series"]
        ax.semilogy(t, pos, label=f"{r['grade']} ({r['max_pos_sigma_3d_in_blackout_m']:.1f} m)")
    ax.axhline(limit_pos_m, color="k", ls=":", label=f"requirement {limit_pos_m:g} m")
    for w0, w1 in windows:
        ax.axvspan(w0, w1, color="grey", alpha=0.15)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("3-D position 1-sigma, true (m)")
    ax.set_title(f"{name}: {kind.upper()} grade sweep, LinCov vs the simulated world's models; "
                 "grey: GNSS blackout", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _imu_grade(name: str) -> dict:
    """Scenario overrides of one IMU grade: the world's IMU (biases +, -, + per axis) and the filter tuned to it."""
    over = {f"imu.{k}": ([1.0, -1.0, 1.0] * np.asarray(v)).tolist() if k.endswith(("deg_per_hr", "_ug")) else v
            for k, v in grade_figures(name, "imu").items()}
    over.update({f"filter.config.{k}": v for k, v in filter_tuning(name).items()})
    return over


def _gnss_grade(name: str) -> dict:
    """Scenario overrides of one GNSS receiver grade: its fix sigmas and rate (the filter weights each fix by the
    covariance its message carries, so it is tuned to the grade by construction)."""
    return {f"gnss.{k}": v for k, v in grade_figures(name, "gnss").items()}


def _imu_columns(f=None) -> str:
    if f is None:
        return f"{'gyro b deg/h':>12s} {'ARW deg/rt h':>12s} {'acc b ug':>9s} {'VRW ug/rtHz':>11s}"
    return (f"{f['gyro_bias_deg_per_hr']:12.3g} {f['gyro_arw_deg_per_sqrt_hr']:12.3g} {f['accel_bias_ug']:9.4g} "
            f"{f['accel_vrw_ug_per_sqrt_hz']:11.4g}")


def _gnss_columns(f=None) -> str:
    if f is None:
        return f"{'pos sig E/N/U m':>18s} {'vel sig E/N/U m/s':>20s} {'rate Hz':>7s}"
    return (f"{'/'.join(f'{x:.2f}' for x in f['pos_sigma_enu_m']):>18s} "
            f"{'/'.join(f'{x:.3f}' for x in f['vel_sigma_enu_mps']):>20s} {f['rate_hz']:7.3g}")


# --sweep KIND: the catalogue block, its scenario overrides per grade, its table columns
SWEEPS = {"imu": (_imu_grade, _imu_columns, "world and filter per catalogue IMU grade"),
          "gnss": (_gnss_grade, _gnss_columns, "fixes per catalogue GNSS receiver grade, the scenario's IMU")}


def sweep(sc, windows, draws, step, limit_pos_m, out, kind: str = "imu") -> list[dict]:
    """Every catalogue grade of ``kind`` (imu: in the world, the filter tuned to it; gnss: the receiver's fixes)."""
    import tempfile
    overrides, columns, what = SWEEPS[kind]
    rows = []
    for name, grade in CATALOGUE[kind].items():
        sg = apply_overrides(sc, overrides(name), pathlib.Path(tempfile.mkdtemp(prefix="hyper_nav_sweep_")))
        res = lincov_setup.build(sg, draws=draws, step_s=step, outages_s=windows).run(record_every=1)
        pos = np.sqrt(res.total_var[:, 6:9].sum(axis=1))
        inside = np.zeros(len(res.t_s), bool)
        for a, b in windows:
            inside |= (res.t_s >= a) & (res.t_s <= b)
        k = int(np.argmax(np.where(inside, pos, -1))) if inside.any() else len(pos) - 1
        share = res.share("pos", k)
        top = sorted(share.items(), key=lambda x: -x[1])[:2]
        rows.append({"grade": name, "description": grade["description"], "figures": grade_figures(name, kind),
                     "max_pos_sigma_3d_in_blackout_m": float(pos[k]), "at_t_s": float(res.t_s[k]),
                     "final_pos_sigma_3d_m": float(pos[-1]),
                     "filter_pos_sigma_3d_m": float(math.sqrt(res.filter_var[k, 6:9].sum())),
                     "meets": bool(pos[k] < limit_pos_m), "dominant_sources": {g: round(s, 3) for g, s in top},
                     "cpu_s": res.cpu_s, "_series": (res.t_s, pos)})
    plot_sweep(rows, windows, limit_pos_m, out / f"sweep_{kind}.png", sc.name, kind)
    for r in rows:
        r.pop("_series")
    print(f"\n grade sweep: {what}; 3-D position 1-sigma (LinCov, simulated world's models), largest inside the "
          f"blackout {windows} (the end of the flight without one); limit {limit_pos_m:g} m")
    print(f" {'grade':16s} {columns()} {'pos 1-sig m':>11s} {'at end m':>9s} {'meets':>6s}  dominant sources "
          f"(variance share)")
    for r in rows:
        dom = ", ".join(f"{g} {100 * s:.0f}%" for g, s in r["dominant_sources"].items())
        print(f" {r['grade']:16s} {columns(r['figures'])} {r['max_pos_sigma_3d_in_blackout_m']:11.1f} "
              f"{r['final_pos_sigma_3d_m']:9.2f} {'yes' if r['meets'] else 'no':>6s}  {dom}")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="default")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help="scenario field override")
    ap.add_argument("--blackout", action="append", type=parse_window, default=[], metavar="T0:T1",
                    help="GNSS outage window (s), repeatable (beside the scenario's gnss.outages_s)")
    ap.add_argument("--epochs", default="", help="table epochs, comma-separated seconds (default: the last epoch "
                    "inside each blackout, and the end of the flight)")
    ap.add_argument("--draws", default="prior", choices=lincov_setup.DRAWS,
                    help="prior: the world as mc_campaign draws it; scenario: the fixed values as 1-sigma")
    ap.add_argument("--step", type=float, default=None, help="LinCov step (s); default 0.1 or the GNSS period")
    ap.add_argument("--lever-arm-sigma-m", type=float, default=0.0, help="GNSS lever-arm uncertainty, per axis (m)")
    ap.add_argument("--sweep", choices=tuple(SWEEPS), action="append", default=[],
                    help="also sweep the catalogue's grades of this sensor (imu, gnss; repeatable)")
    ap.add_argument("--limit-pos-m", type=float, default=100.0, help="sweep requirement on 3-D position 1-sigma")
    ap.add_argument("--out", default="results/lincov")
    a = ap.parse_args(argv)
    sc = load_with_settings(a.scenario, a.set)
    out = pathlib.Path(a.out) / sc.name
    out.mkdir(parents=True, exist_ok=True)
    lc = lincov_setup.build(sc, draws=a.draws, step_s=a.step, outages_s=a.blackout,
                            lever_arm_sigma_m=a.lever_arm_sigma_m)
    windows = lc.meas[0].outages_s if lc.meas else ()
    res = lc.run(record_every=1)
    # default: the last epoch of each outage (before the first fix after it) and the end of the flight
    last_in = [float(res.t_s[res.t_s < w[1] - 1e-9][-1]) for w in windows if np.any(res.t_s < w[1] - 1e-9)]
    epochs = [float(x) for x in a.epochs.split(",") if x.strip()] or sorted(set(last_in) | {float(res.t_s[-1])})
    rows = budget_table(res, epochs)
    print(f"LinCov error budget, scenario {sc.name}: the configured filter against the simulated world's error "
          f"models (draws={a.draws}); GNSS outages {list(windows)}; one pass, {res.cpu_s:.2f} s CPU, "
          f"{res.n_updates} updates")
    print_table(rows, res.groups)
    keep = np.isclose(res.t_s % 1.0, 0.0, atol=1e-6) | np.isclose(res.t_s % 1.0, 1.0, atol=1e-6)
    doc = {"what": "LinCov true error covariance of the configured filter vs the simulated world's error models "
                   "(data: simulated world models, no random draws)",
           "scenario": sc.name, "draws": a.draws, "outages_s": [list(w) for w in windows],
           "cpu_s": res.cpu_s, "n_updates": res.n_updates, "groups": list(res.groups), "table": rows,
           "series_1hz": {"t_s": res.t_s[keep].tolist(),
                          "var_enu_by_group": res.var[keep].tolist(),
                          "filter_var_enu": res.filter_var[keep].tolist(),
                          "order": "att E N U (rad^2), vel E N U ((m/s)^2), pos E N U (m^2)"}}
    for kind in a.sweep:
        doc["sweep" if kind == "imu" else f"sweep_{kind}"] = sweep(sc, list(windows), a.draws, a.step,
                                                                  a.limit_pos_m, out, kind)
    (out / "budget.json").write_text(json.dumps(doc, indent=1))
    plot(res, out / "budget.png", f"LinCov error budget, {sc.name} (simulated world's error models, draws="
         f"{a.draws}); grey: GNSS outages", windows)
    print(f"\nwrote {out / 'budget.json'} and {out / 'budget.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
