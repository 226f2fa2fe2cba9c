"""Re-estimation windows cut from a simulated flight (offline studies, the
seed 000 reproduction and tests; the node cuts them from live topics with
``core.lever_arm.window.WindowBuffer``).

The window starts from the fused solution the fusion core released at t0, as
``nav/state`` carries it: nominal navigation state, biases and covariance, but
not the nominal values of the optional blocks (``gm``, ``lev``), which the
message does not carry; the replay starts the modes at their static deflection,
as the filter does at start-up.
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.fusion import FusionEngine
from hyper_nav_sim.core import simulate
from hyper_nav_sim.core.simulate import gnss_measurements

from hyper_nav_aiding.lever_arm.core.window import DataWindow


@dataclass
class SimulatedFlight:
    """The scenario's IMU stream and loosely coupled GNSS measurements."""
    scenario: object
    traj: object
    imu: object                  # hyper_nav_sim.core.simulate.ImuStream
    gnss: list                   # time-ordered GnssPosition / GnssVelocity

    @classmethod
    def from_scenario(cls, sc, noise_free: bool = False) -> "SimulatedFlight":
        """``noise_free``: the mean of the data (IMU white noise and GNSS noise
        off, biases kept), with the GNSS measurement covariances of the noisy
        scenario (the Cramer-Rao bound's sensitivities are of the mean)."""
        traj = sc.trajectory()
        if not noise_free:
            return cls(sc, traj, simulate.imu_stream(sc, traj), gnss_measurements(sc, traj))
        quiet = copy.deepcopy(sc)
        quiet.data["imu"]["gyro_arw_deg_per_sqrt_hr"] = 0.0
        quiet.data["imu"]["accel_vrw_ug_per_sqrt_hz"] = 0.0
        noisy_gnss = gnss_measurements(sc, traj)
        quiet.data["gnss"]["pos_sigma_enu_m"] = [0.0] * 3
        quiet.data["gnss"]["vel_sigma_enu_mps"] = [0.0] * 3
        mean_gnss = [dataclasses.replace(m, cov_enu_m2=n.cov_enu_m2) if m.kind == "gnss_pos" else
                     dataclasses.replace(m, cov_enu_m2ps2=n.cov_enu_m2ps2)
                     for m, n in zip(gnss_measurements(quiet, traj), noisy_gnss)]
        return cls(sc, traj, simulate.imu_stream(quiet, traj), mean_gnss)

    def true_frequencies(self, t0_s: float, t1_s: float) -> np.ndarray:
        """Mean of the simulated natural frequencies over [t0, t1] (rad/s)."""
        from hyper_nav_sim.core.lever_arm import LeverArmConfig
        la = LeverArmConfig.from_config(self.scenario.data["lever_arm"])
        return la.natural_freq_radps(np.linspace(t0_s, t1_s, 201)).mean(axis=0)

    def fused_state_at(self, cfg, t0_s: float):
        """Fly the fusion core with ``cfg`` from the start to t0; returns the
        released solution at t0 as ``nav/state`` carries it (state without the
        optional blocks' nominal values, covariance)."""
        return self.fused_states_at(cfg, [t0_s])[0]

    def fused_states_at(self, cfg, epochs_s) -> list:
        """``fused_state_at`` for several epochs in one flight."""
        eng = FusionEngine(cfg, self.scenario.filter_initial_state())
        out, j, k = [], 0, 0
        for t0 in sorted(epochs_s):
            n = int(np.searchsorted(self.imu.t_s, t0 + 1e-9))
            for k in range(k, n):
                t = self.imu.t_s[k]
                eng.add_imu(t, self.imu.dtheta_b_rad[k], self.imu.dvel_b_mps[k],
                            None if self.imu.load_f_b_mps2 is None else self.imu.load_f_b_mps2[k])
                while j < len(self.gnss) and self.gnss[j].t_s <= t + 1e-9:
                    eng.add_measurement(self.gnss[j])
                    j += 1
            k = n
            sol = [s for s in eng.release(final=True) if s.t_s <= t0 + 1e-9][-1]
            state = sol.state.copy()
            state.extra = {}
            out.append((state, sol.P.copy()))
        return out

    def window(self, state, P, duration_s: float) -> DataWindow:
        """The window of ``duration_s`` after the fused state (see module doc)."""
        t0 = state.t_s
        k0 = int(np.searchsorted(self.imu.t_s, t0 + 1e-9))
        k1 = int(np.searchsorted(self.imu.t_s, t0 + duration_s + 1e-9))
        t_end = self.imu.t_s[k1 - 1]
        w = DataWindow(state.copy(), P.copy(), self.imu.t_s[k0:k1].copy(), self.imu.dtheta_b_rad[k0:k1].copy(),
                       self.imu.dvel_b_mps[k0:k1].copy(),
                       tuple(m for m in self.gnss if t0 < m.t_s <= t_end + 1e-9),
                       None if self.imu.load_f_b_mps2 is None else self.imu.load_f_b_mps2[k0:k1].copy())
        w.check()
        return w


def start_window(flight: SimulatedFlight, cfg, duration_s: float) -> DataWindow:
    """The window from the scenario's start: the filter's initial state and
    covariance (no flight to t0 needed; tests)."""
    state = flight.scenario.filter_initial_state()
    return flight.window(state, cfg.initial_covariance(), duration_s)


