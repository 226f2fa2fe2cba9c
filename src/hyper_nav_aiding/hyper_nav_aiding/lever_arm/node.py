"""Lever-arm learning node (RL-DLAC, seed 000 section III, Fig. 5).

Subscribes ``nav/delayed/state`` (hyper_nav_msgs/NavState, the fused solution as released),
``gnss/fix`` (NavSatFix), ``gnss/vel`` (TwistWithCovarianceStamped, ENU) and
``imu/data_raw`` (sensor_msgs/Imu); keeps the latest window of them
(``core.lever_arm.window.WindowBuffer``); feeds the position residual
nav - GNSS at each fix epoch to the trigger (``core.lever_arm.trigger``). When
it fires, the window is re-estimated in a worker process
(``core.lever_arm.worker``; the callbacks never wait for it). An accepted
estimate is published on ``nav/model_update`` (hyper_nav_msgs/ModelUpdate,
model "lever_arm") stamped at the trigger epoch plus ``update_delay_s`` (or,
for a job that ends later, at the newest IMU epoch seen plus
``update_lead_s``); a rejected, failed or timed-out one publishes nothing (the
filter keeps its model) and says so on ``/diagnostics``. Parameters: the
``lever_arm_learning`` block of the scenario (``core.lever_arm.config``) and
the filter configuration (``filter.*``, as the fusion node's).
"""
from __future__ import annotations

import time
import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TwistWithCovarianceStamped
from hyper_nav_msgs.msg import ModelUpdate
from hyper_nav_msgs.msg import NavState as NavStateMsg
from rclpy.node import Node
from sensor_msgs.msg import Imu, NavSatFix

from hyper_nav_filter import conversions
from hyper_nav_filter.core.config import ALL_PARAMS, FilterConfig
from hyper_nav_filter.clock_gate import ClockAllowance
from hyper_nav_filter.ros_util import assign_fields, declare_params, diagnostic_array, publisher_qos, run_node

from hyper_nav_aiding.lever_arm import conversions as lac
from hyper_nav_aiding.lever_arm.core.config import PARAMS, LeverArmLearningConfig
from hyper_nav_aiding.lever_arm.core.monitor import ReestimationMonitor
from hyper_nav_aiding.lever_arm.core.worker import ReestimationWorker
from hyper_nav_filter.core.imu_load import ImuLoadPairing


