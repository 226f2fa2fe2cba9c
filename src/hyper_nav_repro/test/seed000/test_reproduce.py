"""The seed 000 reproduction command in its short mode (every part on a 5 s
flight with 1 s windows): it prints, writes the JSON and the PNGs, and its
numbers are the ones the parts compute."""
import json

import numpy as np

from hyper_nav_repro.seed000.reproduce import PAPER, main


def test_short_mode_writes_every_part(tmp_path, capsys):
    assert main(["--short", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Table 5" in out and "0.31 %" in out
    r = json.loads((tmp_path / "seed000_rl_dlac.json").read_text())
    assert r["paper"] == PAPER
    # 1 s of the paper's smooth flight tells little about the frequencies (bound > 30 %; 10 s: > 200 %)
    paper_case = r["bound"]["cases"][0]
    assert min(paper_case["sigma_pct"]) > 30.0
    assert len(r["surface"]["noisy"]["w1"]["reward_m"]) == 3
    run = r["table5"]["runs"][0]
    table2 = np.array(PAPER["initial_radps"])
    assert np.all(np.abs(np.array(run["learned_radps"]) / table2 - 1) <= 0.25 + 1e-9)      # the search box
    assert run["n_passes"] == 2 * 5 + 1 + 7 and len(run["episode_rewards_m"]) == 2
    for case in ("paper", "excited", "excited_world"):
        assert set(r["compare"][case]["summary"]) == {"ddpg", "cmaes", "nelder_mead", "max_likelihood"}
        assert r["compare"][case]["data"].startswith("simulator world" if case != "excited" else "perfect-model")
        assert all(v["data"] == r["compare"][case]["data"] for v in r["compare"][case]["summary"].values())
    ident = r["identifier"]
    assert ident["data"].startswith("simulator world") and "carrier-phase-grade" in ident["data"]
    (row,) = ident["runs"]
    assert row["set"] == "paper Table 4" and row["ddpg"]["n_passes"] >= 1
    ml = row["max_likelihood"]
    # a window with no doublet (the short flight) leaves the frequencies unobservable: not converged, not counted
    assert ml["within_3_sigma"] == (ml["converged"] and bool(np.all(np.abs(ml["error_over_sigma"]) < 3.0)))
    assert ident["all_three_within_3_sigma"] == int(ml["within_3_sigma"]) and ident["n"] == 1
    nav = r["navigation"]["runs"]
    assert set(nav) == {"KF-FLAC (rigid r0)", "DLAC, Table 2", "RL-DLAC"}
    assert all(v["rms_3d"]["pos"] < 10.0 for v in nav.values())
    for png in ("reward_per_episode", "frequency_estimates", "navigation_errors", "reward_surface"):
        assert (tmp_path / f"{png}.png").stat().st_size > 10_000
