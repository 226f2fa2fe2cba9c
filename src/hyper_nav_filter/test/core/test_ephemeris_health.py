"""The RINEX readers keep IODE and the health word; the ephemeris selection
never picks a record flagged unhealthy."""
from dataclasses import replace
from pathlib import Path

import pytest

from hyper_nav_gnss.orbits.ephemeris import select_ephemeris
from hyper_nav_gnss.formats.rinex_nav import read_rinex2_nav, read_rinex3_nav

REAL = Path(__file__).resolve().parents[5] / "shared" / "gnss-real"


@pytest.fixture(scope="module")
def gps():
    if not (REAL / "brdc1180.21n").is_file():
        pytest.skip(f"{REAL} not available")
    return read_rinex2_nav(REAL / "brdc1180.21n")[0]


def test_rinex2_keeps_iode_and_health(gps):
    # first records of brdc1180.21n: IODE column of broadcast orbit line 1 (read by hand)
    assert [e.iode for e in gps[:4]] == [31, 6, 13, 65]
    assert all(e.health == 0 for e in gps) and len(gps) == 105


def test_rinex3_keeps_aode_and_health():
    path = REAL / "BRDC00IGS_R_20230010000_01D_MN_GC-subset.rnx"
    if not path.is_file():
        pytest.skip(f"{path} not available")
    ephs, _ = read_rinex3_nav(path)
    c01 = [e for e in ephs if e.sat_id == "C01"]
    assert c01[0].iode == 1 and c01[0].health == 0          # BDS AODE 1, SatH1 0 in the file
    assert all(isinstance(e.iode, int) and e.iode >= 0 for e in ephs)


def test_selection_skips_unhealthy_records(gps):
    sat = gps[0].sat_id
    recs = sorted((e for e in gps if e.sat_id == sat), key=lambda e: e.toe_s)
    assert len(recs) >= 2
    t = recs[0].toe_s + 60.0                          # nearest: the first record
    assert select_ephemeris(recs, sat, t) is recs[0]
    sick = [replace(recs[0], health=1)] + recs[1:]
    chosen = select_ephemeris(sick, sat, t)
    assert chosen is recs[1] or (chosen is None and abs(t - recs[1].toe_s) > 7200.0)
    assert select_ephemeris([replace(r, health=63) for r in recs], sat, t) is None
