"""RTKLIB's single-point solution (RTKLIB 2.4.3 through the ``pyrtklib``
binding) on the same observations, as the field's reference implementation
beside ours. No rclpy.

* RINEX: :func:`postpos_rinex` runs RTKLIB's own ``postpos`` (the engine of
  ``rnx2rtkp``: its own reading, ``uniqnav``, system selection, epoch
  loop and ``.pos`` writer) on the files decompressed to a temporary folder
  and reads the ``.pos`` it writes back: RTKLIB as it runs.
  :func:`solve_rinex` (``readrnx`` + ``pntpos`` per epoch, every observation
  of the epoch handed over, no ``uniqnav``) is the older wrapper, kept for
  the comparison of the two.

* RINEX: ``readrnx`` reads the observation file (Hatanaka files are expanded
  to a temporary RINEX file first: RTKLIB's own reader calls the ``crx2rnx``
  program, which is not installed) and the navigation file (gunzipped the
  same way).
* UBX: RTKLIB decodes the log itself (``input_ubxf``) for the observations;
  its UBX decoder in this build gives no Galileo I/NAV record from the
  u-blox X20 log (and only what a receiver has decoded so far at each
  epoch), so it is handed *our* decoded records of the whole log written as
  a RINEX 3 navigation file (:func:`~hyper_nav_gnss.formats.rinex_nav.write_rinex3_nav`):
  the same broadcast information as our solution.

Options (``prcopt_t``): single mode, the systems asked for, ionosphere
``IFLC`` (dual frequency: RTKLIB forms the combination of its first two
frequency slots, i.e. the codes of its own priority table) or ``BRDC``
(Klobuchar), Saastamoinen troposphere, the same elevation mask; RTKLIB's
default error model and no RAIM (its ``posopt[4]`` off), as ``rnx2rtkp``
runs by default. Epochs are returned with RTKLIB's time (GPST).
"""
from __future__ import annotations

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
    engine: str = "pntpos"         # postpos (RTKLIB's own engine) or pntpos (epoch by epoch)


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


def postpos_rinex(obs_path, nav_paths, systems=("G", "E", "C"), dual=True, elmask_deg=10.0) -> RtklibSolution:
    """RTKLIB ``postpos`` (single mode, forward) on a RINEX observation file
    and its navigation file(s) as archives hold them: the files are
    decompressed into a temporary folder (RTKLIB's own decompression calls
    programs that are not installed), ``postpos`` writes an llh ``.pos``
    (GPST, 3 decimals; time tag = receiver time - receiver clock bias, as
    RTKLIB's single solution) which is read back with the project's reader.
    Options as :func:`_options` (systems, mask, IFLC or broadcast
    ionosphere, Saastamoinen troposphere, RTKLIB's default error model)."""
    rk = _rk()
    from hyper_nav_gnss.formats.rinex_file import read_rinex_bytes

    from hyper_nav_workbench.core.importer.rtklib_pos import read_pos
    navs = [nav_path for nav_path in ([nav_paths] if isinstance(nav_paths, (str, pathlib.Path)) else nav_paths)]
    with tempfile.TemporaryDirectory(prefix="rtklib_") as tmp:
        files = [pathlib.Path(tmp) / "obs.rnx"]
        files[0].write_bytes(read_rinex_bytes(obs_path))
        for k, n in enumerate(navs):
            files.append(pathlib.Path(tmp) / f"nav{k}.rnx")
            files[-1].write_bytes(read_rinex_bytes(n))
        out = pathlib.Path(tmp) / "rtklib.pos"
        opt = _options(rk, systems, dual, elmask_deg)
        sopt = rk.solopt_default
        sopt.posf, sopt.times, sopt.timef, sopt.timeu = rk.SOLF_LLH, rk.TIMES_GPST, 1, 3
        sopt.outhead, sopt.height, sopt.sstat, sopt.trace, sopt.outvel = 1, 0, 0, 0, 0
        fopt = rk.filopt_t()
        t0 = rk.gtime_t()
        ret = rk.postpos(t0, t0, 0.0, 0.0, opt, sopt, fopt, [str(f) for f in files], len(files),
                         rk.Arr1Dchar(str(out)), "", "")
        if ret != 0 or not out.exists():
            raise RuntimeError(f"RTKLIB postpos returned {ret} on {obs_path} / {navs}")
        try:
            pos = read_pos(out)
        except ValueError:
            return RtklibSolution(np.zeros(0), np.zeros((0, 3)), np.zeros(0, int), np.zeros(0, bool),
                                  "postpos: no solution", None, "postpos")
    from hyper_nav_gnss import earth
    xyz = np.asarray(earth.geodetic_to_ecef(pos.lat_rad, pos.lon_rad, pos.alt_m), float).reshape(-1, 3)
    return RtklibSolution(pos.t_gpst_s, xyz, pos.n_sat, pos.quality == 5, "", None, "postpos")


def rinex_codes(obs_path, systems) -> dict:
    """The observation codes RTKLIB's RINEX reader puts in its first two
    frequency slots, per system (its code priorities on this file's header)."""
    rk = _rk()
    from hyper_nav_gnss.formats.rinex_file import read_rinex_bytes
    with tempfile.TemporaryDirectory(prefix="rtklib_") as tmp:
        o = pathlib.Path(tmp) / "obs.rnx"
        text = read_rinex_bytes(obs_path).decode("ascii", errors="replace").splitlines()
        head = next(k for k, ln in enumerate(text) if "END OF HEADER" in ln) + 1
        starts = [k for k in range(head, min(len(text), head + 20000)) if text[k].startswith(">")] or [len(text)]
        o.write_text("\n".join(text[:starts[min(30, len(starts) - 1)]]) + "\n")     # the first 30 epochs
        obs, nav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
        if rk.readrnx(str(o), 1, "", obs, nav, sta) != 1:
            return {}
    return _used_codes(rk, obs.data, obs.n, systems)


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
    from hyper_nav_gnss.formats.rinex_file import read_rinex_bytes
    navs = [nav_path] if isinstance(nav_path, (str, pathlib.Path)) else list(nav_path)
    with tempfile.TemporaryDirectory(prefix="rtklib_") as tmp:
        o = pathlib.Path(tmp) / "obs.rnx"
        o.write_bytes(read_rinex_bytes(obs_path))
        obs, nav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
        if rk.readrnx(str(o), 1, "", obs, nav, sta) != 1:
            raise RuntimeError(f"RTKLIB readrnx could not read {obs_path}")
        for k, n in enumerate(navs):
            nv = pathlib.Path(tmp) / f"nav{k}.rnx"
            nv.write_bytes(read_rinex_bytes(n))
            if rk.readrnx(str(nv), 1, "", obs, nav, sta) != 1:
                raise RuntimeError(f"RTKLIB readrnx could not read {n}")
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
    from hyper_nav_gnss.formats.rinex_nav import write_rinex3_nav
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
