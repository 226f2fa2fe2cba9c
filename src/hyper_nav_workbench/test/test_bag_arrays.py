"""Bags read into arrays (core/bag_arrays.py) against the per-message path
(bag.BagReader + rosbags deserialization): every field of every message of
every topic of the committed bags, bit for bit; a truncated bag read as far
as the tolerant reader reads it; the compiled record walk against its plain
reference."""
import pathlib
import shutil

import numpy as np
import pytest

from hyper_nav_filter.offline_arrays import log_order, stamp_order
from hyper_nav_workbench.core import bag_arrays
from hyper_nav_workbench.core.bag import BagWriter, deserialize, read_bag, serialize, typestore

ROOT = pathlib.Path(__file__).resolve().parents[3]
COMMITTED = sorted(p.parent for p in (ROOT / "bags").glob("*/*.mcap"))


def _get(msg, path: str):
    """The value at a dotted path; None where the message has no such element (a shorter sequence)."""
    for part in path.split("."):
        if part.isdigit():
            if int(part) >= len(msg):
                return None
            msg = msg[int(part)]
        else:
            msg = getattr(msg, part)
    return msg


def _same(column_value, msg_value) -> bool:
    if column_value is None or msg_value is None:
        return column_value is None and msg_value is None
    if isinstance(msg_value, str):
        return column_value.decode() == msg_value
    a, b = np.atleast_1d(column_value), np.atleast_1d(msg_value)
    if a.shape != b.shape:
        return False
    if a.dtype.kind == "f":
        return np.array_equal(a.view(np.uint8), b.astype(a.dtype).view(np.uint8))    # bit for bit (NaN too)
    if a.dtype.kind == "S":
        return [x.decode() for x in a.ravel()] == [str(x) for x in b.ravel()]
    return np.array_equal(a, b)


def _compare(bag_path):
    arrays = bag_arrays.read_arrays(bag_path)
    reader = read_bag(bag_path)
    per_topic = {}
    for rec in reader:
        per_topic.setdefault(rec.topic, []).append((rec.t_ns, deserialize(rec.raw, rec.msgtype)))
    assert set(arrays.topics) == set(per_topic)
    checked = 0
    for topic, msgs in per_topic.items():
        ta = arrays.topics[topic]
        assert ta.msgtype == reader.topics[topic]
        assert len(ta) == len(msgs), topic
        assert np.array_equal(ta.t_ns, [t for t, _ in msgs]), topic          # the same order: log time, file order
        for path, col in ta.fields.items():
            for k, (_, m) in enumerate(msgs):
                assert _same(col[k], _get(m, path)), (topic, path, k)
                checked += 1
    return arrays, reader, checked


@pytest.mark.parametrize("bag_path", COMMITTED, ids=[p.name for p in COMMITTED])
def test_array_reader_equals_the_per_message_reader_on_every_topic(bag_path):
    arrays, reader, checked = _compare(bag_path)
    assert not arrays.truncated and arrays.error is None
    assert {"/imu/data_raw", "/gnss/fix", "/gnss/vel", "/truth/state"} <= set(arrays.topics)
    assert checked > 50_000
    imu = arrays.topics["/imu/data_raw"]
    assert imu["orientation_covariance"].shape == (len(imu), 9)
    assert imu.stamp_ns.dtype == np.int64 and np.all(np.diff(imu.stamp_ns) > 0)


def test_a_truncated_bag_is_read_as_far_as_the_tolerant_reader_reads(tmp_path):
    src = COMMITTED[0]
    cut = tmp_path / "cut"
    cut.mkdir()
    mcap = next(src.glob("*.mcap"))
    data = mcap.read_bytes()
    (cut / mcap.name).write_bytes(data[: int(len(data) * 0.6)])        # recorder killed: no summary, chunk cut
    arrays, reader, _ = _compare(cut)
    assert arrays.truncated and reader.truncated and "cut short" in arrays.error
    assert 0 < sum(arrays.counts.values()) == sum(reader.counts.values())


