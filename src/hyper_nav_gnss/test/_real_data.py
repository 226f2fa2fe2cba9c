"""Locate ../shared/real-data and ../shared/gnss-real beside the repo for the
real-GNSS tests, as hyper_nav_sim/test/core/gnss/_data.py does for
gnss-real (same rule: repo root / .. / shared). ``HYPER_NAV_SHARED`` points
elsewhere (a git worktree whose parent holds no shared folder). Tests skip
with the path they looked for when the data are absent; nothing is copied."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

# this file: <repo>/src/hyper_nav_gnss/test/_real_data.py -> parents[3] = repo root
SHARED = Path(os.environ.get("HYPER_NAV_SHARED") or Path(__file__).resolve().parents[3] / ".." / "shared")
WALK_UBX = "walk_0827/gnss_1730.ubx"
WALK_POS = "walk_0827/gnss_1730_sf.pos"
WALK_IMU = "walk_0827/imu_1730_sf.csv"
TLSE_OBS = "tlse_2024001/TLSE00FRA_R_20240011200_15M_01S_MO.crx.gz"
TLSE_NAV = "tlse_2024001/BRDC00IGS_R_20240010000_01D_MN.rnx.gz"
# header APPROX POSITION XYZ of TLSE (good to about 1 m, README of real-data)
TLSE_XYZ_M = (4627852.5264, 119640.5140, 4372994.8358)


def real_file(name: str) -> Path:
    """A file of ../shared/real-data (skip the test when absent)."""
    p = SHARED / "real-data" / name
    if not p.exists():
        pytest.skip(f"real-data file {p} absent (expected ../shared/real-data beside the repo, or HYPER_NAV_SHARED)")
    return p


def gnss_real_file(name: str) -> Path:
    p = SHARED / "gnss-real" / name
    if not p.exists():
        pytest.skip(f"gnss-real file {p} absent (expected ../shared/gnss-real beside the repo, or HYPER_NAV_SHARED)")
    return p

