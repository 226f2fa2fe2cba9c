"""Issue 37 item 5 in the scenarios: the tightly coupled seed 004 scenarios
fly range-bias states in the realistic world (the filter's default) and
white range errors in the perfect-model world, where the truth is the
receiver's broadcast models and the only pseudorange error its white noise;
a scenario that says ``range_errors`` keeps it in both."""
import pathlib
import tempfile

from hyper_nav_sim.core.scenario import apply_overrides, load_scenario


def _sc(name, **fields):
    sc = load_scenario(name)
    return apply_overrides(sc, fields, pathlib.Path(tempfile.mkdtemp(prefix="sc_"))) if fields else sc


def test_realistic_world_range_bias_states_perfect_world_white():
    for name in ("seed004_tight", "seed004_virtual"):
        real = _sc(name).filter_config()
        assert real.range_errors == "states" and real.layout.has("rb32"), name
        perfect = _sc(name, **{"world.model": "perfect"}).filter_config()
        assert perfect.range_errors == "white" and not perfect.layout.has("rb32"), name
        told = _sc(name, **{"world.model": "perfect", "filter.config.range_errors": "states"}).filter_config()
        assert told.layout.has("rb32"), name
    # the pseudoranges take the receiver's own sigmas: the range errors are the states', not a white floor
    assert _sc("seed004_virtual").filter_sources()["gnss_raw"]["sigma_scale"] == 1.0
    # loosely coupled scenarios: unchanged
    assert _sc("default").filter_config().state_blocks == ("att", "vel", "pos", "bg", "ba")
