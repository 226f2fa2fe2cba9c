"""One pass of the core filter over a data window with candidate natural
frequencies: the environment's transition (seed 000 section III.B.1, "the
GNSS/INS integration navigation model ... evaluates the current dynamic
lever-arm model") and the unit of cost of every identifier here.

The pass runs ``hyper_nav_filter.core.eskf.ErrorStateKF`` (the fusion node's
24-state filter, eqs. 15-31) with ``lever_arm_natural_freq_radps`` replaced
(``FilterConfig.with_updates``, as a model update does), from the window's
initial fused state and covariance, in time order: predict with each IMU
sample, then the GNSS measurements stamped in the interval, with the
engine's measurement context (``ModelContext.at``), as
``FusionEngine._process_epoch`` does; the window is in order, so the
engine's re-processing and snapshots are not needed. It records each measurement's
innovation (predicted minus measured, before the update) and its covariance
S = H P H^T + R: the rewards, the likelihood and the Fisher information are
functions of these.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hyper_nav_filter.core.config import FilterConfig
from hyper_nav_filter.core.eskf import ErrorStateKF
from hyper_nav_filter.core.measurements import ModelContext

from hyper_nav_aiding.lever_arm.core.window import DataWindow

FREQ_FIELD = "lever_arm_natural_freq_radps"


@dataclass
class KindInnovations:
    """Innovations of one measurement kind over a pass: times (M,), innovation
    nu (M, d), its covariance S (M, d, d) and whether the gate accepted it."""
    t_s: np.ndarray
    nu: np.ndarray
    S: np.ndarray
    accepted: np.ndarray


@dataclass
class WindowPass:
    freqs_radps: np.ndarray
    kinds: dict                      # kind -> KindInnovations
    final_pos_residual_enu_m: np.ndarray | None

    def neg_log_likelihood(self) -> float:
        """-log p(innovations) up to a constant: 1/2 sum (nu^T S^-1 nu + log det S)
        over every measurement (accepted or not, so the value is smooth in the
        frequencies)."""
        total = 0.0
        for ki in self.kinds.values():
            sol = np.linalg.solve(ki.S, ki.nu[..., None])[..., 0]
            total += 0.5 * float(np.sum(ki.nu * sol) + np.sum(np.linalg.slogdet(ki.S)[1]))
        return total


def config_with_frequencies(cfg: FilterConfig, freqs_radps) -> FilterConfig:
    """The filter configuration with other natural frequencies (the only field changed)."""
    return cfg.with_updates({FREQ_FIELD: tuple(float(w) for w in freqs_radps)})


def replay(window: DataWindow, cfg: FilterConfig, freqs_radps) -> WindowPass:
    """Run the filter with ``freqs_radps`` over ``window``; see the module doc."""
    cfg_w = config_with_frequencies(cfg, freqs_radps)
    if window.initial_P.shape != (cfg_w.layout.dim,) * 2:
        raise ValueError(f"window covariance {window.initial_P.shape} does not match the filter's "
                         f"{cfg_w.layout.dim} states")
    kf = ErrorStateKF(cfg_w, window.initial_state, window.initial_P)
    lever_b = cfg_w.antenna_lever_arm_b_m
    rec: dict[str, list] = {}
    gnss, j = window.gnss, 0
    t_prev = window.t0_s
    last_pos = None
    for k in range(len(window.imu_t_s)):
        imu = window.imu_sample(k, t_prev)
        t = imu.t_s
        kf.predict(imu)
        t_prev = t
        while j < len(gnss) and gnss[j].t_s <= t + 1e-9:
            meas = gnss[j]
            j += 1
            ctx = ModelContext.at(kf, imu, lever_b).shifted(meas.t_s - t)
            nu, H, R = kf.model(meas, ctx)
            S = H @ kf.P @ H.T + R
            res = kf.update(meas.kind, meas.t_s, nu, H, R)
            rec.setdefault(meas.kind, []).append((meas.t_s, np.array(nu, float), 0.5 * (S + S.T), res.accepted))
            if meas.kind == "gnss_pos":
                last_pos = np.array(nu, float)
    kinds = {kind: KindInnovations(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                                   np.array([r[2] for r in rows]), np.array([r[3] for r in rows]))
             for kind, rows in rec.items()}
    return WindowPass(np.asarray(freqs_radps, float), kinds, last_pos)
