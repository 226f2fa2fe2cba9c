"""Offline simulation of every sensor stream of a scenario (no ROS).

The sensor nodes call the same functions for their own stream, so a live
graph and this offline run produce the same data for the same scenario.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .gnss_model import GnssFixes, drop_outages, parse_outages, simulate_fixes
from .imu_model import ImuErrors, corrupt_increments, imu_epochs
from .baro_model import BaroErrors, simulate_baro_pa
from .lever_arm import LeverArmConfig, add_lever_arm_to_increments
from .mag_model import MagnetometerErrors, simulate_magnetometer_T
from .radar import EarlyWarningRadar
from .scenario import Scenario

from hyper_nav_filter.core.measurements import GnssPosition, GnssVelocity


@dataclass
class ImuStream:
    t_s: np.ndarray
    dt_s: float
    dtheta_b_rad: np.ndarray
    dvel_b_mps: np.ndarray
    # with the elastic lever arm on: the lever-arm-free specific force at the CG as the load
    # sensor measures it (``_measured_load``), (N, n_sub, 3): the means over the n_sub equal
    # sub-intervals of each IMU interval (body FLU, m/s^2), whose body-z part loads the structure
    # (F_n = m f_b,z, ``lever_arm.normal_force_from_trajectory``): the known input u_q of seed 000 eq. 22
    load_f_b_mps2: np.ndarray | None = None


def imu_stream(sc: Scenario, traj, error_free: bool = False) -> ImuStream:
    """IMU increments; with ``lever_arm.enabled`` the elastic lever-arm
    acceleration (seed 000 eq. 1) is added to the accelerometers before the
    sensor errors, integrated as ``world.lever_arm`` says (the simulator's
    own Runge-Kutta in the realistic world, the filter's discretisation in
    the perfect-model one), and the structure's load (the CG specific force,
    as measured: ``_measured_load``) is returned beside them
    (``ImuStream.load_f_b_mps2``)."""
    dt = 1.0 / sc["imu.rate_hz"]
    t = imu_epochs(sc["duration_s"], sc["imu.rate_hz"])
    dth, dv = traj.imu_increments(t, dt)
    if error_free:
        return ImuStream(t, dt, dth, dv)
    load = None
    if "lever_arm" in sc.data:
        cfg = LeverArmConfig.from_config(sc.data["lever_arm"])
        if cfg.enabled:
            world = sc.world_config()
            load = _measured_load(traj, t, dt, cfg.load_sensor_rate_hz, sc)
            dv = add_lever_arm_to_increments(dv, t, dt, traj, cfg, rng=sc.rng("lever_arm"),
                                             integrator=world.lever_arm_integrator, step_s=world.lever_arm_step_s)
    dth, dv = corrupt_increments(dth, dv, dt, ImuErrors.from_scenario(sc), sc.rng("imu"))
    return ImuStream(t, dt, dth, dv, load)


def _measured_load(traj, t_end_s, dt_s: float, rate_hz: float, sc: Scenario) -> np.ndarray:
    """The structure's load as the filter may know it: the lever-arm-free
    specific force (seed 000 eqs. 4-6, the known input of eq. 22) measured
    by a second accelerometer triad at the structure's rigid root, of the
    navigation IMU's grade (the scenario's ``imu`` accelerometer errors:
    bias, noise, scale factor, misalignment, Markov) with its own noise
    draw (stream ``structure_load``), sampled at ``lever_arm.load_sensor_rate_hz``
    (an integer multiple n of the IMU rate): returns (N, n, 3), the mean
    specific force over each of the n equal sub-intervals of every IMU
    interval (t - dt, t]. The higher modes need the sub-interval samples:
    a 50 Hz interval mean held over the interval is a staircase whose steps
    ring mode 3 (w dt = 2.3) as the world's continuous load does not
    (``benchmarks/lever_arm_model_fit.py``). The filter never gets the exact
    force: handing it the truth would make the world the filter's model."""
    n = int(round(rate_hz * dt_s))
    if n < 1 or abs(n - rate_hz * dt_s) > 1e-6:
        raise ValueError(f"lever_arm.load_sensor_rate_hz: must be a whole multiple of imu.rate_hz "
                         f"({1.0 / dt_s:g} Hz), got {rate_hz:g}")
    h = dt_s / n
    t_sub = (np.asarray(t_end_s, float)[:, None] - dt_s + h * np.arange(1, n + 1)).ravel()
    dth_sub, dv_sub = traj.imu_increments(t_sub, h)
    _, dv_meas = corrupt_increments(dth_sub, dv_sub, h, ImuErrors.from_scenario(sc), sc.rng("structure_load"))
    return (dv_meas / h).reshape(len(t_end_s), n, 3)


