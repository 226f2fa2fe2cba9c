"""spp OBS NAV --sp3 FILE on the shared TLSE file (2024-01-01): no precise
product of that day is in the shared data, so (1) the 2023 GFZ product
(../shared/gnss-real, written as an SP3 file by the test) is refused with
both spans named, and (2) a product written by the test from the day's own
broadcast orbits and clocks (the relativistic term removed, Galileo and BeiDou
clocks moved to the E1/E5a and B1I/B3I ionosphere-free references, as IGS products hold them)
must give the broadcast solution back: that proves the plumbing (transmit
time, frames, relativity, Galileo and BeiDou clock references, interpolation), not the
precise products' accuracy (tested in hyper_nav_gnss/test/orbits/test_precise.py). What remains is
the interpolation (mm), the SP3's 1 mm / 1 ps resolution and the two relativistic forms: the
precise -2 r.v/c^2 (IGS) differs from the broadcast F e sqrtA sinE by the harmonic terms' radial
velocity (up to about 1.5 cm of clock per satellite, measured on TLSE's satellites)."""
from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.formats import rinex_nav
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.signals import _F_B1I, _F_B3I
from hyper_nav_workbench.spp import main

_T = Path(__file__).resolve().parents[2] / "hyper_nav_gnss" / "test"


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


rd = _load("hyper_nav_gnss_real_data", _T / "_real_data.py")
gd = _load("gnss_test_data", _T / "_data.py")
sys.path.insert(0, str(_T / "orbits"))
from sp3_writer import write_antex, write_clk, write_sp3  # noqa: E402


