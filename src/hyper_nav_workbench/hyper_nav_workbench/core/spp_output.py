"""Single-point solutions (:class:`hyper_nav_gnss.positioning.spp.SppSolution`)
written as the field's tools read them. No rclpy.

* :func:`write_pos`: RTKLIB solution file (RTKLIB 2.4.3 manual, Appendix
  B.1, llh form; what ``rnx2rtkp`` writes, what ``rtkplot``, GNSS_IMU and
  this project's ``core/importer/rtklib_pos.py`` read): ``%`` header, then
  per solved epoch ``yyyy/mm/dd hh:mm:ss.sss`` GPST, latitude and longitude
  [deg], ellipsoidal height [m], Q = 5 (single), satellites used, sdn sde
  sdu sdne sdeu sdun [m] (signed square roots of the ENU covariance, as
  RTKLIB's ``sqvar``), age 0, ratio 0. The time is the epoch's receiver
  time tag (RINEX), where RTKLIB's single solution writes the receiver time
  minus its clock bias (the same epoch for a steered receiver clock; match
  within a fraction of the interval).
* :func:`write_csv`: every epoch (solved or not): time, status, geodetic and
  ECEF position, ENU sigmas, receiver clock and inter-system biases [m],
  DOPs, the satellites used, excluded by RAIM (id:w-test) and below the mask,
  the RAIM test statistic and threshold.
* :func:`write_nmea`: NMEA 0183 v4.11 ``GNGGA``, ``GNRMC``, one ``GNGSA``
  per system (system id 1 GPS, 3 Galileo, 4 BeiDou, 5 QZSS), ``GNGST``
  (error ellipse and sigmas from the solution's covariance, RMS of the
  post-fit residuals), UTC from GPST and the leap seconds. The altitude is
  the ellipsoidal height with geoid separation 0 (no geoid model is
  applied; GGA's field 11 says 0.0).
* :func:`write_kml` (Google Earth: the track and the mean position) and
  :func:`write_gpx` (GPX 1.1 track, UTC times).
* :func:`write_fix_bag`: an MCAP bag of ``sensor_msgs/NavSatFix`` on
  ``/gnss/fix`` (full ENU covariance), for the graph's ``player`` and the
  fusion node's loosely coupled ``gnss`` source.
"""
from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from hyper_nav_gnss import earth

GPS_EPOCH = _dt.datetime(1980, 1, 6)
# GPST - UTC [s] from these UTC dates (IERS bulletin C; the last change 2017-01-01)
LEAP_SECONDS = ((_dt.datetime(2017, 1, 1), 18), (_dt.datetime(2015, 7, 1), 17), (_dt.datetime(2012, 7, 1), 16),
                (_dt.datetime(2009, 1, 1), 15), (_dt.datetime(2006, 1, 1), 14), (_dt.datetime(1999, 1, 1), 13),
                (_dt.datetime(1997, 7, 1), 12), (_dt.datetime(1996, 1, 1), 11), (_dt.datetime(1994, 7, 1), 10),
                (_dt.datetime(1993, 7, 1), 9), (_dt.datetime(1992, 7, 1), 8), (_dt.datetime(1991, 1, 1), 7),
                (_dt.datetime(1990, 1, 1), 6), (_dt.datetime(1988, 1, 1), 5), (_dt.datetime(1985, 7, 1), 4),
                (_dt.datetime(1983, 7, 1), 3), (_dt.datetime(1982, 7, 1), 2), (_dt.datetime(1981, 7, 1), 1))
NMEA_SYSTEM_ID = {"G": 1, "E": 3, "C": 4, "J": 5}
SYSTEM_NAMES = {"G": "GPS", "E": "Galileo", "C": "BeiDou", "J": "QZSS", "R": "GLONASS"}


def gpst_datetime(t_gpst_s: float) -> _dt.datetime:
    """Continuous GPST seconds -> calendar date in GPST."""
    return GPS_EPOCH + _dt.timedelta(seconds=float(t_gpst_s))


def utc_datetime(t_gpst_s: float) -> _dt.datetime:
    """Continuous GPST seconds -> UTC (GPST - leap seconds)."""
    g = gpst_datetime(t_gpst_s)
    for since, n in LEAP_SECONDS:
        if g - _dt.timedelta(seconds=n) >= since:
            return g - _dt.timedelta(seconds=n)
    return g


def _time_str(d: _dt.datetime, decimals: int = 3) -> str:
    s = d.second + d.microsecond * 1e-6
    return f"{d:%Y/%m/%d %H:%M}:{s:0{3 + decimals}.{decimals}f}"