def test_messages_of_one_topic_with_different_layouts(tmp_path):
    """frame ids of different lengths and sequences of different sizes on one topic, interleaved."""
    T = typestore().types
    path = tmp_path / "mixed"
    frames = ["a", "base_link", "", "imu_link_long_name"]
    with BagWriter(path) as w:
        for k in range(40):
            hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=k, nanosec=7 * k),
                                           frame_id=frames[k % 4])
            m = T["sensor_msgs/msg/NavSatFix"](hdr, T["sensor_msgs/msg/NavSatStatus"](0, 1), 1.0 * k, -2.0 * k,
                                               0.5 * k, np.arange(9.0) * k, k % 4)
            w.write("/fix", "sensor_msgs/msg/NavSatFix", 10 + k, serialize(m, "sensor_msgs/msg/NavSatFix"))
            st = T["diagnostic_msgs/msg/DiagnosticStatus"](level=0, name="n" * (k % 3),
                                                           message="m", hardware_id="h",
                                                           values=[T["diagnostic_msgs/msg/KeyValue"]("k", "v")] * (k % 2))
            arr = T["diagnostic_msgs/msg/DiagnosticArray"](hdr, [st] * (k % 3))
            w.write("/diag", "diagnostic_msgs/msg/DiagnosticArray", 10 + k,
                    serialize(arr, "diagnostic_msgs/msg/DiagnosticArray"))
    arrays, _, checked = _compare(path)
    assert arrays.topics["/fix"]["header.frame_id"].tolist()[:4] == [b"a", b"base_link", b"", b"imu_link_long_name"]
    assert checked > 400


def test_compiled_record_walk_equals_the_plain_walk():
    mcap = next(COMMITTED[0].glob("*.mcap"))
    data = np.fromfile(mcap, np.uint8)
    fast = bag_arrays.walk_records(data, 8)
    plain = bag_arrays.walk_records(data, 8, compiled=False)
    assert len(fast[0]) > 10
    for a, b in zip(fast, plain):
        assert np.array_equal(a, b)