def test_spp_refuses_a_product_of_another_day(tmp_path, capsys):
    sp3 = tmp_path / "GFZ0MGXRAP_20230010000_01D_05M_ORB.SP3"
    write_sp3(sp3, gd.read_sp3_csv(gd.SP3_2023), frame="IGS20", agency="GFZ")
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    assert main([str(obs), str(nav), "--sp3", str(sp3), "--short", "3", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "GFZ0MGXRAP_20230010000_01D_05M_ORB.SP3 covers 2023-01-01 00:00:00 .. 2023-01-01 02:00:00 GPST" in err
    assert "the observations span 2024-01-01 12:00:00 .. 2024-01-01 12:00:02 GPST" in err
    assert not (tmp_path / "o").exists()


def _rel_s(eph, t):
    mu, _ = ep.constants(eph.system)
    n = np.sqrt(mu / eph.sqrtA ** 6) + eph.delta_n
    E = ep._kepler_E(np.atleast_1d(eph.M0 + n * (t - eph.toe_s)), eph.e)[0]
    return -2 * np.sqrt(mu) / ep.C_MPS ** 2 * eph.e * eph.sqrtA * np.sin(E)


def _broadcast_product(nav, t_mid_gpst, t0_gpst, t1_gpst, step_s=300.0):
    """SP3 rows of G, E (the I/NAV records the dual mode's E1+E5b pairs use) and C from the broadcast record
    of each satellite at t_mid, clocks moved to the IGS references (E1/E5a, B1I/B3I)."""""
    from collections import Counter

    from hyper_nav_gnss.corrections.receiver_model import _select
    from hyper_nav_workbench.core.spp_run import _PostProcessingStore
    ephs = list(rinex_nav.read_rinex_nav(nav))
    store = _PostProcessingStore()
    for e in ephs:
        store.add(e)
    k_if = _F_B1I ** 2 / (_F_B1I ** 2 - _F_B3I ** 2)
    rows = []
    for sat in sorted({e.sat_id for e in ephs if e.system in "GCE"}):
        # the record spp itself picks at t_mid (its choice is per minute)
        eph = _select(store, sat[0], int(sat[1:]), t_mid_gpst, ep.GAL_CLOCK_E1E5B if sat[0] == "E" else 0, Counter())
        if eph is None:
            continue
        to_igs = {"C": -k_if * eph.tgd, "E": eph.tgd - eph.tgd2}.get(sat[0], 0.0)   # E: I/NAV -> E1/E5a
        for t in np.arange(t0_gpst, t1_gpst + 1.0, step_s):
            ts = float(ep.system_time_s(sat[0], t))
            r, _, clk, _ = ep.satellite_position_ecef(eph, ts)
            clk = clk - _rel_s(eph, ts) + to_igs
            rows.append((float(t), sat, r, clk))
    return rows


def _csv(path):
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    return {r["gpst"]: r for r in rows}


@pytest.mark.slow
def test_spp_with_a_product_made_of_broadcast_gives_the_broadcast_solution(tmp_path, capsys):
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    t_start = ep.calendar_to_system_s("G", 2024, 1, 1, 12, 0, 0.0)
    sp3 = tmp_path / "BRD.sp3"
    write_sp3(sp3, _broadcast_product(nav, t_start + 30.0, t_start - 3600.0, t_start + 3600.0))
    n = "60"
    assert main([str(obs), str(nav), "--short", n, "--out", str(tmp_path / "b"), "--formats", "csv,pos"]) == 0
    assert main([str(obs), str(nav), "--short", n, "--out", str(tmp_path / "p"), "--formats", "csv,pos",
                 "--sp3", str(sp3)]) == 0
    out = capsys.readouterr().out
    assert "[spp] orbits: precise SP3-d BRD.sp3" in out and "systems CEG" in out
    stem = "TLSE00FRA_R_20240011200_15M_01S_MO"
    pos = (tmp_path / "p" / f"{stem}.pos").read_text()
    assert "% orbits    : precise SP3-d BRD.sp3" in pos
    assert "orbits" not in (tmp_path / "b" / f"{stem}.pos").read_text()
    b, p = _csv(tmp_path / "b" / f"{stem}.csv"), _csv(tmp_path / "p" / f"{stem}.csv")
    assert b.keys() == p.keys() and len(b) == int(n)
    d = np.array([[float(p[k][c]) - float(b[k][c]) for c in ("x_ecef_m", "y_ecef_m", "z_ecef_m")] for k in b])
    dclk = np.array([float(p[k]["clock_bias_m"]) - float(b[k]["clock_bias_m"]) for k in b])
    used = [(b[k]["used"], p[k]["used"]) for k in b]
    print(f"precise-made-of-broadcast minus broadcast: max |d pos| {np.abs(d).max() * 1e3:.2f} mm, "
          f"max |d clock| {np.abs(dclk).max() * 1e3:.2f} mm")
    assert all(x == y for x, y in used)
    assert np.abs(d).max() < 0.01 and np.abs(dclk).max() < 0.01
    # the clocks from a RINEX CLK file (30 s) and an SP3 without clocks: the same solution
    rows = _broadcast_product(nav, t_start + 30.0, t_start - 3600.0, t_start + 3600.0)
    write_sp3(tmp_path / "BRD_noclk.sp3", [(t, s, r, np.nan) for t, s, r, _ in rows])
    write_clk(tmp_path / "BRD.clk", [(t, s, c) for t, s, _, c in _broadcast_product(
        nav, t_start + 30.0, t_start - 600.0, t_start + 600.0, step_s=30.0)])
    assert main([str(obs), str(nav), "--short", n, "--out", str(tmp_path / "c"), "--formats", "csv,pos",
                 "--sp3", str(tmp_path / "BRD_noclk.sp3"), "--clk", str(tmp_path / "BRD.clk")]) == 0
    assert "clocks BRD.clk" in (tmp_path / "c" / f"{stem}.pos").read_text()
    c = _csv(tmp_path / "c" / f"{stem}.csv")
    d = np.array([[float(c[k][x]) - float(b[k][x]) for x in ("x_ecef_m", "y_ecef_m", "z_ecef_m")] for k in b])
    print(f"with --clk: max |d pos| {np.abs(d).max() * 1e3:.2f} mm")
    assert np.abs(d).max() < 0.01 and all(c[k]["used"] == b[k]["used"] for k in b)


# ANTEX frequencies of the dual mode's pairs (GPS 1C+2W, Galileo 1X+7X, BeiDou 2I+6I)
_PAIRS = {"G": ("G01", "G02", 1575.42e6, 1227.60e6), "E": ("E01", "E07", 1575.42e6, 1207.14e6),
          "C": ("C02", "C06", _F_B1I, _F_B3I)}


def _pcos(sat):
    """Test offsets: x 0.3 m, z 0.8-1.6 m by PRN, the second frequency's z 0.1 m above the first's."""
    z = 0.8 + 0.025 * int(sat[1:])
    f1, f2, _, _ = _PAIRS[sat[0]]
    return {f1: (0.3, 0.0, z), f2: (0.3, 0.0, z + 0.1)}


@pytest.mark.slow
def test_spp_with_antenna_offsets(tmp_path, capsys):
    """A product of centres of mass: the broadcast (antenna) positions minus
    the ionosphere-free offset of each satellite's pair (x 0.3 m, z 0.8-1.6
    m by PRN, 0.1 m apart between the frequencies: z_IF = z1 - 0.155 m for
    GPS): with --atx the broadcast solution comes back (mm); without it the
    solution moves by decimetres and a WARNING names the missing offsets."""
    from hyper_nav_gnss.orbits.satellite_antenna import pco_ecef_m
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    t_start = ep.calendar_to_system_s("G", 2024, 1, 1, 12, 0, 0.0)
    rows = _broadcast_product(nav, t_start + 30.0, t_start - 3600.0, t_start + 3600.0)
    com = []
    for t, sat, r, clk in rows:
        f1, f2, fa, fb = _PAIRS[sat[0]]
        a1 = fa ** 2 / (fa ** 2 - fb ** 2)
        p = _pcos(sat)
        body = a1 * np.array(p[f1]) + (1.0 - a1) * np.array(p[f2])
        com.append((t, sat, r - pco_ecef_m(body[None], r[None], np.array([t]))[0], clk))
    write_sp3(tmp_path / "COM.sp3", com)
    write_antex(tmp_path / "test.atx", {s: [(None, None, _pcos(s))] for s in sorted({r[1] for r in rows})})
    n = "30"
    args = [str(obs), str(nav), "--short", n, "--formats", "csv"]
    assert main(args + ["--out", str(tmp_path / "b")]) == 0
    assert main(args + ["--out", str(tmp_path / "a"), "--sp3", str(tmp_path / "COM.sp3"),
                        "--atx", str(tmp_path / "test.atx")]) == 0
    out_a = capsys.readouterr().out
    assert main(args + ["--out", str(tmp_path / "n"), "--sp3", str(tmp_path / "COM.sp3")]) == 0
    out_n = capsys.readouterr().out
    assert "satellite antenna offsets test.atx" in out_a and "WARNING" not in out_a
    assert "NO satellite antenna offsets" in out_n and "WARNING: precise orbits without --atx" in out_n
    stem = "TLSE00FRA_R_20240011200_15M_01S_MO"
    b, a, m = (_csv(tmp_path / d / f"{stem}.csv") for d in ("b", "a", "n"))
    xyz = ("x_ecef_m", "y_ecef_m", "z_ecef_m")
    da = np.array([[float(a[k][c]) - float(b[k][c]) for c in xyz] for k in b])
    dn = np.array([[float(m[k][c]) - float(b[k][c]) for c in xyz] for k in b])
    print(f"with --atx: max |d pos| {np.abs(da).max() * 1e3:.1f} mm; without: max 3-D "
          f"{np.linalg.norm(dn, axis=1).max():.3f} m")
    assert np.abs(da).max() < 0.01
    assert np.linalg.norm(dn, axis=1).min() > 0.05

