"""Plots of one recorded run that navigation engineers read (``report``
writes them beside the bag):

* ``errors.png``: each error component (E, N, U of position, velocity,
  attitude) with the filter's own +/-3 sigma envelope (from the covariance
  in ``nav/state``), and the share of epochs inside it;
* ``consistency.png``: NEES of position, velocity and attitude (3 dof each)
  and the NIS of the updates over time, with their 95 % chi-square bands;
* ``track.png``: ground track and altitude of truth, solution and GNSS
  fixes, GNSS outages shaded, aiding fixes (map matching, radar: the
  ``horizontal_fix`` sources) marked.

The arrays come from ``arrays(...)`` (pure numpy; tests check the numbers),
the drawing from matplotlib (Agg).
"""
from __future__ import annotations

import pathlib

import numpy as np
from scipy.stats import chi2

from hyper_nav_filter.conversions import stamp_to_s

from hyper_nav_workbench.core import scoring

BAND = (0.025, 0.975)
KIND_DOF = {"gnss_fix": 3, "gnss_vel": 3, "horizontal_fix": 2, "baro_height": 1}


def sigma_enu(msgs) -> dict:
    """{"pos_enu_m", "vel_enu_mps", "att_enu_deg"}: (n, 3) 1-sigma from each
    NavState's covariance (``state_blocks`` names its layout) and the
    covariance blocks {"pos", "vel", "att"} (n, 3, 3)."""
    out = {"pos": [], "vel": [], "att": []}
    for m in msgs:
        n = int(m.state_dim)
        P = np.asarray(m.covariance, float).reshape(n, n)
        start, sl = 0, {}
        for entry in m.state_blocks:
            name, size = entry.split(":")
            sl[name] = slice(start, start + int(size))
            start += int(size)
        for b in out:
            out[b].append(P[sl[b], sl[b]])
    cov = {b: np.array(v).reshape(-1, 3, 3) for b, v in out.items()}
    d = {b: np.sqrt(np.maximum(np.diagonal(c, axis1=1, axis2=2), 0.0)) for b, c in cov.items()}
    return {"pos_enu_m": d["pos"], "vel_enu_mps": d["vel"], "att_enu_deg": np.rad2deg(d["att"]), "cov": cov}


def nees(err: dict, cov: dict) -> dict:
    """NEES per epoch of each 3-dof block: e^T P^-1 e (errors in SI)."""
    e = {"pos": err["pos_enu_m"], "vel": err["vel_enu_mps"], "att": np.deg2rad(err["att_enu_deg"])}
    return {b: np.einsum("ni,ni->n", e[b], np.linalg.solve(cov[b], e[b][..., None])[..., 0]) for b in e}


def arrays(nav_msgs, truth_msgs) -> dict:
    """Errors (``core.scoring.errors``), sigmas, NEES and NIS of a run."""
    err = scoring.errors(scoring.states_from_msgs(nav_msgs), scoring.states_from_msgs(truth_msgs))
    t_nav = np.array([stamp_to_s(m.header.stamp) for m in nav_msgs])
    idx = np.searchsorted(t_nav, err["t"] - 1e-7)
    matched = [nav_msgs[i] for i in idx]
    sig = sigma_enu(matched)
    n_upd = np.array([m.n_updates for m in nav_msgs])
    new = np.r_[False, np.diff(n_upd) > 0] & (np.array([m.last_nis for m in nav_msgs]) >= 0)
    return {"err": err, "sigma": sig, "nees": nees(err, sig["cov"]),
            "nis_t": t_nav[new], "nis": np.array([m.last_nis for m in nav_msgs])[new],
            "inside_3sigma": {k: np.mean(np.abs(err[k]) <= 3 * sig[k], axis=0)
                              for k in ("pos_enu_m", "vel_enu_mps", "att_enu_deg")}}