class LeverArmLearningNode(Node):
    def __init__(self, **node_kwargs):
        """``node_kwargs``: rclpy Node options (tests pass a context and parameter overrides)."""
        super().__init__("lever_arm_learning", **node_kwargs)
        self.filter_cfg = FilterConfig(**declare_params(self, ALL_PARAMS, "filter.", "filter."))
        self.p = LeverArmLearningConfig.from_flat(declare_params(self, PARAMS), "")
        self.freqs_radps = np.asarray(self.filter_cfg.lever_arm_natural_freq_radps, float)
        self.monitor = ReestimationMonitor(self.p)
        # the DDPG worker imports jax and compiles the networks once, at start
        self.worker = ReestimationWorker(warm_up=self.p.reestimation.method == "ddpg", grace_s=self.p.worker_grace_s,
                                         nice=self.p.worker_nice)
        self._closing = False
        qos = publisher_qos(self.p.qos_depth)
        self.pub_update = self.create_publisher(ModelUpdate, "nav/model_update", publisher_qos(10))
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", publisher_qos(100))
        self._qos, self._subs = qos, []
        # while a job runs, the clock (when the time source waits for this node) stays update_lead_s short of
        # its update's epoch, trigger + update_delay_s: the update is stamped there whatever the job's wall
        # time, and reaches the filter before that epoch is released
        self.allowance = ClockAllowance(self, source=lambda: float("inf") if self._job is None else
                                        self._job["t_trigger"] + self.p.update_delay_s - self.p.update_lead_s)
        # inputs only once the worker process runs (spawned, numeric stack imported, networks compiled):
        # the sensors wait for this node's subscriptions, so the flight starts when it can re-estimate
        self._wait_timer = self.create_timer(0.1, self._start_when_ready)
        self.create_timer(0.1, self._timed(self._poll_worker))
        self.create_timer(self.p.diagnostics_period_s, self._publish_diagnostics)
        self.counts = {k: 0 for k in ("imu", "gnss_fix", "gnss_vel", "nav_state", "rejected_imu_nan",
                                      "rejected_imu_out_of_order", "rejected_gnss_nan", "rejected_nav_state_nan",
                                      "rejected_nav_state_layout", "jobs_started", "jobs_accepted", "jobs_rejected",
                                      "jobs_failed", "jobs_timed_out", "model_updates_published")}
        self._imu_t = None
        # the structure's load (``load_topic``): IMU samples wait for their interval's load samples
        self._pairing = ImuLoadPairing() if self.p.load_topic else None
        self._last_trigger_t = float("nan")
        self._job = None                 # {"t_trigger", "window_t0", "window_t1"}
        self._last = "none yet"
        self._last_ok = True
        # callback wall time (s): {"idle": [n, sum, max], "busy": [...]} (busy = a job is running)
        self.cb_time = {"idle": [0, 0.0, 0.0], "busy": [0, 0.0, 0.0]}

    def _start_when_ready(self):
        if not self.worker.ready:
            self.worker.poll()                       # takes the worker's "ready" (no job runs yet)
            return
        self._wait_timer.cancel()
        qos = self._qos
        self._subs = [self.create_subscription(Imu, "imu/data_raw", self._timed(self._on_imu), qos),
                      self.create_subscription(NavSatFix, "gnss/fix", self._timed(self._on_fix), qos),
                      self.create_subscription(TwistWithCovarianceStamped, "gnss/vel", self._timed(self._on_vel), qos),
                      self.create_subscription(NavStateMsg, "nav/delayed/state", self._timed(self._on_state), qos)]
        if self._pairing is not None:
            self._subs.append(self.create_subscription(Imu, self.p.load_topic, self._timed(self._on_load), qos))
        self.get_logger().info("worker ready; subscribed to imu/data_raw, gnss/fix, gnss/vel, nav/delayed/state"
                               + (f", {self.p.load_topic}" if self._pairing is not None else ""))

    # ---- callbacks -------------------------------------------------------------------
    def _timed(self, fn):
        def wrapped(*args):
            t0 = time.perf_counter()
            try:
                return fn(*args)
            finally:
                dt = time.perf_counter() - t0
                st = self.cb_time["busy" if self.worker.busy else "idle"]
                st[0] += 1
                st[1] += dt
                st[2] = max(st[2], dt)
        return wrapped

    def _on_imu(self, msg):
        t, w, f = conversions.imu_rates(msg)
        if not (np.isfinite(t) and np.all(np.isfinite(w)) and np.all(np.isfinite(f))):
            self.counts["rejected_imu_nan"] += 1
            return
        if self._imu_t is not None and t <= self._imu_t:
            self.counts["rejected_imu_out_of_order"] += 1
            return
        self.counts["imu"] += 1
        if self._pairing is None:
            self._take_imu(t, w, f, None)
            return
        self._pairing.add_imu(t, w, f)
        self._release_paired()

    def _on_load(self, msg):
        t, _, f = conversions.imu_rates(msg)
        if np.isfinite(t) and np.all(np.isfinite(f)):
            self._pairing.add_load(t, f)
            self._release_paired()

    def _release_paired(self):
        for t, w, f, load in self._pairing.ready(lambda: -np.inf if self._imu_t is None else self._imu_t):
            self._take_imu(t, w, f, load)

    def _take_imu(self, t, w, f, load):
        window = None
        if self._imu_t is not None:
            dt = t - self._imu_t
            window = self.monitor.add_imu(t, w * dt, f * dt, busy=self.worker.busy, load_f_b_mps2=load)
        self._imu_t = t
        self._submit(window)

    def _on_fix(self, msg):
        m = conversions.gnss_position(msg)
        if not (np.isfinite([m.t_s, m.lat_rad, m.lon_rad, m.alt_m]).all() and np.all(np.isfinite(m.cov_enu_m2))):
            self.counts["rejected_gnss_nan"] += 1
            return
        self.counts["gnss_fix"] += 1
        self._submit(self.monitor.add_gnss(m, busy=self.worker.busy))

    def _on_vel(self, msg):
        m = conversions.gnss_velocity(msg)
        if not (np.isfinite(m.t_s) and np.all(np.isfinite(m.vel_enu_mps)) and np.all(np.isfinite(m.cov_enu_m2ps2))):
            self.counts["rejected_gnss_nan"] += 1
            return
        self.counts["gnss_vel"] += 1
        self._submit(self.monitor.add_gnss(m, busy=self.worker.busy))

    def _on_state(self, msg):
        try:
            state, P = lac.navstate(msg, self.filter_cfg.layout)
        except ValueError as exc:
            self.counts[f"rejected_nav_state_{'layout' if str(exc) in ('layout', 'covariance') else 'nan'}"] += 1
            return
        self.counts["nav_state"] += 1
        self._submit(self.monitor.add_state(state, P, busy=self.worker.busy))

    def _submit(self, window):
        """Start a re-estimation of the window the trigger cut (None: nothing to do)."""
        if window is None:
            return
        t_trigger = window.t_end_s
        self.worker.submit((window, self.filter_cfg, self.freqs_radps.copy(), self.p.reestimation),
                           self.p.reestimation.timeout_s)
        self._job = {"t_trigger": t_trigger, "window": (window.t0_s, window.t_end_s)}
        self._last_trigger_t = t_trigger
        self.counts["jobs_started"] += 1
        self.get_logger().info(f"re-estimation started at t={t_trigger:.2f} s on the window "
                               f"[{window.t0_s:.2f}, {window.t_end_s:.2f}] s ({self.p.reestimation.method})")

    def _poll_worker(self):
        if self._closing:
            return
        out = self.worker.poll()
        if out is None:
            return
        job, self._job = self._job, None
        keep = f"filter stays on {np.round(self.freqs_radps, 4).tolist()} rad/s"
        if out.status == "timeout":
            self.counts["jobs_timed_out"] += 1
            self._last, self._last_ok = f"timed out after {out.wall_s:.1f} s; {keep}", False
        elif out.status == "error":
            self.counts["jobs_failed"] += 1
            self._last, self._last_ok = f"failed: {str(out.value).strip().splitlines()[-1]}; {keep}", False
        elif not out.value.accepted:
            self.counts["jobs_rejected"] += 1
            self._last, self._last_ok = f"rejected ({out.value.reason}); {keep}", out.value.reason.startswith("no ")
        else:
            r = out.value
            # deterministic (trigger + update_delay_s) unless the job ended after it in sim time
            t_apply = max(job["t_trigger"] + self.p.update_delay_s,
                          (self._imu_t if self._imu_t is not None else job["t_trigger"]) + self.p.update_lead_s)
            m = ModelUpdate()
            assign_fields(m, lac.model_update_fields(t_apply, r.freqs_radps, r.sigma_radps, self.get_name(), r.note()))
            self.pub_update.publish(m)
            self.counts["jobs_accepted"] += 1
            self.counts["model_updates_published"] += 1
            self.freqs_radps = np.asarray(r.freqs_radps, float)
            self._last, self._last_ok = (f"published {np.round(r.freqs_radps, 4).tolist()} rad/s from "
                                         f"t={t_apply:.2f} s ({r.note()})"), True
        self.get_logger().info(f"re-estimation (window {job['window'] if job else '?'}): {self._last}")
        self._publish_diagnostics()

    # ---- diagnostics -------------------------------------------------------------------
    def on_shutdown(self):
        """Final /diagnostics (a job still running is abandoned: the model stays), then stop the worker."""
        if self.worker.busy:
            self._last, self._last_ok = ("abandoned at shutdown while running; filter stays on "
                                         f"{np.round(self.freqs_radps, 4).tolist()} rad/s"), False
        self._closing = True
        self._publish_diagnostics()
        self.worker.close()

    def _publish_diagnostics(self):
        c = dict(self.counts)
        c.update(self.monitor.counters)
        trig = self.monitor.trigger
        c["trigger_statistic_m"] = f"{trig.statistic_m:.3f}"
        c["trigger_armed"] = trig.armed
        c["trigger_suppressed_cooldown"] = trig.n_suppressed_cooldown
        c["model_freqs_radps"] = ", ".join(f"{w:.4f}" for w in self.freqs_radps)
        c["reestimation_running"] = self.worker.busy
        c["worker_ready"] = self.worker.ready
        c["worker_restarts"] = self.worker.n_restarts
        c["last_reestimation"] = self._last
        c["last_trigger_t_s"] = f"{self._last_trigger_t:.3f}"
        for k, (n, s, mx) in self.cb_time.items():
            c[f"callback_{k}_count"] = n
            c[f"callback_{k}_mean_ms"] = f"{1e3 * s / max(n, 1):.3f}"
            c[f"callback_{k}_max_ms"] = f"{1e3 * mx:.3f}"
        rejected = sum(v for k, v in self.counts.items() if k.startswith("rejected_"))
        ok = self._last_ok and rejected == 0
        msg = f"last re-estimation: {self._last}" if self._last_ok else f"re-estimation {self._last}"
        self.pub_diag.publish(diagnostic_array(self, "hyper_nav_aiding: lever_arm_learning", ok, msg, c))



def main(args=None):
    run_node(LeverArmLearningNode, args)


if __name__ == "__main__":
    main()
