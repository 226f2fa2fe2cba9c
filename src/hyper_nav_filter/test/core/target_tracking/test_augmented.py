"""Augmented glide model (maneuver parameters as states) and its PCRB:
the bound reduces to the known-maneuver bound as the parameters' process
noise and prior vanish, grows when they do not, and the known-maneuver bound
of the augmented model agrees with ``pcrb`` (the eq. 21 model with chi)."""
import numpy as np

from hyper_nav_filter.core.target_tracking import augmented as au
from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking import pcrb
from hyper_nav_filter.core.target_tracking.config import TrackerConfig

CFG = TrackerConfig(nominal_c_l=0.3)
X0 = np.array([55000.0, 0.0, 0.0, 6800.0, np.deg2rad(-0.2), np.deg2rad(80.0)])


def _truth(n=400, a_l=0.0):
    """A glide flown by the augmented model itself (c_l 0.3; lateral lift a_l from 150 s)."""
    par = np.tile([0.3, 0.0, 1.09], (n, 1))
    par[150:, 1] = a_l
    return au.perfect_model_truth(CFG.model, X0, par, 1.0), par


def test_augmented_bound_reduces_to_known_maneuver_bound():
    x, par = _truth(a_l=0.5)
    F = au.truth_jacobians(CFG.model, x, par, 1.0)
    known = au.rms_sigma(au.known_bound(F, CFG.P0, CFG.R))
    for factor, rtol in ((1e-3, 2e-3), (1e-5, 1e-6), (0.0, 1e-9)):
        aug = au.rms_sigma(au.augmented_bound(F, CFG.P0, CFG.R, au.ManeuverNoise().scaled(factor), 1.0))
        np.testing.assert_allclose(aug, known, rtol=rtol)
    # with the scenario-size noise the maneuver costs: v, gamma, psi bounds at least 20 % above
    aug = au.rms_sigma(au.augmented_bound(F, CFG.P0, CFG.R, au.ManeuverNoise(), 1.0))
    assert np.all(aug >= known * (1 - 1e-9))
    assert np.all(aug[[3, 4, 5]] > 1.2 * known[[3, 4, 5]]), (aug / known)


def test_known_bound_agrees_with_the_eq21_pcrb():
    """Without lateral lift the augmented model is eq. 21 (lambda1 = a_v,
    lambda1 lambda2 = 1 + a_v^2); both bounds within 0.5 %."""
    x, par = _truth(a_l=0.0)
    F = au.truth_jacobians(CFG.model, x, par, 1.0)
    known = au.rms_sigma(au.known_bound(F, CFG.P0, CFG.R))
    x7 = np.concatenate([x, np.zeros((len(x), 1))], axis=1)
    u = np.tile(gm.glide_inputs(0.3, 100.0), (len(x), 1))
    Fo = pcrb.jacobians(CFG.model, x7, u, np.zeros(len(x)), 1.0)
    np.testing.assert_allclose(known, pcrb.rms_bound(pcrb.bound(Fo, CFG.P0, CFG.R)), rtol=5e-3)


def test_jacobian_matches_a_perturbed_step():
    y = np.concatenate([X0, [0.3, 0.8, 1.05]])[None] / au.AUG_SCALE
    f0, F = au.transition(CFG.model, y, 1.0)
    d = np.array([0.3, 0.2, -0.1, 0.05, 0.1, -0.2, 0.01, -0.02, 0.01]) * 1e-2
    f1, _ = au.transition(CFG.model, y + d, 1.0)
    np.testing.assert_allclose(f1[0] - f0[0], F[0] @ d, atol=1e-6, rtol=1e-3)
