"""Seed 002 tracker core: model Jacobian, configuration errors, the online
tracker's input checks and its agreement with the batch run."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hyper_nav_filter.core.target_tracking import ekf, filters
from hyper_nav_filter.core.target_tracking import glide_model as gm
from hyper_nav_filter.core.target_tracking.config import TrackerConfig, TrackerConfigError
from hyper_nav_filter.core.target_tracking.tracker import Tracker

CFG = TrackerConfig(filter_type="EKF")


def test_analytic_jacobian_matches_autodiff():
    rng = np.random.default_rng(0)
    m = gm.GlideModel(k_chi=2.0)
    for _ in range(3):
        x = jnp.array([rng.uniform(25e3, 60e3), rng.uniform(-1, 1), rng.uniform(-0.3, 0.3), rng.uniform(2e3, 7e3),
                       rng.uniform(-0.03, 0.01), rng.uniform(0, 6), rng.uniform(-1, 1)], jnp.float32)
        u = jnp.array([rng.uniform(0.2, 1.5), rng.uniform(3.0, 40.0), rng.uniform(20, 200)], jnp.float32)
        A = np.asarray(gm.jacobian(m, x, u))
        J = np.asarray(jax.jacfwd(lambda y: gm.derivative(m, y, u))(x))
        np.testing.assert_allclose(A, J, rtol=1e-4, atol=1e-6 * np.abs(J).max())


def test_inverse_3x3():
    S = jnp.array([[4.0, 0.1, 0.2], [0.1, 100.0, 3.0], [0.2, 3.0, 90.0]])
    np.testing.assert_allclose(np.asarray(ekf.inv3(S) @ S), np.eye(3), atol=1e-6)


def test_glide_inputs_are_eqs_14_17():
    u = gm.true_inputs(np.array([2.0]), np.deg2rad(60.0), 50.0)[0]
    assert u[0] == pytest.approx(1.0) and u[1] == pytest.approx(5.0) and u[2] == 50.0
    # the lateral lift c_l sin(sigma) recovered from lambda1, lambda2 (corrected eq. 21)
    assert np.sqrt(u[0] * u[1] - 1 - u[0] ** 2) == pytest.approx(2.0 * np.sin(np.deg2rad(60.0)))


@pytest.mark.parametrize("d, msg", [({"q_v_mps": "x"}, "tracker.q_v_mps: expected a number"),
                                    ({"filter_type": "UKF"}, "tracker.filter_type"),
                                    ({"model": {"rho0_kgpm3": -1.0}}, "tracker.model.rho0_kgpm3: must be > 0"),
                                    ({"imm_q_scale": [1.0]}, "tracker.imm_q_scale"),
                                    ({"bogus": 1}, "tracker.bogus: unknown field")])
def test_config_errors_name_the_field(d, msg):
    with pytest.raises(TrackerConfigError, match=msg.replace(".", r"\.")):
        TrackerConfig.from_dict(d)


def test_config_round_trips_through_node_parameters():
    cfg = TrackerConfig.from_dict({"filter_type": "IMM", "q_v_mps": 7.0, "model": {"k_chi": 3.0}})
    assert TrackerConfig.from_parameters(cfg.as_parameters()) == cfg


def _glide_track(n=60, seed=1):
    """Truth from the filter's own model (no maneuver) and radar noise."""
    x = np.array([45e3, 0.2, 0.05, 6000.0, -0.002, 1.2, 0.0])
    xs = [x]
    step = jax.jit(lambda y: gm.propagate_phys(CFG.model, y, jnp.asarray(CFG.u_nominal), 1.0))
    for _ in range(n - 1):
        xs.append(np.asarray(step(jnp.asarray(xs[-1]))))
    xs = np.array(xs)
    z = xs[:, :3] + np.array([2000.0, 0.01, 0.01]) * np.random.default_rng(seed).standard_normal((n, 3))
    return np.arange(n, dtype=float), xs, z


def test_online_tracker_equals_batch_run_and_rejects_bad_input():
    t, xs, z = _glide_track()
    x0 = xs[0] + np.array([500.0, 3e-4, -2e-4, 30.0, 0.001, 0.01, 0.0])
    # offline: the batch scan over the whole track
    filt = filters.build_filter(CFG)
    dt = np.diff(t, prepend=t[0])[:, None]
    _, out = filters.run_batch(filt, gm.to_scaled(x0)[None], CFG.P0[None], gm.measurement_to_scaled(z)[:, None], dt)
    x_off = gm.to_physical(np.asarray(out["x"][:, 0]))
    # online, one message at a time, with bad messages in between
    trk = Tracker(CFG, x0, t[0], 1.0)
    x_on = []
    for k in range(len(t)):
        assert trk.add_measurement(t[k], z[k]) is None
        x_on.append(trk.last.x)
        if k == 10:
            before = trk.last
            assert trk.add_measurement(t[k] + 0.5, [np.nan, z[k, 1], z[k, 2]]) == "rejected_radar_nan"
            assert trk.add_measurement(t[k], z[k]) == "rejected_radar_out_of_order"          # duplicate stamp
            assert trk.add_measurement(t[k] - 3.0, z[k]) == "rejected_radar_out_of_order"
            assert trk.add_measurement(np.inf, z[k]) == "rejected_radar_nan"
            assert trk.add_measurement(t[k] + 0.5, z[k, :2]) == "rejected_radar_nan"        # malformed
            assert trk.last is before                                                      # state untouched
    # same numbers up to float32 round-off (the scan and the single step compile differently)
    d = np.abs(np.array(x_on)[:, :6] - x_off[:, :6]).max(axis=0)
    assert np.all(d < [0.2, 2e-6, 2e-6, 0.05, 2e-6, 2e-5]), d
    assert trk.counters == {"accepted": len(t), "predict_only_steps": 0, "rejected_radar_nan": 3,
                            "rejected_radar_out_of_order": 2}
    # a 5 s gap is bridged by predict-only steps of one radar interval
    assert trk.add_measurement(t[-1] + 5.0, z[-1]) is None
    assert trk.counters["predict_only_steps"] == 4 and trk.last.t_s == t[-1] + 5.0
    # the estimate is a track, not the raw measurement: error well below the radar noise
    err = np.array(x_on)[20:, :3] - xs[20:, :3]
    assert np.sqrt(np.mean(err[:, 0] ** 2)) < 1000.0            # radar: 2000 m
    assert np.sqrt(np.mean(err[:, 1:] ** 2)) < 3e-3             # radar: 0.01 rad
