"""Residual trigger (core.lever_arm.trigger): fires above the threshold and
not below, once per excursion (hysteresis), not within the cool-down, and
only on a full averaging window."""
import numpy as np
import pytest

from hyper_nav_aiding.lever_arm.core.trigger import ResidualTrigger, TriggerConfig


def run(trig, t, norms):
    """Feed residuals of the given norms (along east) at epochs t; return firing epochs."""
    return [ti for ti, n in zip(t, norms) if trig.update(ti, [n, 0.0, 0.0])]


def test_fires_above_threshold_and_not_below():
    t = np.arange(0.0, 10.0, 0.1)
    assert run(ResidualTrigger(TriggerConfig(3.0, 2.0, 0.0, 0.0)), t, np.full(len(t), 2.99)) == []
    fired = run(ResidualTrigger(TriggerConfig(3.0, 2.0, 0.0, 0.0)), t, np.where(t >= 5.0, 3.01, 1.0))
    assert fired == [pytest.approx(5.0)]


def test_hysteresis_one_firing_per_excursion():
    """Above the threshold, dip between release and threshold, above again:
    one firing; below the release, then above: a second one."""
    trig = ResidualTrigger(TriggerConfig(3.0, 2.0, 0.0, 0.0))
    t = np.arange(0.0, 6.0, 0.1)
    norms = np.select([t < 1, t < 2, t < 3, t < 4, t < 5], [1.0, 4.0, 2.5, 4.0, 1.5], 4.0)
    fired = run(trig, t, norms)
    assert fired == [pytest.approx(1.0), pytest.approx(5.0)]
    assert trig.n_fired == 2


def test_cooldown_delays_the_next_firing():
    trig = ResidualTrigger(TriggerConfig(3.0, 2.0, 10.0, 0.0))
    t = np.arange(0.0, 30.0, 0.1)
    # excursions at 1 s and 4 s (re-armed in between), the second inside the cool-down: it
    # fires when the cool-down ends (11 s) since the statistic is still above the threshold
    norms = np.select([t < 1, t < 2, t < 4], [0.0, 5.0, 0.0], 5.0)
    fired = run(trig, t, norms)
    assert fired == [pytest.approx(1.0), pytest.approx(11.0)]
    assert trig.n_suppressed_cooldown > 0


def test_averaging_removes_white_noise_and_keeps_a_bias():
    """5 m white fixes averaged over 2 s (21 fixes: 1.1 m per axis) stay below
    a 5 m threshold; a 6 m bias added fires after a full window."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 60.0, 0.1)
    noise = rng.standard_normal((len(t), 3)) * 5.0
    trig = ResidualTrigger(TriggerConfig(5.0, 2.0, 0.0, 2.0))
    assert not any(trig.update(ti, r) for ti, r in zip(t[:300], noise[:300]))
    trig = ResidualTrigger(TriggerConfig(5.0, 2.0, 0.0, 2.0))
    fired = [ti for ti, r in zip(t, noise) if trig.update(ti, r + [6.0, 0.0, 0.0])]
    assert fired and fired[0] >= 2.0


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="release_m"):
        TriggerConfig(3.0, 3.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="cooldown_s"):
        TriggerConfig(3.0, 2.0, -1.0, 0.0)
    with pytest.raises(ValueError, match="residual"):
        ResidualTrigger(TriggerConfig(3.0, 2.0, 0.0, 0.0)).update(0.0, [np.nan, 0, 0])
