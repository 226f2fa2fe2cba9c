"""SPP solution writers (core/spp_output.py): the RTKLIB .pos read back by the
project's own importer reader (core/importer/rtklib_pos.py), NMEA parsed by
pynmeagps (checksums, positions, GST sigmas from the covariance), KML and
GPX parsed as XML, GPST -> UTC leap seconds; all against the solutions
written, with stated tolerances."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from hyper_nav_gnss import earth
from hyper_nav_gnss.positioning.spp import SppSolution
from hyper_nav_workbench.core import spp_output
from hyper_nav_workbench.core.importer.rtklib_pos import read_pos

T0 = 2295 * 604800.0 + 129600.0            # 2024-01-01 12:00:00 GPST
XYZ = np.array([4627852.5264, 119640.5140, 4372994.8358])


def _sols(n=5):
    rng = np.random.default_rng(3)
    lat, lon, _ = earth.ecef_to_geodetic(XYZ)
    C = earth.C_n_e(lat, lon)
    cov_enu = np.array([[0.49, 0.05, -0.1], [0.05, 0.81, 0.2], [-0.1, 0.2, 4.0]])
    out = []
    for k in range(n):
        s = SppSolution(T0 + k, T0 + k, "ok" if k != 2 else "fault_excluded",
                        XYZ + rng.normal(0, 1.0, 3), C @ cov_enu @ C.T, 1234.5 + k, "G", {"E": 3.2, "C": -7.5},
                        {"gdop": 1.5, "pdop": 1.3, "hdop": 0.7, "vdop": 1.1, "tdop": 0.8},
                        ["G05", "G07", "E12", "C20", "G13"], np.array([0.3, -0.2, 0.5, -0.4, 9.0]),
                        np.ones(5), np.full(5, 0.6), np.zeros(5), np.full(5, 45.0), np.ones(5, bool),
                        np.array([True, True, True, True, k != 2]),
                        [("G13", 5.4, 40.1)] if k == 2 else [], ["G30"], 3.2, 16.3, 1, 4)
        out.append(s)
    out.append(SppSolution(T0 + n, T0 + n, "too_few_satellites"))
    return out


def test_pos_reads_back_in_the_importer_reader(tmp_path):
    sols = _sols()
    n = spp_output.write_pos(tmp_path / "a.pos", sols, {"inp file": "obs.rnx nav.rnx"})
    assert n == 5                                       # the unsolved epoch is not written (as rnx2rtkp)
    pos = read_pos(tmp_path / "a.pos")
    assert pos.counts["epochs"] == 5 and not pos.counts["malformed_lines"]
    assert np.allclose(pos.t_gpst_s, T0 + np.arange(5), atol=1e-6)
    assert np.all(pos.quality == 5)
    assert list(pos.n_sat) == [5, 5, 4, 5, 5]
    for k, s in enumerate(sols[:5]):
        xyz = np.asarray(earth.geodetic_to_ecef(pos.lat_rad[k], pos.lon_rad[k], pos.alt_m[k]))
        assert np.linalg.norm(xyz - s.pos_ecef_m) < 2e-4      # 1e-9 deg and 0.1 mm printed
    assert np.allclose(pos.sigma_neu_m[0], [0.9, 0.7, 2.0], atol=1e-4)      # sdn, sde, sdu of the ENU covariance
    text = (tmp_path / "a.pos").read_text()
    assert "% pos mode  : Single" in text and "2024/01/01 12:00:00.000" in text


def test_nmea_sentences_parse_and_carry_the_solution(tmp_path):
    pynmeagps = pytest.importorskip("pynmeagps")
    sols = _sols()
    assert spp_output.write_nmea(tmp_path / "a.nmea", sols) == 5
    lines = (tmp_path / "a.nmea").read_bytes().decode("ascii").split("\r\n")[:-1]
    msgs = [pynmeagps.NMEAReader.parse(ln, validate=pynmeagps.VALCKSUM) for ln in lines]
    ids = [m.msgID for m in msgs]
    assert ids.count("GGA") == ids.count("RMC") == ids.count("GST") == 5
    assert ids.count("GSA") == 15                        # GPS, Galileo, BeiDou each epoch
    gga = [m for m in msgs if m.msgID == "GGA"]
    for m, s in zip(gga, sols):
        la, lo, h = spp_output.geodetic(s)
        assert abs(m.lat - la) < 1e-8 and abs(m.lon - lo) < 1e-8 and abs(m.alt - h) < 1e-3
        assert m.numSV == s.n_used and m.HDOP == pytest.approx(0.7)
    # UTC = GPST - 18 s in 2024
    assert str(gga[0].time) == "11:59:42"
    gst = [m for m in msgs if m.msgID == "GST"][0]
    assert gst.stdLat == pytest.approx(0.9, abs=1e-3) and gst.stdLong == pytest.approx(0.7, abs=1e-3)
    assert gst.stdAlt == pytest.approx(2.0, abs=1e-3)
    ev = np.linalg.eigvalsh(np.array([[0.49, 0.05], [0.05, 0.81]]))
    assert gst.stdMajor == pytest.approx(math.sqrt(ev[1]), abs=1e-3) and gst.stdMinor == pytest.approx(math.sqrt(ev[0]), abs=1e-3)
    gsa = [m for m in msgs if m.msgID == "GSA"][:3]
    assert [m.svid_01 for m in gsa] == [5, 12, 20]


def test_kml_gpx_and_csv(tmp_path):
    sols = _sols()
    assert spp_output.write_kml(tmp_path / "a.kml", sols, "TLSE") == 5
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.parse(tmp_path / "a.kml").getroot()
    coords = root.find(".//k:LineString/k:coordinates", ns).text.split()
    assert len(coords) == 5
    lo, la, h = (float(x) for x in coords[0].split(","))
    assert (la, lo) == pytest.approx(spp_output.geodetic(sols[0])[:2], abs=1e-8)
    assert spp_output.write_gpx(tmp_path / "a.gpx", sols) == 5
    g = ET.parse(tmp_path / "a.gpx").getroot()
    pts = g.findall(".//{http://www.topografix.com/GPX/1/1}trkpt")
    assert len(pts) == 5 and float(pts[1].get("lat")) == pytest.approx(spp_output.geodetic(sols[1])[0], abs=1e-8)
    assert pts[0].find("{http://www.topografix.com/GPX/1/1}time").text == "2024-01-01T11:59:42.000Z"
    assert spp_output.write_csv(tmp_path / "a.csv", sols) == 6
    rows = [r.split(",") for r in (tmp_path / "a.csv").read_text().splitlines()]
    head = rows[0]
    r2 = dict(zip(head, rows[3]))
    assert r2["status"] == "fault_excluded" and r2["excluded_w"] == "G13:5.4" and r2["n_used"] == "4"
    assert float(r2["isb_C_m"]) == -7.5 and float(r2["clock_bias_m"]) == 1236.5 and r2["below_mask"] == "G30"
    assert float(r2["x_ecef_m"]) == pytest.approx(sols[2].pos_ecef_m[0], abs=1e-4)
    last = dict(zip(head, rows[-1]))
    assert last["status"] == "too_few_satellites" and last["lat_deg"] == ""


def test_leap_seconds():
    assert spp_output.utc_datetime(T0).isoformat() == "2024-01-01T11:59:42"
    # 2016-12-31 23:59:59 UTC (GPST 00:00:16 on 2017-01-01 with 17 s) and after the leap second
    t16 = (spp_output._dt.datetime(2016, 6, 1) - spp_output.GPS_EPOCH).total_seconds()
    assert (spp_output.gpst_datetime(t16) - spp_output.utc_datetime(t16)).total_seconds() == 17
