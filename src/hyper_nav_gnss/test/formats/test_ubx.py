"""u-blox UBX reader (core/gnss/ubx.py, navmsg/*) on the walk_0827 raw log:
counts, signal lists, RAWX values against pyubx2's own full parse, decoded
GPS LNAV and BDS D1 records against RTKLIB's decoder (pyrtklib input_ubxf),
and bad input (a log cut mid-frame, a flipped checksum byte)."""
from __future__ import annotations

import importlib.util
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.formats.ubx import read_ubx

_spec = importlib.util.spec_from_file_location("hyper_nav_gnss_real_data", Path(__file__).parents[1] / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)         # pytest --import-mode=importlib: the helper by path
_spec.loader.exec_module(rd)


@pytest.fixture(scope="module")
def walk_bytes():
    return rd.real_file(rd.WALK_UBX).read_bytes()


@pytest.fixture(scope="module")
def walk(walk_bytes):
    t0 = time.perf_counter()
    log = read_ubx(walk_bytes)
    print(f"\nread {len(walk_bytes)} bytes of UBX in {time.perf_counter() - t0:.2f} s wall")
    return log


def test_walk_log_counts_and_signals(walk):
    c = walk.counts
    assert c["rawx_epochs"] == 536 and len(walk.epochs) == 536          # README: 536 RXM-RAWX epochs
    assert c["sfrbx"] == 2328                                            # README: 2,328 RXM-SFRBX subframes
    assert c["other_0x01_0x07"] == 536                                   # NAV-PVT, counted, not read
    assert not walk.errors and c["bad_checksum"] == 0 and c["truncated_frame"] == 0
    sig = {}
    for ep in walk.epochs:
        for s, code in zip(ep.system, ep.signal):
            sig.setdefault(s, set()).add(code)
    # u-blox X20: GPS L1 C/A, L2 CL, L5 Q; Galileo E1 C, E5a Q, E6 B; BDS B1C, B2a, B3I; SBAS L1
    assert sig == {"G": {"1C", "2L", "5Q"}, "E": {"1C", "5Q", "6B"}, "C": {"1P", "5P", "6I"}, "S": {"1C"}}
    sats = {(s, int(p)) for ep in walk.epochs for s, p in zip(ep.system, ep.prn)}
    per_sys = Counter(s for s, _ in sats)
    assert per_sys["G"] >= 7 and per_sys["E"] >= 7 and per_sys["C"] >= 10
    # 4 Hz: 0.25 s between epochs (receiver time tags)
    dt = np.diff([e.t_rx_gpst_s for e in walk.epochs])
    assert np.allclose(np.median(dt), 0.25, atol=1e-3)


def test_rawx_values_match_pyubx2_full_parse(walk, walk_bytes):
    """The numpy payload decoding against pyubx2's own RXM-RAWX parse (an
    independent decoder of the same bytes), every measurement of 40 epochs."""
    import io
    from pyubx2 import UBXReader
    rdr = UBXReader(io.BytesIO(walk_bytes), protfilter=2, quitonerror=0)
    k = 0
    for _, msg in rdr:
        if msg is None or msg.identity != "RXM-RAWX":
            continue
        ep = walk.epochs[k]
        assert ep.t_rx_gpst_s == pytest.approx(msg.week * 604800.0 + msg.rcvTow, abs=1e-9)
        j = 0
        for i in range(1, msg.numMeas + 1):
            g = getattr(msg, f"gnssId_{i:02d}")
            if g == "IMES":
                continue
            assert ep.pseudorange_m[j] == getattr(msg, f"prMes_{i:02d}")
            assert ep.doppler_hz[j] == pytest.approx(getattr(msg, f"doMes_{i:02d}"), rel=1e-7)
            assert ep.cn0_dbhz[j] == getattr(msg, f"cno_{i:02d}")
            assert ep.lock_time_s[j] == pytest.approx(getattr(msg, f"locktime_{i:02d}") * 1e-3)
            assert ep.prn[j] == getattr(msg, f"svId_{i:02d}")
            assert bool(ep.locked[j]) == bool(getattr(msg, f"prValid_{i:02d}"))
            cp_valid = bool(getattr(msg, f"cpValid_{i:02d}"))
            assert bool(ep.tracking_flags[j] & 2) == cp_valid
            assert bool(ep.tracking_flags[j] & 4) == bool(getattr(msg, f"halfCyc_{i:02d}"))
            if cp_valid:
                assert ep.carrier_phase_cycles[j] == getattr(msg, f"cpMes_{i:02d}")
            else:
                assert np.isnan(ep.carrier_phase_cycles[j])
            assert ep.pseudorange_sigma_m[j] == pytest.approx(0.01 * 2 ** getattr(msg, f"prStd_{i:02d}"))
            j += 1
        assert j == len(ep)
        k += 1
        if k == 40:
            break
    assert k == 40


