"""Diagnostic (issue 24, seed 000): the simulator's elastic lever arm (the
world, ``hyper_nav_sim.core.lever_arm``, RK4) beside the filter's modal model
(``hyper_nav_filter.core.elastic_lever_arm``, exact ZOH per IMU interval,
driven as the filter drives it), on one excitation with the same true
natural frequencies. Prints the RMS of the modal displacement q (m), rate
q' (m/s), the lever-arm velocity increment per IMU interval (m/s) and its
running sum (the velocity effect, m/s) and double sum (position effect, m)
for:

* world            the simulator's RK4 modes (the reference),
* filter (fed)     the filter's ``LeverArmCompensator`` fed the measured
                   increments (CG + world lever arm, no sensor noise), as in flight,
* filter (cg load) the same model fed the lever-arm-free (CG) specific force
                   for its load (the world's own load), i.e. discretisation only:
                   its 50 Hz interval mean held over the interval,
* filter (8 sub)   the same with the load's means over 8 sub-intervals (the
                   400 Hz load sensor's samples, no sensor noise), each held
                   over its sub-interval (what the filter does now).

    python benchmarks/lever_arm_model_fit.py [--duration 3]
"""
from __future__ import annotations

import argparse

import numpy as np

from hyper_nav_filter.core.elastic_lever_arm import LeverArmCompensator, TABLE4_FREQ_RADPS
from hyper_nav_filter.core.blocks.lever_arm import modal_model
from hyper_nav_sim.core import lever_arm as sim_la
from hyper_nav_sim.core.imu_model import imu_epochs
from hyper_nav_sim.core.scenario import load_scenario


def doublet_scenario(duration_s: float):
    sc = load_scenario("seed000_elastic")
    sc.data["duration_s"] = duration_s
    la = sc.data["lever_arm"]
    la["natural_freq_initial_radps"] = list(TABLE4_FREQ_RADPS)
    la["natural_freq_final_radps"] = list(TABLE4_FREQ_RADPS)
    sc.data["maneuvers"] = [{"type": "climb", "t_start_s": 0.3 + 0.15 * i, "duration_s": 0.15, "delta": d}
                            for i, d in enumerate((0.03, -0.06, 0.03))]
    return sc


def compare(sc, integrator: str = "rk4") -> dict:
    traj = sc.trajectory()
    dt = 1.0 / sc["imu.rate_hz"]
    t = imu_epochs(sc["duration_s"], sc["imu.rate_hz"])
    dth, dv_cg = traj.imu_increments(t, dt)
    la = sim_la.LeverArmConfig.from_config(sc.data["lever_arm"])
    dv_meas, resp = sim_la.add_lever_arm_to_increments(dv_cg, t, dt, traj, la, return_response=True,
                                                       integrator=integrator)
    dv_world = dv_meas - dv_cg
    cfg = sc.filter_config().with_updates({"lever_arm_natural_freq_radps": tuple(la.natural_freq_radps(t[-1]))})
    model = modal_model(cfg)
    comp = LeverArmCompensator(model)
    out = {"world": (resp.q, resp.qdot, dv_world)}
    n_sub = 8
    t_sub = (t[:, None] - dt + dt / n_sub * np.arange(1, n_sub + 1)).ravel()
    f_sub = (traj.imu_increments(t_sub, dt / n_sub)[1] / (dt / n_sub)).reshape(len(t), n_sub, 3)
    for label, load_f in (("filter (fed)", dv_meas / dt), ("filter (cg load)", dv_cg / dt), ("filter (8 sub)", f_sub)):
        lev = np.concatenate([resp.q0, resp.qdot0])
        w_prev = None
        q, qd, dvl = np.empty((len(t), 3)), np.empty((len(t), 3)), np.empty((len(t), 3))
        for k in range(len(t)):
            m = comp.model
            lev1, q_int = m.step(lev, m.modal_input(load_f[k]), dt)
            _, _, w_mid, w_dot = comp.compensate(lev, dth[k], dv_meas[k], dt, w_prev)
            from hyper_nav_filter.core.elastic_lever_arm import lever_arm_dvel
            dvl[k] = lever_arm_dvel(m.Y, m.r0_b_m, lev[:3], lev[3:], lev1[:3], lev1[3:], q_int,
                                    w_mid - 0.5 * dt * w_dot, w_mid, w_mid + 0.5 * dt * w_dot, dt)
            lev, w_prev = lev1, w_mid
            q[k], qd[k] = lev[:3], lev[3:]
        out[label] = (q, qd, dvl)
    return out


def report(out: dict, dt: float) -> None:
    q_w, qd_w, dv_w = out["world"]
    rms = lambda a: float(np.sqrt(np.mean(np.square(a))))  # noqa: E731
    print(f"{'':18s} {'q rms (m)':>30s} {'dv/interval rms':>16s} {'vel effect rms':>15s} {'pos effect rms':>15s}")
    for label, (q, qd, dv) in out.items():
        vel = np.cumsum(dv, axis=0)
        pos = np.cumsum(vel, axis=0) * dt
        print(f"{label:18s} {' '.join(f'{rms(q[:, i]):9.3e}' for i in range(3))} {rms(dv):16.3e} "
              f"{rms(vel):15.3e} {rms(pos):15.3e}")
        if label != "world":
            dvel = np.cumsum(dv - dv_w, axis=0)
            dpos = np.cumsum(dvel, axis=0) * dt
            print(f"{'  minus world':18s} {' '.join(f'{rms(q[:, i] - q_w[:, i]):9.3e}' for i in range(3))} "
                  f"{rms(dv - dv_w):16.3e} {rms(dvel):15.3e} {rms(dpos):15.3e}   "
                  f"(dv rel {rms(dv - dv_w) / rms(dv_w):.3g})")
            print(f"{'  rel err per mode':18s} "
                  + " ".join(f"{rms(q[:, i] - q_w[:, i]) / rms(q_w[:, i]):9.3g}" for i in range(3)) + "   q' "
                  + " ".join(f"{rms(qd[:, i] - qd_w[:, i]) / rms(qd_w[:, i]):9.3g}" for i in range(3)))


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=3.0)
    ap.add_argument("--integrator", default="rk4")
    a = ap.parse_args()
    sc = doublet_scenario(a.duration)
    report(compare(sc, a.integrator), 1.0 / sc["imu.rate_hz"])
