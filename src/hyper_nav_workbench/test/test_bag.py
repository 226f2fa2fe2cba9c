"""Unit tests of hyper_nav_workbench.core.bag (pure Python, no rclpy)."""

import math

import numpy as np
import pytest

from hyper_nav_workbench.core import bag

IMU = "sensor_msgs/msg/Imu"
STRING = "std_msgs/msg/String"
NAV = "hyper_nav_msgs/msg/NavState"
T0 = 1_700_000_000_000_000_000  # log time of the first message (ns)


def imu(i):
    t = bag.typestore().types
    return t[IMU](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=i, nanosec=1000 * i), frame_id="imu"),
        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.full(9, -1.0),
        angular_velocity=t["geometry_msgs/msg/Vector3"](x=1e-3 * i, y=-float(i), z=math.pi),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=t["geometry_msgs/msg/Vector3"](x=float(i), y=2.0 * i, z=9.81),
        linear_acceleration_covariance=np.eye(3).ravel(),
    )


def nav_state():
    t = bag.typestore().types
    return t[NAV](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=12, nanosec=345), frame_id="enu"),
        child_frame_id="base_link",
        mode=t[NAV].MODE_LOOSELY_COUPLED,
        mechanization_frame="ENU",
        lat_rad=0.768,
        lon_rad=1.919,
        alt_m=25_000.5,
        vel_enu_mps=np.array([1500.0, -20.0, 3.5]),
        q_b_enu=t["geometry_msgs/msg/Quaternion"](x=0.1, y=0.2, z=0.3, w=math.sqrt(1 - 0.14)),
        roll_rad=0.01,
        pitch_rad=-0.02,
        heading_rad=1.5,
        omega_ib_b_radps=np.array([1e-3, 2e-3, 3e-3]),
        accel_b_mps2=np.array([0.5, 0.0, 9.8]),
        gyro_bias_b_radps=np.array([1e-6, -1e-6, 2e-6]),
        accel_bias_b_mps2=np.array([1e-3, 2e-3, -3e-3]),
        state_blocks=["att:3", "vel:3"],
        state_dim=6,
        covariance=np.arange(36, dtype=np.float64),
        n_updates=42,
        n_rejected=1,
        last_nis=3.25,
    )


def write_sample(path, n_imu=300):
    """Bag: n_imu Imu at 100 Hz, a String every 10th, one NavState. Returns the written records."""
    written = []
    with bag.BagWriter(path) as writer:
        for i in range(n_imu):
            t_ns = T0 + i * 10_000_000
            written.append(("/imu/data_raw", IMU, t_ns, bag.serialize(imu(i), IMU)))
            if i % 10 == 0:
                written.append(("/note", STRING, t_ns + 1, bag.serialize(bag.typestore().types[STRING](data=f"note {i}"), STRING)))
            if i == n_imu // 2:
                written.append(("/nav/state", NAV, t_ns + 2, bag.serialize(nav_state(), NAV)))
        for record in written:
            writer.write(*record)
    return written, writer.counts


def assert_imu(msg, i):
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (i, 1000 * i, "imu")
    assert (msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z) == (1e-3 * i, -float(i), math.pi)
    assert (msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z) == (float(i), 2.0 * i, 9.81)
    assert msg.orientation.w == 1.0
    np.testing.assert_array_equal(msg.linear_acceleration_covariance, np.eye(3).ravel())


def test_roundtrip(tmp_path):
    path = tmp_path / "bag"
    written, counts = write_sample(path)
    assert counts == {"/imu/data_raw": 300, "/note": 30, "/nav/state": 1}
    assert (path / "metadata.yaml").is_file() and list(path.glob("*.mcap"))

    reader = bag.read_bag(path)
    assert reader.topics == {"/imu/data_raw": IMU, "/note": STRING, "/nav/state": NAV}
    records = list(reader)
    assert not reader.truncated and reader.error is None
    assert reader.counts == counts
    assert [tuple(r) for r in records] == written  # same order, times and bytes

    imus = [r for r in records if r.topic == "/imu/data_raw"]
    assert [r.t_ns for r in imus] == [T0 + i * 10_000_000 for i in range(300)]
    for i, r in enumerate(imus):
        assert_imu(bag.deserialize(r.raw, IMU), i)
    assert [bag.deserialize(r.raw, STRING).data for r in records if r.topic == "/note"] == [f"note {i}" for i in range(0, 300, 10)]

    (nav,) = [r for r in records if r.topic == "/nav/state"]
    got, want = bag.deserialize(nav.raw, NAV), nav_state()
    assert nav.t_ns == T0 + 150 * 10_000_000 + 2
    for field in ("child_frame_id", "mode", "mechanization_frame", "lat_rad", "lon_rad", "alt_m", "roll_rad",
                  "pitch_rad", "heading_rad", "state_blocks", "state_dim", "n_updates", "n_rejected", "last_nis"):
        assert getattr(got, field) == getattr(want, field), field
    for field in ("vel_enu_mps", "omega_ib_b_radps", "accel_b_mps2", "gyro_bias_b_radps", "accel_bias_b_mps2", "covariance"):
        np.testing.assert_array_equal(getattr(got, field), getattr(want, field))
    assert (got.header.stamp.sec, got.header.stamp.nanosec, got.header.frame_id) == (12, 345, "enu")
    assert (got.q_b_enu.x, got.q_b_enu.y, got.q_b_enu.z, got.q_b_enu.w) == (0.1, 0.2, 0.3, want.q_b_enu.w)


def test_topic_filter(tmp_path):
    write_sample(tmp_path / "bag")
    reader = bag.read_bag(tmp_path / "bag", topics=["/note"])
    assert reader.topics == {"/note": STRING}
    assert len(list(reader)) == 30 and reader.counts == {"/note": 30}


