"""train_lekf: generate the glide data set and train the L-EKF end to end
(seed 002 section 3.1); writes the parameter set (``.npz`` + ``.json`` with
the training configuration, data seed, loss history and test loss).

    ros2run hyper_nav_repro train_lekf                       # = make train-lekf
    ros2run hyper_nav_repro train_lekf --tracks 64 --epochs 2 --out /tmp/lekf_try

The data set (``--tracks`` flights from seed ``--data-seed``) is cached in
``build/tracking_data/``; the filter configuration (model, Q, R, nominal
input) is the scenario's ``tracker:`` block (``--scenario``), the same the
evaluation uses.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

import jax
import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking import params_store
from hyper_nav_filter.core.target_tracking.lekf import Lekf, LekfArch, count_parameters
from hyper_nav_filter.core.target_tracking.training import TrackSet, TrainConfig, make_eval, noisy_batch, train

from . import training_set as td
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.core.tracking_setup import tracker_config

REPO = pathlib.Path(__file__).resolve().parents[4]
DEFAULT_OUT = params_store.TRAINED_DIR / "lekf_seed002"


def load_dataset(n: int, seed: int, rate_hz: float, t_chi_s: float, workers: int, cache_dir: pathlib.Path, log=print):
    cache = cache_dir / f"tracks_seed{seed}_n{n}_r{rate_hz:g}_tchi{t_chi_s:g}.npz"
    if cache.exists():
        z = np.load(cache, allow_pickle=False)
        return z["X"], z["U"], z["L"], json.loads(str(z["flights"]))
    log(f"[train_lekf] flying {n} glide trajectories (data seed {seed}, {workers} worker(s)) ...")
    t0 = time.monotonic()
    tracks = td.generate(n, seed, rate_hz, t_chi_s, workers=workers, log=log)
    X, U, L = td.stack(tracks)
    flights = [tr.flight for tr in tracks]
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(cache, X=X, U=U, L=L, flights=json.dumps(flights))
    log(f"[train_lekf] data set: {n} tracks, {int(L.sum())} radar epochs, {time.monotonic() - t0:.0f} s")
    return X, U, L, flights


def track_set(X, U, L, idx, cfg, arch: LekfArch, dt):
    hi = np.asarray(arch.imn_output_range) * cfg.u_nominal
    return TrackSet(gm.to_scaled(X[idx]), np.clip(U[idx], 1e-3, hi * 0.999), L[idx], dt)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Train the seed 002 L-EKF (writes the parameter set).")
    ap.add_argument("--scenario", default="seed002_s1", help="scenario whose tracker: block configures the filter")
    ap.add_argument("--tracks", type=int, default=1080, help="data set size (paper: 1080)")
    ap.add_argument("--data-seed", type=int, default=20020)
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--chunk", type=int, default=100)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--seed", type=int, default=0, help="initialization and noise seed of the training")
    ap.add_argument("--paper-widths", action="store_true", help="the paper's layer widths (slow on a CPU)")
    ap.add_argument("--time-limit-min", type=float, default=None, help="stop after this many minutes of training")
    ap.add_argument("--workers", type=int, default=2, help="processes flying the data set")
    ap.add_argument("--cache-dir", default=str(REPO / "build" / "tracking_data"))
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="parameter set path stem")
    args = ap.parse_args(argv)

    sc = load_scenario(args.scenario)
    cfg = tracker_config(sc)
    rate = float(sc.data["radar"]["rate_hz"])
    X, U, L, flights = load_dataset(args.tracks, args.data_seed, rate, cfg.nominal_t_chi_s, args.workers,
                                    pathlib.Path(args.cache_dir))
    i_tr, i_va, i_te = td.split(args.tracks, args.data_seed)
    arch = LekfArch.paper() if args.paper_widths else LekfArch()
    tcfg = TrainConfig(epochs=args.epochs, batch=min(args.batch, len(i_tr)), chunk=args.chunk,
                       learning_rate=args.lr, seed=args.seed)
    net = Lekf(cfg.model, cfg.u_nominal, cfg.Q, cfg.R, arch)
    variables = net.init_variables(jax.random.PRNGKey(args.seed))
    dt = 1.0 / rate
    sets = [track_set(X, U, L, i, cfg, arch, dt) for i in (i_tr, i_va, i_te)]
    print(f"[train_lekf] {count_parameters(variables)} parameters; train/val/test {len(i_tr)}/{len(i_va)}/{len(i_te)} "
          f"tracks; {tcfg}")
    t0 = time.monotonic()
    evaluate = make_eval(net)

    def loss_on(ts, variables, seed):
        x0, P0b, Z, DT, valid, Xs, Us = noisy_batch(ts, np.arange(len(ts.length)), cfg.R, cfg.P0,
                                                    np.random.default_rng(seed))
        return float(evaluate(variables, net.init_carry(x0, P0b), Z, DT, valid, Xs, Us)[0])

    ekf_test = loss_on(sets[2], variables, args.seed + 2)      # untrained L-EKF = EKF
    def checkpoint(best, history):
        params_store.save(str(args.out) + "_partial", arch, jax.device_get(best),
                          {"history": history, "data": {"data_seed": args.data_seed}, "n_parameters": 0})

    variables, history = train(net, variables, sets[0], sets[1], tcfg, cfg.P0,
                               time_limit_s=None if args.time_limit_min is None else 60 * args.time_limit_min,
                               on_epoch=checkpoint)
    wall = time.monotonic() - t0
    test = loss_on(sets[2], variables, args.seed + 2)
    print(f"[train_lekf] test WMAE {test:.3f} (EKF, i.e. untrained: {ekf_test:.3f}); training {wall / 60:.1f} min")
    meta = {"training": tcfg.as_dict(), "data": {"tracks": args.tracks, "data_seed": args.data_seed,
                                                  "split": [len(i_tr), len(i_va), len(i_te)], "radar_rate_hz": rate,
                                                  "generator": "hyper_nav_repro.seed002.training_set.random_flight"},
            "tracker_config": cfg.as_parameters(), "scenario": args.scenario, "history": history,
            "test_wmae": test, "test_wmae_ekf": ekf_test, "training_wall_s": wall,
            "best_epoch": int(min(history, key=lambda h: h["val_loss"])["epoch"]),
            "n_parameters": count_parameters(variables), "jax": jax.__version__}
    stem = params_store.save(args.out, arch, jax.device_get(variables), meta)
    print(f"[train_lekf] wrote {stem}.npz / .json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
