"""hyper_nav_msgs/GnssEphemeris fields from a broadcast record (the inverse
of ``hyper_nav_filter.conversions.gnss_ephemeris``), shared by the gnss
node and the offline studies that feed the fusion core messages. The
message object is passed in (rclpy or any duck-typed class); no rclpy here."""
from __future__ import annotations

from hyper_nav_filter.conversions import GNSS_SYSTEMS, s_to_stamp_fields

SYSTEM_CODES = {s: code for code, s in GNSS_SYSTEMS.items()}      # 'G' -> 1 (SYSTEM_GPS), 'E' -> 2, 'C' -> 3, ...


def fill_gnss_ephemeris(msg, eph, t_s: float, klobuchar=None):
    """Fill ``msg`` (GnssEphemeris) with the record ``eph``, stamped t_s;
    ``klobuchar``: optional (alpha[4], beta[4]) the source broadcasts."""
    msg.header.stamp.sec, msg.header.stamp.nanosec = s_to_stamp_fields(t_s)
    msg.header.frame_id = ""
    msg.system = SYSTEM_CODES[eph.system]
    msg.prn, msg.week = int(eph.prn), int(eph.week)
    msg.toe_s, msg.toc_s = float(eph.toe), float(eph.toc)
    msg.sqrt_a_sqrtm, msg.e, msg.i0_rad, msg.omega0_rad = float(eph.sqrtA), float(eph.e), float(eph.i0), float(eph.Omega0)
    msg.omega_rad, msg.m0_rad, msg.delta_n_radps = float(eph.omega), float(eph.M0), float(eph.delta_n)
    msg.idot_radps, msg.omega_dot_radps = float(eph.idot), float(eph.OmegaDot)
    msg.cuc_rad, msg.cus_rad, msg.crc_m, msg.crs_m = float(eph.cuc), float(eph.cus), float(eph.crc), float(eph.crs)
    msg.cic_rad, msg.cis_rad = float(eph.cic), float(eph.cis)
    msg.af0_s, msg.af1_sps, msg.af2_sps2, msg.tgd_s = float(eph.af0), float(eph.af1), float(eph.af2), float(eph.tgd)
    msg.iode, msg.health = int(eph.iode), int(eph.health)
    msg.tgd2_s, msg.data_source, msg.accuracy_m = float(eph.tgd2), int(eph.data_source), float(eph.accuracy_m)
    if klobuchar is not None:
        msg.klobuchar_alpha = [float(x) for x in klobuchar[0]]
        msg.klobuchar_beta = [float(x) for x in klobuchar[1]]
    return msg
