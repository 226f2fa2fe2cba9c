"""The bounds of one seed 002 flight and the filters' ratios to them, with
the Monte Carlo's confidence intervals (issue 40; core in
``core.tracking.flight_bounds``).

Columns (each along the simulated truth, eq. 21 with the truth's
model-equivalent parameters, no kinematic process noise):

* ``known``: PCRB with the maneuver known (the flights' own prior: a fixed
  maneuver). A bound for every estimator on these flights.
* ``windowed_<W>s`` / ``windowed_flight``: CRB with the maneuver parameters
  a_v, a_l, c_d unknown deterministic offsets from the truth's, constant over
  W-second windows (flight: one constant offset), no prior on them, the
  hand-over estimate a measurement of the initial state (P0). A bound for
  estimators unbiased over that family of maneuvers only: every filter here
  holds a prior on the maneuver (the random walks, the nominal glide input,
  the L-EKF's training) and goes below it in v, gamma, psi (measured, issue
  40), so it is reported as a reference, not as a bound of these filters.
* ``random_walk``: the unknown-maneuver PCRB of issue 24 (parameters as the
  AUG-IMM's random walks, conditioned on the true mode sequence). A bound on the
  MSE averaged over parameter paths drawn from those walks -- not a bound on
  these flights (a reference; ``fixed_path`` says by how much its own optimal
  filter goes below it on each flight, ``walk_draws`` checks it on draws).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from hyper_nav_filter.core.target_tracking import augmented as au
from hyper_nav_filter.core.target_tracking import flight_bounds as fb
from hyper_nav_filter.core.target_tracking import glide_model as gm

WINDOWS_S = (10.0, 30.0, 100.0, np.inf)
TABLE_WINDOW_S = np.inf         # the windowed CRB shown in the table: one offset per flight (the others in table2.json)
BOUND_KEYS = ("known", "windowed_flight", "random_walk")
IS_BOUND = {"known": "bound for every estimator on this flight (the only estimator-independent one)",
            "windowed_flight": ("CRB for estimators unbiased for every maneuver = truth + one constant offset; NOT a "
                                "bound for these filters (each holds a prior on the maneuver: biased)"),
            "random_walk": ("reference, NOT a bound on this flight: bounds the MSE averaged over parameter paths "
                            "drawn from the AUG-IMM's random walks")}
H_AUG = np.eye(gm.N_Z, au.N_AUG)


def _key(w):
    return f"windowed_{w:g}s" if np.isfinite(w) else "windowed_flight"


def flight_bounds(cfg, setup, t, x_true, par, high):
    """Bound covariances (N, n, n) scaled, per key, along one flight, and the
    random-walk PCRB's decomposition on it (``fixed_path``)."""
    dt = float(t[1] - t[0])
    F_aug = au.truth_jacobians(cfg.model, x_true, par, dt)
    out = {"known": au.known_bound(F_aug, cfg.P0, cfg.R)}
    P0a, Qs = au.bound_model(cfg.P0, setup.glide, dt, noise_high=setup.maneuver, high_steps=high)
    out["random_walk"], K = fb.kalman_bound(F_aug, P0a, H_AUG, cfg.R, Qs)
    for w in WINDOWS_S:
        out[_key(w)] = fb.windowed_crb(F_aug, cfg.P0, H_AUG, cfg.R, au.N_KIN, fb.window_ids(t, w))
    # the random-walk PCRB's own Kalman filter on this fixed flight: noise part C + the path's bias m m^T
    y = np.concatenate([np.asarray(x_true, float)[:, :au.N_KIN], par], axis=1) / au.AUG_SCALE
    drive = y[1:] - au.transition(cfg.model, y[:-1], dt)[0]         # the truth's increments and model residual
    P0e = np.zeros_like(P0a)
    P0e[:au.N_KIN, :au.N_KIN] = cfg.P0[:au.N_KIN, :au.N_KIN]
    m0 = np.concatenate([np.zeros(au.N_KIN), (par[0] - np.asarray(au.AugFilterConfig().params0)) / au.AUG_SCALE[au.N_KIN:]])
    C, m = fb.fixed_path_error(F_aug, K, H_AUG, cfg.R, P0e, m0, drive)
    drive_par = drive.copy()
    drive_par[:, :au.N_KIN] = 0.0
    _, m_par = fb.fixed_path_error(F_aug, K, H_AUG, cfg.R, P0e, np.zeros(au.N_AUG), drive_par)
    out["fixed_path_noise"] = C
    out["fixed_path_total"] = C + np.einsum("ti,tj->tij", m, m)
    out["fixed_path_increments_only"] = C + np.einsum("ti,tj->tij", m_par, m_par)
    return out


def rms(P):
    return fb.rms_over_time(P[:, :au.N_KIN, :au.N_KIN], au.AUG_SCALE)


