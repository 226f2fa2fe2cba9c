"""The guidance loop flown offline, without ROS: the same cores as the live
graph (``CommandedFlight``/``CommandLoop`` of the truth node, ``GlideGuidance``
of the guidance node, ``FusionEngine`` of the fusion node), in one process.

``fly_on_truth(sc)`` is the live loop "guidance on ``truth/state``" step for
step: the truth evaluated at the truth node's own epochs (k / clock_rate_hz,
every truth_rate), one epoch at a time, each stamp through the message's
(sec, nanosec) round trip, so that the live flight recorded in a bag equals
it bit for bit (``test/test_guidance_graph.py``).

``fly_on_navigation(sc, ...)`` closes the loop through navigation: the IMU
increments (exact, from the commanded flight, ``gauss_legendre_increments``)
corrupted by the scenario's IMU error model as one continuous process
(``ImuErrorState``), the loosely coupled GNSS fixes of ``gnss_model`` (white
noise: not the raw-GNSS realistic world), both generated as the flight
advances, fed to the fusion engine in time order; the guidance flies on the
engine's navigation: ``stream="delayed"`` its released (1 s delayed)
solutions (``FusionEngine.release``, the live ``nav/delayed/state``),
``stream="current"`` its current-time state (``FusionEngine.current``, issue
35: the state at the IMU sample just added, the live ``nav/state``), read
after every IMU sample, acted on at the guidance grid's stamps. GNSS outages
drop the fixes in their windows (a blackout, or INS alone from a time on).
The command for the navigation stamp t_nav applies at
ceil((t_nav + apply_delay_s) / period_s): on the delayed stream
apply_delay_s must exceed the filter's output delay; on the current stream
one guidance period (0.1 s, as the truth-fed loop) is enough.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.measurements import GnssPosition, GnssVelocity
from hyper_nav_filter.core.stream_runner import StreamRunner
from hyper_nav_sim.core.boost_glide_config import parse_flight
from hyper_nav_sim.core.commanded_flight import CommandedFlight, CommandLoop
from hyper_nav_sim.core.gnss_model import simulate_fixes
from hyper_nav_sim.core.guidance_config import GuidanceConfig
from hyper_nav_sim.core.imu_model import ImuErrors, ImuErrorState, corrupt_increments, imu_epochs
from hyper_nav_sim.core.scenario import Scenario

from .core.law import GlideGuidance, miss_enu_m


STREAMS = ("delayed", "current")


@dataclass
class LoopResult:
    """One closed-loop flight."""
    flight: CommandedFlight
    t_end_s: float
    miss: dict                                   # miss_enu_m at the flight's end
    commands: list = field(default_factory=list)  # (t_nav_s, sigma_cmd_rad, c_l_cmd) as computed
    nav_error_end_m: float = 0.0                 # |nav - truth| (3-D) at the last navigation stamp used
    refused: dict = field(default_factory=dict)


def with_changes(sc: Scenario, changes: dict) -> Scenario:
    """A copy of the scenario with dotted fields changed (``guidance.apply_delay_s``, ``seed``)."""
    data = copy.deepcopy(sc.data)
    for dotted, v in changes.items():
        d = data
        *head, last = dotted.split(".")
        for k in head:
            d = d.setdefault(k, {})
        d[last] = v
    GuidanceConfig.from_config(data["guidance"])
    return Scenario(sc.path, data)


def make_flight(sc: Scenario):
    cfg = GuidanceConfig.from_config(sc.data["guidance"])
    fl = dict(sc.data["flight"])
    fl.setdefault("duration_s", sc["duration_s"])
    flight = CommandedFlight(**parse_flight(fl), step_s=cfg.period_s, apply_delay_s=cfg.apply_delay_s,
                             bank_max_rad=cfg.bank_limit_rad)
    return cfg, flight


def stamp_round_trip(t_s: float) -> float:
    sec, nsec = s_to_stamp_fields(t_s)
    return sec + nsec * 1e-9


def on_grid(t_s: float, period_s: float) -> bool:
    return abs(t_s - round(t_s / period_s) * period_s) <= 1e-6


def _finish(cfg, flight, loop, commands, nav_err=0.0):
    loop.expect = False
    flight.advance(flight.duration_s + 1.0)
    tr = flight.truth(np.array([flight.duration_s]))
    miss = miss_enu_m(cfg, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0])
    return LoopResult(flight, flight.duration_s, miss, commands, nav_err, dict(flight.refused))


def fly_on_truth(sc: Scenario) -> LoopResult:
    """Guidance on the exact truth, at the truth node's epochs (see module doc)."""
    cfg, flight = make_flight(sc)
    loop = CommandLoop(flight, cfg.t_start_s, expect=True)
    law = GlideGuidance(cfg, flight.vehicle)
    base = 1.0 / sc["graph.clock_rate_hz"]
    every = max(1, int(round(sc["graph.clock_rate_hz"] / sc["graph.truth_rate_hz"])))
    steps = np.arange(0, int(np.floor(sc["duration_s"] / base + 1e-9)) + 1)
    t_truth = steps[steps % every == 0] * base
    commands = []
    h = flight.step_s
    for i in range(len(t_truth)):
        t = t_truth[i]
        loop.advance(math.ceil(t / h - 1e-9) * h)
        if flight.flown_s < t - 1e-9:
            if flight.finished:
                break
            raise RuntimeError(f"the loop stalls at {t:.3f} s: guidance.apply_delay_s too short for its stream")
        t_nav = stamp_round_trip(t)
        if not on_grid(t_nav, cfg.period_s) or t_nav < cfg.t_start_s - 1e-9:
            continue
        tr = flight.truth(t_truth[i:i + 1])
        c = law.command(t_nav, float(tr.lat_rad[0]), float(tr.lon_rad[0]), float(tr.alt_m[0]),
                        tr.vel_enu_mps[0].tolist())
        commands.append((t_nav, c.sigma_cmd_rad, c.c_l_cmd))
        loop.receive(t_nav, c.sigma_cmd_rad, c.c_l_cmd)
    return _finish(cfg, flight, loop, commands)