def test_stamp_order_is_stamp_then_topic_name_then_log_order(tmp_path):
    T = typestore().types
    path = tmp_path / "order"
    with BagWriter(path) as w:
        for topic, stamps in (("/imu/data_raw", [3, 1, 2, 2]), ("/gnss/fix", [2, 1])):
            for i, s in enumerate(stamps):
                hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=s, nanosec=0), frame_id=topic)
                m = T["sensor_msgs/msg/NavSatFix"](hdr, T["sensor_msgs/msg/NavSatStatus"](0, 1), float(i), 0.0, 0.0,
                                                   np.zeros(9), 0)
                w.write(topic, "sensor_msgs/msg/NavSatFix", 100 + i, serialize(m, "sensor_msgs/msg/NavSatFix"))
    b = bag_arrays.read_arrays(path)
    imu, fix = b.topics["/imu/data_raw"], b.topics["/gnss/fix"]
    which, row = stamp_order([imu, fix])
    got = [((imu, fix)[w].topic, int((imu, fix)[w].stamp_ns[r] // 10**9), float((imu, fix)[w]["latitude"][r]))
           for w, r in zip(which, row)]
    assert got == [("/gnss/fix", 1, 1.0), ("/imu/data_raw", 1, 1.0), ("/gnss/fix", 2, 0.0),
                   ("/imu/data_raw", 2, 2.0), ("/imu/data_raw", 2, 3.0), ("/imu/data_raw", 3, 0.0)]
    which, row = log_order([imu, fix])
    assert [(imu, fix)[w].t_ns[r] for w, r in zip(which, row)] == [100, 100, 101, 101, 102, 103]


@pytest.fixture(scope="module")
def imported_twice(tmp_path_factory):
    """A KF-GINS-format set (test/core/importer/kfgins_files.py) imported by the array writer and by the
    per-message reference writer."""
    import sys
    sys.path.insert(0, str(pathlib.Path(__file__).parent / "core" / "importer"))
    from kfgins_files import filter_block_of, write_import_file, write_kfgins_set
    from hyper_nav_workbench import import_data
    from hyper_nav_sim.core.scenario import load_scenario
    from hyper_nav_workbench.graph import apply_overrides
    d = tmp_path_factory.mktemp("kfgins_arrays")
    sc = apply_overrides(load_scenario("default"), {"duration_s": 30.0}, d)
    write_kfgins_set(sc, d)
    imported = import_data.load_import(write_import_file(d, filter_block_of(sc)))
    fast = import_data.write(imported, d / "fast")
    ref = import_data.write(imported, d / "ref", per_message=True)
    assert fast == ref == {"/imu/data_raw": 1500, "/gnss/fix": 300, "/gnss/vel": 300, "/truth/state": 1501}
    return d / "fast", d / "ref"


def test_the_array_writer_writes_the_messages_of_the_per_message_writer(imported_twice):
    fast, ref = (bag_arrays.read_arrays(p) for p in imported_twice)
    assert not fast.truncated and fast.counts == ref.counts
    for topic, a in fast.topics.items():
        b = ref.topics[topic]
        assert np.array_equal(a.t_ns, b.t_ns) and a.fields.keys() == b.fields.keys()
        for path, col in a.fields.items():
            if topic == "/truth/state" and path.startswith("q_b_enu"):
                # a stack of rotations through scipy, one at a time through Shepperd's method
                np.testing.assert_allclose(col, b[path], rtol=0, atol=2e-15)
            else:
                assert np.array_equal(col, b[path]), (topic, path)
    # the same log order across topics (ties: imu, gnss, truth, as written)
    order = [log_order([x.topics[t] for t in sorted(x.topics)]) for x in (fast, ref)]
    assert np.array_equal(order[0][0], order[1][0]) and np.array_equal(order[0][1], order[1][1])
    meta_fast = (imported_twice[0] / "metadata.yaml").read_text()
    meta_ref = (imported_twice[1] / "metadata.yaml").read_text()
    assert meta_fast == meta_ref.replace("ref.mcap", "fast.mcap")


def test_a_bag_of_the_array_writer_decodes_with_rosbags_and_mcap_ros2(imported_twice):
    from mcap_ros2.reader import read_ros2_messages
    fast = imported_twice[0]
    reader = read_bag(fast)
    assert reader._records is None            # rosbags read it (the tolerant fallback was not needed)
    n, last = {}, {}
    for rec in reader:
        m = deserialize(rec.raw, rec.msgtype)
        n[rec.topic] = n.get(rec.topic, 0) + 1
        last[rec.topic] = m
    assert not reader.truncated and n == {"/imu/data_raw": 1500, "/gnss/fix": 300, "/gnss/vel": 300,
                                          "/truth/state": 1501}
    decoded = {}
    for m in read_ros2_messages(next(fast.glob("*.mcap"))):
        decoded.setdefault(m.channel.topic, []).append(m.ros_msg)
    assert {t: len(v) for t, v in decoded.items()} == n
    imu = decoded["/imu/data_raw"][-1]
    assert imu.header.frame_id == "imu_link" and imu.angular_velocity.x == last["/imu/data_raw"].angular_velocity.x
    assert list(decoded["/gnss/fix"][-1].position_covariance) == list(last["/gnss/fix"].position_covariance)
    assert decoded["/truth/state"][-1].lat_rad == last["/truth/state"].lat_rad


@pytest.mark.parametrize("content", [b"", b"\x89MCA", b"not an mcap file at all"])
def test_an_empty_short_or_foreign_file_is_reported_not_read(tmp_path, content):
    """(the file is mapped from the page cache when it can be: an empty or short one is read as before)"""
    (tmp_path / "x.mcap").write_bytes(content)
    got = bag_arrays.read_arrays(tmp_path)
    assert got.topics == {} and got.truncated and "not an MCAP file (bad magic)" in got.error
