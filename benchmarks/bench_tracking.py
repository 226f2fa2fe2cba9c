"""Tracking-loop cost: 12 channels at 1 kHz, seconds of simulated time per CPU
second (x real time), compiled kernel and its pure-Python reference, one core.

Run: python benchmarks/bench_tracking.py [--seconds 20]
"""
import argparse
import time

import numpy as np

from hyper_nav_gnss.receiver.tracking import ChannelBank, LoopConfig


def rate(compiled, sim_s, cfg, n_ch=12, cn0_dbhz=40.0):
    n = int(sim_s * 1000)
    rng = np.random.default_rng(0)
    t = np.arange(n)[:, None] * 1e-3
    f_in = 1000.0 + 50.0 * t + np.zeros((1, n_ch))      # Doppler ramp, 50 Hz/s
    cn0 = np.full((n, n_ch), cn0_dbhz)
    bank = ChannelBank(cfg, n_ch, 1000.0, 50.0, compiled=compiled)
    bank.run(f_in[:100], cn0[:100], rng)               # compile / warm up
    t0 = time.process_time()
    for k in range(0, n, 1000):                        # 1 s blocks, noise drawn per block (included)
        bank.run(f_in[k:k + 1000], cn0[k:k + 1000], rng)
    return sim_s / (time.process_time() - t0)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=20.0)
    a = ap.parse_args(argv)
    for name, cfg in (("unaided", LoopConfig()), ("aided", LoopConfig.aided_default())):
        rc = rate(True, a.seconds, cfg)
        rp = rate(False, min(a.seconds, 2.0), cfg)
        print(f"{name}: 12 channels at 1 kHz: compiled {rc:.0f}x real time, pure-Python reference {rp:.2f}x real time "
              f"(CPU time, one core, noise generation included)")


if __name__ == "__main__":
    main()
