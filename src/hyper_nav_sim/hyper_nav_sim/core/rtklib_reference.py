"""RTKLIB's single-point solution (``pntpos``, RTKLIB 2.4.3 through the
``pyrtklib`` binding) on the same observations, as the field's reference
implementation beside ours. No rclpy.

* RINEX: ``readrnx`` reads the observation file (Hatanaka files are expanded
  to a temporary RINEX file first: RTKLIB's own reader calls the ``crx2rnx``
  program, which is not installed) and the navigation file (gunzipped the
  same way).
* UBX: RTKLIB decodes the log itself (``input_ubxf``) for the observations;
  its UBX decoder in this build gives no Galileo I/NAV record from the
  u-blox X20 log (and only what a receiver has decoded so far at each
  epoch), so it is handed *our* decoded records of the whole log written as
  a RINEX 3 navigation file (:func:`~hyper_nav_filter.core.gnss.rinex_nav.write_rinex3_nav`):
  the same broadcast information as our solution.

Options (``prcopt_t``): single mode, the systems asked for, ionosphere
``IFLC`` (dual frequency: RTKLIB forms the combination of its first two
frequency slots, i.e. the codes of its own priority table) or ``BRDC``
(Klobuchar), Saastamoinen troposphere, the same elevation mask; RTKLIB's
default error model and no RAIM (its ``posopt[4]`` off), as ``rnx2rtkp``
runs by default. Epochs are returned with RTKLIB's time (GPST).
"""
from __future__ import annotations

import gzip
import pathlib
import tempfile
from dataclasses import dataclass

import numpy as np

UNIX_GPS_OFFSET_S = 315964800.0


@dataclass
class RtklibSolution:
    t_gpst_s: np.ndarray           # continuous GPST seconds
    pos_ecef_m: np.ndarray         # (n, 3), NaN where pntpos failed
    n_sat: np.ndarray
    ok: np.ndarray
    message: str = ""
    codes: dict | None = None      # observation codes RTKLIB used per system (first two slots)


def _rk():
    import pyrtklib
    return pyrtklib


def _options(rk, systems, dual: bool, elmask_deg: float):
    opt = rk.prcopt_default
    opt.mode = rk.PMODE_SINGLE
    mask = 0
    for s in systems:
        mask |= {"G": rk.SYS_GPS, "E": rk.SYS_GAL, "C": rk.SYS_CMP, "J": rk.SYS_QZS}[s]
    opt.navsys = mask
    opt.ionoopt = rk.IONOOPT_IFLC if dual else rk.IONOOPT_BRDC
    opt.tropopt = rk.TROPOPT_SAAS
    opt.elmin = float(np.deg2rad(elmask_deg))
    opt.nf = 2 if dual else 1
    return opt


def _t(gt) -> float:
    return float(gt.time) + float(gt.sec) - UNIX_GPS_OFFSET_S


def _solve(rk, data, n, nav, opt, sol, msg, ssat):
    azel = rk.Arr1Ddouble(2 * max(n, 1))
    ok = rk.pntpos(data, int(n), nav, opt, sol, azel, ssat.ptr, msg)
    return bool(ok), [float(sol.rr[k]) for k in range(3)], int(sol.ns)


