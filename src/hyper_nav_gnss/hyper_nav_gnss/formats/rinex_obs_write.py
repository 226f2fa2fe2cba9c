"""RINEX 3.04 observation files written (the format ``rinex_obs`` reads, and
RTKLIB, georinex and every GNSS tool): a receiver's code, phase, Doppler and
C/N0 per satellite and epoch, GPS time, as the RINEX 3.04 specification
(IGS/RTCM, 2018) lays them out: ``SYS / # / OBS TYPES`` per system, epoch
lines ``> yyyy mm dd hh mm ss.sssssss  0 nn``, one line per satellite with
16-character fields (F14.3, LLI, signal strength).

Used to hand a simulated station to RTKLIB and ``spp`` alike
(``benchmarks/synthetic_station_day.py``)."""
from __future__ import annotations

import datetime as _dt
import pathlib

import numpy as np

_GPS_EPOCH = _dt.datetime(1980, 1, 6)


def _calendar(t_gpst_s: float) -> tuple[_dt.datetime, float]:
    """GPST seconds -> (datetime to the whole second, seconds with fraction)."""
    whole = int(np.floor(t_gpst_s))
    d = _GPS_EPOCH + _dt.timedelta(seconds=whole)
    return d, d.second + (t_gpst_s - whole)


def _label(text: str, label: str) -> str:
    return f"{text:<60.60s}{label}"


def _types_lines(system: str, codes: list[str]) -> list[str]:
    """``SYS / # / OBS TYPES``: 13 types on the first line, continuation lines after."""
    out = []
    for k in range(0, len(codes), 13):
        chunk = "".join(f" {c:3s}" for c in codes[k:k + 13])
        head = f"{system}  {len(codes):3d}" if k == 0 else " " * 6
        out.append(_label(head + chunk, "SYS / # / OBS TYPES"))
    return out


def header_lines(obs_types: dict[str, list[str]], approx_xyz_m, t_first_gpst_s: float, interval_s: float | None,
                 marker: str = "SIM0", antenna_delta_hen_m=(0.0, 0.0, 0.0), program: str = "hyper-nav",
                 comments=()) -> list[str]:
    """The header of a mixed observation file."""
    d, sec = _calendar(t_first_gpst_s)
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d %H%M%S UTC")
    h = [_label(f"{3.04:9.2f}{'':11s}{'OBSERVATION DATA':20s}{'M':20s}", "RINEX VERSION / TYPE"),
         _label(f"{program:20.20s}{'':20s}{now:20s}", "PGM / RUN BY / DATE")]
    h += [_label(c, "COMMENT") for c in comments]
    h += [_label(marker, "MARKER NAME"), _label("GEODETIC", "MARKER TYPE"),
          _label(f"{'':20s}{'':40s}", "OBSERVER / AGENCY"),
          _label(f"{'0':20s}{'SIMULATED':20s}{'':20s}", "REC # / TYPE / VERS"),
          _label(f"{'0':20s}{'SIMULATED':20s}", "ANT # / TYPE"),
          _label("".join(f"{x:14.4f}" for x in approx_xyz_m), "APPROX POSITION XYZ"),
          _label("".join(f"{x:14.4f}" for x in antenna_delta_hen_m), "ANTENNA: DELTA H/E/N")]
    for s in sorted(obs_types):
        h += _types_lines(s, obs_types[s])
    if interval_s:
        h.append(_label(f"{interval_s:10.3f}", "INTERVAL"))
    h.append(_label(f"{d.year:6d}{d.month:6d}{d.day:6d}{d.hour:6d}{d.minute:6d}{sec:13.7f}     GPS",
                    "TIME OF FIRST OBS"))
    h.append(_label("", "END OF HEADER"))
    return h


def epoch_lines(t_gpst_s: float, sats: dict[str, dict[str, float]], obs_types: dict[str, list[str]]) -> list[str]:
    """One epoch: ``sats`` {sat_id: {code: value}}; a type a satellite lacks is blank."""
    d, sec = _calendar(t_gpst_s)
    ids = sorted(s for s in sats if s[0] in obs_types)
    out = [f"> {d.year:4d} {d.month:02d} {d.day:02d} {d.hour:02d} {d.minute:02d}{sec:11.7f}  0{len(ids):3d}"]
    for sid in ids:
        vals = sats[sid]
        fields = []
        for code in obs_types[sid[0]]:
            v = vals.get(code)
            fields.append(f"{v:14.3f}  " if v is not None and np.isfinite(v) else " " * 16)
        out.append((sid + "".join(fields)).rstrip())
    return out


def write_rinex3_obs(path, epochs, obs_types: dict[str, list[str]], approx_xyz_m, interval_s: float | None = None,
                     **header) -> int:
    """Write ``epochs`` (an iterable of (t_gpst_s, {sat_id: {code: value}}),
    in time order) to ``path``; ``header``: ``header_lines``'s keywords.
    Returns the number of epochs written."""
    epochs = list(epochs)
    if not epochs:
        raise ValueError("no epoch to write")
    lines = header_lines(obs_types, approx_xyz_m, epochs[0][0], interval_s, **header)
    for t, sats in epochs:
        lines += epoch_lines(t, sats, obs_types)
    pathlib.Path(path).write_text("\n".join(lines) + "\n")
    return len(epochs)