def _llh_rad(sol):
    """(lat, lon, h) [rad, rad, m] of a solution, computed once per solution
    (every writer asks: the profile showed 8 conversions an epoch)."""
    got = sol.__dict__.get("_llh_cache")
    if got is None or got[0] is not sol.pos_ecef_m:
        lat, lon, h = earth.ecef_to_geodetic(np.asarray(sol.pos_ecef_m, float))
        got = (sol.pos_ecef_m, float(lat), float(earth.wrap_lon_rad(lon)), float(h))
        sol.__dict__["_llh_cache"] = got
    return got[1:]


def geodetic(sol) -> tuple[float, float, float]:
    """(lat_deg, lon_deg, h_m) of a solution."""
    lat, lon, h = _llh_rad(sol)
    return math.degrees(lat), math.degrees(lon), h


def cov_enu(sol) -> np.ndarray:
    """The position covariance in ENU at the solution [m^2] (computed once
    per solution, as :func:`_llh_rad`: the .pos, CSV and NMEA writers ask)."""
    got = sol.__dict__.get("_cov_enu_cache")
    if got is None or got[0] is not sol.cov_ecef_m2 or got[1] is not sol.pos_ecef_m:
        lat, lon, _ = _llh_rad(sol)
        C = earth.C_n_e(lat, lon)                      # ENU -> ECEF
        got = (sol.cov_ecef_m2, sol.pos_ecef_m, C.T @ np.asarray(sol.cov_ecef_m2, float) @ C)
        sol.__dict__["_cov_enu_cache"] = got
    return got[2].copy()


def _sq(v: float) -> float:
    return -math.sqrt(-v) if v < 0 else math.sqrt(v)


def write_pos(path, sols, header: dict | None = None) -> int:
    """RTKLIB llh .pos of the solved epochs (module docstring); ``header``:
    extra ``% key : value`` lines (input files, options). Returns the epochs written."""
    ok = [s for s in sols if s.valid]
    lines = ["% program   : hyper-nav spp"]
    for k, v in (header or {}).items():
        lines.append(f"% {k:<10s}: {v}")
    if ok:
        for lab, s in (("obs start", ok[0]), ("obs end", ok[-1])):
            w, tow = divmod(s.t_rx_gpst_s, 604800.0)
            lines.append(f"% {lab:<10s}: {_time_str(gpst_datetime(s.t_rx_gpst_s), 1)} GPST "
                         f"(week{int(w):04d} {tow:8.1f}s)")
    lines += ["% pos mode  : Single", "%",
              "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)",
              "%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)"
              "  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio"]
    for s in ok:
        la, lo, h = geodetic(s)
        Q = cov_enu(s)
        lines.append(f"{_time_str(gpst_datetime(s.t_rx_gpst_s))} {la:14.9f} {lo:14.9f} {h:10.4f} {5:3d} {s.n_used:3d} "
                     f"{_sq(Q[1, 1]):8.4f} {_sq(Q[0, 0]):8.4f} {_sq(Q[2, 2]):8.4f} {_sq(Q[1, 0]):8.4f} "
                     f"{_sq(Q[0, 2]):8.4f} {_sq(Q[2, 1]):8.4f} {0.0:6.2f} {0.0:6.1f}")
    Path(path).write_text("\n".join(lines) + "\n")
    return len(ok)


CSV_COLUMNS = ("gpst", "week", "tow_s", "status", "lat_deg", "lon_deg", "height_m", "x_ecef_m", "y_ecef_m",
               "z_ecef_m", "sigma_e_m", "sigma_n_m", "sigma_u_m", "clock_bias_m", "clock_reference_system",
               "isb_E_m", "isb_C_m", "isb_J_m", "gdop", "pdop", "hdop", "vdop", "tdop", "n_used", "used",
               "excluded_w", "below_mask", "raim_statistic", "raim_threshold", "dof")


