"""Classical identifiers (core.lever_arm.identifiers) where the bound allows."""
import numpy as np
from hyper_nav_filter.core.elastic_lever_arm import TABLE4_FREQ_RADPS

TRUE = np.asarray(TABLE4_FREQ_RADPS)

from hyper_nav_aiding.core.lever_arm import identifiers
from hyper_nav_aiding.core.lever_arm.crb import fisher_information
from hyper_nav_aiding.core.lever_arm.env import LeverArmFrequencyEnv


def test_max_likelihood_reaches_the_bound(doublet, pm_window_noisy):
    """From 1 % off Table 4 on the ringing window with 5 m / 0.1 m/s fixes,
    maximum likelihood on the innovations lands within 3 sigma of the CRB
    (CRB 0.10/0.14/1.25 %) and reports that sigma."""
    _, cfg, _ = doublet
    env = LeverArmFrequencyEnv(pm_window_noisy, cfg, TRUE * 1.01)
    res = identifiers.max_likelihood(env, 30, grid_points=0)
    crb = fisher_information(pm_window_noisy, cfg, TRUE).sigma_radps
    err = res.freqs_radps - TRUE
    print(f"\nML error {100 * err / TRUE} %, CRB {100 * crb / TRUE} %, {res.n_passes} passes, {res.note}")
    assert np.all(np.abs(err) < 3 * crb)
    np.testing.assert_allclose(res.sigma_radps, crb, rtol=0.3)
    assert res.n_passes <= 31
