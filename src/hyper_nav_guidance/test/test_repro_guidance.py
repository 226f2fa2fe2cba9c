"""repro_guidance's short mode (one seed): every case flies to the target
altitude, writes its JSON and PNGs, and the table's figures hold their bounds:
the truth-fed loop within the law's tolerance, navigation in the loop within
2x the same-latency truth loop plus the navigation error (GNSS throughout)."""
import json

import pytest

from hyper_nav_guidance.repro_guidance import main

pytestmark = pytest.mark.slow


def test_short_mode(tmp_path):
    main(["--out", str(tmp_path), "--short"])
    r = json.loads((tmp_path / "repro_guidance.json").read_text())
    s = r["summary"]
    assert set(s) == {"truth", "truth_1.1s", "nav_delayed", "blackout_60s", "ins_after_50s"}
    assert all((tmp_path / f).stat().st_size > 10000 for f in ("tracks.png", "miss.png", "commands.png"))
    assert s["truth"]["miss_mean_m"] < 5.0
    assert s["nav_delayed"]["miss_mean_m"] < 2.0 * s["truth_1.1s"]["miss_mean_m"] + s["nav_delayed"]["nav_error_end_mean_m"]
    assert all(run["refused"] == {} for runs in r["runs"].values() for run in runs)
    assert r["pending"]                          # the current-time stream is named as not run
