"""The spp command in its short mode on the shared recordings: TLSE (RINEX)
with RTKLIB beside on the same epochs and the walk log (UBX), and on a bag
of imported receiver data; JSON and PNGs written, figures printed."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

import yaml

from hyper_nav_workbench import import_data
from hyper_nav_workbench.spp import main

_spec = importlib.util.spec_from_file_location(
    "hyper_nav_gnss_real_data", Path(__file__).resolve().parents[2] / "hyper_nav_gnss" / "test" / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)


def _data_dir() -> str:
    return str(rd.real_file(rd.TLSE_OBS).parents[1])


@pytest.mark.slow
def test_spp_tlse_short_beside_rtklib(tmp_path, capsys):
    assert main(["tlse", "--short", "30", "--out", str(tmp_path), "--data-dir", _data_dir()]) == 0
    out = capsys.readouterr().out
    assert "read in" in out and "RTKLIB IFLC" in out and "RTKLIB BRDC" in out
    doc = json.loads((tmp_path / "spp.json").read_text())
    df = doc["runs"]["gps_galileo_beidou_dual_frequency"]
    assert df["ours_same_epochs"]["epochs"] == df["rtklib_same_epochs"]["epochs"] == 30
    assert df["ours_same_epochs"]["horizontal_rms_m"] < 1.0 and df["ours_same_epochs"]["vertical_rms_m"] < 2.0
    assert df["counts"]["unhealthy_E18"] == 30
    assert df["rtklib"]["codes"]["G"] == [["1C"], ["2W"]]
    for png in ("errors_gps_galileo_beidou_dual_frequency.png", "errors_gps_single_frequency.png", "skyplot.png"):
        assert (tmp_path / png).stat().st_size > 10_000


@pytest.mark.slow
def test_spp_walk_and_a_bag(tmp_path, capsys):
    assert main(["walk", "--short", "40", "--out", str(tmp_path / "walk"), "--data-dir", _data_dir()]) == 0
    doc = json.loads((tmp_path / "walk" / "spp.json").read_text())
    r = doc["runs"]["dual_frequency"]
    assert r["ours_all"]["epochs"] == 40 and r["status"] == {"ok": 40}
    # the RTK reference's absolute datum lies well above every single-point solution, RTKLIB's too
    # (docs/gnss_real_data.md): the spread about the mean is what compares
    assert r["ours_same_epochs"]["horizontal_rms_about_mean_m"] < 2.0
    assert r["ours_same_epochs"]["mean_enu_m"][2] < -10.0 and r["rtklib_same_epochs"]["mean_enu_m"][2] < -10.0
    f = tmp_path / "imp.yaml"
    f.write_text(yaml.safe_dump({"preset": "ubx", "gnss": {"file": str(rd.real_file(rd.WALK_UBX))}}))
    import_data.write(import_data.load_import(f), tmp_path / "bag")
    capsys.readouterr()
    assert main(["--bag", str(tmp_path / "bag"), "--short", "20", "--out", str(tmp_path / "bagout"), "--no-plots"]) == 0
    doc = json.loads((tmp_path / "bagout" / "spp.json").read_text())
    assert doc["kind"] == "bag" and doc["epochs"] == 20 and doc["records"] == 19
    st = {k: r["status"] for k, r in doc["runs"].items()}      # the default runs: every epoch solved
    assert st["dual_frequency"].get("ok", 0) + st["dual_frequency"].get("fault_excluded", 0) == 20, st
    assert st["gps_single_frequency"] == {"no_test": 20}      # 4 GPS records in the log: no redundancy to test


def test_spp_bad_description_exits_2(tmp_path, capsys):
    f = tmp_path / "d.yaml"
    f.write_text(yaml.safe_dump({"preset": "rinex", "gnss": {"file": "x.crx"}, "spp": {"runz": {}}}))
    assert main([str(f)]) == 2
    assert "spp.runz: unknown field" in capsys.readouterr().err


def test_spp_help_documents_every_option(capsys):
    from hyper_nav_workbench.spp import parser
    ap = parser()
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for a in ap._actions:
        for opt in a.option_strings:
            assert opt in text
        if a.option_strings:
            assert a.help, a.option_strings
    for word in ("OBS NAV", ".pos", "NMEA", "KML", "GPX", "--ref", "header", "Hatanaka", "RINEX 2.11", "4.0x"):
        assert word in text


def test_spp_on_files_directly(tmp_path, capsys, monkeypatch):
    """``spp OBS NAV`` on the shared TLSE files, no description: the header's
    position as reference (marker + antenna height), positions written in
    every format; the .pos reads back in the importer's reader with the
    positions of the CSV; the zipped navigation file reads the same; a
    navigation file with no record fails with its name."""
    import zipfile

    from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    monkeypatch.chdir(tmp_path)
    assert main([str(obs), str(nav), "--short", "20", "--ref", "header"]) == 0
    out = capsys.readouterr().out
    d = tmp_path / "spp_TLSE00FRA_R_20240011200_15M_01S_MO"           # default: the current directory
    assert "ANTENNA: DELTA H/E/N" in out
    doc = json.loads((d / "spp.json").read_text())
    r = doc["runs"]["dual_frequency"]
    assert r["ours_all"]["epochs"] == 20
    assert r["ours_all"]["horizontal_rms_m"] < 1.0 and r["ours_all"]["vertical_rms_m"] < 2.0
    stem = "TLSE00FRA_R_20240011200_15M_01S_MO"
    pos = read_pos(d / f"{stem}.pos")
    assert len(pos.t_gpst_s) == 20 and np.all(pos.quality == 5)
    rows = (d / f"{stem}.csv").read_text().splitlines()
    head = rows[0].split(",")
    first = dict(zip(head, rows[1].split(",")))
    assert abs(float(first["lat_deg"]) - np.rad2deg(pos.lat_rad[0])) < 1e-9
    assert float(first["height_m"]) == pytest.approx(pos.alt_m[0], abs=1e-4)
    assert first["used"].count("G") >= 8 and first["clock_reference_system"] == "G"
    for ext in ("nmea", "kml", "gpx"):
        assert (d / f"{stem}.{ext}").stat().st_size > 1000
    # the navigation file zipped: the same solution
    with zipfile.ZipFile(tmp_path / "nav.zip", "w", zipfile.ZIP_DEFLATED) as z:
        import gzip
        z.writestr("BRDC.rnx", gzip.decompress(nav.read_bytes()))
    assert main([str(obs), str(tmp_path / "nav.zip"), "--short", "20", "--out", str(tmp_path / "z"),
                 "--formats", "pos"]) == 0
    assert (tmp_path / "z" / f"{stem}.pos").read_text().splitlines()[-20:] == \
        (d / f"{stem}.pos").read_text().splitlines()[-20:]
    # the same solutions as NavSatFix in an MCAP bag, read back with the project's bag reader
    from hyper_nav_workbench.core.bag import deserialize, read_bag
    assert main([str(obs), str(nav), "--short", "20", "--out", str(tmp_path / "b"), "--formats", "pos",
                 "--fix-bag", str(tmp_path / "fixbag")]) == 0
    fixes = [deserialize(r.raw, r.msgtype) for r in read_bag(tmp_path / "fixbag", ["/gnss/fix"])]
    assert len(fixes) == 20
    f0 = fixes[0]
    assert abs(f0.latitude - np.rad2deg(pos.lat_rad[0])) < 1e-9 and abs(f0.altitude - pos.alt_m[0]) < 1e-4
    assert f0.header.stamp.sec == int(pos.t_gpst_s[0] + 315964800.0) and f0.position_covariance_type == 3
    assert f0.status.service == 1 | 4 | 8                        # GPS, BeiDou, Galileo used
    assert np.sqrt(f0.position_covariance[8]) == pytest.approx(pos.sigma_neu_m[0, 2], abs=1e-4)
    # a navigation file that yields no record: exit 2, the file named
    (tmp_path / "empty.zip").write_bytes(b"")
    capsys.readouterr()
    assert main([str(obs), str(tmp_path / "empty.zip"), "--short", "5", "--out", str(tmp_path / "e")]) == 2
    assert "empty.zip: empty file" in capsys.readouterr().err


@pytest.mark.slow
def test_rtklib_beside_is_its_own_postpos():
    """RTKLIB beside = RTKLIB's own postpos (pyrtklib) on the shared TLSE
    files, its .pos read back: GPS L1 + broadcast ionosphere on all 900
    epochs, 10 satellites, and the figures docs/gnss_real_data.md quotes
    against the header's antenna reference point (H 0.912, V 3.006 m;
    tolerance 5 mm); dual frequency IFLC: H 0.465 m, V 1.098 m."""
    from hyper_nav_workbench.core import rtklib_reference as rr
    from hyper_nav_workbench.core import spp_run
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    hdr = spp_run.read_files(obs, [nav], {"x": {"signals": {"G": ["1C"]}}}, max_epochs=1).header
    ref = spp_run.header_reference(hdr, str(obs))
    for dual, systems, h, v in ((False, ("G",), 0.912, 3.006), (True, ("G", "E", "C"), 0.465, 1.098)):
        sol = rr.postpos_rinex(obs, [nav], systems, dual, 10.0)
        assert sol.engine == "postpos" and len(sol.t_gpst_s) == 900 and sol.ok.all()
        if not dual:
            assert np.all(sol.n_sat == 10)
        e = spp_run.error_enu(sol.pos_ecef_m, np.tile(ref.xyz_m, (900, 1)), ref.xyz_m)
        st = spp_run.stats(e)
        assert st["horizontal_rms_m"] == pytest.approx(h, abs=5e-3) and st["vertical_rms_m"] == pytest.approx(v, abs=5e-3)


def test_rinex4_navigation_klobuchar_used_or_warned(tmp_path, capsys):
    """GPS L1 single frequency with a RINEX 4 navigation file written from
    the TLSE day's records: with its > ION Klobuchar record the positions
    are those of the RINEX 3 file (whose header holds the same set); without
    it a WARNING names the missing ionosphere and the heights move by
    metres (no silent loss of the model)."""
    spec = importlib.util.spec_from_file_location(
        "hyper_nav_rinex_formats", Path(__file__).resolve().parents[2] / "hyper_nav_gnss" / "test" / "formats"
        / "test_rinex_formats.py")
    rf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rf)
    from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
    obs, nav = rd.real_file(rd.TLSE_OBS), rd.real_file(rd.TLSE_NAV)
    rf._v4_nav(nav, tmp_path / "v4.rnx", per_system=100000)
    lines = (tmp_path / "v4.rnx").read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("> ION G01 LNAV"))
    (tmp_path / "v4_noion.rnx").write_text("\n".join(lines[:k] + lines[k + 4:]) + "\n")
    stem = "TLSE00FRA_R_20240011200_15M_01S_MO"
    pos = {}
    for name, nv in (("v3", nav), ("v4", tmp_path / "v4.rnx"), ("noion", tmp_path / "v4_noion.rnx")):
        capsys.readouterr()
        assert main([str(obs), str(nv), "--mode", "single", "--short", "10", "--formats", "pos",
                     "--out", str(tmp_path / name)]) == 0
        out = capsys.readouterr().out
        assert ("WARNING: no Klobuchar set for G" in out) == (name == "noion")
        pos[name] = read_pos(tmp_path / name / f"{stem}.pos")
    assert np.array_equal(pos["v3"].alt_m, pos["v4"].alt_m) and np.array_equal(pos["v3"].lat_rad, pos["v4"].lat_rad)
    assert np.mean(np.abs(pos["noion"].alt_m - pos["v3"].alt_m)) > 2.0