def fly_on_navigation(sc: Scenario, stream: str = "delayed", gnss_outages=()) -> LoopResult:
    """Guidance on the fusion engine's solutions (module doc). ``gnss_outages``:
    [(t0, t1), ...] windows without GNSS fixes (t1 may be inf)."""
    if stream not in STREAMS:
        raise ValueError(f"stream {stream!r}: one of {STREAMS}")
    cfg, flight = make_flight(sc)
    fcfg = sc.filter_config()
    if stream == "delayed" and cfg.apply_delay_s <= fcfg.output_delay_s:
        raise ValueError(f"guidance.apply_delay_s ({cfg.apply_delay_s:g} s) must exceed the delayed stream's "
                         f"output_delay_s ({fcfg.output_delay_s:g} s)")
    loop = CommandLoop(flight, cfg.t_start_s, expect=True)
    law = GlideGuidance(cfg, flight.vehicle)
    eng = FusionEngine(fcfg, sc.filter_initial_state())
    dt = 1.0 / sc["imu.rate_hz"]
    t_imu = imu_epochs(sc["duration_s"], sc["imu.rate_hz"])
    t_gnss = imu_epochs(sc["duration_s"], sc["gnss.rate_hz"])
    errors, rng_imu, rng_gnss, st = ImuErrors.from_scenario(sc), sc.rng("imu"), sc.rng("gnss"), ImuErrorState()
    commands, h = [], flight.step_s
    run = StreamRunner(eng, [_GnssFixes(flight, sc, t_gnss, rng_gnss, gnss_outages)])
    last_nav = None

    def act(sols):
        nonlocal last_nav
        for s in sols:
            t_nav = s.t_s
            if not on_grid(t_nav, cfg.period_s) or t_nav < cfg.t_start_s - 1e-9 or t_nav > flight.flown_s + 1e-9:
                continue
            x = s.state
            c = law.command(t_nav, float(x.lat_rad), float(x.lon_rad), float(x.alt_m), list(x.vel_enu_mps))
            commands.append((t_nav, c.sigma_cmd_rad, c.c_l_cmd))
            loop.receive(t_nav, c.sigma_cmd_rad, c.c_l_cmd)
            last_nav = (t_nav, float(x.lat_rad), float(x.lon_rad), float(x.alt_m))

    k, n_imu = 0, len(t_imu)
    while k < n_imu:
        t = t_imu[k]
        loop.advance(math.ceil(t / h - 1e-9) * h)
        if flight.flown_s < t - 1e-9:
            if flight.finished:
                break
            raise RuntimeError(f"the loop stalls at {t:.3f} s: guidance.apply_delay_s too short for its stream")
        # the IMU samples of the flown step, in one call (one continuous error process)
        k1 = int(np.searchsorted(t_imu, flight.flown_s + 1e-9, side="right"))
        dth_b, dv_b = flight.imu_increments(t_imu[k:k1], dt)
        dth_b, dv_b = corrupt_increments(dth_b, dv_b, dt, errors, rng_imu, st)
        for i in range(k1 - k):
            t = t_imu[k + i]
            released = run.step(t, dth_b[i], dv_b[i])
            if stream == "delayed":
                act(released)
            elif eng.current is not None and abs(eng.current.t_s - t) <= 1e-9:
                act((eng.current,))              # the state at this sample (formed when it was added)
        k = k1
    nav_err = 0.0
    if last_nav is not None:
        from hyper_nav_gnss import earth
        tr = flight.truth(np.array([last_nav[0]]))
        d = earth.position_error_enu_m(last_nav[1], last_nav[2], last_nav[3],
                                       tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0])
        nav_err = float(np.linalg.norm(d))
    return _finish(cfg, flight, loop, commands, nav_err)


