"""The recorder's clock allowance follows what it has written, not its node
clock (core/record_pace.py)."""
import pytest

from hyper_nav_sim.core.bag import serialize, typestore
from hyper_nav_sim.core.record_pace import RecordPace, header_stamp_s


def _imu_raw(sec, nsec):
    T = typestore().types
    hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id="imu_link")
    import numpy as np
    q = T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
    v = T["geometry_msgs/msg/Vector3"](0.0, 0.0, 0.0)
    m = T["sensor_msgs/msg/Imu"](hdr, q, np.zeros(9), v, np.zeros(9), v, np.zeros(9))
    return serialize(m, "sensor_msgs/msg/Imu")


def test_header_stamp_from_raw_cdr():
    assert header_stamp_s(_imu_raw(12, 340_000_000)) == pytest.approx(12.34, abs=1e-12)
    assert header_stamp_s(b"\x00\x01") is None


def test_a_recorder_behind_its_queue_holds_the_clock_a_silent_stream_does_not():
    pace = RecordPace(lead_s=0.5, gap_wall_s=1.0)
    assert pace.allowance_s(clock_s=3.0, wall_s=0.0) == 3.5            # nothing written yet: the node clock
    pace.written(2.0, wall_s=10.0)
    # the node clock (newest /clock) is at 9 s, the recorder has written the IMU up to 2 s: 2.5, not 9.5
    assert pace.allowance_s(clock_s=9.0, wall_s=10.2) == 2.5
    pace.written(8.9, wall_s=10.3)                                      # caught up
    assert pace.allowance_s(clock_s=9.0, wall_s=10.4) == pytest.approx(9.4)
    pace.written(1.0, wall_s=10.5)                                      # an older stamp never moves it back
    assert pace.allowance_s(clock_s=9.0, wall_s=10.6) == pytest.approx(9.4)
    # the IMU stream silent for more than gap_wall_s: nothing queued (a gap in the data): the node clock
    assert pace.allowance_s(clock_s=12.0, wall_s=11.6) == 12.5
    # never ahead of the node clock
    assert pace.allowance_s(clock_s=5.0, wall_s=10.6) == 5.5
