"""Satellite antenna offsets (orbits/satellite_antenna.py, formats/antex.py)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.formats.antex import read_antex
from hyper_nav_gnss.formats.rinex_file import RinexFormatError
from hyper_nav_gnss.orbits import ephemeris as ep
from hyper_nav_gnss.orbits.satellite_antenna import body_axes, pco_ecef_m, sun_position_ecef

sys.path.insert(0, str(Path(__file__).parent))
from sp3_writer import write_antex  # noqa: E402

T2021 = ep.calendar_to_system_s("G", 2021, 4, 28, 18, 0, 0.0)


def test_antex_reader_validity_and_units(tmp_path):
    t_switch = T2021 + 3600.0
    write_antex(tmp_path / "a.atx", {"G05": [(None, t_switch, {"G01": (0.1, 0.0, 1.2), "G02": (0.1, 0.0, 1.3)}),
                                             (t_switch, None, {"G01": (0.3, 0.01, 0.9)})],
                                     "C06": [(T2021 - 86400.0, None, {"C02": (0.5, 0.0, 2.0)})]})
    a = read_antex(tmp_path / "a.atx")
    assert a.counts == {"satellite_antennas": 3, "receiver_antennas_skipped": 1}
    np.testing.assert_allclose(a.pco_body_m("G05", "G01", T2021), [0.1, 0.0, 1.2])
    np.testing.assert_allclose(a.pco_body_m("G05", "G02", T2021), [0.1, 0.0, 1.3])
    np.testing.assert_allclose(a.pco_body_m("G05", "G01", t_switch + 1.0), [0.3, 0.01, 0.9])
    assert a.pco_body_m("G05", "G02", t_switch + 1.0) is None          # the newer entry has no L2
    assert a.pco_body_m("C06", "C02", T2021 - 86401.0) is None         # before VALID FROM
    assert a.pco_body_m("E11", "E01", T2021) is None
    write_antex(tmp_path / "v13.atx", {}, version=1.3)
    with pytest.raises(RinexFormatError, match="v13.atx line 1: ANTEX version 1.3 is not read"):
        read_antex(tmp_path / "v13.atx")


def test_sun_position_against_rtklib():
    """Within 0.5 deg of RTKLIB's sunmoonpos and 1 % in distance (measured max 0.45 deg over 8 dates
    of 2021-22, nearly all a constant longitude offset: orbits/satellite_antenna.py's docstring)."""
    rk = pytest.importorskip("pyrtklib")
    worst = 0.0
    for k in range(8):
        t = T2021 + k * 45 * 86400.0 + k * 3 * 3600.0
        wk, sow = divmod(t, 604800.0)
        gt = rk.gpst2time(int(wk), float(sow))
        rsun, rmoon, gmst = rk.Arr1Ddouble(3), rk.Arr1Ddouble(3), rk.Arr1Ddouble(1)
        rk.sunmoonpos(rk.gpst2utc(gt), rk.Arr1Ddouble(5), rsun, rmoon, gmst)
        ref = np.array([rsun[i] for i in range(3)])
        ours = sun_position_ecef(t)[0]
        ang = np.degrees(np.arccos(ours @ ref / np.linalg.norm(ours) / np.linalg.norm(ref)))
        worst = max(worst, ang)
        assert abs(np.linalg.norm(ours) / np.linalg.norm(ref) - 1.0) < 0.01
    print(f"sun direction vs RTKLIB sunmoonpos: max {worst:.3f} deg")
    assert worst < 0.5


def test_body_axes_and_offset():
    r = np.array([[15e6, -10e6, 18e6], [-20e6, 5e6, -15e6]])
    t = np.array([T2021, T2021 + 7200.0])
    sun = sun_position_ecef(t)
    ex, ey, ez = body_axes(r, sun)
    for a, b in ((ex, ey), (ey, ez), (ez, ex)):
        np.testing.assert_allclose(np.sum(a * b, 1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.cross(ex, ey), ez, atol=1e-12)              # right-handed
    np.testing.assert_allclose(ez, -r / np.linalg.norm(r, axis=1, keepdims=True))
    es = (sun - r) / np.linalg.norm(sun - r, axis=1, keepdims=True)
    np.testing.assert_allclose(np.sum(ey * es, 1), 0.0, atol=1e-12)           # panels' axis normal to the Sun
    assert np.all(np.sum(ex * es, 1) > 0.0)                                   # +x toward the Sun's half
    d = pco_ecef_m(np.array([[0.3, 0.0, 1.5], [0.0, 0.0, 1.0]]), r, t)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), [np.hypot(0.3, 1.5), 1.0])
    np.testing.assert_allclose(np.sum(d * ez, 1), [1.5, 1.0])
