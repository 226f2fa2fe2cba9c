"""replay_order.live_order: the replay order of a recording does not depend
on the order its records are given in; the node's late-input reports put
those inputs right after the IMU sample they followed; a report whose
message is not in the records is returned, not lost."""
import random
from types import SimpleNamespace as NS

from hyper_nav_filter.offline import replay_records
from hyper_nav_filter.replay_order import LateInput, live_order, split_late_inputs

MS = 1_000_000


def msg(t_ms, label=""):
    return NS(header=NS(stamp=NS(sec=t_ms // 1000, nanosec=(t_ms % 1000) * MS)), label=label)


def stream():
    recs = [("/imu/data_raw", msg(t, f"imu{t}")) for t in range(0, 1000, 20)]
    recs += [("/gnss/fix", msg(t, f"fix{t}")) for t in range(0, 1000, 100)]
    recs += [("/gnss/vel", msg(t, f"vel{t}")) for t in range(0, 1000, 100)]
    return recs


def labels(records):
    return [m.label for _, m in records]


def test_stamp_order_whatever_the_record_order():
    recs = stream()
    ref = labels(live_order(recs).records)
    for seed in range(5):
        shuffled = recs[:]
        random.Random(seed).shuffle(shuffled)
        assert labels(live_order(shuffled).records) == ref
    # ties: topic name, so gnss at an IMU stamp comes before the IMU sample (the engine does not mind)
    assert ref[:3] == ["fix0", "vel0", "imu0"]


def test_late_inputs_follow_the_imu_sample_they_followed_live():
    recs = stream()
    late = [LateInput("gnss/fix", 300 * MS, 0, 360 * MS, "applied"),
            LateInput("gnss/vel", 300 * MS, 0, 360 * MS, "applied"),
            LateInput("gnss/fix", 500 * MS, 0, 1700 * MS, "gnss_pos_stale")]   # beyond the last IMU sample
    ro = live_order(recs[::-1], late)
    order = labels(ro.records)
    assert order.index("fix300") == order.index("imu360") + 1 and order.index("vel300") == order.index("fix300") + 1
    assert order[-1] == "fix500" and order[-2] == "imu980"
    assert ro.placed == 3 and ro.missing == ()
    assert len(order) == len(recs)


def test_report_without_its_message_is_returned_as_missing():
    ro = live_order(stream(), [LateInput("gnss/fix", 310 * MS, 0, 360 * MS, "applied")])
    assert ro.placed == 0 and len(ro.missing) == 1 and len(ro.records) == len(stream())


def test_reports_as_messages_and_split_from_the_records():
    rep = NS(header=NS(stamp=NS(sec=0, nanosec=300 * MS)), topic="/gnss/fix", occurrence=0,
             after_imu_stamp=NS(sec=0, nanosec=340 * MS), outcome="applied")
    recs = stream() + [("/nav/late_inputs", rep)]
    inputs, late = split_late_inputs(recs)
    assert late == [rep] and len(inputs) == len(stream())
    fed, ro = replay_records(recs)
    order = labels(fed)
    assert order.index("fix300") == order.index("imu340") + 1 and ro.placed == 1
    given, none = replay_records(recs, order="given")
    assert none is None and labels(given) == labels(stream())
