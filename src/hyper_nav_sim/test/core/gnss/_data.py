"""Locate /work/shared/gnss-real (beside the repo) for the GNSS tests."""
from __future__ import annotations

from pathlib import Path

import pytest

from hyper_nav_sim.core.gnss import broadcast_error

# this file: <repo>/src/hyper_nav_sim/test/core/gnss/_data.py -> parents[5] = repo root
REAL_DIR = Path(__file__).resolve().parents[5] / ".." / "shared" / "gnss-real"
RINEX2 = "brdc1180.21n"
RINEX3 = "BRDC00IGS_R_20230010000_01D_MN_GC-subset.rnx"
SP3_2021 = "sp3_COD0MGXFIN_20211180000_G.csv"
SP3_2023 = "sp3_GFZ0MGXRAP_20230010000_GC_0000-0200.csv"


def real_file(name: str) -> Path:
    if not REAL_DIR.is_dir():
        pytest.skip(f"real GNSS data directory {REAL_DIR} absent (expected ../shared/gnss-real beside the repo)")
    return REAL_DIR / name


def read_sp3_csv(name: str):
    """Rows (t_gpst_s, sat, r_e_m[3], clk_s or nan)."""
    return broadcast_error.read_sp3_csv(real_file(name))


REAL_DATA_DIR = Path(__file__).resolve().parents[5] / ".." / "shared" / "real-data"
TLSE_NAV = "tlse_2024001/BRDC00IGS_R_20240010000_01D_MN.rnx.gz"


def real_data_file(name: str) -> Path:
    p = REAL_DATA_DIR / name
    if not p.exists():
        pytest.skip(f"real-data file {p} absent (expected ../shared/real-data beside the repo)")
    return p
