"""RINEX 3 observation reader (core/gnss/rinex_obs.py) on the TLSE file of
../shared/real-data (Hatanaka + gzip): counts, the header's signal lists,
values against georinex (an independent reader) over the first minute, and
bad input written to tmp_path (a requested observation type the header does
not list, a malformed epoch line): named, counted, the rest read."""
from __future__ import annotations

import importlib.util
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from hyper_nav_gnss.formats.rinex_obs import read_rinex_obs, read_text

_spec = importlib.util.spec_from_file_location("hyper_nav_gnss_real_data", Path(__file__).parents[1] / "_real_data.py")
rd = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rd)

SEL = {"G": ["1C", "2W"], "E": ["1X", "7X", "5X"], "C": ["2I", "6I"]}


@pytest.fixture(scope="module")
def tlse():
    path = rd.real_file(rd.TLSE_OBS)
    t0 = time.perf_counter()
    obs = read_rinex_obs(path, signals=SEL)
    print(f"\nTLSE 15 min 1 Hz, G/E/C selected codes: read in {time.perf_counter() - t0:.2f} s wall")
    return obs


def test_tlse_counts_header_and_signal_lists(tlse):
    h = tlse.header
    assert len(tlse.epochs) == 900 and tlse.counts["epochs"] == 900 and not tlse.errors
    assert np.allclose(h["approx_xyz_m"], rd.TLSE_XYZ_M) and h["antenna_delta_hen_m"][0] == pytest.approx(1.053)
    assert h["obs_types"]["G"] == ["C1C", "C1X", "C2W", "C2X", "C5X", "D1C", "D1X", "D2W", "D2X", "D5X", "L1C", "L1X",
                                   "L2W", "L2X", "L5X", "S1C", "S1X", "S2W", "S2X", "S5X"]
    assert len(h["obs_types"]["E"]) == 20 and len(h["obs_types"]["C"]) == 24 and h["interval_s"] == 1.0
    sats = {}
    for ep in tlse.epochs:
        for s, p, c in zip(ep.system, ep.prn, ep.signal):
            sats.setdefault(s, set()).add(int(p))
            assert c in SEL[s]
    # the header's PRN / # OF OBS list: 12 GPS, 6 Galileo, 14 BeiDou satellites
    assert (len(sats["G"]), len(sats["E"]), len(sats["C"])) == (12, 6, 14)
    dt = np.diff([e.t_rx_gpst_s for e in tlse.epochs])
    assert np.all(dt == 1.0)
    # first epoch 2024-01-01 12:00:00 GPST = GPS week 2295, 129600 s of week
    assert tlse.epochs[0].t_rx_gpst_s == 2295 * 604800.0 + 129600.0


def test_tlse_values_match_georinex(tlse):
    """Every C, L, S value of four codes over the first 60 epochs against
    georinex's own reading of the same file (exact: both parse F14.3)."""
    gr = pytest.importorskip("georinex")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = gr.load(rd.real_file(rd.TLSE_OBS), use=["G", "E"], meas=["C1C", "C2W", "C1X", "C7X", "L1C", "S1C"],
                     tlim=["2024-01-01T12:00:00", "2024-01-01T12:00:59"])
    assert ds.sizes["time"] == 60
    n = 0
    for k, ep in enumerate(tlse.epochs[:60]):
        for j, (s, p, c) in enumerate(zip(ep.system, ep.prn, ep.signal)):
            if s not in ("G", "E") or ("C" + c) not in ds:
                continue
            sv = f"{s}{int(p):02d}"
            ref = float(ds["C" + c].sel(sv=sv).values[k])
            assert ep.pseudorange_m[j] == ref, (sv, c, k)
            if c == "1C":
                assert ep.cn0_dbhz[j] == float(ds["S1C"].sel(sv=sv).values[k])
                lv = float(ds["L1C"].sel(sv=sv).values[k])
                assert (np.isnan(lv) and np.isnan(ep.carrier_phase_cycles[j])) or ep.carrier_phase_cycles[j] == lv
            n += 1
    assert n > 60 * 15


def test_missing_observation_type_and_malformed_epoch_are_named_and_counted(tmp_path):
    text = read_text(rd.real_file(rd.TLSE_OBS)).splitlines()
    head = text.index(next(x for x in text if "END OF HEADER" in x))
    epochs = [k for k in range(head + 1, len(text)) if text[k].startswith(">")]
    cut = text[:epochs[5]]                                # header + 5 epochs
    cut[epochs[2]] = "> 2024 01 01 12 00 xx"              # a malformed epoch record
    f = tmp_path / "bad.rnx"
    f.write_text("\n".join(cut) + "\n")
    obs = read_rinex_obs(f, signals={"G": ["1C", "2L"], "E": ["1X"]})
    assert obs.counts["missing_code_G2L"] == 1
    assert any("signal G 2L: no C2L in the header" in e for e in obs.errors)
    assert any("malformed epoch record" in e and "line" in e for e in obs.errors)
    # the malformed epoch's satellite lines are not epochs: each is named as well; the other 4 epochs are read
    assert len(obs.epochs) == 4
    assert all(set(ep.signal) <= {"1C", "1X"} for ep in obs.epochs)


def _same_epochs(a, b):
    assert len(a.epochs) == len(b.epochs) and a.counts == b.counts and a.errors == b.errors
    for x, y in zip(a.epochs, b.epochs):
        for k in x.__dataclass_fields__:
            u, v = getattr(x, k), getattr(y, k)
            if isinstance(u, np.ndarray):
                assert u.dtype == v.dtype and np.array_equal(u, v, equal_nan=True), k
            else:
                assert u == v and type(u) is type(v), k


def test_code_and_cn0_reading_at_once_equals_the_line_by_line_one(tmp_path, monkeypatch):
    """Codes and C/N0 only (single-point positioning) are read with every
    satellite line's numbers parsed at once; the same epochs, channels,
    values, types and counts as the line-by-line reading, on TLSE (every
    system and code of the header, and the SPP plan); a file with a
    malformed satellite line falls back to the line-by-line reading, which
    names the line."""
    from hyper_nav_gnss.formats import rinex_obs
    path = rd.real_file(rd.TLSE_OBS)
    text = read_text(path)
    plain = tmp_path / "tlse.rnx"
    plain.write_text(text)
    spp_plan = {"G": ["1C", "2W", "2L", "5Q", "5X"], "E": ["1X", "7X", "1C", "7Q", "5Q", "5X"], "C": ["2I", "6I"]}
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("> 2024 01 01 12 00 30.0"))
    bad = list(lines)
    bad[k + 1] = bad[k + 1][:1] + "0x" + bad[k + 1][3:]                  # a satellite number that is not one
    broken = tmp_path / "broken.rnx"
    broken.write_text("\n".join(bad) + "\n")
    fast = rinex_obs._read_code_and_cn0
    for f, signals in ((plain, None), (plain, spp_plan), (broken, spp_plan)):
        monkeypatch.setattr(rinex_obs, "_read_code_and_cn0", fast)
        calls = []
        monkeypatch.setattr(rinex_obs, "_read_code_and_cn0", lambda *a: calls.append(fast(*a)) or calls[-1])
        a = read_rinex_obs(f, signals=signals, observables="S")
        assert len(calls) == 1 and (calls[0] is None) == (f == broken)
        monkeypatch.setattr(rinex_obs, "_read_code_and_cn0", lambda *a: None)
        b = read_rinex_obs(f, signals=signals, observables="S")
        _same_epochs(a, b)
        assert len(a.epochs) == 900
    assert any(f"line {k + 2} " in e for e in a.errors)
