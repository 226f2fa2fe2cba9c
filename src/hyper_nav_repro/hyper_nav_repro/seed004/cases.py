"""Seed 004 (Gao et al. 2023) section 3, Tables 4-5: the four cases flown
offline through the fusion core (no ROS), the way the node graph feeds it:
messages through the scenario's declared sources, the receiver's raw epochs
and ephemerides through the ``gnss_raw`` source, and in case (b) the
virtual GNSS core's epochs through the ``gnss_virtual`` source with its own
noise.

Cases (issue #8), scenario ``seed004_virtual`` (lock lost on every
satellite from 30 s, never regained):

* ``a`` no lock loss: the same flight and receiver without the loss;
* ``b`` lock loss with virtual compensation: the lost satellites' virtual
  pseudoranges and rates (:class:`~hyper_nav_aiding.virtual_gnss.core.virtual_gnss.VirtualGnss`);
* ``c`` lock loss without compensation as the paper defines it: the receiver
  does not notice its loss and corrupted observations reach the filter
  (:class:`hyper_nav_sim.core.gnss.undetected_lock_loss.UndetectedLockLoss`);
* ``d`` lock loss, the filter coasting on the INS alone (the unlocked
  channels are dropped, as the filter's input does).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.core.nav_state import ImuSample
from hyper_nav_filter.sources.router import SourceRouter
from hyper_nav_workbench.core import scoring
from hyper_nav_sim.core.gnss.undetected_lock_loss import UndetectedLockLoss
from hyper_nav_sim.gnss_messages import fill_gnss_ephemeris

from hyper_nav_aiding.virtual_gnss.conversions import fill_gnss_measurements
from hyper_nav_aiding.virtual_gnss.core.virtual_gnss import VirtualGnss
from hyper_nav_aiding.virtual_gnss.offline import Flight
from hyper_nav_aiding.virtual_gnss.parameters import VirtualGnssNodeParams, from_scenario

CASES = ("a", "b", "c", "d")
CASE_NAMES = {"a": "no lock loss", "b": "lock loss, virtual compensation",
              "c": "lock loss, no compensation (corrupted observations)", "d": "lock loss, INS coasting"}


@dataclass
class CaseResult:
    case: str
    t_s: np.ndarray
    pos_err_enu_m: np.ndarray
    vel_err_enu_mps: np.ndarray
    nees_pos: np.ndarray              # position NEES (3 dof) of the released solutions
    pos_sigma_m: np.ndarray           # sqrt(trace P_pos)
    stats: dict                       # filter gate statistics per measurement kind
    counters: dict                    # virtual GNSS counters (case b)
    wall_s: float


def imu_message(t_s: float, dt_s: float, dtheta_b_rad, dvel_b_mps):
    """sensor_msgs/Imu as the imu node publishes it (mean rates over the interval)."""
    from sensor_msgs.msg import Imu
    m = Imu()
    m.header.stamp.sec, m.header.stamp.nanosec = s_to_stamp_fields(t_s)
    w, a = np.asarray(dtheta_b_rad) / dt_s, np.asarray(dvel_b_mps) / dt_s
    m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = map(float, w)
    m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = map(float, a)
    m.orientation_covariance[0] = -1.0
    return m


def run_case(fl: Flight, case: str, virtual: dict | None = None, rng_seed: int = 0, gate: bool = True) -> CaseResult:
    """Fly one case over a prepared flight; ``virtual`` overrides fields of
    the scenario's ``virtual_gnss`` block (case b). ``gate=False`` flies the
    paper's filter, which has no innovation gate: without it the corrupted
    observations of case (c) reach the filter (with our chi-square gate they
    are all rejected and (c) is (d)).

    The fusion core takes the messages through the scenario's declared
    sources (``hyper_nav_filter.sources.SourceRouter``, the fusion node's
    code): ``imu/data_raw``, ``gnss/raw`` + ``gnss/ephemeris`` (source
    ``gnss_raw``, tracked channels) and, in case (b), ``gnss/virtual`` (source
    ``gnss_virtual``, virtual channels, its own noise), in the order the node
    receives them; the virtual GNSS core takes what its node takes."""
    from hyper_nav_msgs.msg import GnssEphemeris, GnssMeasurements
    if case not in CASES:
        raise ValueError(f"case must be one of {CASES}, got {case!r}")
    sc = fl.sc
    epochs = fl.epochs_no_loss if case == "a" else fl.epochs_loss
    cfg = sc.filter_config()
    table = {k: v for k, v in sc.filter_sources().items() if case == "b" or v.get("channels") != "virtual"}
    eng = FusionEngine(cfg, sc.filter_initial_state())
    if not gate:
        eng.kf.gate_threshold = lambda dof: np.inf      # the paper's filter (eqs. 1-7) gates nothing
    router = SourceRouter(eng, table)
    vg = corrupt = None
    if case == "b":
        params = VirtualGnssNodeParams.from_values({**from_scenario(sc), **{f"virtual_gnss.{k}": v for k, v in
                                                                               (virtual or {}).items()}})
        vg = VirtualGnss(params.config, params.corrections, params.lever_arm_b_m, params.rate_hz,
                         np.random.default_rng([sc["seed"], 8, rng_seed]))
        vtopic = params.config.topic
    if case == "c":
        corrupt = UndetectedLockLoss(np.random.default_rng([sc["seed"], 6, rng_seed]))
    imu = fl.imu
    sols, j, eph_set = [], 0, None
    t0 = time.perf_counter()
    for k in range(len(imu.t_s)):
        new = router.handle_topic("imu/data_raw", imu_message(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k],
                                                              imu.dvel_b_mps[k]))[1]
        if vg is not None:
            vg.add_imu(ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k]))
            for s in new:                                # nav/state -> the virtual node
                vg.add_state(s.state, _pos_sigma(s, cfg))
        sols += new
        while j < len(epochs) and epochs[j].t_s <= imu.t_s[k] + 1e-9:
            e = epochs[j]
            j += 1
            if e.ephemeris_set is not eph_set:           # gnss/ephemeris: a new set is broadcast
                eph_set = e.ephemeris_set
                for eph in eph_set:
                    router.handle_topic("gnss/ephemeris", fill_gnss_ephemeris(GnssEphemeris(), eph, e.t_s))
                    if vg is not None:
                        vg.add_ephemeris(eph)
            raw = e.raw() if corrupt is None else corrupt.epoch(e.raw())
            router.handle_topic("gnss/raw", fill_gnss_measurements(GnssMeasurements(), raw, e.elevation_rad,
                                                                   e.azimuth_rad, "gnss_antenna", virtual=False))
            if vg is not None:
                if e.fix is not None:
                    vg.add_fix(e.t_s, e.fix.r_e_m, e.fix.v_e_mps)
                vg.add_raw(raw)
        if vg is not None:
            for v in vg.ready():                        # gnss/virtual -> the fusion's virtual source
                el, az = vg.geometry.pop(v.t_s)
                router.handle_topic(vtopic, fill_gnss_measurements(GnssMeasurements(), v, el, az, "gnss_antenna"))
    sols += eng.release(final=True)
    wall = time.perf_counter() - t0
    e = scoring.solution_errors(sols, fl.traj)
    t, pos, vel = e["t"], e["pos_enu_m"], e["vel_enu_mps"]
    psl = cfg.layout.sl("pos")
    nees = np.array([p @ np.linalg.solve(s.P[psl, psl], p) for p, s in zip(pos, sols)])
    sig = np.array([np.sqrt(np.trace(s.P[psl, psl])) for s in sols])
    return CaseResult(case, t, pos, vel, nees, sig, {k: list(v) for k, v in eng.kf.stats.items()},
                      dict(vg.counters) if vg is not None else {}, wall)


def _pos_sigma(sol, cfg) -> float:
    psl = cfg.layout.sl("pos")
    return float(np.sqrt(np.trace(sol.P[psl, psl]) / 3.0))


def statistics(res: CaseResult, t_from_s: float = 0.0) -> dict:
    """Seed 004 Tables 4-5 statistics (mean, standard deviation, maximum) of
    the horizontal and vertical position [m] and velocity [m/s] error norms
    over the solutions with t >= t_from_s, and the mean position NEES."""
    m = res.t_s >= t_from_s - 1e-9
    p, v = res.pos_err_enu_m[m], res.vel_err_enu_mps[m]
    out = {}
    for name, x in (("pos_h_m", np.hypot(p[:, 0], p[:, 1])), ("pos_v_m", np.abs(p[:, 2])),
                    ("vel_h_mps", np.hypot(v[:, 0], v[:, 1])), ("vel_v_mps", np.abs(v[:, 2]))):
        out[name] = {"mean": float(x.mean()), "std": float(x.std()), "max": float(x.max())}
    out["nees_pos_mean"] = float(res.nees_pos[m].mean())
    out["pos_sigma_mean_m"] = float(res.pos_sigma_m[m].mean())
    return out

