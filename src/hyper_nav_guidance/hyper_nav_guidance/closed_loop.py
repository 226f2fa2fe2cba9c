"""The guidance loop flown offline, without ROS: the same cores as the live
graph (``CommandedFlight``/``CommandLoop`` of the truth node, ``GlideGuidance``
of the guidance node, ``FusionEngine`` of the fusion node), in one process.

``fly_on_truth(sc)`` is the live loop "guidance on ``truth/state``" step for
step: the truth evaluated at the truth node's own epochs (k / clock_rate_hz,
every truth_rate), one epoch at a time, each stamp through the message's
(sec, nanosec) round trip, so that the live flight recorded in a bag equals
it bit for bit (``test/test_guidance_graph.py``).

``fly_on_navigation(sc, ...)`` closes the loop through navigation, as the
live graph does (``test/test_guidance_graph.py``: the same commands bit for
bit): the IMU increments and the loosely coupled GNSS fixes (white noise:
not the raw-GNSS realistic world) of the commanded flight, drawn as it
advances (``hyper_nav_sim.core.flown_streams``, as the sensor nodes draw
them), through the messages' own round trips (rates and stamps of
sensor_msgs/Imu, degrees of NavSatFix), fed to the fusion engine in time order; the guidance flies on the
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
from hyper_nav_sim.core.commanded_flight import CommandedFlight, CommandLoop, flight_of_scenario
from hyper_nav_sim.core.flown_streams import FlownFixes, FlownImu, FlownRaw
from hyper_nav_sim.core.guidance_config import GuidanceConfig
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
    """(GuidanceConfig, CommandedFlight): ``commanded_flight.flight_of_scenario``."""
    return flight_of_scenario(sc)


def stamp_ns_s(t_s: float) -> tuple[int, float]:
    """The stamp a message carries for flight time ``t_s``: (integer ns, the seconds its receiver reads)."""
    sec, nsec = s_to_stamp_fields(t_s)
    return sec * 1_000_000_000 + nsec, sec + nsec * 1e-9


def stamp_round_trip(t_s: float) -> float:
    return stamp_ns_s(t_s)[1]


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


def fly_on_navigation(sc: Scenario, stream: str = "delayed", gnss_outages=(), late_inputs=None) -> LoopResult:
    """Guidance on the fusion engine's solutions (module doc). ``gnss_outages``:
    [(t0, t1), ...] windows without GNSS fixes (t1 may be inf), beside the
    scenario's ``gnss.outages_s``. ``late_inputs``: a live run's late GNSS
    inputs (``late_inputs_of(bag)``), fed where they arrived there: the
    run's current-time stream, commands and flight, bit for bit."""
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
    imu = FlownImu(sc, flight)
    commands, h = [], flight.step_s
    sources = (sc.data.get("filter") or {}).get("sources") or {}
    if any(v.get("type") not in ("imu", "gnss_fix", "gnss_vel") for v in sources.values()):
        raise ValueError(f"scenario {sc.name}: fly_on_navigation flies the loosely coupled filter (IMU and GNSS "
                         f"fixes); filter.sources declares {sorted(v.get('type') for v in sources.values())}")
    fixes = FlownRaw(sc, flight, gnss_outages) if "raw" in sc.data["gnss"] else FlownFixes(sc, flight, gnss_outages)
    run = StreamRunner(eng, [_GnssFixes(fixes, late_inputs)])
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

    while not imu.done:
        t = imu.t_s[imu.k]
        loop.advance(math.ceil(t / h - 1e-9) * h)
        if flight.flown_s < t - 1e-9:
            if flight.finished:
                break
            raise RuntimeError(f"the loop stalls at {t:.3f} s: guidance.apply_delay_s too short for its stream")
        # the IMU samples of the flown step (FlownImu: one continuous error process, cut by steps)
        t_k, dth_b, dv_b = imu.until_flown()
        w_b, f_b = dth_b / imu.dt_s, dv_b / imu.dt_s            # as the IMU node's messages carry them
        for i in range(len(t_k)):
            t = stamp_round_trip(t_k[i])                         # and their stamps
            released = run.step(t, w_b[i], f_b[i], rates=True)
            if stream == "delayed":
                act(released)
            elif eng.current is not None and abs(eng.current.t_s - t) <= 1e-9:
                act((eng.current,))              # the state at this sample (formed when it was added)
    nav_err = 0.0
    if last_nav is not None:
        from hyper_nav_gnss import earth
        tr = flight.truth(np.array([last_nav[0]]))
        d = earth.position_error_enu_m(last_nav[1], last_nav[2], last_nav[3],
                                       tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0])
        nav_err = float(np.linalg.norm(d))
    return _finish(cfg, flight, loop, commands, nav_err)