def model_consistent_window(window: DataWindow, cfg, freqs_radps, rng=None) -> DataWindow:
    """The perfect-model switch (STYLE pattern 16, for tests and for bounds
    with a right model): the window's GNSS measurements moved onto the filter's
    own open-loop prediction with ``freqs_radps`` (plus white noise of the
    measurements' covariances when ``rng`` is given). With these frequencies a
    replay's noise-free innovations are zero."""
    from hyper_nav_gnss import earth
    from hyper_nav_filter.core.eskf import ErrorStateKF
    from hyper_nav_filter.core.measurements import ModelContext

    from hyper_nav_aiding.lever_arm.core.replay import config_with_frequencies

    cfg_w = config_with_frequencies(cfg, freqs_radps)
    kf = ErrorStateKF(cfg_w, window.initial_state, window.initial_P)
    lever_b = cfg_w.antenna_lever_arm_b_m
    out, j, t_prev = [], 0, window.t0_s
    for k in range(len(window.imu_t_s)):
        imu = window.imu_sample(k, t_prev)
        t = imu.t_s
        kf.predict(imu)
        t_prev = t
        while j < len(window.gnss) and window.gnss[j].t_s <= t + 1e-9:
            m = window.gnss[j]
            j += 1
            nu, _, R = kf.model(m, ModelContext.at(kf, imu, lever_b).shifted(m.t_s - t))
            shift = np.asarray(nu, float)
            if rng is not None:
                shift = shift - rng.multivariate_normal(np.zeros(len(shift)), R)
            if m.kind == "gnss_pos":
                r_m, r_n = earth.radii(m.lat_rad)
                out.append(dataclasses.replace(m, lat_rad=m.lat_rad + shift[1] / (r_m + m.alt_m),
                                               lon_rad=m.lon_rad + shift[0] / ((r_n + m.alt_m) * np.cos(m.lat_rad)),
                                               alt_m=m.alt_m + shift[2]))
            else:
                out.append(dataclasses.replace(m, vel_enu_mps=m.vel_enu_mps + shift))
    return dataclasses.replace(window, gnss=tuple(out))


def triggered_window(flight: SimulatedFlight, cfg, lc, monitor_from_s: float = -np.inf, release_every: int = 10):
    """Fly the fusion core with ``cfg`` over the scenario and feed the
    lever-arm node's core (``ReestimationMonitor``) as the node would be fed:
    IMU increments, GNSS measurements, released solutions as ``nav/state``
    carries them. Returns (window, trigger epoch, monitor) at the first firing
    from ``monitor_from_s`` on, or (None, None, monitor)."""
    from hyper_nav_aiding.lever_arm.core.monitor import ReestimationMonitor

    mon = ReestimationMonitor(lc, monitor_from_s)
    eng = FusionEngine(cfg, flight.scenario.filter_initial_state())
    imu, j = flight.imu, 0
    for k in range(len(imu.t_s)):
        t = imu.t_s[k]
        load = None if imu.load_f_b_mps2 is None else imu.load_f_b_mps2[k]
        eng.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k], load)
        windows = [mon.add_imu(t, imu.dtheta_b_rad[k], imu.dvel_b_mps[k], load_f_b_mps2=load)]
        while j < len(flight.gnss) and flight.gnss[j].t_s <= t + 1e-9:
            eng.add_measurement(flight.gnss[j])
            windows.append(mon.add_gnss(flight.gnss[j]))
            j += 1
        if k % release_every == release_every - 1:
            for sol in eng.release():
                state = sol.state.copy()
                state.extra = {}
                windows.append(mon.add_state(state, sol.P))
        window = next((w for w in windows if w is not None), None)
        if window is not None:
            return window, window.t_end_s, mon
    return None, None, mon


def with_gnss_sigmas(window: DataWindow, pos_sigma_m: float, vel_sigma_mps: float, rng=None) -> DataWindow:
    """The window with other GNSS measurement sigmas (per ENU axis): the
    covariances replaced and, with ``rng``, the fixes re-drawn around the
    noise-free ones of ``window`` (pass a noise-free window then)."""
    from hyper_nav_gnss import earth
    out = []
    for m in window.gnss:
        if m.kind == "gnss_pos":
            m = dataclasses.replace(m, cov_enu_m2=np.eye(3) * pos_sigma_m**2)
            if rng is not None:
                d = rng.standard_normal(3) * pos_sigma_m
                r_m, r_n = earth.radii(m.lat_rad)
                m = dataclasses.replace(m, lat_rad=m.lat_rad + d[1] / (r_m + m.alt_m),
                                        lon_rad=m.lon_rad + d[0] / ((r_n + m.alt_m) * np.cos(m.lat_rad)),
                                        alt_m=m.alt_m + d[2])
        else:
            m = dataclasses.replace(m, cov_enu_m2ps2=np.eye(3) * vel_sigma_mps**2)
            if rng is not None:
                m = dataclasses.replace(m, vel_enu_mps=m.vel_enu_mps + rng.standard_normal(3) * vel_sigma_mps)
        out.append(m)
    return dataclasses.replace(window, gnss=tuple(out))
