"""Training and evaluation tracks for the seed 002 target trackers, flown by
the simulator's boost-glide dynamics (``boost_glide.DynamicTrajectory``).

``random_flight(rng)`` draws a quasi-equilibrium glide (seed 002 section
3.1.2: "different c_l ... CV, CA, turns, square waves"): start point, speed
and heading, a constant or varying normalized lift program, and 0-3 lateral
maneuvers in sequence (constant lateral acceleration, turns, square waves,
evasive weaves, S-turns) with random loads, windows and periods. Maneuver
sets that come close to the three evaluation scenarios' (same type, load
within 0.5 g, start within 100 s) are redrawn, and the data seed is not the
scenarios' seed: the evaluation flights are never trained on.

Each track is the filter's truth state and input along its flight
(``hyper_nav_sim.core.tracking_setup.truth_track``).
"""
from __future__ import annotations

import functools
import multiprocessing

import numpy as np

from hyper_nav_filter.core.target_tracking import glide_model as gm

from hyper_nav_sim.core.boost_glide import DynamicTrajectory
from hyper_nav_sim.core.scenario import load_scenario
from hyper_nav_sim.core.tracking_setup import PERIODIC, Track, truth_track

# seed 002 Table 1's scenarios: the reproduction evaluates them, the training set avoids them
EVAL_SCENARIOS = {1: "seed002_s1", 2: "seed002_s2", 3: "seed002_s3"}
VEHICLE_FIELDS = ("mass_kg", "s_ref_m2", "cd0", "k_induced", "cl_alpha_per_rad", "c_l_max")
LATERAL = ("lateral_ca", "turn_left", "turn_right") + PERIODIC
MAX_DURATION_S = 1250.0


@functools.lru_cache(maxsize=None)
def _eval_flights() -> tuple[dict, ...]:
    """The ``flight:`` blocks of the evaluation scenarios (``EVAL_SCENARIOS``)."""
    return tuple(load_scenario(name).data["flight"] for name in EVAL_SCENARIOS.values())


def vehicle() -> dict:
    """The evaluation flights' vehicle (CAV-H: mass, reference area, drag polar, lift limits)."""
    flight = _eval_flights()[0]
    return {k: flight[k] for k in VEHICLE_FIELDS}


def _close_to_eval(m: dict) -> bool:
    for flight in _eval_flights():
        for e in flight["maneuvers"]:
            if e["type"] == m["type"] and abs(abs(e["load_g"]) - abs(m["load_g"])) < 0.5 \
                    and abs(e["t_start_s"] - m["t_start_s"]) < 100.0:
                return True
    return False


def random_flight(rng: np.random.Generator) -> dict:
    """One random glide (a ``flight:`` dict)."""
    start = {"lat_deg": float(rng.uniform(-20, 20)), "lon_deg": float(rng.uniform(-180, 180)),
             "alt_m": float(rng.uniform(55e3, 65e3)), "speed_mps": float(rng.uniform(6500, 7200)),
             "gamma_deg": float(rng.uniform(-1.5, -0.5)), "psi_deg": float(rng.uniform(0, 360))}
    if rng.random() < 0.4:
        c_l = float(rng.uniform(0.15, 0.6))
    else:
        t_c = float(rng.uniform(150, 900))
        c_l = [[0.0, float(rng.uniform(0.15, 0.6))], [t_c, float(rng.uniform(0.15, 0.6))]]
    n_man = int(rng.choice(4, p=[0.15, 0.35, 0.3, 0.2]))
    mans, t = [], float(rng.uniform(0, 300))
    while len(mans) < n_man and t < MAX_DURATION_S - 100:
        typ = str(rng.choice(LATERAL))
        dur = float(rng.uniform(100, 600))
        load = float(rng.uniform(0.5, 5.0))
        m = {"type": typ, "t_start_s": round(t, 1), "t_end_s": round(min(t + dur, MAX_DURATION_S + 50), 1),
             "load_g": round(load * (float(rng.choice([-1.0, 1.0])) if typ == "lateral_ca" else 1.0), 2)}
        if typ in PERIODIC:
            m["period_s"] = round(float(rng.uniform(40, 300)), 1)
        if _close_to_eval(m):
            continue
        mans.append(m)
        t = m["t_end_s"] + float(rng.uniform(0, 250))
    return {**vehicle(), "duration_s": MAX_DURATION_S, "end_speed_mps": 2000.0, "start": start,
            "c_l_program": c_l, "maneuvers": mans}


def fly(flight: dict, rate_hz: float = 1.0, nominal_t_chi_s: float = 100.0) -> Track:
    traj = DynamicTrajectory.from_config(flight)
    t = np.arange(0.0, np.floor(traj.duration_s * rate_hz) / rate_hz + 1e-9, 1.0 / rate_hz)
    x, u = truth_track(traj, t, flight.get("maneuvers", []), nominal_t_chi_s)
    return Track(t, x, u, flight)


def _fly_seeded(args):
    seed, i, rate_hz, t_chi = args
    return fly(random_flight(np.random.default_rng([seed, i])), rate_hz, t_chi)


def generate(n: int, seed: int, rate_hz: float = 1.0, nominal_t_chi_s: float = 100.0, workers: int = 1,
             log=None) -> list[Track]:
    """n random tracks; track i comes from the generator seeded [seed, i], so
    any subset is reproducible on its own."""
    jobs = [(seed, i, rate_hz, nominal_t_chi_s) for i in range(n)]
    if workers > 1:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            out = []
            for k, tr in enumerate(pool.imap(_fly_seeded, jobs, chunksize=4)):
                out.append(tr)
                if log and (k + 1) % 100 == 0:
                    log(f"  {k + 1}/{n} tracks")
            return out
    out = []
    for k, job in enumerate(jobs):
        out.append(_fly_seeded(job))
        if log and (k + 1) % 100 == 0:
            log(f"  {k + 1}/{n} tracks")
    return out


def split(n: int, seed: int, fractions=(0.8, 0.1, 0.1)):
    """Random train/validation/test index split (seed 002 section 3.1.2: 80/10/10)."""
    order = np.random.default_rng([seed, 10**6]).permutation(n)
    n_tr = int(round(fractions[0] * n))
    n_va = int(round(fractions[1] * n))
    return order[:n_tr], order[n_tr: n_tr + n_va], order[n_tr + n_va:]


def stack(tracks: list[Track]):
    """Pad to a common length: (X (n, T, 7) physical, U (n, T, 3), length (n,))."""
    T = max(len(tr.t_s) for tr in tracks)
    n = len(tracks)
    X = np.zeros((n, T, gm.N_X))
    U = np.zeros((n, T, gm.N_U))
    L = np.zeros(n, int)
    for i, tr in enumerate(tracks):
        k = len(tr.t_s)
        X[i, :k], U[i, :k], L[i] = tr.x, tr.u, k
        X[i, k:], U[i, k:] = tr.x[-1], tr.u[-1]
    return X, U, L