class _GnssFixes:
    """The GNSS fixes as a feed of the engine's runner: drawn for every epoch
    up to each IMU sample (the flight is flown as it goes), dropped in the outages."""

    def __init__(self, flight, sc, t_gnss, rng_gnss, gnss_outages):
        self.args, self.j = (flight, sc, t_gnss), 0
        self.rng, self.outages = rng_gnss, gnss_outages

    def until(self, eng, t):
        flight, sc, t_gnss = self.args
        self.j = _gnss_until(eng, flight, sc, t_gnss, self.j, t, self.rng, self.outages)


def _gnss_until(eng, flight, sc, t_gnss, j, t, rng_gnss, gnss_outages):
    """Add the GNSS fixes up to t (drawn for every epoch, dropped in the outages); returns the next index."""
    while j < len(t_gnss) and t_gnss[j] <= t + 1e-9:
        tg = t_gnss[j]
        g = simulate_fixes(flight, t_gnss[j:j + 1], sc["gnss.pos_sigma_enu_m"], sc["gnss.vel_sigma_enu_mps"],
                           sc["gnss.antenna_lever_arm_b_m"], rng_gnss)
        if not any(a <= tg < b for a, b in gnss_outages):
            eng.add_measurement(GnssVelocity(tg, g.vel_enu_mps[0], np.diag(g.vel_sigma_enu_mps**2)))
            eng.add_measurement(GnssPosition(tg, g.lat_rad[0], g.lon_rad[0], g.alt_m[0],
                                             np.diag(g.pos_sigma_enu_m**2)))
        j += 1
    return j


def replay_commands(sc: Scenario, commands) -> LoopResult:
    """The flight a recorded command stream gives: the commands
    [(t_nav_s, sigma_cmd_rad, c_l_cmd), ...] (e.g. a bag's guidance/command)
    given to a fresh ``CommandedFlight``, flown to its end; the miss at its end.
    The live flight equals it bit for bit (the apply step depends on the stamp only)."""
    cfg, flight = make_flight(sc)
    for t, s, c in commands:
        flight.command(t, s, c)
    flight.run()
    tr = flight.truth(np.array([flight.duration_s]))
    miss = miss_enu_m(cfg, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0], tr.vel_enu_mps[0])
    return LoopResult(flight, flight.duration_s, miss, list(commands), 0.0, dict(flight.refused))


def truth_epochs(sc: Scenario, n: int) -> np.ndarray:
    """The truth node's first n truth/state epochs (k / clock_rate_hz, every truth_rate), exactly."""
    base = 1.0 / sc["graph.clock_rate_hz"]
    every = max(1, int(round(sc["graph.clock_rate_hz"] / sc["graph.truth_rate_hz"])))
    return np.arange(0, n * every, every) * base


def bag_loop(bag) -> tuple[list, np.ndarray]:
    """The loop recorded in a bag: its commands [(t_nav_s, bank_rad, c_l)] (guidance/command) in stamp
    order, and the truth/state rows [lat, lon, alt, vE, vN, vU] in stamp order."""
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    cmds, truth = [], []
    for rec in read_bag(bag, topics=("/guidance/command", "/truth/state")):
        m = deserialize(rec.raw, rec.msgtype)
        if rec.topic.endswith("guidance/command"):
            cmds.append((_stamp_s(m.header.stamp), float(m.bank_rad), float(m.c_l)))
        else:
            truth.append((_stamp_s(m.header.stamp), m.lat_rad, m.lon_rad, m.alt_m, *[float(v) for v in m.vel_enu_mps]))
    truth.sort(key=lambda r: r[0])
    return sorted(cmds), np.array([r[1:] for r in truth])


def _stamp_s(stamp) -> float:
    from hyper_nav_filter.conversions import stamp_to_s
    return stamp_to_s(stamp)


def replay_equals(sc: Scenario, commands, truth_rows: np.ndarray) -> tuple[bool, LoopResult]:
    """Whether the truth rows (the truth node's samples in order) equal, bit for bit, the flight the
    commands give offline at the truth node's epochs."""
    replay = replay_commands(sc, commands)
    t = truth_epochs(sc, len(truth_rows))
    if len(t) == 0 or t[-1] > replay.flight.duration_s + 1e-9:
        return False, replay
    want = np.array([[float(s.lat_rad[0]), float(s.lon_rad[0]), float(s.alt_m[0]), *s.vel_enu_mps[0]]
                     for s in (replay.flight.truth(t[i:i + 1]) for i in range(len(t)))])
    return bool(np.array_equal(np.asarray(truth_rows, float), want)), replay
