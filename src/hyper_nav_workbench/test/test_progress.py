"""Progress lines of long runs: sim time, real-time factor, ETA."""
import io

from hyper_nav_workbench.progress import Progress


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_progress_line_rate_eta_and_interval():
    clock, out = FakeClock(), io.StringIO()
    p = Progress("run_graph", total=300.0, interval_s=5.0, stream=out, clock=clock)
    clock.t += 2.0
    p.update(6.0)                            # within the interval: silent
    assert out.getvalue() == ""
    clock.t += 8.0                           # 10 s wall, 30 s sim: 3x, 270 s left -> 1.5 min
    p.update(30.0)
    assert p.lines[-1] == "[run_graph]  10%, 30.0/300.0 s sim, 3.00x real time, ETA 1.5 min"
    p.restart(30.0)                          # rates from here on (start-up excluded)
    clock.t += 60.0
    p.update(300.0, force=True)
    p.done("1500 solutions")
    assert p.lines[-1] == "[run_graph] done: 300.0 s sim in 60 s wall, 4.50x real time; 1500 solutions"


def test_progress_in_runs_per_minute():
    clock = FakeClock()
    p = Progress("mc_campaign", total=20, unit="runs", sim=False, stream=io.StringIO(), clock=clock)
    clock.t += 120.0
    assert p.line(10) == "[mc_campaign]  50%, 10.0/20.0 runs, 5.0 per min, ETA 2.0 min"
