"""The lever-arm node over DDS (one process, real rclpy): fed a short seed
000 elastic flight (IMU, GNSS, fused nav/state from the core), it fires,
runs a re-estimation that times out, publishes no model update, keeps its
model and says so on /diagnostics (WARN); a NaN nav/state is counted."""
import os
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TwistWithCovarianceStamped
from hyper_nav_msgs.msg import ModelUpdate
from hyper_nav_msgs.msg import NavState as NavStateMsg
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu, NavSatFix

from hyper_nav_aiding.lever_arm.node import LeverArmLearningNode
from hyper_nav_aiding.lever_arm.sim_windows import SimulatedFlight
from hyper_nav_filter.conversions import s_to_stamp_fields
from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_filter.output import OutputFrames, navstate_fields
from hyper_nav_filter.ros_util import assign_fields, publisher_qos
from hyper_nav_sim.core.scenario import load_scenario


def _stamp(m, t):
    m.header.stamp.sec, m.header.stamp.nanosec = s_to_stamp_fields(t)
    return m


def flight_messages(duration_s=4.0):
    """(t, topic, message) of a short flight in time order, nav/state 1 s behind."""
    sc = load_scenario("seed000_elastic")
    sc.data["duration_s"] = duration_s
    cfg = sc.filter_config()
    fl = SimulatedFlight.from_scenario(sc)
    eng = FusionEngine(cfg, sc.filter_initial_state())
    frames = OutputFrames("map", "enu", "base_link", 0.0, 0.0, 0.0)
    out, j, dt = [], 0, fl.imu.dt_s
    for k, t in enumerate(fl.imu.t_s):
        m = _stamp(Imu(), t)
        w, a = fl.imu.dtheta_b_rad[k] / dt, fl.imu.dvel_b_mps[k] / dt
        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = map(float, w)
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = map(float, a)
        out.append((t, "imu", m))
        eng.add_imu(t, fl.imu.dtheta_b_rad[k], fl.imu.dvel_b_mps[k])
        while j < len(fl.gnss) and fl.gnss[j].t_s <= t + 1e-9:
            g = fl.gnss[j]
            j += 1
            eng.add_measurement(g)
            if g.kind == "gnss_pos":
                f = _stamp(NavSatFix(), g.t_s)
                f.latitude, f.longitude, f.altitude = float(np.rad2deg(g.lat_rad)), float(np.rad2deg(g.lon_rad)), \
                    float(g.alt_m)
                f.position_covariance = g.cov_enu_m2.ravel().tolist()
                out.append((t, "fix", f))
            else:
                v = _stamp(TwistWithCovarianceStamped(), g.t_s)
                v.twist.twist.linear.x, v.twist.twist.linear.y, v.twist.twist.linear.z = map(float, g.vel_enu_mps)
                cov = np.eye(6) * 1e6
                cov[:3, :3] = g.cov_enu_m2ps2
                v.twist.covariance = cov.ravel().tolist()
                out.append((t, "vel", v))
        for sol in eng.release():
            s = NavStateMsg()
            assign_fields(s, navstate_fields(sol, cfg.layout, frames))
            out.append((t, "state", s))
    return sc, cfg, out


def test_a_timed_out_reestimation_keeps_the_model_and_says_so():
    sc, cfg, msgs = flight_messages()
    params = [Parameter(f"filter.{k}", value=v) for k, v in cfg.as_dict().items()]
    params += [Parameter(k, value=v) for k, v in {
        "trigger.threshold_m": 0.3, "trigger.release_m": 0.1, "trigger.averaging_s": 0.3, "window_s": 1.0,
        "state_period_s": 0.5, "method": "cmaes", "budget_passes": 100000, "timeout_s": 0.5,
        "worker_grace_s": 1.0, "diagnostics_period_s": 0.2}.items()]
    ctx = rclpy.context.Context()
    # this pytest process's own domain (conftest.py): a fixed one was once shared with a graph-lane worker
    # (its own subscriber made the count 2)
    rclpy.init(context=ctx, domain_id=int(os.environ["ROS_DOMAIN_ID"]))
    node = None
    try:
        node = LeverArmLearningNode(context=ctx, parameter_overrides=params)
        feeder = rclpy.create_node("feeder", context=ctx)
        qos = publisher_qos(2000)
        pubs = {"imu": feeder.create_publisher(Imu, "imu/data_raw", qos),
                "fix": feeder.create_publisher(NavSatFix, "gnss/fix", qos),
                "vel": feeder.create_publisher(TwistWithCovarianceStamped, "gnss/vel", qos),
                "state": feeder.create_publisher(NavStateMsg, "nav/delayed/state", qos)}
        got = {"diag": [], "update": []}
        feeder.create_subscription(DiagnosticArray, "/diagnostics", lambda m: got["diag"].append(m), 100)
        feeder.create_subscription(ModelUpdate, "nav/model_update", lambda m: got["update"].append(m), 10)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)
        ex.add_node(feeder)
        # the node subscribes once its worker process runs (a loaded machine: up to a minute or more);
        # these bounds only guard against a hang
        t_end = time.monotonic() + 300.0
        while any(p.get_subscription_count() < 1 for p in pubs.values()) and time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
        assert all(p.get_subscription_count() == 1 for p in pubs.values())
        bad = NavStateMsg()
        assign_fields(bad, {"lat_rad": float("nan")})
        pubs["state"].publish(bad)
        for _, topic, m in msgs:
            pubs[topic].publish(m)
            ex.spin_once(timeout_sec=0.0)

        def last():
            st = [s for a in got["diag"] for s in a.status if s.name == "hyper_nav_aiding: lever_arm_learning"]
            return (st[-1], {kv.key: kv.value for kv in st[-1].values}) if st else (None, {})
        t_end = time.monotonic() + 300.0
        while time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
            st, v = last()
            if v.get("jobs_rejected") == "1" or v.get("jobs_timed_out") == "1":
                break
        n_imu = len([m for m in msgs if m[1] == "imu"])
        t_end = time.monotonic() + 300.0          # let the node take the rest of the stream
        while last()[1].get("imu") != str(n_imu) and time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
        st, v = last()
        print("\n", st.message if st else None, {k: v[k] for k in v if k.startswith(("jobs", "rejected", "model"))})
        assert int(v["jobs_started"]) == 1 and int(v["jobs_accepted"]) == 0
        assert "timed out" in st.message and "filter stays on [20.8453, 50.0123, 98.7743]" in st.message
        assert st.level == DiagnosticStatus.WARN
        assert v["model_freqs_radps"] == "20.8453, 50.0123, 98.7743" and not got["update"]
        assert int(v["rejected_nav_state_nan"]) == 1
        assert int(v["imu"]) == n_imu
    finally:
        if node is not None:
            node.worker.close()
        ctx.try_shutdown()
