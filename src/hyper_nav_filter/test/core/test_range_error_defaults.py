"""Issue 37 item 5: the tightly coupled filter's range errors are states by
default. A layout with the receiver clock (``clk``, tightly coupled) and no
range-bias block gets ``rb32`` (``filter.config.range_errors: states``, the
declared default) with the declared sigma and correlation time (the values
measured on seed 004's realistic world: 2.2 m, 1500 s); ``white`` keeps the
pseudorange sigmas alone; a loosely coupled layout is left as it is."""
import numpy as np
import pytest

from hyper_nav_filter.core.config import PARAM_BY_NAME, FilterConfig
from hyper_nav_filter.core.params import ConfigError

TC = ["att", "vel", "pos", "bg", "ba", "clk"]


def test_tightly_coupled_layout_gets_range_bias_states_by_default():
    cfg = FilterConfig.from_dict({"state_blocks": TC})
    assert cfg.range_errors == "states" == PARAM_BY_NAME["range_errors"].default
    assert cfg.state_blocks == tuple(TC) + ("rb32",)
    assert cfg.layout.has("rb32") and cfg.layout.sl("rb32").stop - cfg.layout.sl("rb32").start == 32
    assert (cfg.range_bias_sigma_m, cfg.range_bias_tau_s) == (2.2, 1500.0)
    P0 = np.diag(cfg.initial_covariance())[cfg.layout.sl("rb32")]
    np.testing.assert_allclose(P0, 2.2 ** 2)
    # the configuration written out and read back is the same one (node parameters, filter.yaml)
    assert FilterConfig.from_dict(cfg.as_dict()) == cfg
    assert FilterConfig.from_dict(cfg.as_dict()).state_blocks == cfg.state_blocks


def test_white_range_errors_loosely_coupled_and_explicit_blocks_are_left_alone():
    assert FilterConfig.from_dict({"state_blocks": TC, "range_errors": "white"}).state_blocks == tuple(TC)
    assert FilterConfig().state_blocks == ("att", "vel", "pos", "bg", "ba")          # loosely coupled default
    assert FilterConfig.from_dict({"state_blocks": TC + ["rb"]}).state_blocks == tuple(TC) + ("rb",)
    assert FilterConfig.from_dict({"state_blocks": TC + ["isb", "rb32"]}).state_blocks == tuple(TC) + ("isb", "rb32")
    with pytest.raises(ConfigError, match="range_errors"):
        FilterConfig.from_dict({"state_blocks": TC, "range_errors": "correlated"})


def test_lci_frame_layout_is_left_as_listed():
    """The LCI frame (seed 001, flown loosely coupled) is where the default was
    not measured: its layout stays as listed."""
    cfg = FilterConfig.from_dict({"state_blocks": TC, "mechanization_frame": "LCI"})
    assert cfg.state_blocks == tuple(TC)