def solve_rinex(obs_path, nav_path, systems=("G", "E", "C"), dual=True, elmask_deg=10.0,
                times_gpst_s=None) -> RtklibSolution:
    """pntpos on every epoch of a RINEX observation file (or only those at
    ``times_gpst_s``, within 1 ms)."""
    rk = _rk()
    from hyper_nav_filter.core.gnss.rinex_obs import read_text
    with tempfile.TemporaryDirectory(prefix="rtklib_") as tmp:
        o = pathlib.Path(tmp) / "obs.rnx"
        o.write_text(read_text(obs_path))
        nv = pathlib.Path(tmp) / "nav.rnx"
        p = pathlib.Path(nav_path)
        if p.suffix == ".gz":
            with gzip.open(p, "rb") as f:
                nv.write_bytes(f.read())
        else:
            nv.write_bytes(p.read_bytes())
        obs, nav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
        if rk.readrnx(str(o), 1, "", obs, nav, sta) != 1 or rk.readrnx(str(nv), 1, "", obs, nav, sta) != 1:
            raise RuntimeError(f"RTKLIB readrnx could not read {obs_path} / {nav_path}")
    d = obs.data
    tt = np.array([_t(d[i].time) for i in range(obs.n)])
    starts = np.flatnonzero(np.r_[True, np.diff(tt) != 0])
    ends = np.r_[starts[1:], obs.n]
    want = None if times_gpst_s is None else np.asarray(times_gpst_s, float)
    opt = _options(rk, systems, dual, elmask_deg)
    sol, msg, ssat = rk.sol_t(), rk.Arr1Dchar(256), rk.Arr1Dssat_t(rk.MAXSAT)
    ts, ps, ns, oks = [], [], [], []
    for a, b in zip(starts, ends):
        t = tt[a]
        if want is not None and not np.any(np.abs(want - t) < 1e-3):
            continue
        ok, r, nsat = _solve(rk, d[int(a):int(b)].ptr, b - a, nav, opt, sol, msg, ssat)
        ts.append(t)
        ps.append(r if ok else [np.nan] * 3)
        ns.append(nsat)
        oks.append(ok)
    codes = _used_codes(rk, d, obs.n, systems)
    return RtklibSolution(np.array(ts), np.array(ps, float).reshape(-1, 3), np.array(ns), np.array(oks, bool),
                          "".join(msg[i] for i in range(64)).split("\x00")[0], codes)


def _used_codes(rk, d, n, systems) -> dict:
    """The observation codes in RTKLIB's first two frequency slots, per system (a sample of epochs)."""
    out: dict = {}
    step = max(1, n // 2000)
    names = {rk.SYS_GPS: "G", rk.SYS_GAL: "E", rk.SYS_CMP: "C", rk.SYS_QZS: "J"}
    prn = rk.Arr1Dint(1)
    for i in range(0, n, step):
        o = d[i]
        s = names.get(int(rk.satsys(int(o.sat), prn)))
        if s not in systems:
            continue
        codes = list(o.code)
        for k in range(2):
            if codes[k]:
                out.setdefault(s, [set(), set()])[k].add(rk.code2obs(int(codes[k])))
    return {s: [sorted(x) for x in v] for s, v in out.items()}


def solve_ubx(ubx_path, records, iono, systems=("G", "E", "C"), dual=True, elmask_deg=10.0) -> RtklibSolution:
    """pntpos on every RXM-RAWX epoch RTKLIB decodes from a UBX log, with
    ``records`` (our decoded BroadcastEphemeris of the whole log, written as
    RINEX 3 navigation) as its navigation data."""
    rk = _rk()
    from hyper_nav_filter.core.gnss.rinex_nav import write_rinex3_nav
    with tempfile.TemporaryDirectory(prefix="rtklib_") as tmp:
        nv = pathlib.Path(tmp) / "nav.rnx"
        write_rinex3_nav(nv, records, iono)
        obs0, nav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
        if rk.readrnx(str(nv), 1, "", obs0, nav, sta) != 1:
            raise RuntimeError("RTKLIB readrnx could not read the navigation file written from the log")
    raw = rk.raw_t()
    rk.init_raw(raw, rk.STRFMT_UBX)
    fw = rk.FileWrapper(str(ubx_path), "rb")
    opt = _options(rk, systems, dual, elmask_deg)
    sol, msg, ssat = rk.sol_t(), rk.Arr1Dchar(256), rk.Arr1Dssat_t(rk.MAXSAT)
    ts, ps, ns, oks = [], [], [], []
    codes: dict = {}
    while True:
        r = rk.input_ubxf(raw, fw)
        if r == -2:
            break
        if r != 1:
            continue
        n = raw.obs.n
        ok, pos, nsat = _solve(rk, raw.obs.data.ptr, n, nav, opt, sol, msg, ssat)
        ts.append(_t(raw.time))
        ps.append(pos if ok else [np.nan] * 3)
        ns.append(nsat)
        oks.append(ok)
        if len(ts) == 1:
            codes = _used_codes(rk, raw.obs.data, n, systems)
    return RtklibSolution(np.array(ts), np.array(ps, float).reshape(-1, 3), np.array(ns), np.array(oks, bool),
                          "".join(msg[i] for i in range(64)).split("\x00")[0], codes)