class _GnssFixes:
    """The GNSS fixes as a feed of the engine's runner (``FlownFixes``: drawn
    as the flight is flown, none in the outages), through the messages' round
    trips (stamps; latitude and longitude in degrees), in the live fusion
    node's order of arrival: each before the IMU sample at its own stamp (it
    arrived before that sample), or, when ``late`` names it (the bag's
    ``nav/late_inputs``: {(topic, stamp_ns): after_imu_ns}), right after the
    IMU sample it followed there (``replay_order.live_order``'s rule; at once
    when that sample is in already: a receiver epoch exists only once the
    flight is flown past it, ``FlownRaw``)."""

    def __init__(self, fixes: FlownFixes, late: dict | None = None):
        self.fixes, self.late = fixes, dict(late or {})
        self.held: dict[int, list] = {}             # IMU stamp (ns) -> measurements fed right after it
        self.last_imu_ns = -1                       # the newest IMU sample added (ns)

    def before(self, eng, t):
        for t_s, lat, lon, alt, vel, pos_cov, vel_cov in _fix_rows(self.fixes.until(t + 1e-9)):
            ns, tg = stamp_ns_s(t_s)
            lat, lon = (np.deg2rad(float(np.rad2deg(x))) for x in (lat, lon))
            for topic, m in (("gnss/fix", GnssPosition(tg, lat, lon, alt, pos_cov)),
                             ("gnss/vel", GnssVelocity(tg, vel, vel_cov))):
                after = self.late.get((topic, ns))
                if after is None or after <= self.last_imu_ns:   # on time, or late behind a sample already in
                    eng.add_measurement(m)
                else:
                    self.held.setdefault(after, []).append(m)

    def until(self, eng, t):
        self.last_imu_ns = stamp_ns_s(t)[0]
        for m in self.held.pop(self.last_imu_ns, ()):
            eng.add_measurement(m)


def _fix_rows(items):
    """(t_s, lat_rad, lon_rad, alt_m, vel_enu_mps, pos_cov, vel_cov) of white-noise fixes (``GnssFixes``
    of one epoch) or of the receiver's epochs that have a fix (``GnssEpoch``), as the GNSS node sends them."""
    for g in items:
        if hasattr(g, "fix"):                        # a receiver epoch: its least-squares fix, if any
            f = g.fix
            if f is not None:
                yield (float(g.t_s), float(f.lat_rad), float(f.lon_rad), float(f.alt_m),
                       np.asarray(f.vel_enu_mps, float), np.asarray(f.cov_pos_enu_m2, float),
                       np.asarray(f.cov_vel_enu_m2ps2, float))
        else:
            yield (float(g.t_s[0]), float(g.lat_rad[0]), float(g.lon_rad[0]), float(g.alt_m[0]), g.vel_enu_mps[0],
                   np.diag(g.pos_sigma_enu_m**2), np.diag(g.vel_sigma_enu_mps**2))


def late_inputs_of(bag) -> dict:
    """{(topic, stamp_ns): after_imu_ns} of the GNSS inputs a live run's fusion
    node reported late (``nav/late_inputs`` in its bag), for ``fly_on_navigation``."""
    from hyper_nav_filter.replay_order import LateInput
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    out = {}
    for rec in read_bag(bag, topics=("/nav/late_inputs",)):
        r = LateInput.from_msg(deserialize(rec.raw, rec.msgtype))
        if r.topic in ("gnss/fix", "gnss/vel") and r.occurrence == 0:
            out[(r.topic, r.stamp_ns)] = r.after_imu_ns
    return out


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