def _rtklib_records(path):
    """Ephemerides RTKLIB (pyrtklib input_ubxf) decodes from the same log, by (system, prn)."""
    rk = pytest.importorskip("pyrtklib")
    raw = rk.raw_t()
    rk.init_raw(raw, rk.STRFMT_UBX)
    fw = rk.FileWrapper(str(path), "rb")
    out = {}
    while True:
        r = rk.input_ubxf(raw, fw)
        if r == -2:
            break
        if r == 2:
            e = raw.nav.eph[raw.ephsat - 1]
            sat = e.sat
            sysid = ("G", sat) if sat <= rk.MAXPRNGPS else None
            if sat > 105:                             # RTKLIB 2.4.3 numbering: GPS 1-32, ..., BDS from 106
                sysid = ("C", sat - 105)
            if sysid:
                out[sysid] = e
    return out


def test_lnav_and_d1_records_match_rtklib(walk):
    ref = _rtklib_records(rd.real_file(rd.WALK_UBX))
    ours = {(e.system, e.prn): e for e in walk.records() if e.system in ("G", "C")}
    assert len(ours) == 12 and set(ours) == set(ref)       # 4 GPS + 8 BDS complete sets in 134 s
    for key, e in ours.items():
        r = ref[key]
        pairs = {"sqrtA^2": (e.sqrtA ** 2, r.A), "e": (e.e, r.e), "i0": (e.i0, r.i0), "Omega0": (e.Omega0, r.OMG0),
                 "omega": (e.omega, r.omg), "M0": (e.M0, r.M0), "delta_n": (e.delta_n, r.deln),
                 "OmegaDot": (e.OmegaDot, r.OMGd), "idot": (e.idot, r.idot), "crc": (e.crc, r.crc),
                 "crs": (e.crs, r.crs), "cuc": (e.cuc, r.cuc), "cus": (e.cus, r.cus), "cic": (e.cic, r.cic),
                 "cis": (e.cis, r.cis), "toe": (e.toe, r.toes), "af0": (e.af0, r.f0), "af1": (e.af1, r.f1),
                 "af2": (e.af2, r.f2), "tgd": (e.tgd, r.tgd[0]), "iode": (e.iode, r.iode), "health": (e.health, r.svh)}
        if key[0] == "C":
            pairs["tgd2"] = (e.tgd2, r.tgd[1])
        for name, (a, b) in pairs.items():
            assert a == pytest.approx(b, rel=1e-12, abs=1e-25), f"{key} {name}: ours {a}, RTKLIB {b}"
    assert ours[("C", 50)].health == 1                    # SatH1 set in the log: unhealthy, kept and flagged


def test_cut_mid_frame_and_flipped_checksum_are_counted(walk_bytes, walk):
    cut = walk_bytes[: len(walk_bytes) // 2 + 37]
    log = read_ubx(cut)
    assert log.counts["truncated_frame"] == 1 and "frame after byte" in log.errors[0]
    assert 200 < len(log.epochs) < 536                      # everything before the cut was read
    assert [e.t_rx_gpst_s for e in log.epochs] == [e.t_rx_gpst_s for e in walk.epochs[:len(log.epochs)]]
    # flip one byte inside the first RXM-RAWX payload
    k = walk_bytes.index(b"\xb5\x62\x02\x15")
    bad = bytearray(walk_bytes)
    bad[k + 6 + 20] ^= 0x5A
    log = read_ubx(bytes(bad))
    assert log.counts["bad_checksum"] == 1 and "checksum mismatch" in log.errors[0]
    assert "0x02 0x15" in log.errors[0]
    assert len(log.epochs) == 535 and log.epochs[0].t_rx_gpst_s == walk.epochs[1].t_rx_gpst_s
    assert len(log.records()) == len(walk.records())


def test_rawx_with_a_wrong_measurement_count_is_named():
    from pyubx2 import UBXMessage
    payload = bytes(16 + 32)                                 # numMeas = 0 in the header, one block present
    msg = UBXMessage(0x02, 0x15, 0, payload=payload)
    log = read_ubx(msg.serialize())
    assert log.counts["rawx_bad_length"] == 1 and "numMeas 0 needs 16 bytes, payload has 48" in log.errors[0]
    assert not log.epochs
