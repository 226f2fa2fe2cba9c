"""Fit a static IMU recording to the simulator's error model by Allan
deviation and print the scenario ``imu:`` block (issue 39).

    imu_allan_fit recording.csv --gyro-unit deg/s --accel-unit g
    imu_allan_fit recording.csv --columns t=time,gx=wx,gy=wy,gz=wz,ax=fx,ay=fy,az=fz

The CSV has a header; the default column names are t, gx, gy, gz, ax, ay,
az (rates and specific forces, one row per sample; ``--columns`` maps
other names). Per axis the overlapping Allan deviation
(``core.allan``, IEEE Std 952) is fitted with AVAR = N^2/tau +
(0.664 B)^2 (+ K^2 tau / 3 with ``--rate-random-walk``); the block gives
the mean over the axes of N (ARW / VRW) and B (bias instability), in the
scenario's datasheet units. A static recording cannot tell the turn-on
bias from gravity and Earth rate: the block leaves the constant biases at 0
and says so. Rows with a non-finite value or a non-increasing time are
refused, counted and reported; a non-uniform rate (> 1 % jitter) is
refused.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import yaml

from hyper_nav_filter.core import units

from hyper_nav_workbench.core import allan

GYRO_UNITS = {"rad/s": 1.0, "deg/s": np.pi / 180.0, "deg/h": np.pi / 180.0 / 3600.0}
ACCEL_UNITS = {"m/s2": 1.0, "g": 9.80665, "mg": 9.80665e-3}
DEFAULT_COLUMNS = {"t": "t", "gx": "gx", "gy": "gy", "gz": "gz", "ax": "ax", "ay": "ay", "az": "az"}


def read_csv(path, columns: dict):
    import csv
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ValueError(f"{path}: empty file")
    header = [h.strip() for h in rows[0]]
    idx = {}
    for key, name in columns.items():
        if name not in header:
            raise ValueError(f"{path}: no column {name!r} for {key} (columns: {header})")
        idx[key] = header.index(name)
    data, bad = [], 0
    for r in rows[1:]:
        try:
            v = [float(r[idx[k]]) for k in DEFAULT_COLUMNS]
        except (ValueError, IndexError):
            bad += 1
            continue
        if not np.all(np.isfinite(v)):
            bad += 1
            continue
        data.append(v)
    a = np.array(data)
    keep = np.concatenate([[True], np.diff(a[:, 0]) > 0]) if len(a) else np.zeros(0, bool)
    bad += int((~keep).sum())
    return a[keep], bad


def fit(rate, dt_s, rrw: bool):
    taus, adev, _ = allan.overlapping_adev(rate, dt_s)
    rel = allan.adev_relative_sigma(taus, len(rate), dt_s)
    out = [allan.fit_noise_terms(taus, adev[:, k], rel, rate_random_walk=rrw) for k in range(rate.shape[1])]
    return {key: float(np.mean([o[key] for o in out])) for key in ("N", "B", "K")}, taus, adev


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("csv")
    ap.add_argument("--gyro-unit", default="rad/s", choices=sorted(GYRO_UNITS))
    ap.add_argument("--accel-unit", default="m/s2", choices=sorted(ACCEL_UNITS))
    ap.add_argument("--time-unit", default="s", choices=("s", "ms", "us", "ns"))
    ap.add_argument("--columns", default="", help="KEY=NAME,... for keys t gx gy gz ax ay az")
    ap.add_argument("--rate-random-walk", action="store_true", help="also fit a rate random walk K (reported)")
    a = ap.parse_args(argv)
    cols = dict(DEFAULT_COLUMNS)
    for item in filter(None, a.columns.split(",")):
        k, _, v = item.partition("=")
        if k not in DEFAULT_COLUMNS:
            from hyper_nav_filter.core.params import unknown_field
            ap.error(unknown_field("--columns ", k, DEFAULT_COLUMNS))
        cols[k] = v
    try:
        data, bad = read_csv(a.csv, cols)
    except (OSError, ValueError) as exc:
        print(f"imu_allan_fit: {exc}", file=sys.stderr)
        return 2
    if len(data) < 1000:
        print(f"imu_allan_fit: {len(data)} usable samples; need >= 1000", file=sys.stderr)
        return 2
    t = data[:, 0] * {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}[a.time_unit]
    dts = np.diff(t)
    dt = float(np.median(dts))
    if np.max(np.abs(dts - dt)) > 0.01 * dt:
        print(f"imu_allan_fit: sample interval not uniform (median {dt:g} s, extremes {dts.min():g} / "
              f"{dts.max():g} s); resample first", file=sys.stderr)
        return 2
    gyro = data[:, 1:4] * GYRO_UNITS[a.gyro_unit]
    acc = data[:, 4:7] * ACCEL_UNITS[a.accel_unit]
    g, _, _ = fit(gyro, dt, a.rate_random_walk)
    f, _, _ = fit(acc, dt, a.rate_random_walk)
    block = {"imu": {
        "rate_hz": round(1.0 / dt, 6),
        "gyro_bias_deg_per_hr": [0.0, 0.0, 0.0],
        "gyro_arw_deg_per_sqrt_hr": float(g["N"] / float(units.deg_per_sqrt_hr(1.0))),
        "gyro_bias_instability_deg_per_hr": float(g["B"] / float(units.deg_per_hr(1.0))),
        "accel_bias_ug": [0.0, 0.0, 0.0],
        "accel_vrw_ug_per_sqrt_hz": float(f["N"] / float(units.ug_per_sqrt_hz(1.0))),
        "accel_bias_instability_ug": float(f["B"] / float(units.ug(1.0))),
    }}
    print(f"# Allan fit of {a.csv}: {len(data)} samples at {1.0 / dt:g} Hz ({t[-1] - t[0]:.0f} s), "
          f"{bad} rows refused (non-finite, unreadable or out of order)")
    print("# turn-on biases: not observable from a static recording (gravity, Earth rate): set from the data sheet")
    if a.rate_random_walk:
        print(f"# rate random walk K: gyro {g['K']:.3g} rad/s/sqrt(s), accel {f['K']:.3g} m/s^2/sqrt(s) "
              "(not in the simulator's model)")
    print(yaml.safe_dump(block, sort_keys=False), end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
