"""The liveness core on synthetic /diagnostics statuses: dead nodes, missing
streams, no false alarm at the start, between reports or after the end."""
from hyper_nav_workbench.core.liveness import ERROR, OK, STALE, WARN, LivenessConfig, LivenessMonitor, StreamSpec

NODES = ("imu", "gnss", "fusion")
STREAMS = (StreamSpec("imu/data_raw", 3.0, critical=True), StreamSpec("gnss/fix", 3.0))


class Run:
    """A graph at real-time factor 3 whose nodes report once per wall second."""

    def __init__(self, end_s=60.0, hb=5.0):
        self.m = LivenessMonitor(LivenessConfig(NODES, STREAMS, heartbeat_timeout_s=hb, end_s=end_s), 0.0)
        self.wall, self.sim = 0.0, 0.0
        self.imu = self.fix = 0
        self.alive = set(NODES)
        self.imu_on = self.gnss_on = True

    def second(self):
        """One wall second: 3 s of sim time, then every live node reports."""
        for _ in range(3):
            self.sim += 1.0
            self.m.on_clock(self.sim)
            self.imu += 50 if self.imu_on else 0
            self.fix += 10 if self.gnss_on else 0
        self.wall += 1.0
        if "imu" in self.alive:
            self.m.on_status("imu", {"published imu/data_raw": str(self.imu), "heartbeat": "1"}, self.wall)
        if "gnss" in self.alive:
            self.m.on_status("gnss", {"published gnss/fix": str(self.fix)}, self.wall)
        if "fusion" in self.alive:
            self.m.on_status("fusion", {"received imu/data_raw": str(self.imu), "received gnss/fix": str(self.fix),
                                        "published nav/state": "0"}, self.wall + 0.3)

    def verdicts(self):
        return {v.name: v for v in self.m.evaluate(self.wall + 0.5)}


def test_waiting_then_all_alive_without_false_alarm():
    r = Run()
    v = r.verdicts()
    assert v["node imu"].level == STALE and v["stream imu/data_raw"].level == STALE      # no /clock yet
    for _ in range(20):
        r.second()
        assert {x.level for x in r.verdicts().values()} == {OK}, r.verdicts()


def test_stream_that_stops_while_its_node_lives_is_missing_since_its_last_progress():
    """Judged at the producer and at the consumer: the longest silence counts."""
    r = Run()
    for _ in range(4):
        r.second()                             # sim 12 s
    r.gnss_on = False
    for _ in range(2):
        r.second()                             # 6 s without fixes, counted between fusion's reports
    v = r.verdicts()["stream gnss/fix"]
    assert v.level == WARN and v.since_s == 12.0, v
    assert "nothing received at fusion for 6.0 s (since t = 12.0 s)" in v.message
    assert r.verdicts()["stream imu/data_raw"].level == OK
    r.gnss_on = True
    r.second()
    assert r.verdicts()["stream gnss/fix"].level == OK         # back


def test_critical_stream_is_an_error():
    r = Run()
    r.second()
    r.imu_on = False
    for _ in range(2):
        r.second()
    v = r.verdicts()["stream imu/data_raw"]
    assert v.level == ERROR and v.since_s == 3.0


def test_killed_node_is_dead_with_the_time_of_its_last_heartbeat():
    r = Run()
    for _ in range(3):
        r.second()                             # last gnss status at sim 9 s
    r.alive.discard("gnss")
    r.gnss_on = False
    for _ in range(4):
        r.second()
        assert r.verdicts()["node gnss"].level == OK           # within the 5 s heartbeat timeout
    r.second()
    v = r.verdicts()["node gnss"]
    assert v.level == ERROR and v.since_s == 9.0 and "dead: no heartbeat for 5.5 s, last at t = 9.0 s" in v.message
    assert r.verdicts()["stream gnss/fix"].level == WARN        # fusion, alive, receives no fixes


def test_stream_lost_with_every_node_that_reported_it():
    r = Run()
    for _ in range(2):
        r.second()
    r.alive -= {"imu", "fusion"}
    r.imu_on = False
    for _ in range(7):
        r.second()
    v = r.verdicts()["stream imu/data_raw"]
    assert v.level == ERROR and v.since_s == 6.0 and "fusion, imu reported it until t = 6.0 s" in v.message


def test_finished_node_and_streams_after_the_end_are_not_faults():
    r = Run(end_s=12.0)
    for _ in range(4):
        r.second()
    r.imu_on = r.gnss_on = False               # every stream ends with the scenario
    r.m.on_status("imu", {"finished": "true", "published imu/data_raw": str(r.imu)}, r.wall)
    r.alive.discard("imu")
    for _ in range(10):
        r.second()
    v = r.verdicts()
    assert v["node imu"].level == OK and v["node imu"].message == "finished"
    assert v["stream imu/data_raw"].level == OK and v["stream gnss/fix"].level == OK


def test_node_never_started():
    m = LivenessMonitor(LivenessConfig(("imu",), (), startup_timeout_s=60.0), 0.0)
    assert m.node_verdict("imu", 59.0).level == STALE
    v = m.node_verdict("imu", 61.0)
    assert v.level == ERROR and "never started" in v.message


def test_stamps_and_own_sim_time_make_silence_exact():
    """A producer that reports the stamp of its last message and its own sim
    time: the silence is exact even with sparse reports and no /clock."""
    m = LivenessMonitor(LivenessConfig(("player",), (StreamSpec("gnss/fix", 3.0),)), 0.0)
    m.on_status("player", {"published gnss/fix": "21", "last gnss/fix": "2.000", "sim_time_s": "2.1"}, 1.0)
    m.on_status("player", {"published gnss/fix": "100", "last gnss/fix": "9.900", "sim_time_s": "10.0"}, 2.0)
    assert m.stream_verdict(m.cfg.streams[0], 2.5).level == OK
    m.on_status("player", {"published gnss/fix": "101", "last gnss/fix": "10.000", "sim_time_s": "18.9"}, 3.0)
    v = m.stream_verdict(m.cfg.streams[0], 3.5)
    assert v.level == WARN and v.since_s == 10.0 and "for 8.9 s (since t = 10.0 s)" in v.message
    assert m.sim_s == 18.9                                          # from the status, without /clock
