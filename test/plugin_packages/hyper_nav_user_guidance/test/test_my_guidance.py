"""The user's own test suite: their node in hyper-nav's loop through the
hyper_nav_guidance_loop fixture (the project's pytest plugin; no conftest)."""
import math


def test_my_guidance_in_the_loop(hyper_nav_guidance_loop):
    run = hyper_nav_guidance_loop(("hyper_nav_user_guidance", "user_guidance"), scenario="guidance_glide",
                                  overrides={"duration_s": 130.0, "graph.real_time_factor": 10.0})
    print("miss", run.miss, "truth node", run.truth_node)
    assert run.replay_equal                                  # the live flight is the commands' flight
    assert int(run.truth_node["commands missed"]) == 0
    assert not any(k.startswith("commands refused") for k in run.truth_node)
    assert int(run.truth_node["commands accepted"]) >= 1000 and len(run.commands) >= 1000
    assert run.bag is not None and (run.bag / "metadata.yaml").exists()
    assert math.isfinite(run.miss["miss_m"]) and run.miss["miss_m"] < 20000.0
