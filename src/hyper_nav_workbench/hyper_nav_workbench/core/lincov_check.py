"""LinCov against Monte Carlo (issue 39): per-axis 1-sigma of one LinCov
pass beside the RMS over Monte Carlo runs of the real filter
(``montecarlo.run_one``: the fusion engine on simulated sensors), with the
Monte Carlo's own 95 % sampling band, and the split by source against runs
that draw one kind of input at a time (``montecarlo.DRAWS``):

  initial  the initial navigation errors     <-> LinCov's "initial *" groups
  biases   the turn-on IMU biases (and the scale factors the filter carries)
  noise    every sensor noise stream (white noise, Markov drifts, GNSS noise)

With one kind drawn, the others are the scenario's fixed values in every
run; their (common) effect is removed by taking the spread about the mean
over runs (the system is linear to first order), so the Monte Carlo figure
is the standard deviation (N - 1 dof) instead of the RMS (N dof).
No rclpy.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2

from hyper_nav_filter.core.lincov import INIT_GROUPS

NAV = {"att": slice(0, 3), "vel": slice(3, 6), "pos": slice(6, 9)}
SCALE_GROUPS = ("gyro scale factor", "accel scale factor")


def groups_of_draw(draw: str, groups, state_blocks) -> list[str]:
    """The LinCov groups a Monte Carlo draw kind switches on."""
    if draw == "initial":
        return [g for g in groups if g in INIT_GROUPS]
    bias = ["gyro bias (turn-on)", "accel bias (turn-on)"]
    bias += [g for g, b in zip(SCALE_GROUPS, ("sg", "sa")) if b in state_blocks]
    if draw == "biases":
        return [g for g in groups if g in bias]
    if draw == "noise":
        return [g for g in groups if g not in INIT_GROUPS and g not in bias and g not in SCALE_GROUPS]
    raise ValueError(f"draw {draw!r}: not in (initial, biases, noise)")


def sampling_band(n: int, about_mean: bool, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` band of (MC RMS or std) / true sigma for n Gaussian runs."""
    dof = n - 1 if about_mean else n
    lo, hi = chi2.ppf([(1 - level) / 2, (1 + level) / 2], dof)
    return float(math.sqrt(lo / dof)), float(math.sqrt(hi / dof))


def mc_spread(runs: list[dict], about_mean: bool) -> tuple[np.ndarray, dict]:
    """(t_s, {block: (T, 3) per-axis RMS or std over the runs, ENU; att rad})."""
    runs = sorted(runs, key=lambda r: r["k"])
    t = np.asarray(runs[0]["t_s"], float)
    out = {}
    for b in NAV:
        e = np.array([r["err"][b] for r in runs])                  # (n, T, 3)
        out[b] = e.std(axis=0, ddof=1) if about_mean else np.sqrt(np.mean(e**2, axis=0))
    return t, out


def compare(res, runs: list[dict], groups=None, about_mean: bool = False, skip_s: float = 0.0,
            level: float = 0.95, end_s: float = math.inf) -> dict:
    """Per block and axis at the Monte Carlo's epochs: LinCov's sigma (of
    ``groups`` only, default all), the MC figure, their ratio; the largest
    relative difference in [skip_s, end_s] and the MC's own sampling band
    (``level``). The errors of one run are strongly correlated in time (an
    initial attitude error persists), so the epochs of one campaign do not
    sample the band independently: one campaign's draws sit high or low
    together."""
    t_mc, mc = mc_spread(runs, about_mean)
    idx = [i for i, g in enumerate(res.groups) if groups is None or g in groups]
    var = res.var[:, idx, :].sum(axis=1)
    k = np.array([int(np.argmin(np.abs(res.t_s - t))) for t in t_mc])
    if np.max(np.abs(res.t_s[k] - t_mc)) > 1e-6:
        raise ValueError("LinCov epochs do not contain the Monte Carlo's")
    m = (t_mc >= skip_s) & (t_mc <= end_s)
    n = len(runs)
    lo, hi = sampling_band(n, about_mean, level)
    out = {"n_runs": n, "about_mean": about_mean, "band_level": level, "band": [lo, hi], "t_s": t_mc.tolist(), "blocks": {}}
    for b, sl in NAV.items():
        lin = np.sqrt(var[k][:, sl])
        ratio = np.where(lin > 0, mc[b] / np.maximum(lin, 1e-300), np.nan)
        rm = ratio[m]
        out["blocks"][b] = {"lincov_sigma": lin.tolist(), "mc": mc[b].tolist(), "ratio": ratio.tolist(),
                            "max_abs_rel_diff": float(np.nanmax(np.abs(rm - 1.0))) if rm.size else math.nan,
                            "share_within_10pct": float(np.nanmean(np.abs(rm - 1.0) <= 0.10)) if rm.size else math.nan,
                            "share_within_band": float(np.nanmean((rm >= lo) & (rm <= hi))) if rm.size else math.nan}
    return out


def run_mc(data: dict, n_runs: int, draws=("noise", "biases", "initial"), grid_hz: float = 1.0,
           workers: int = 0) -> list[dict]:
    """n_runs of ``montecarlo.run_one`` (in-process, or on a local dask
    cluster of ``workers`` processes as ``mc_campaign`` uses)."""
    from hyper_nav_workbench.core import montecarlo
    if workers <= 0:
        return [montecarlo.run_one(data, k, tuple(draws), grid_hz) for k in range(n_runs)]
    from dask.distributed import Client

    from hyper_nav_workbench.campaign import new_local_cluster
    with new_local_cluster(workers) as cl, Client(cl) as client:
        futs = client.map(montecarlo.run_one, [data] * n_runs, range(n_runs), draws=tuple(draws), grid_hz=grid_hz,
                          pure=False)
        return client.gather(futs)
