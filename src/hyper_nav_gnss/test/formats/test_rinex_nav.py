"""RINEX 3 navigation reader/writer (core/gnss/rinex_nav.py) and the
per-signal group delays (signal_delays.py) on the TLSE day's merged
broadcast file (../shared/real-data): record counts per system, values
against hand-read lines, a malformed record named and counted, the writer's
round trip, and Galileo's two clocks (I/NAV for E1/E5b, F/NAV for E1/E5a)
giving the same single-signal clocks through our group-delay formulas."""
from __future__ import annotations

import gzip
import importlib.util
from dataclasses import astuple
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.orbits.ephemeris import GAL_CLOCK_E1E5A, GAL_CLOCK_E1E5B, satellite_position_ecef
from hyper_nav_gnss.formats.rinex_nav import read_rinex3_nav, read_rinex3_nav_records, write_rinex3_nav
from hyper_nav_gnss.corrections.signal_delays import NoGroupDelay, group_delay_s

_spec = importlib.util.spec_from_file_location("hyper_nav_gnss_real_data", Path(__file__).parents[1] / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)


@pytest.fixture(scope="module")
def nav():
    return read_rinex3_nav_records(rd.real_file(rd.TLSE_NAV))


def test_counts_per_system_and_header_klobuchar(nav):
    c = nav.counts
    assert (c["G"], c["E"], c["C"], c["J"]) == (452, 5390, 1080, 100)
    assert (c["skipped_R"], c["skipped_S"], c["skipped_I"]) == (1199, 11235, 145) and not nav.errors
    a, b = nav.iono["G"]
    assert len(a) == 4 and len(b) == 4 and a[0] > 0 and b[0] > 0
    assert nav.iono["C"][0][0] == pytest.approx(3.1665e-08)      # first BDSA line of the header
    # the older two-value interface still reads GPS and BDS only
    ephs, iono = read_rinex3_nav(rd.real_file(rd.TLSE_NAV))
    assert {e.system for e in ephs} == {"G", "C"} and len(ephs) == 452 + 1080


def test_a_galileo_record_against_its_lines(nav):
    """E02 2023 12 31 23 30 00 (file lines 8737-8744): hand-read values."""
    with gzip.open(rd.real_file(rd.TLSE_NAV), "rt") as f:
        lines = f.read().splitlines()
    k = lines.index(next(x for x in lines if x.startswith("E02 2023 12 31 23 30 00")))
    rec = lines[k:k + 8]
    e = next(x for x in nav if x.sat_id == "E02" and abs(x.af0 - float(rec[0][23:42])) == 0.0)
    assert e.af1 == float(rec[0][42:61])
    assert e.sqrtA == float(rec[2][61:80]) and e.e == float(rec[2][23:42])
    assert e.toe == float(rec[3][4:23]) and e.i0 == float(rec[4][4:23])
    assert e.data_source == int(float(rec[5][23:42])) and e.week == int(float(rec[5][42:61]))
    assert e.tgd == float(rec[6][42:61]) and e.tgd2 == float(rec[6][61:80])
    assert e.accuracy_m == float(rec[6][4:23]) and e.health == int(float(rec[6][23:42]))
    assert e.week == 2295


def test_malformed_record_is_named_and_counted_and_writer_round_trips(nav, tmp_path):
    recs = [e for e in nav if e.system in ("G", "E", "C")][:60]
    f = tmp_path / "nav.rnx"
    assert write_rinex3_nav(f, recs, nav.iono) == 60
    back = read_rinex3_nav_records(f)
    assert len(back) == 60
    for a, b in zip(recs, back):
        for x, y in zip(astuple(a), astuple(b)):
            assert x == y or x == pytest.approx(y, rel=1e-12, abs=1e-22)
    lines = f.read_text().splitlines()
    k = next(i for i, x in enumerate(lines) if x.startswith(("G", "E", "C")) and " 20" in x[3:9])
    lines[k + 2] = lines[k + 2][:23] + "   not-a-number    " + lines[k + 2][42:]
    f.write_text("\n".join(lines) + "\n")
    bad = read_rinex3_nav_records(f)
    assert bad.counts["malformed"] == 1 and len(bad) == 59
    assert f"line {k + 1} ({lines[k][:3]})" in bad.errors[0]


def test_galileo_inav_and_fnav_clocks_agree_through_the_group_delays(nav):
    """The same satellite and issue of data broadcast twice: I/NAV (clock for
    E1/E5b) and F/NAV (clock for E1/E5a). The E1 and E5a single-signal clocks
    dt - d_s (OS SIS ICD 5.1.5, signal_delays.py) must agree between them up
    to the two clock fits and the BGD resolution (2^-32 s): measured max
    1.84 ns over 2692 pairs (0.55 m); asserted < 2 ns. Orbits identical."""
    by = {}
    for e in nav:
        if e.system == "E":
            kind = "F" if e.data_source & GAL_CLOCK_E1E5A else ("I" if e.data_source & GAL_CLOCK_E1E5B else "?")
            by.setdefault((e.prn, e.toe_s, e.iode), {})[kind] = e
    pairs = [(v["I"], v["F"]) for v in by.values() if "I" in v and "F" in v]
    assert len(pairs) > 2000
    worst = 0.0
    for i, f in pairs:
        t = i.toe_s + 300.0
        ri, _, ci, _ = satellite_position_ecef(i, t)
        rf, _, cf, _ = satellite_position_ecef(f, t)
        assert np.linalg.norm(ri - rf) < 1e-3              # same orbit parameters (to the printed digits)
        for code in ("1C", "5Q"):
            worst = max(worst, abs((ci - group_delay_s(i, code)) - (cf - group_delay_s(f, code))))
    print(f"\nGalileo I/NAV vs F/NAV single-signal clocks: max difference {worst * 1e9:.2f} ns over {len(pairs)} pairs")
    assert worst < 2e-9
    with pytest.raises(NoGroupDelay, match="no broadcast group delay"):
        group_delay_s(pairs[0][1], "7Q")                # E5b from an F/NAV record: no BGD(E1,E5b) in it