def summary(P_by_key, t, high, par) -> dict:
    """JSON of the bounds: RMS over the flight per state, what each is, and
    the decomposition of the random-walk PCRB on the flight."""
    rw = rms(P_by_key["random_walk"])
    return {
        "rms": {k: rms(P).tolist() for k, P in P_by_key.items()},
        "what": {**IS_BOUND, **{_key(w): f"CRB for estimators unbiased for every maneuver = truth + offsets "
                                          f"constant over {w:g} s windows; NOT a bound for these filters"
                                 for w in WINDOWS_S if np.isfinite(w)},
                 "fixed_path_total": ("MSE of the random-walk PCRB's own (linearized) Kalman filter on this flight: "
                                      "radar noise and hand-over part + the flight's own bias (its parameter "
                                      "increments, model residual and the filter's initial parameter error)"),
                 "fixed_path_increments_only": "the same, bias from the truth's parameter increments only",
                 "fixed_path_noise": "its radar-noise and hand-over part alone"},
        "fixed_path_over_random_walk": (rms(P_by_key["fixed_path_total"]) / rw).tolist(),
        "fixed_path_increments_only_over_random_walk": (rms(P_by_key["fixed_path_increments_only"]) / rw).tolist(),
        "fixed_path_noise_over_random_walk": (rms(P_by_key["fixed_path_noise"]) / rw).tolist(),
        "first_100s_share_of_bound_variance": {
            k: (np.sum(np.diagonal(P_by_key[k], axis1=1, axis2=2)[np.asarray(t) <= 100.0, :au.N_KIN], 0)
                / np.sum(np.diagonal(P_by_key[k], axis1=1, axis2=2)[:, :au.N_KIN], 0)).tolist()
            for k in ("known", "random_walk", _key(TABLE_WINDOW_S))},
    }


def ratio_cells(err, P_by_key, keys=BOUND_KEYS) -> dict:
    """RMSE over runs and epochs (err (runs, T, 6) physical) with its 95 %
    Monte Carlo interval, and its ratio to each bound (ratio, lo, hi)."""
    r, lo, hi = fb.rmse_interval(err)
    out = {"rmse": r.tolist(), "rmse_ci95": [lo.tolist(), hi.tolist()], "ratios": {}}
    for k in keys:
        b = rms(P_by_key[k])
        out["ratios"][k] = {"ratio": (r / b).tolist(), "ci95": [(lo / b).tolist(), (hi / b).tolist()]}
    return out


def walk_draws(cfg, setup, t, x0_phys, par, high, draws: int, rng, filter_name: str = "AUG-IMM") -> dict:
    """The random-walk PCRB where it must hold: ``draws`` parameter paths
    drawn from the walks it assumes (prior N(par[0], init_sigma^2), glide /
    maneuver densities on the flight's mode sequence ``high``), each flown by
    eq. 21 (perfect model), radar noise and a hand-over error ~ N(0, P0); the
    filter (started at par[0], the prior's mean) over them, RMSE with its 95 %
    interval, against the bound averaged over the draws (each along its own
    path). Returns the ratios."""
    dt = float(t[1] - t[0])
    n = len(t)
    q = np.where(np.asarray(high, bool)[:, None], setup.maneuver.q, setup.glide.q) * np.sqrt(dt)
    paths = fb.random_walk_paths(par[0], setup.glide.init_sigma, q, rng, draws)        # (draws, n, 3)
    x_true = np.stack([au.perfect_model_truth(cfg.model, x0_phys, p, dt) for p in paths])   # (draws, n, 6)
    # draws that leave the glide (h outside 10-150 km, v below 1 km/s, non-finite) are dropped and counted:
    # the walks' maneuver densities (a_l 1.5 per sqrt(s)) spin a long path off any flight
    ok = np.all(np.isfinite(x_true), axis=(1, 2)) & np.all((x_true[..., 0] > 1e4) & (x_true[..., 0] < 1.5e5)
                                                          & (x_true[..., 3] > 1e3), axis=1)
    var = []
    for i in np.flatnonzero(ok):
        try:
            F = au.truth_jacobians(cfg.model, x_true[i], paths[i], dt)
            var.append(np.diagonal(au.augmented_bound(F, cfg.P0, cfg.R, setup.glide, dt, noise_high=setup.maneuver,
                                                      high_steps=high), axis1=1, axis2=2)[:, :au.N_KIN])
        except np.linalg.LinAlgError:
            ok[i] = False
    var = [v for v in var if np.all(np.isfinite(v))] if len(var) == ok.sum() else var
    x_true, paths, draws_kept = x_true[ok], paths[ok], int(ok.sum())
    bound = np.sqrt(np.mean(np.stack(var), axis=(0, 1))) * au.AUG_SCALE[:au.N_KIN]
    draws = draws_kept
    Z = x_true[..., :3] + np.sqrt(np.diag(cfg.R)) * gm.STATE_SCALE[:3] * rng.standard_normal((draws, n, 3))
    x0 = x_true[:, 0] + rng.standard_normal((draws, au.N_KIN)) * np.sqrt(np.diag(cfg.P0))[:au.N_KIN] * gm.STATE_SCALE[:6]
    fcfg = replace(setup.filter_config(filter_name), params0=tuple(par[0]))
    DT = np.full(n, dt)
    DT[0] = 0.0
    xa, _, _ = au.aug_filter_run(cfg.model, fcfg, x0, cfg.P0, cfg.R,
                                 np.swapaxes(gm.measurement_to_scaled(Z), 0, 1), DT)
    e = np.swapaxes(xa[..., :6], 0, 1) - x_true
    e[..., 5] = np.mod(e[..., 5] + np.pi, 2 * np.pi) - np.pi
    r, lo, hi = fb.rmse_interval(e)
    return {"filter": filter_name, "draws": draws, "draws_dropped": int(len(ok) - draws), "duration_s": float(t[-1] - t[0]), "bound_rms": bound.tolist(),
            "rmse": r.tolist(), "ratio": (r / bound).tolist(), "ci95": [(lo / bound).tolist(), (hi / bound).tolist()],
            "data": "perfect model, parameter paths drawn from the bound's random walks"}