def write_csv(path, sols) -> int:
    """One row per epoch, solved or not (module docstring). Returns the rows."""
    rows = [",".join(CSV_COLUMNS)]
    for s in sols:
        w, tow = divmod(s.t_rx_gpst_s, 604800.0)
        base = [_time_str(gpst_datetime(s.t_rx_gpst_s)), str(int(w)), f"{tow:.3f}", s.status]
        if np.all(np.isfinite(s.pos_ecef_m)):
            la, lo, h = geodetic(s)
            sd = np.sqrt(np.maximum(np.diag(cov_enu(s)), 0.0))
            pos = [f"{la:.9f}", f"{lo:.9f}", f"{h:.4f}"] + [f"{x:.4f}" for x in s.pos_ecef_m] + \
                  [f"{x:.4f}" for x in sd]
        else:
            pos = [""] * 9
        clk = [f"{s.clock_bias_m:.4f}" if np.isfinite(s.clock_bias_m) else "", s.reference_system] + \
              [f"{s.isb_m[k]:.4f}" if k in s.isb_m else "" for k in ("E", "C", "J")]
        dop = [f"{s.dop[k]:.3f}" if k in s.dop else "" for k in ("gdop", "pdop", "hdop", "vdop", "tdop")]
        used = [sid for sid, u in zip(s.sat_ids, s.used) if u]
        rows.append(",".join(base + pos + clk + dop + [
            str(s.n_used), " ".join(used), " ".join(f"{e[0]}:{e[1]:.1f}" for e in s.excluded), " ".join(s.below_mask),
            f"{s.test_statistic:.3f}" if np.isfinite(s.test_statistic) else "",
            f"{s.test_threshold:.3f}" if np.isfinite(s.test_threshold) else "", str(s.dof)]))
    Path(path).write_text("\n".join(rows) + "\n")
    return len(rows) - 1


def _nmea(body: str) -> str:
    cs = 0
    for ch in body.encode("ascii"):
        cs ^= ch
    return f"${body}*{cs:02X}"


def _lat_nmea(lat_deg: float) -> tuple[str, str]:
    a = abs(lat_deg)
    d = int(a)
    return f"{d:02d}{(a - d) * 60.0:010.7f}", "N" if lat_deg >= 0 else "S"


def _lon_nmea(lon_deg: float) -> tuple[str, str]:
    a = abs(lon_deg)
    d = int(a)
    return f"{d:03d}{(a - d) * 60.0:010.7f}", "E" if lon_deg >= 0 else "W"


def nmea_sentences(s) -> list[str]:
    """GGA, RMC, GSA (per system), GST of one solved epoch."""
    u = utc_datetime(s.t_rx_gpst_s)
    hms = f"{u:%H%M}{u.second + u.microsecond * 1e-6:05.2f}"
    la, lo, h = geodetic(s)
    lat, ns = _lat_nmea(la)
    lon, ew = _lon_nmea(lo)
    hdop = s.dop.get("hdop", float("nan"))
    out = [_nmea(f"GNGGA,{hms},{lat},{ns},{lon},{ew},1,{min(s.n_used, 99):02d},{hdop:.2f},{h:.3f},M,0.000,M,,"),
           _nmea(f"GNRMC,{hms},A,{lat},{ns},{lon},{ew},,,{u:%d%m%y},,,A,V")]
    used = [sid for sid, ok in zip(s.sat_ids, s.used) if ok]
    for sysc, sid_no in NMEA_SYSTEM_ID.items():
        prns = [str(int(x[1:])) for x in used if x[0] == sysc][:12]
        if not prns:
            continue
        f = prns + [""] * (12 - len(prns))
        out.append(_nmea(f"GNGSA,A,3,{','.join(f)},{s.dop.get('pdop', float('nan')):.2f},{hdop:.2f},"
                         f"{s.dop.get('vdop', float('nan')):.2f},{sid_no}"))
    Q = cov_enu(s)
    ev, evec = np.linalg.eigh(Q[:2, :2])
    major = evec[:, 1]                                     # (east, north) of the larger axis
    orient = math.degrees(math.atan2(major[0], major[1])) % 180.0
    res = np.asarray(s.residual_m, float)[np.asarray(s.used, bool)]
    rms = float(np.sqrt(np.mean(res ** 2))) if len(res) else 0.0
    out.append(_nmea(f"GNGST,{hms},{rms:.3f},{math.sqrt(max(ev[1], 0)):.3f},{math.sqrt(max(ev[0], 0)):.3f},"
                     f"{orient:.1f},{math.sqrt(max(Q[1, 1], 0)):.3f},{math.sqrt(max(Q[0, 0], 0)):.3f},"
                     f"{math.sqrt(max(Q[2, 2], 0)):.3f}"))
    return out


def write_nmea(path, sols) -> int:
    """NMEA sentences of every solved epoch (module docstring). Returns the epochs written."""
    lines, n = [], 0
    for s in sols:
        if s.valid:
            lines += nmea_sentences(s)
            n += 1
    Path(path).write_text("\r\n".join(lines) + ("\r\n" if lines else ""))
    return n


