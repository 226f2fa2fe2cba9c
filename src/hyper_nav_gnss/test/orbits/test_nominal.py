"""Nominal (file-free) GPS / BDS-3 constellations against the real geometry."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits import constellation as cs
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.formats import rinex_nav
from hyper_nav_gnss.orbits import nominal as nm

_spec = importlib.util.spec_from_file_location("gnss_test_data", Path(__file__).parents[1] / "_data.py")
data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(data)

LAT, LON = np.deg2rad(26.5), np.deg2rad(119.0)          # seed 004 start point
R_RX = earth.geodetic_to_ecef(LAT, LON, 0.0)
DAY = np.arange(0.0, 86400.0, 600.0)                    # a day at 10-min steps


def _elevations(ephs, t_gpst):
    """(n_sat, n_t) elevations [deg], vectorised over time per satellite."""
    C = earth.C_n_e(LAT, LON)
    el = np.empty((len(ephs), t_gpst.size))
    for k, e in enumerate(ephs):
        r, *_ = ep.satellite_position_ecef(e, ep.system_time_s(e.system, t_gpst))
        d = (r - R_RX) @ C
        el[k] = np.rad2deg(np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])))
    return el


def _counts(ephs, t_gpst, mask=7.5):
    el = _elevations(ephs, t_gpst) >= mask
    sysv = np.array([e.system for e in ephs])
    return {s: el[sysv == s].sum(axis=0) for s in ("G", "C")}


@pytest.mark.parametrize("date", ["2023-01-01T00:00:00", "2026-03-10T12:00:00"])
def test_visible_count_in_real_range(date):
    """Over a day at 10-min steps at 26.5N 119E, mask 7.5 deg. Measured with the
    real IGS 2023-01-01 constellation (templates) at this place: GPS 6..13,
    BDS-3 (+ C01..C05 GEO) 13..17; so GPS is tested in 7..14 (the brief's
    "8-14" is not what the real sky gives: 7 occurs for ~5 % of the day)."""
    t0 = nm.gpst_from_date(date)
    ephs = nm.nominal_constellation(t0)
    assert sum(e.system == "G" for e in ephs) == 31 and sum(e.system == "C" for e in ephs) == 32
    n = _counts(ephs, t0 + DAY)
    assert 7 <= n["G"].min() and n["G"].max() <= 14 and 8.5 <= n["G"].mean() <= 11.0
    assert 10 <= n["C"].min() and n["C"].max() <= 20


def test_gps_period_and_ground_track_repeat():
    """Orbital period 2 pi / n = 43077.4 s: 11 h 58 min - 2.6 s (the nominal
    a = 26559.7 km alone gives 43077.6 s; "11 h 58 min" is the rounded half
    sidereal day), measured from the propagated orbit as the time to return to
    the same inertial position; the Earth-fixed track repeats after 2 periods."""
    t0 = nm.gpst_from_date("2024-06-15T03:20:00")
    e = nm.gps_nominal(t0)[0]
    mu, we = ep.constants("G")
    n = np.sqrt(mu / e.sqrtA ** 6) + e.delta_n
    T = 2 * np.pi / n
    assert abs(T - (11 * 3600 + 58 * 60)) < 3.0
    # inertial argument of latitude via r_i = R3(-we t) r_e: returns after T (within 1 s)
    t = e.toe_s + np.linspace(T - 60, T + 60, 241)
    r0, *_ = ep.satellite_position_ecef(e, e.toe_s)
    r, *_ = ep.satellite_position_ecef(e, t)
    th = we * (t - e.toe_s) - e.OmegaDot * (t - e.toe_s)   # undo Earth rotation and node regression
    ri = np.stack([np.cos(th) * r[:, 0] - np.sin(th) * r[:, 1], np.sin(th) * r[:, 0] + np.cos(th) * r[:, 1],
                   r[:, 2]], -1)
    t_ret = t[np.argmin(np.linalg.norm(ri - r0, axis=1))]
    assert abs(t_ret - e.toe_s - T) <= 1.0
    assert abs(t_ret - e.toe_s - (11 * 3600 + 58 * 60)) < 3.5
    r2, *_ = ep.satellite_position_ecef(e, e.toe_s + 2 * T)
    assert np.linalg.norm(r2 - r0) < 1.0
    # a later nominal set (another toe) describes the same satellite
    e2 = nm.gps_nominal(t0 + 7200.0, clock_ref_gpst_s=t0)[0]
    ra, _, ca, _ = ep.satellite_position_ecef(e, e.toe_s + 3600.0)
    rb, _, cb, _ = ep.satellite_position_ecef(e2, e.toe_s + 3600.0)
    assert np.linalg.norm(ra - rb) < 1e-3 and abs(ca - cb) < 1e-15


def test_elements_and_clocks_realistic():
    t0 = nm.gpst_from_date("2024-06-15T03:20:00")
    ephs = nm.nominal_constellation(t0)
    for e in ephs:
        assert e.cuc == e.cus == e.crc == e.crs == e.cic == e.cis == 0.0
        assert abs(e.toe_s - ep.system_time_s(e.system, t0)) <= 8.0
        assert 0.0 < e.e < 0.02 and abs(e.af0) < 1e-3 and abs(e.af1) < 2.1e-11 and abs(e.tgd) <= 1e-8
        assert abs(e.delta_n) < 6e-9
    af0 = np.array([e.af0 for e in ephs])
    assert 5e-5 < np.median(np.abs(af0)) < 5e-4
    gps = [e for e in ephs if e.system == "G"]
    raan = {round(np.rad2deg(e.Omega0) % 360.0, 3) for e in gps}
    assert len(raan) == 6                                   # six planes ...
    d = np.diff(np.sort(list(raan)))
    assert np.allclose(d, 60.0, atol=1e-6)                  # ... 60 deg apart
    assert all(abs(np.rad2deg(e.i0) - 55.0) < 1e-9 for e in ephs if not e.is_geo)
    # seeded: same seed -> same records, other seed -> other clocks
    assert nm.nominal_constellation(t0) == ephs
    assert nm.nominal_constellation(t0, seed=1)[0].af0 != ephs[0].af0


def test_bds_geo_longitude_station_kept_and_igso_crossing():
    t0 = nm.gpst_from_date("2024-06-15T03:20:00")
    ephs = nm.bds_nominal(t0)
    t = t0 + DAY
    for e in ephs:
        r, *_ = ep.satellite_position_ecef(e, ep.system_time_s("C", t))
        lat, lon, alt = earth.ecef_to_geodetic(r)
        if e.is_geo:
            lon_deg = np.rad2deg(lon)
            assert np.ptp(lon_deg) < 0.1 and np.all(np.abs(lon_deg - nm.BDS_GEO_LON_DEG[e.prn]) < 0.1)
            assert np.all(np.abs(np.rad2deg(lat)) < 0.01)
        elif e.prn in nm.BDS_IGSO_PRNS:
            assert np.rad2deg(np.abs(lat)).max() > 54.0
            tt = t0 + np.arange(0.0, 86400.0, 60.0)
            r, *_ = ep.satellite_position_ecef(e, ep.system_time_s("C", tt))
            lat, lon, _ = earth.ecef_to_geodetic(r)
            k = np.flatnonzero(np.diff(np.sign(lat)) != 0)
            assert np.all(np.abs(np.rad2deg(lon[k]) - 118.0) < 0.5)      # figure-8 node at 118E
        else:
            assert abs(np.linalg.norm(r, axis=1).mean() - 27906.1e3) < 50e3


def test_compare_with_real_template_constellation():
    """Same place and times (a day from 2023-01-01 01:00 GPST, 10-min steps):
    visible counts of the nominal constellation vs the real-template one of
    constellation.py (GPS: all 31; BDS: the BDS-3 MEO/IGSO PRNs and the GEO
    C01..C05 present in the file). Measured: mean |diff| 1.3 (GPS) / 1.4 (BDS),
    max 4; test: mean <= 2, 90th percentile <= 3, max <= 5."""
    tmpl, _ = rinex_nav.read_rinex3_nav(data.real_file(data.RINEX3))
    t0 = nm.gpst_from_date("2023-01-01T01:00:00")
    keep = set(nm.BDS_MEO_PRNS) | set(nm.BDS_IGSO_PRNS) | set(nm.BDS_GEO_LON_DEG)
    real = [e for e in cs.synthetic_constellation(tmpl, t0) if e.system == "G" or e.prn in keep]
    a = _counts(real, t0 + DAY)
    b = _counts(nm.nominal_constellation(t0), t0 + DAY)
    for s in ("G", "C"):
        d = np.abs(a[s].astype(int) - b[s].astype(int))
        assert d.mean() <= 2.0 and np.percentile(d, 90) <= 3 and d.max() <= 5, (s, d.mean(), d.max())
    # and the visible-satellite function agrees with the vectorised count here
    v = cs.visible_satellites(nm.nominal_constellation(t0), R_RX, t0, 7.5)
    assert len(v.sat_ids) == b["G"][0] + b["C"][0]
