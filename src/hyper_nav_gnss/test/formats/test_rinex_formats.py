"""RINEX as archives and versions hold it (core/gnss/rinex_file.py,
rinex_obs.py, rinex_nav.py): a few epochs cut from the shared TLSE file and
written back plain, gzip, .Z, zip, bzip2 and Hatanaka all read the same;
a RINEX 2.11 observation file written by the test from the same values
reads the same pseudoranges; RINEX 2 GPS navigation (the shared brdc1180.21n);
a RINEX 4 navigation file written by the test from the TLSE day's records
(> EPH LNAV/INAV/D1 read as the RINEX 3 records, > ION Klobuchar used,
CNAV, NeQuick-G, STO and EOP counted); refusals that name the file, the line
and what."""
from __future__ import annotations

import bz2
import gzip
import importlib.util
import zipfile
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.formats.rinex_file import RinexFormatError, read_rinex_text
from hyper_nav_gnss.formats.rinex_nav import read_rinex2_nav, read_rinex_nav, read_rinex3_nav_records
from hyper_nav_gnss.formats.rinex_obs import read_rinex_obs

_spec = importlib.util.spec_from_file_location("hyper_nav_gnss_real_data", Path(__file__).parents[1] / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)

SEL = {"G": ["1C", "2W"], "E": ["1X", "7X"], "C": ["2I", "6I"]}


