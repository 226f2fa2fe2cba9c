"""``plot_scenarios``: one PNG per scenario showing the flight (ground track,
altitude and speed against time), so a user can see what is flown.

    ros2run hyper_nav_sim plot_scenarios --out plots/          # every installed scenario
    ros2run hyper_nav_sim plot_scenarios default seed003 --out plots/
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

from .core.scenario import load_scenario, scenario_dirs


def all_scenario_names() -> list[str]:
    names = set()
    for d in scenario_dirs():
        names.update(p.stem for p in d.glob("*.yaml"))
    return sorted(names)


def ground_track_deg(lon_rad, lat_rad) -> tuple[np.ndarray, np.ndarray]:
    """(lon, lat) in degrees for plotting, longitude in [-180, 180), with a
    break (NaN) where the track crosses 180 deg instead of a line across the map."""
    from hyper_nav_gnss.earth import wrap_lon_rad
    lon = np.rad2deg(wrap_lon_rad(np.asarray(lon_rad, float)))
    lat = np.rad2deg(np.asarray(lat_rad, float))
    cut = np.flatnonzero(np.abs(np.diff(lon)) > 180.0) + 1
    return np.insert(lon, cut, np.nan), np.insert(lat, cut, np.nan)


def plot_scenario(name: str, out_dir: pathlib.Path, step_s: float = 0.5) -> pathlib.Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sc = load_scenario(name)
    traj = sc.trajectory()
    t = np.arange(0.0, traj.duration_s + 1e-9, step_s)
    tr = traj.truth(t)
    speed = np.linalg.norm(tr.vel_enu_mps, axis=1)
    load_g = np.linalg.norm(tr.f_b_mps2, axis=1) / 9.80665
    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    lon_deg, lat_deg = ground_track_deg(tr.lon_rad, tr.lat_rad)
    ax[0, 0].plot(lon_deg, lat_deg)
    ax[0, 0].plot(lon_deg[0], lat_deg[0], "go", label="start")
    ax[0, 0].set_xlabel("longitude [deg]")
    ax[0, 0].set_ylabel("latitude [deg]")
    ax[0, 0].set_title("ground track")
    ax[0, 0].legend()
    ax[0, 1].plot(t, tr.alt_m / 1000.0)
    ax[0, 1].set_ylabel("altitude [km]")
    ax[1, 0].plot(t, speed)
    ax[1, 0].set_ylabel("speed [m/s]")
    ax[1, 1].plot(t, load_g)
    ax[1, 1].set_ylabel("specific force [g]")
    for a in (ax[0, 1], ax[1, 0], ax[1, 1]):
        a.set_xlabel("time [s]")
    for a in ax.ravel():
        a.grid(True, alpha=0.3)
    fig.suptitle(f"{sc.name}: {sc.data.get('description', '')[:110]}")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{pathlib.Path(name).stem}.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="plot_scenarios", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenarios", nargs="*", help="scenario names or YAML paths (default: all installed)")
    ap.add_argument("--out", default="plots", help="output directory")
    args = ap.parse_args(argv)
    for name in args.scenarios or all_scenario_names():
        print(f"[plot_scenarios] {plot_scenario(name, pathlib.Path(args.out))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
