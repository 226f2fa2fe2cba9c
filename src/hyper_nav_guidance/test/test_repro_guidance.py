"""repro_guidance's short mode (one seed, both streams): every case flies to
the target altitude, writes its JSON and PNGs, and the table's figures hold
their bounds: the truth-fed loop within the law's tolerance, navigation in
the loop within 2x the same-latency truth loop plus the navigation error
(GNSS throughout), and the current-time stream (issue 35) missing by less
than the delayed one on the same seed."""
import json

import pytest

from hyper_nav_guidance.repro_guidance import main

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    out = tmp_path_factory.mktemp("guidance")
    main(["--out", str(out), "--short"])
    return out, json.loads((out / "repro_guidance.json").read_text())


def test_short_mode(short):
    tmp_path, r = short
    s = r["summary"]
    assert set(s) == {"truth", "truth_1.1s", "nav_delayed", "blackout_60s_delayed", "ins_after_50s_delayed",
                      "nav_current", "blackout_60s_current", "ins_after_50s_current"}
    assert all((tmp_path / f).stat().st_size > 10000 for f in ("tracks.png", "miss.png", "commands.png"))
    assert s["truth"]["miss_mean_m"] < 5.0
    assert s["nav_delayed"]["miss_mean_m"] < 2.0 * s["truth_1.1s"]["miss_mean_m"] + s["nav_delayed"]["nav_error_end_mean_m"]
    assert all(run["refused"] == {} for runs in r["runs"].values() for run in runs)
    assert r["pending"] == []                    # both streams were run


def test_current_stream_misses_less_than_delayed(short):
    """Same seed (0), GNSS throughout: on the current-time stream (commands
    0.1 s after the state) the miss is below the delayed stream's (1.1 s) by
    at least 1 m. Measured (10 seeds, docs/guidance.md): mean 1.76 m against
    3.37 m, the current stream lower on 8 of 10 seeds, by 2.23 m on seed 0
    (0.71 m against 2.94 m); the 1.1 s latency alone costs 3.15 m on truth.
    The 60 s blackout supports no per-seed order (current lower on 7 of 10;
    seed 0: 3.45 m against 3.04 m): only that it flew to the end."""
    _, r = short
    runs = r["runs"]
    cur, dly = runs["nav_current"][0], runs["nav_delayed"][0]
    assert cur["seed"] == dly["seed"]
    assert cur["commands"] >= dly["commands"]       # it acted on its stream up to the end
    assert cur["miss_m"] < dly["miss_m"] - 1.0, (cur["miss_m"], dly["miss_m"])
    b = runs["blackout_60s_current"][0]
    assert b["commands"] >= runs["blackout_60s_delayed"][0]["commands"] and b["refused"] == {}