def gnss_receiver(sc: Scenario):
    """The receiver simulation configured by ``gnss.raw`` in the scenario's
    world (``world:`` block, :mod:`.gnss.world`)."""
    from .gnss.receiver import GnssReceiverConfig, GnssReceiverSim
    from .gnss.world import GnssWorld
    cfg = dict(sc.data["gnss"]["raw"])
    cfg["rate_hz"] = sc["gnss.rate_hz"]
    cfg.setdefault("antenna_lever_arm_b_m", sc["gnss.antenna_lever_arm_b_m"])
    rx = GnssReceiverSim(GnssReceiverConfig.from_dict(cfg))
    world = sc.world_config()
    if world.realistic:
        rx.world = GnssWorld.realistic(rx.broadcast_ionosphere(), rx.cfg.troposphere == "hopfield", world,
                                       sc.world_seed())
    return rx


def gnss_raw_stream(sc: Scenario, traj):
    """Raw GNSS epochs (pseudoranges, Doppler, lock flags, ephemerides, LS
    fix) from :func:`gnss_receiver` at ``gnss.rate_hz``: a list of
    ``core.gnss.receiver.GnssEpoch``."""
    t = imu_epochs(sc["duration_s"], sc["gnss.rate_hz"])
    return gnss_receiver(sc).simulate(traj, t, sc.rng("gnss_raw"))


def gnss_stream(sc: Scenario, traj) -> GnssFixes:
    """Loosely coupled fixes; none inside the ``gnss.outages_s`` windows (a blackout)."""
    t = imu_epochs(sc["duration_s"], sc["gnss.rate_hz"])
    fixes = simulate_fixes(traj, t, sc["gnss.pos_sigma_enu_m"], sc["gnss.vel_sigma_enu_mps"],
                           sc["gnss.antenna_lever_arm_b_m"], sc.rng("gnss"))
    return drop_outages(fixes, parse_outages(sc.data["gnss"].get("outages_s")))


def mag_stream(sc: Scenario, traj):
    t = imu_epochs(sc["duration_s"], sc["magnetometer.rate_hz"])
    return t, simulate_magnetometer_T(traj, t, sc["magnetometer.epoch_decimal_year"],
                                      sc["magnetometer.noise_nT"], sc.rng("mag"),
                                      errors=MagnetometerErrors.from_config(sc.data["magnetometer"]))


def baro_stream(sc: Scenario, traj):
    """(t_s, static pressure Pa, true altitude m) from the ``barometer:`` block."""
    cfg = sc.data["barometer"]
    t = imu_epochs(sc["duration_s"], float(cfg.get("rate_hz", 10.0)))
    alt = traj.truth(t).alt_m
    return t, simulate_baro_pa(alt, BaroErrors.from_config(cfg, prefix="barometer"), sc.rng("baro")), alt


def radar_stream(sc: Scenario, traj):
    """Early-warning radar track (seed 002 section 3.2) from the ``radar:`` block."""
    cfg = dict(sc.data["radar"])
    radar = EarlyWarningRadar(**cfg)
    t = imu_epochs(sc["duration_s"], radar.rate_hz)
    return radar.measure(traj, t, sc.rng("radar"))


def gnss_measurements(sc, traj, delay_s: float = 0.0, sort: bool = True) -> list:
    """GNSS velocity and position fixes of the scenario as core measurements."""
    g = gnss_stream(sc, traj)
    meas = []
    for i in range(len(g.t_s)):
        meas.append(GnssVelocity(g.t_s[i], g.vel_enu_mps[i], np.diag(g.vel_sigma_enu_mps**2)))
        meas.append(GnssPosition(g.t_s[i], g.lat_rad[i], g.lon_rad[i], g.alt_m[i], np.diag(g.pos_sigma_enu_m**2)))
    if sort:
        meas.sort(key=lambda m: (m.t_s, m.kind))
    return meas