def truncate(path, fraction):
    (mcap,) = path.glob("*.mcap")
    data = mcap.read_bytes()
    mcap.write_bytes(data[: int(len(data) * fraction)])
    return mcap


@pytest.mark.parametrize("keep_metadata", [False, True])
def test_truncated(tmp_path, keep_metadata):
    path = tmp_path / "bag"
    written, counts = write_sample(path)
    mcap = truncate(path, 0.6)
    if not keep_metadata:
        (path / "metadata.yaml").unlink()

    reader = bag.read_bag(path)
    records = list(reader)
    assert reader.truncated is True
    assert str(mcap) in reader.error
    assert 0 < len(records) < len(written)
    assert [tuple(r) for r in records] == written[: len(records)]  # a prefix, byte for byte
    assert 0 < reader.counts["/imu/data_raw"] < counts["/imu/data_raw"]
    for i, r in enumerate(r for r in records if r.topic == "/imu/data_raw"):
        assert r.t_ns == T0 + i * 10_000_000
        assert_imu(bag.deserialize(r.raw, IMU), i)


def test_flushed_messages_survive_a_crash(tmp_path):
    """What was flush()ed is readable after a crash; the pending chunk is lost."""
    path = tmp_path / "bag"
    writer = bag.BagWriter(path)
    for i in range(200):
        writer.write("/imu", IMU, T0 + i, bag.serialize(imu(i), IMU))
        if i == 99:
            writer.flush()
    writer.abort()  # like a killed recorder: file closed, no summary, no metadata.yaml
    reader = bag.read_bag(path)
    records = list(reader)
    assert reader.truncated and "footer" in reader.error
    assert [r.t_ns for r in records] == [T0 + i for i in range(100)]
    assert_imu(bag.deserialize(records[-1].raw, IMU), 99)


def test_refuses_existing_directory(tmp_path):
    path = tmp_path / "bag"
    path.mkdir()
    with pytest.raises(FileExistsError, match="bag"):
        bag.BagWriter(path)
    write_sample(tmp_path / "other", n_imu=3)
    with pytest.raises(FileExistsError) as info:
        bag.BagWriter(tmp_path / "other")
    assert info.value.filename == str(tmp_path / "other")


def test_typestore_has_project_messages():
    store = bag.typestore()
    assert store is bag.typestore()
    assert NAV in store.types and IMU in store.types


def test_written_as_rosbag2_jazzy_with_qos_and_crcs(tmp_path):
    """metadata.yaml: version 9, ros_distro jazzy, offered QoS per topic; MCAP:
    profile ros2, channel metadata offered_qos_profiles + topic_type_hash,
    non-zero chunk CRCs that the mcap reader verifies, a rosbag2 metadata record."""
    import yaml
    from mcap.reader import make_reader
    path = tmp_path / "bag"
    latched = bag.qos_profile(durability="transient_local", depth=200)
    with bag.BagWriter(path) as w:
        w.add_topic("/gnss/ephemeris", STRING, [latched])
        w.add_topic("/imu/data_raw", IMU, [bag.qos_profile(depth=2000)])
        for i in range(50):
            w.write("/imu/data_raw", IMU, T0 + i, bag.serialize(imu(i), IMU))
        w.write("/gnss/ephemeris", STRING, T0 + 60, bag.serialize(bag.typestore().types[STRING](data="eph"), STRING))
        w.write("/note", STRING, T0 + 61, bag.serialize(bag.typestore().types[STRING](data="n"), STRING))
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["ros_distro"] == "jazzy" and info["version"] == 9 and info["storage_identifier"] == "mcap"
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert topics["/gnss/ephemeris"]["topic_metadata"]["offered_qos_profiles"] == [latched]
    assert topics["/imu/data_raw"]["message_count"] == 50
    assert topics["/note"]["topic_metadata"]["offered_qos_profiles"] == []
    assert topics["/imu/data_raw"]["topic_metadata"]["type_description_hash"].startswith("RIHS01_")
    with (path / "bag.mcap").open("rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        assert sum(1 for _ in reader.iter_messages()) == 52          # CRCs verified while reading
        assert [m.name for m in reader.iter_metadata()] == ["rosbag2"]
    assert summary.statistics.message_count == 52
    chunk_crcs = []
    with (path / "bag.mcap").open("rb") as f:
        from mcap.records import Chunk
        from mcap.stream_reader import StreamReader
        chunk_crcs = [r.uncompressed_crc for r in StreamReader(f, skip_magic=False, emit_chunks=True).records if isinstance(r, Chunk)]
    assert chunk_crcs and all(c != 0 for c in chunk_crcs)
    meta = {c.topic: c.metadata for c in summary.channels.values()}
    assert yaml.safe_load(meta["/gnss/ephemeris"]["offered_qos_profiles"]) == [latched]
    # read back: QoS per topic, by rosbags and by the tolerant reader of a cut copy
    assert bag.read_bag(path).qos["/gnss/ephemeris"] == [latched]
    (path / "metadata.yaml").unlink()
    assert bag.read_bag(path).qos["/gnss/ephemeris"] == [latched]


def test_playback_qos_keeps_transient_local():
    latched = bag.qos_profile(durability="transient_local", depth=200)
    assert bag.playback_qos([latched]) == {"reliability": "reliable", "durability": "transient_local", "depth": 200}
    assert bag.playback_qos([latched, bag.qos_profile(depth=10)])["durability"] == "volatile"
    assert bag.playback_qos([bag.qos_profile(reliability="best_effort")])["reliability"] == "best_effort"
    assert bag.playback_qos([]) == {"reliability": "reliable", "durability": "volatile", "depth": 0}
