"""Compile (or load from numba's on-disk cache) every fast-path kernel
(``core/fast``) once, by running a small filter through them: ``make setup``
runs it after the build so that no node compiles on its first message, and
the fusion node calls it before it subscribes
(``python -m hyper_nav_filter.core.warmup``). It sits beside the filter it
drives, above ``fast/``, whose kernels the filter's modules import."""
from __future__ import annotations

import time

import numpy as np

from .config import FilterConfig
from .eskf import ErrorStateKF
from .measurements import GnssPosition, GnssVelocity, ModelContext
from .nav_state import ImuSample, NavState


def warm_up(frames=("ENU", "LCI")) -> float:
    """Run each kernel once on a small filter in each mechanization frame of
    ``frames``; returns the seconds it took."""
    t0 = time.perf_counter()
    nav = NavState(0.0, 0.5, 2.0, 1000.0, np.array([100.0, 0.0, 0.0]), np.eye(3))
    for frame in frames:
        cfg = FilterConfig(mechanization_frame=frame, state_blocks=("att", "vel", "pos", "bg", "gm", "ba", "lev"))
        kf = ErrorStateKF(cfg, nav)
        for k in (1, 2):
            kf.predict(ImuSample(0.01 * k, 0.01, np.zeros(3), np.array([0.0, 0.0, 0.098])))
        s = kf.state
        fix = GnssPosition(kf.t_s, s.lat_rad, s.lon_rad, s.alt_m, np.eye(3))
        kf.update(fix.kind, kf.t_s, *kf.model(fix, ModelContext(np.zeros(3), np.zeros(3), 0.0)))
        vel = GnssVelocity(kf.t_s, kf.state.vel_enu_mps, np.eye(3))
        ctx = ModelContext.at(kf, ImuSample(kf.t_s, 0.01, np.zeros(3), np.array([0.0, 0.0, 0.098])), np.ones(3))
        kf.update(vel.kind, kf.t_s, *kf.model(vel, ctx))
    return time.perf_counter() - t0


if __name__ == "__main__":
    import sys
    # `python -m hyper_nav_filter.core.warmup [ENU|LCI ...]`: make setup compiles the two frames' kernels in
    # two processes at once (numba's cache takes concurrent writers: each entry is written to a temporary
    # file and renamed)
    frames = tuple(sys.argv[1:]) or ("ENU", "LCI")
    print(f"[setup] fast-path kernels ({', '.join(frames)}) ready in {warm_up(frames):.1f} s")