def outages(t_fix: np.ndarray, t0: float, t1: float, factor: float = 2.5) -> list[tuple[float, float]]:
    """Intervals without GNSS fixes: gaps longer than ``factor`` nominal
    periods, and before the first / after the last fix."""
    if len(t_fix) < 2:
        return [(t0, t1)]
    period = float(np.median(np.diff(t_fix)))
    out = [(t0, float(t_fix[0]))] if t_fix[0] - t0 > factor * period else []
    gaps = np.nonzero(np.diff(t_fix) > factor * period)[0]
    out += [(float(t_fix[i]), float(t_fix[i + 1])) for i in gaps]
    if t1 - t_fix[-1] > factor * period:
        out.append((float(t_fix[-1]), t1))
    return out


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_errors(a: dict, path, title: str) -> None:
    plt = _plt()
    err, sig = a["err"], a["sigma"]
    fig, axes = plt.subplots(3, 3, figsize=(14, 9), sharex=True)
    for r, (key, label) in enumerate([("pos_enu_m", "position error [m]"), ("vel_enu_mps", "velocity error [m/s]"),
                                      ("att_enu_deg", "attitude error [deg]")]):
        for c, axis in enumerate("ENU"):
            ax = axes[r, c]
            s3 = 3 * sig[key][:, c]
            ax.fill_between(err["t"], -s3, s3, color="tab:blue", alpha=0.18, lw=0, label="filter +/-3 sigma")
            ax.plot(err["t"], err[key][:, c], color="k", lw=0.7, label="error")
            ax.set_title(f"{axis}: {100 * a['inside_3sigma'][key][c]:.1f} % inside 3 sigma", fontsize=9)
            ax.grid(True, alpha=0.3)
            if c == 0:
                ax.set_ylabel(label)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("sim time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def plot_consistency(a: dict, path, title: str, nis_dof: int | None) -> None:
    plt = _plt()
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    lo, hi = chi2.ppf(BAND, 3)
    t = a["err"]["t"]
    for ax, b in zip(axes, ("pos", "vel", "att")):
        v = a["nees"][b]
        ax.semilogy(t, np.maximum(v, 1e-6), lw=0.6, color="k", label=f"NEES {b}")
        ax.axhspan(lo, hi, color="tab:green", alpha=0.2, label="95 % chi-square band (3 dof)")
        inside = np.mean((v > lo) & (v < hi))
        ax.set_ylabel(f"NEES {b}")
        ax.set_title(f"{b}: mean {v.mean():.2f} (expected 3), {100 * inside:.0f} % in band", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    ax = axes[3]
    ax.semilogy(a["nis_t"], np.maximum(a["nis"], 1e-6), ".", ms=2, color="k", label="NIS (last update of an epoch)")
    if nis_dof:
        nlo, nhi = chi2.ppf(BAND, nis_dof)
        ax.axhspan(nlo, nhi, color="tab:green", alpha=0.2, label=f"95 % band ({nis_dof} dof)")
    ax.set_ylabel("NIS")
    ax.set_xlabel("sim time [s]")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def plot_track(truth_msgs, nav_msgs, fixes: dict, gaps, path, title: str) -> None:
    """``fixes``: {label: (t, lat_deg, lon_deg)} (GNSS first, then aiding sources)."""
    plt = _plt()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 10), gridspec_kw={"height_ratios": [2, 1]})
    tt = np.array([stamp_to_s(m.header.stamp) for m in truth_msgs])
    lat = np.rad2deg([m.lat_rad for m in truth_msgs])
    lon = np.rad2deg([m.lon_rad for m in truth_msgs])
    alt = np.array([m.alt_m for m in truth_msgs])
    a1.plot(lon, lat, color="k", lw=1.0, label="truth")
    a1.plot(np.rad2deg([m.lon_rad for m in nav_msgs]), np.rad2deg([m.lat_rad for m in nav_msgs]), color="tab:blue",
            lw=0.8, ls="--", label="fused")
    for (t0, t1) in gaps:
        m = (tt >= t0) & (tt <= t1)
        a1.plot(lon[m], lat[m], color="tab:red", lw=3, alpha=0.5, label="GNSS outage" if t0 == gaps[0][0] else None)
    markers = iter(["o", "^", "s", "D", "v"])
    for label, (t, la, lo) in fixes.items():
        a1.plot(lo, la, next(markers), ms=2.5, ls="none", label=label)
    a1.set_xlabel("longitude [deg]")
    a1.set_ylabel("latitude [deg]")
    a1.legend(loc="best", fontsize=8)
    a1.grid(True, alpha=0.3)
    a2.plot(tt, alt / 1000.0, color="k", lw=1.0, label="truth")
    a2.plot([stamp_to_s(m.header.stamp) for m in nav_msgs], np.array([m.alt_m for m in nav_msgs]) / 1000.0,
            color="tab:blue", lw=0.8, ls="--", label="fused")
    for i, (t0, t1) in enumerate(gaps):
        a2.axvspan(t0, t1, color="tab:red", alpha=0.15, label="GNSS outage" if i == 0 else None)
    for label, (t, _, _) in list(fixes.items())[1:]:
        a2.plot(t, np.interp(t, tt, alt) / 1000.0, "|", ms=8, label=f"{label} fix")
    a2.set_xlabel("sim time [s]")
    a2.set_ylabel("altitude [km]")
    a2.legend(loc="best", fontsize=8)
    a2.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _fixes(bag, topics: dict) -> dict:
    """{label: (t, lat_deg, lon_deg)} of the NavSatFix topics in a bag."""
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    out = {label: ([], [], []) for label in topics.values()}
    for r in read_bag(bag, topics=list(topics)):
        m = deserialize(r.raw, r.msgtype)
        t, la, lo = out[topics[r.topic]]
        t.append(stamp_to_s(m.header.stamp))
        la.append(m.latitude)
        lo.append(m.longitude)
    return {k: tuple(np.array(x) for x in v) for k, v in out.items()}


def write(bag, run: dict, sc) -> dict:
    """The three PNGs beside the bag; returns the figures the report keeps
    (share inside 3 sigma, mean NEES)."""
    bag = pathlib.Path(bag)
    a = arrays(run["nav"], run["truth"])
    plot_errors(a, bag / "errors.png", f"{sc.name}: nav/state - truth/state, filter +/-3 sigma")
    specs = sc.filter_source_specs()
    kinds = {s.type for s in specs if s.type != "imu"}
    dofs = {KIND_DOF.get(k) for k in kinds}
    plot_consistency(a, bag / "consistency.png", f"{sc.name}: consistency (single run)",
                     dofs.pop() if len(dofs) == 1 and None not in dofs else None)
    topics = {"/gnss/fix": "GNSS"}
    topics.update({"/" + s.topic.lstrip("/"): s.id for s in specs if s.type == "horizontal_fix"})
    fixes = _fixes(bag, topics)
    t_nav = a["err"]["t"]
    gaps = outages(fixes["GNSS"][0], float(t_nav[0]) if len(t_nav) else 0.0, float(t_nav[-1]) if len(t_nav) else 0.0)
    plot_track(run["truth"], run["nav"], fixes, gaps, bag / "track.png", f"{sc.name}: ground track and altitude")
    return {"inside_3sigma": {k: v.tolist() for k, v in a["inside_3sigma"].items()},
            "mean_nees": {k: float(v.mean()) for k, v in a["nees"].items()},
            "median_nis": float(np.median(a["nis"])) if len(a["nis"]) else float("nan"), "n_nis": int(len(a["nis"])),
            "gnss_outages_s": gaps}