def write_kml(path, sols, name: str = "spp") -> int:
    """KML 2.2: the track of solved epochs (absolute altitude = ellipsoidal
    height) and a placemark at their mean. Returns the points written."""
    pts = [geodetic(s) for s in sols if s.valid]
    coords = " ".join(f"{lo:.9f},{la:.9f},{h:.3f}" for la, lo, h in pts)
    mean = np.mean(np.array(pts), axis=0) if pts else np.full(3, np.nan)
    doc = f"""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2">
<Document>
<name>{escape(name)}</name>
<Style id="track"><LineStyle><color>ff0000ff</color><width>2</width></LineStyle></Style>
<Placemark><name>{escape(name)} track ({len(pts)} epochs)</name><styleUrl>#track</styleUrl>
<LineString><altitudeMode>absolute</altitudeMode><coordinates>{coords}</coordinates></LineString></Placemark>
<Placemark><name>{escape(name)} mean position</name>
<Point><altitudeMode>absolute</altitudeMode><coordinates>{mean[1]:.9f},{mean[0]:.9f},{mean[2]:.3f}</coordinates></Point></Placemark>
</Document>
</kml>
"""
    Path(path).write_text(doc)
    return len(pts)


def write_gpx(path, sols, name: str = "spp") -> int:
    """GPX 1.1 track of solved epochs (UTC times; ``ele`` = ellipsoidal
    height, ``sat`` and ``hdop``/``vdop``/``pdop``). Returns the points written."""
    rows = []
    for s in sols:
        if not s.valid:
            continue
        la, lo, h = geodetic(s)
        u = utc_datetime(s.t_rx_gpst_s)
        rows.append(f'<trkpt lat="{la:.9f}" lon="{lo:.9f}"><ele>{h:.3f}</ele>'
                    f"<time>{u:%Y-%m-%dT%H:%M:%S}.{u.microsecond // 1000:03d}Z</time><fix>3d</fix>"
                    f"<sat>{s.n_used}</sat><hdop>{s.dop.get('hdop', 0):.2f}</hdop><vdop>{s.dop.get('vdop', 0):.2f}</vdop>"
                    f"<pdop>{s.dop.get('pdop', 0):.2f}</pdop></trkpt>")
    doc = ('<?xml version="1.0" encoding="UTF-8"?>\n'
           '<gpx version="1.1" creator="hyper-nav spp" xmlns="http://www.topografix.com/GPX/1/1">\n'
           f"<trk><name>{escape(name)}</name><trkseg>\n" + "\n".join(rows) + "\n</trkseg></trk>\n</gpx>\n")
    Path(path).write_text(doc)
    return len(rows)


GPST_UNIX_OFFSET_S = 315964800.0        # the importer's default time axis: GPST as seconds since 1970
NAVSAT_SERVICE = {"G": 1, "R": 2, "C": 4, "E": 8}     # sensor_msgs/NavSatStatus SERVICE_* bits


def fix_messages(sols, frame: str = "gnss_antenna", offset_s: float = GPST_UNIX_OFFSET_S):
    """sensor_msgs/NavSatFix of every solved epoch, as (t_ns, msg): stamp =
    GPST + ``offset_s`` (the importer's ``gpst_unix`` axis), status FIX,
    service bits of the systems used, the full ENU position covariance
    (``COVARIANCE_TYPE_KNOWN``), ellipsoidal altitude."""
    from hyper_nav_workbench.core.importer.messages import _header, _stamp_ns, _t
    NavSatFix, Status = _t("sensor_msgs/msg/NavSatFix"), _t("sensor_msgs/msg/NavSatStatus")
    for s in sols:
        if not s.valid:
            continue
        la, lo, h = geodetic(s)
        t = s.t_rx_gpst_s + offset_s
        service = 0
        for sid, u in zip(s.sat_ids, s.used):
            if u:
                service |= NAVSAT_SERVICE.get(sid[0], 0)
        yield _stamp_ns(t), NavSatFix(
            header=_header(t, frame), status=Status(status=0, service=service), latitude=la, longitude=lo,
            altitude=h, position_covariance=cov_enu(s).ravel().astype(float), position_covariance_type=3)


def write_fix_bag(path, sols, topic: str = "/gnss/fix") -> int:
    """An MCAP bag with one NavSatFix per solved epoch on ``topic`` (the
    fusion node's ``gnss`` source reads it; ``player`` publishes it).
    Returns the messages written."""
    from hyper_nav_workbench.core.importer.messages import write_bag
    counts = write_bag(path, {topic: ("sensor_msgs/msg/NavSatFix", fix_messages(sols))})
    return int(counts.get(topic, 0))


WRITERS = {"pos": write_pos, "csv": write_csv, "nmea": write_nmea, "kml": write_kml, "gpx": write_gpx}
