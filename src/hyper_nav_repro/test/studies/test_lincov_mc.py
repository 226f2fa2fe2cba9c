"""The LinCov-vs-Monte-Carlo command (studies.lincov_mc) in a short mode: a
user-style trajectory (another scenario's truth written as a 10 Hz file)
flown with the default sensors and filter, a few runs; the JSON and plot are
written and the trajectory flown is the file's. The full comparison (200
runs per flight) is the command itself (docs/design_studies.md)."""
import json

import numpy as np

from hyper_nav_repro.studies import lincov_mc
from hyper_nav_sim.core.scenario import load_scenario


def test_short_mode_on_a_user_style_trajectory(tmp_path, capsys):
    assert lincov_mc.main(["--scenario", "default", "--trajectory-of", "guidance_glide", "--set", "duration_s=8",
                           "--runs", "3", "--out", str(tmp_path)]) == 0
    out = tmp_path / "seed000_default_on_guidance_glide_file"
    doc = json.loads((out / "lincov_mc.json").read_text())
    assert (out / "lincov_mc_all.png").stat().st_size > 10000
    assert doc["cases"]["all"]["n_runs"] == 3 and "trajectory_file" not in doc["settings"]
    s = doc["cases"]["all"]["summary"]
    assert set(s) == {"pos", "vel", "att"} and all(np.isfinite(v["max_abs_rel_diff"]) for v in s.values())
    # the flight is the glide's, read back from the file (10 Hz: within the interpolation error)
    user = load_scenario(str(tmp_path / "seed000_default_on_guidance_glide_file.yaml"))
    glide = load_scenario("guidance_glide")
    t = np.linspace(0.0, 8.0, 17)
    a, b = user.trajectory().truth(t), glide.trajectory().truth(t)
    assert np.abs(a.alt_m - b.alt_m).max() < 0.01 and np.abs(a.lat_rad - b.lat_rad).max() * 6.4e6 < 0.01
    assert "LinCov pass" in capsys.readouterr().out
