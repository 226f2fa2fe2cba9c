"""study_lincov (studies/lincov_budget.py) in a short mode: one LinCov pass of the default scenario's filter
over 60 s with a 20 s GNSS blackout, and both catalogue sweeps. The grades order as their figures do: a better
IMU grade drifts less through the blackout, a better GNSS receiver leaves a smaller position sigma at the end;
the JSON holds the table, the sweeps and their figures, and the PNGs are written."""
import json

from hyper_nav_repro.studies import lincov_budget
from hyper_nav_sim.core.sensor_catalogue import CATALOGUE


def test_short_budget_with_imu_and_gnss_sweeps(tmp_path, capsys):
    assert lincov_budget.main(["--scenario", "default", "--set", "duration_s=60", "--blackout", "20:40",
                               "--sweep", "imu", "--sweep", "gnss", "--out", str(tmp_path)]) in (0, None)
    (out,) = [d for d in tmp_path.iterdir() if d.is_dir()]                  # named after the scenario run
    doc = json.loads((out / "budget.json").read_text())
    assert doc["outages_s"] == [[20.0, 40.0]] and doc["table"]
    for name in ("budget.png", "sweep_imu.png", "sweep_gnss.png"):
        assert (out / name).stat().st_size > 10_000, name
    imu = {r["grade"]: r for r in doc["sweep"]}
    gnss = {r["grade"]: r for r in doc["sweep_gnss"]}
    assert set(imu) == set(CATALOGUE["imu"]) and set(gnss) == set(CATALOGUE["gnss"])
    blackout = [imu[g]["max_pos_sigma_3d_in_blackout_m"] for g in ("navigation", "tactical", "automotive")]
    assert blackout == sorted(blackout) and blackout[0] < blackout[-1] / 10, blackout
    assert all(20.0 <= r["at_t_s"] <= 40.0 for r in imu.values())
    end = [gnss[g]["final_pos_sigma_3d_m"] for g in ("ublox_f9p", "ublox_m8", "gps_sps")]
    assert end == sorted(end) and end[0] < end[-1] / 2, end
    printed = capsys.readouterr().out
    assert "grade sweep: fixes per catalogue GNSS receiver grade" in printed and "ublox_f9p" in printed
