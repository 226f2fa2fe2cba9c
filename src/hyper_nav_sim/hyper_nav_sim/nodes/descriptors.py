"""The simulator's sensor nodes, declared (``hyper_nav_sim.sensors``): IMU,
GNSS, magnetometer (always started), barometer and radar (started by their
scenario blocks). Exported through the entry points ``hyper_nav.sensor_nodes``
of this package's ``setup.py``. No rclpy here."""
from __future__ import annotations

from dataclasses import fields as dc_fields

from ..sensors import SensorNode


# ---- IMU: imu/data_raw, and imu/load with the elastic lever arm on (seed 000) ----------------
def _imu_topics(sc) -> dict:
    return {"imu/data_raw": sc["imu.rate_hz"]}


def _structure_load(sc) -> bool:
    """Whether the IMU node publishes ``imu/load`` (the elastic lever arm on)."""
    la = sc.data.get("lever_arm")
    return isinstance(la, dict) and bool(la.get("enabled", True))


def _imu_wait_topics(sc) -> list:
    return ["imu/data_raw"] + (["imu/load"] if _structure_load(sc) else [])


def _imu_fields():
    from ..core.imu_model import CONFIG_FIELDS, IGNORED_FIELDS
    return set(CONFIG_FIELDS) | set(IGNORED_FIELDS) | {"grade"}       # grade: core.sensor_catalogue


def _imu_validate(block):
    from ..core.imu_model import ImuErrors
    return ImuErrors.from_config(block)


IMU = SensorNode(name="imu", package="hyper_nav_sim", executable="imu_node", block="imu", order=10,
                 topics=_imu_topics, wait_topics=_imu_wait_topics, fields=_imu_fields, validate=_imu_validate,
                 replay_topics=("imu/data_raw", "imu/load"))


# ---- GNSS: gnss/fix, gnss/vel; gnss/raw and gnss/ephemeris with a gnss.raw block --------------
def _gnss_raw(sc) -> bool:
    return "raw" in (sc.data.get("gnss") or {})


def _gnss_topics(sc) -> dict:
    r = sc["gnss.rate_hz"]
    return {"gnss/fix": r, "gnss/vel": r, **({"gnss/raw": r} if _gnss_raw(sc) else {})}


def _gnss_parameters(sc, subscribers) -> dict:
    # gnss/raw and gnss/ephemeris wait for their own consumers (the recorder, a tightly coupled fusion node)
    return {"raw_min_subscribers": subscribers(["gnss/raw"])}


def _gnss_fields():
    return {"raw", "outages_s", "grade"}       # outages_s: loose fixes withheld in [t0, t1) windows; grade: catalogue


def _gnss_validate(block):
    from ..core.gnss_model import parse_outages
    return parse_outages(block.get("outages_s"))


GNSS = SensorNode(name="gnss", package="hyper_nav_sim", executable="gnss_node", block="gnss", order=20,
                  topics=_gnss_topics, wait_topics=lambda sc: ["gnss/fix", "gnss/vel"], parameters=_gnss_parameters,
                  fields=_gnss_fields, validate=_gnss_validate,
                  replay_topics=("gnss/fix", "gnss/vel", "gnss/raw", "gnss/ephemeris"), latched_topics=("gnss/ephemeris",))


# ---- magnetometer: imu/mag --------------------------------------------------------------------
def _mag_fields():
    from ..core.mag_model import CONFIG_FIELDS
    return set(CONFIG_FIELDS) | {"grade"}                            # grade: core.sensor_catalogue


def _mag_validate(block):
    from ..core.mag_model import MagnetometerErrors
    return MagnetometerErrors.from_config(block)


MAG = SensorNode(name="mag", package="hyper_nav_sim", executable="mag_node", block="magnetometer", order=30,
                 ros_name="magnetometer", topics=lambda sc: {"imu/mag": sc["magnetometer.rate_hz"]},
                 fields=_mag_fields, validate=_mag_validate, replay_topics=("imu/mag",))


# ---- barometer: baro/pressure, started by a barometer block ------------------------------------
def _baro_fields():
    from ..core.baro_model import CONFIG_FIELDS
    return set(CONFIG_FIELDS) | {"rate_hz", "grade"}                 # grade: core.sensor_catalogue


def _baro_validate(block):
    from ..core.baro_model import BaroErrors
    return BaroErrors.from_config(block, prefix="barometer")


def _baro_feed(sc, traj):
    from .baro_messages import feed
    return feed(sc, traj)


BARO = SensorNode(name="baro", package="hyper_nav_sim", executable="baro_node", block="barometer", optional=True,
                  order=40, ros_name="barometer",
                  topics=lambda sc: {"baro/pressure": float(sc.data["barometer"].get("rate_hz", 10.0))},
                  fields=_baro_fields, validate=_baro_validate, replay_topics=("baro/pressure",), mc_feed=_baro_feed)


# ---- early-warning radar (seed 002): radar/track, started by a radar block ---------------------
def _radar_fields():
    from ..core.radar import EarlyWarningRadar
    return {f.name for f in dc_fields(EarlyWarningRadar)}


RADAR = SensorNode(name="radar", package="hyper_nav_sim", executable="radar_node", block="radar", optional=True,
                   order=50, topics=lambda sc: {"radar/track": float(sc.data["radar"].get("rate_hz", 1.0))},
                   fields=_radar_fields, replay_topics=("radar/track",))