@pytest.fixture(scope="module")
def cut(tmp_path_factory):
    """The TLSE header and its first 3 epochs as a plain RINEX 3 file."""
    text = read_rinex_text(rd.real_file(rd.TLSE_OBS))
    lines = text.splitlines()
    end = next(k for k, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    starts = [k for k in range(end, len(lines)) if lines[k].startswith(">")]
    p = tmp_path_factory.mktemp("cut") / "TLSE_cut.rnx"
    p.write_text("\n".join(lines[:starts[3]]) + "\n")
    return p


def _pr(obs):
    return [(e.t_rx_gpst_s, s, int(p), c, float(v)) for e in obs.epochs
            for s, p, c, v in zip(e.system, e.prn, e.signal, e.pseudorange_m)]


def test_archives_read_the_same(cut, tmp_path):
    hatanaka = pytest.importorskip("hatanaka")
    ncompress = pytest.importorskip("ncompress")
    raw = cut.read_bytes()
    ref = read_rinex_obs(cut, signals=SEL)
    assert len(ref.epochs) == 3 and not ref.errors
    (tmp_path / "a.rnx.gz").write_bytes(gzip.compress(raw))
    (tmp_path / "a.rnx.Z").write_bytes(ncompress.compress(raw))
    (tmp_path / "a.rnx.bz2").write_bytes(bz2.compress(raw))
    with zipfile.ZipFile(tmp_path / "a.zip", "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("TLSE_cut.rnx", raw)
    (tmp_path / "a.crx").write_bytes(hatanaka.compress(raw, compression="none"))
    (tmp_path / "a.crx.gz").write_bytes(hatanaka.compress(raw, compression="gz"))
    for name in ("a.rnx.gz", "a.rnx.Z", "a.rnx.bz2", "a.zip", "a.crx", "a.crx.gz"):
        got = read_rinex_obs(tmp_path / name, signals=SEL)
        assert _pr(got) == _pr(ref), name
        assert np.allclose(got.header["approx_xyz_m"], rd.TLSE_XYZ_M)


def test_refusals_name_file_line_and_what(cut, tmp_path):
    with zipfile.ZipFile(tmp_path / "two.zip", "w") as z:
        z.writestr("a.rnx", "x")
        z.writestr("b.rnx", "y")
    with pytest.raises(RinexFormatError, match=r"two.zip: zip archive with 2 files"):
        read_rinex_obs(tmp_path / "two.zip")
    (tmp_path / "empty.rnx").write_bytes(b"")
    with pytest.raises(RinexFormatError, match="empty.rnx: empty file"):
        read_rinex_nav(tmp_path / "empty.rnx")
    (tmp_path / "notes.txt").write_text("hello\n")
    with pytest.raises(RinexFormatError, match=r"notes.txt line 1: not a RINEX file"):
        read_rinex_obs(tmp_path / "notes.txt")
    lines = cut.read_text().splitlines()
    (tmp_path / "v5.rnx").write_text("\n".join(["     5.00" + lines[0][9:]] + lines[1:]) + "\n")
    with pytest.raises(RinexFormatError, match=r"v5.rnx line 1: RINEX observation version 5.00"):
        read_rinex_obs(tmp_path / "v5.rnx")
    with pytest.raises(RinexFormatError, match=r"TLSE_cut.rnx line 1: file type 'O', not a navigation file"):
        read_rinex_nav(cut)


def _v2_obs(obs3, path):
    """A RINEX 2.11 mixed observation file of ``obs3``'s epochs: C1 P2 L1 L2 S1 of GPS, C1 C7 of Galileo."""
    types = ["C1", "P2", "L1", "L2", "S1", "C7"]
    code = {("G", "C1"): "1C", ("G", "P2"): "2W", ("E", "C1"): "1X", ("E", "C7"): "7X"}
    h = obs3.header
    out = [f"{2.11:9.2f}{'':11s}{'OBSERVATION DATA':20s}{'M (MIXED)':20s}RINEX VERSION / TYPE",
           f"{'TLSE':60s}MARKER NAME",
           "".join(f"{x:14.4f}" for x in h["approx_xyz_m"]) + f"{'':18s}APPROX POSITION XYZ",
           "".join(f"{x:14.4f}" for x in h["antenna_delta_hen_m"]) + f"{'':18s}ANTENNA: DELTA H/E/N",
           f"{len(types):6d}" + "".join(f"{t:>6s}" for t in types) + f"{'':{54 - 6 * len(types)}s}# / TYPES OF OBSERV",
           f"{'':60s}END OF HEADER"]
    for e in obs3.epochs:
        sats = {}
        for s, p, c, v, cp, cn in zip(e.system, e.prn, e.signal, e.pseudorange_m, e.carrier_phase_cycles, e.cn0_dbhz):
            if s in ("G", "E"):
                sats.setdefault(f"{s}{int(p):02d}", {})[c] = (v, cp, cn)
        ids = sorted(sats)
        wk, sow = divmod(e.t_rx_gpst_s, 604800.0)
        out.append(f" 24  1  1 12  0{sow - 129600.0:11.7f}  0{len(ids):3d}" + "".join(ids[:12]))
        for k in range(12, len(ids), 12):
            out.append(" " * 32 + "".join(ids[k:k + 12]))
        for sid in ids:
            vals = []
            for t in types:
                c = code.get((sid[0], t))
                if t in ("L1", "S1", "L2"):
                    c = code.get((sid[0], "C1" if t != "L2" else "P2"))
                got = sats[sid].get(c) if c else None
                x = None if got is None else (got[0] if t[0] in "CP" else got[1] if t[0] == "L" else got[2])
                vals.append(f"{x:14.3f}  " if x is not None and np.isfinite(x) else " " * 16)
            out.append("".join(vals[:5]).rstrip())
            out.append("".join(vals[5:]).rstrip())
    Path(path).write_text("\n".join(out) + "\n")


def test_rinex2_observation_file_reads_the_same_pseudoranges(cut, tmp_path):
    obs3 = read_rinex_obs(cut, signals={"G": ["1C", "2W"], "E": ["1X", "7X"]})
    _v2_obs(obs3, tmp_path / "tlse0010.24o")
    obs2 = read_rinex_obs(tmp_path / "tlse0010.24o", signals={"G": ["1C", "2W"], "E": ["1X", "7X"]})
    assert obs2.header["version"] == 2.11 and not obs2.errors
    assert np.allclose(obs2.header["approx_xyz_m"], rd.TLSE_XYZ_M)
    a, b = _pr(obs3), _pr(obs2)
    assert len(a) == len(b) > 50
    assert sorted(a) == sorted(b)                        # same time, satellite, code, value (F14.3)
    hatanaka = pytest.importorskip("hatanaka")             # the same file as Compact RINEX 1 (.yyd), gzipped
    (tmp_path / "tlse0010.24d.gz").write_bytes(hatanaka.compress((tmp_path / "tlse0010.24o").read_bytes(),
                                                                  compression="gz"))
    assert _pr(read_rinex_obs(tmp_path / "tlse0010.24d.gz", signals={"G": ["1C", "2W"], "E": ["1X", "7X"]})) == b
    e3, e2 = obs3.epochs[0], obs2.epochs[0]
    k3 = [i for i, (s, c) in enumerate(zip(e3.system, e3.signal)) if s == "G" and c == "1C"]
    k2 = [i for i, (s, c) in enumerate(zip(e2.system, e2.signal)) if s == "G" and c == "1C"]
    assert np.allclose(e2.cn0_dbhz[k2], e3.cn0_dbhz[k3], equal_nan=True)
    assert np.allclose(e2.carrier_phase_cycles[k2], e3.carrier_phase_cycles[k3], equal_nan=True)


def test_rinex2_navigation(tmp_path):
    p = rd.gnss_real_file("brdc1180.21n")
    nav = read_rinex_nav(p)
    assert nav.version == 2.0 or 2.0 <= nav.version < 3.0
    assert len(nav) == 105 and nav.counts["G"] == 105 and "G" in nav.iono
    ephs, alpha, beta = read_rinex2_nav(p)
    assert np.allclose(nav.iono["G"][0], alpha)
    (tmp_path / "brdc1180.21n.gz").write_bytes(gzip.compress(p.read_bytes()))
    assert len(read_rinex_nav(tmp_path / "brdc1180.21n.gz")) == 105
    glo = p.read_text().splitlines()
    glo[0] = glo[0][:20] + "G" + glo[0][21:]
    (tmp_path / "brdc1180.21g").write_text("\n".join(glo) + "\n")
    with pytest.raises(RinexFormatError, match=r"brdc1180.21g line 1: RINEX 2 navigation file of type 'G' \(GLONASS\)"):
        read_rinex_nav(tmp_path / "brdc1180.21g")


def _v4_nav(v3_path, out_path, per_system=3):
    """A RINEX 4.01 navigation file of the first records of G, E, C of a
    RINEX 3 file, with ION (GPS LNAV from the header's GPSA/GPSB, Galileo
    NeQuick-G), STO, EOP and a GPS CNAV record."""
    lines = read_rinex_text(v3_path).splitlines()
    end = next(k for k, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    gpsa = next(ln for ln in lines[:end] if ln.startswith("GPSA"))
    gpsb = next(ln for ln in lines[:end] if ln.startswith("GPSB"))
    a = [float(gpsa[5 + 12 * k:17 + 12 * k].replace("D", "E")) for k in range(4)]
    b = [float(gpsb[5 + 12 * k:17 + 12 * k].replace("D", "E")) for k in range(4)]
    out = [f"{4.01:9.2f}{'':11s}{'N: GNSS NAV DATA':20s}{'M: MIXED':20s}RINEX VERSION / TYPE",
           f"{'':60s}END OF HEADER",
           "> STO G01 LNAV", "    2024 01 01 00 00 00 GPUT", " " * 4 + f"{1.0:19.12e}" * 4,
           "> EOP G01 CNVX", "    2024 01 01 00 00 00" + f"{0.0:19.12e}" * 3, " " * 23 + f"{0.0:19.12e}" * 3,
           " " * 4 + f"{0.0:19.12e}" * 4,
           "> ION G01 LNAV", "    2024 01 01 00 00 00" + "".join(f"{x:19.12e}" for x in a[:3]),
           " " * 4 + "".join(f"{x:19.12e}" for x in [a[3]] + b[:3]), " " * 4 + f"{b[3]:19.12e}",
           "> ION E01 IFNV", "    2024 01 01 00 00 00" + f"{50.0:19.12e}" * 3, " " * 4 + f"{0.0:19.12e}"]
    n = {"G": 0, "E": 0, "C": 0}
    k = end
    while k < len(lines):
        ln = lines[k]
        s = ln[:1]
        if s in n and n[s] < per_system and ln[1:3].strip().isdigit():
            msg = {"G": "LNAV", "E": "INAV", "C": "D1"}[s]
            out.append(f"> EPH {ln[:3]} {msg}")
            out += lines[k:k + 8]
            n[s] += 1
            k += 8
            continue
        k += 1
    out += ["> EPH G01 CNAV"] + ["    " + f"{0.0:19.12e}" * 4] * 9
    Path(out_path).write_text("\n".join(out) + "\n")
    return a, b


def test_rinex4_navigation_written_from_the_tlse_day(tmp_path):
    v3 = rd.real_file(rd.TLSE_NAV)
    a, b = _v4_nav(v3, tmp_path / "brdc.rnx")
    nav = read_rinex_nav(tmp_path / "brdc.rnx")
    assert nav.version == 4.01
    assert (nav.counts["G"], nav.counts["E"], nav.counts["C"]) == (3, 3, 3)
    assert nav.counts["skipped_EPH_G_CNAV"] == 1 and nav.counts["skipped_STO"] == 1 and nav.counts["skipped_EOP"] == 1
    assert nav.counts["ION_G_LNAV"] == 1 and nav.counts["skipped_ION_E_IFNV"] == 1
    assert any("NeQuick-G" in x for x in nav.notes)
    assert np.allclose(nav.iono["G"][0], a, rtol=1e-9) and np.allclose(nav.iono["G"][1], b, rtol=1e-9)
    v3recs = read_rinex3_nav_records(v3)
    assert np.allclose(v3recs.iono["G"][0], a, rtol=1e-9)
    for r in nav:                                           # the same records as the RINEX 3 reading
        twin = [x for x in v3recs if (x.system, x.prn, x.toc_s, x.week, x.data_source, x.iode) ==
                (r.system, r.prn, r.toc_s, r.week, r.data_source, r.iode)][0]
        assert twin == r


def test_rinex4_unknown_record_and_zero_records_refused(tmp_path):
    v3 = rd.real_file(rd.TLSE_NAV)
    _v4_nav(v3, tmp_path / "ok.rnx")
    lines = (tmp_path / "ok.rnx").read_text().splitlines()
    bad = lines[:2] + lines[2:9] + ["> XYZ G01 LNAV", "    2024 01 01 00 00 00"] + lines[9:]
    (tmp_path / "bad.rnx").write_text("\n".join(bad) + "\n")
    with pytest.raises(RinexFormatError, match=r"bad.rnx line 10: unknown RINEX 4 record '> XYZ G01 LNAV'"):
        read_rinex_nav(tmp_path / "bad.rnx")
    bad2 = [ln.replace("> EPH E", "> EPH E").replace(" INAV", " XNAV") for ln in lines]
    (tmp_path / "bad2.rnx").write_text("\n".join(bad2) + "\n")
    with pytest.raises(RinexFormatError, match=r"bad2.rnx line \d+: unknown > EPH message type 'XNAV' of system 'E'"):
        read_rinex_nav(tmp_path / "bad2.rnx")
    # a RINEX 3 file with GLONASS records only: no record of G/E/C/J -> refused, not read as empty
    text = read_rinex_text(v3).splitlines()
    end = next(k for k, ln in enumerate(text) if "END OF HEADER" in ln) + 1
    glo = text[:end]
    k = end
    while k < len(text) and len(glo) < end + 40:
        if text[k].startswith("R"):
            glo += text[k:k + 4]
        k += 1
    (tmp_path / "glo.rnx").write_text("\n".join(glo) + "\n")
    with pytest.raises(RinexFormatError, match=r"glo.rnx: no broadcast record of G/E/C/J"):
        read_rinex_nav(tmp_path / "glo.rnx")
