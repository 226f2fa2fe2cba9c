"""The scenario files of the five papers: they load, carry the papers'
numbers, and the GNSS lock is lost where the dynamics say it must."""
import pathlib
import tempfile

import numpy as np
import pytest

from hyper_nav_sim.core import simulate
from hyper_nav_gnss.receiver.lock import LockConfig
from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
from hyper_nav_sim.plot import all_scenario_names, plot_scenario

PAPER_SCENARIOS = ["default", "seed000_elastic", "seed001", "seed002_s1", "seed002_s2", "seed002_s3",
                   "seed003", "seed004"]


def override(name, **fields):
    return apply_overrides(load_scenario(name), fields, pathlib.Path(tempfile.mkdtemp(prefix="sc_")))


def test_every_paper_scenario_is_installed_and_valid():
    assert set(PAPER_SCENARIOS) <= set(all_scenario_names())
    for name in PAPER_SCENARIOS:
        sc = load_scenario(name)
        assert sc.trajectory().duration_s >= sc["duration_s"] - 1e-6


def test_papers_numbers():
    s1 = load_scenario("seed001")
    assert s1["imu.rate_hz"] == 500.0 and s1["gnss.rate_hz"] == 1.0 and s1["gnss.pos_sigma_enu_m"][0] == 10.0
    assert s1.data["flight"]["start"]["gamma_deg"] == 90.0                  # vertical launch
    s2 = load_scenario("seed002_s1")
    st = s2.data["flight"]["start"]
    assert (st["alt_m"], st["speed_mps"], st["gamma_deg"], st["psi_deg"]) == (60000.0, 7010.0, -1.0, 90.0)
    assert s2.data["radar"]["sigma_alt_m"] == 2000.0 and s2.data["radar"]["sigma_lat_rad"] == 0.01
    tr = s2.trajectory().truth([s2["duration_s"]])
    assert np.linalg.norm(tr.vel_enu_mps[0]) == pytest.approx(2000.0, abs=5.0)   # terminal speed
    s3 = load_scenario("seed003")
    assert s3["imu.rate_hz"] == 100.0 and s3["magnetometer.rate_hz"] == 1.0 and s3["duration_s"] == 790.0
    tr = s3.trajectory().truth(np.arange(0.0, 790.0, 10.0))
    assert np.all(np.abs(tr.alt_m - 25500.0) < 1500.0)                        # 25 km glide (+1 km climb)
    assert np.all((np.rad2deg(tr.lat_rad) > 40) & (np.rad2deg(tr.lat_rad) < 48))
    assert np.all((np.rad2deg(tr.lon_rad) > 109) & (np.rad2deg(tr.lon_rad) < 112))
    s4 = load_scenario("seed004")
    assert s4.data["gnss"]["raw"]["elevation_mask_deg"] == 7.5
    assert s4.data["gnss"]["raw"]["lock"]["outages"][0][0] == 30.0
    assert s4.data["flight"]["start"]["lat_deg"] == 26.5 and s4.data["flight"]["start"]["lon_deg"] == 119.0


def test_seed004_lock_loss_follows_the_dynamics():
    """Without the scripted outage, every channel out of lock has a vehicle
    Doppler beyond 5 kHz or a Doppler rate beyond the loop's limit (or is
    still in its re-acquisition time), and lock loss does happen."""
    sc = override("seed004", **{"gnss.raw.lock.outages": [], "duration_s": 200.0, "gnss.rate_hz": 0.5})
    epochs = simulate.gnss_raw_stream(sc, sc.trajectory())
    rate_limit = LockConfig().doppler_rate_limit_hzps
    reacq = LockConfig().reacquisition_s
    stress_time = {}
    n_lost = 0
    for e in epochs:
        stressed = (np.abs(e.vehicle_doppler_hz) > 5000.0) | (np.abs(e.vehicle_doppler_rate_hzps) > rate_limit)
        for sid, s in zip(e.sat_ids, stressed):
            if s:
                stress_time[sid] = e.t_s
        for sid, locked in zip(e.sat_ids, e.locked):
            if not locked:
                n_lost += 1
                assert e.t_s - stress_time.get(sid, -np.inf) <= reacq + 2.0 + 1e-9, (e.t_s, sid)
    assert n_lost > 50
    assert max(np.abs(e.vehicle_doppler_hz).max() for e in epochs) > 5000.0


def test_no_lock_loss_in_a_low_dynamics_case():
    sc = override("default", **{"start.vel_enu_mps": [0.0, 200.0, 0.0], "maneuvers": [], "duration_s": 120.0,
                                "gnss.rate_hz": 0.5,
                                "gnss.raw": {"systems": ["G"], "start_gpst_s": "2023-01-01T04:00:00",
                                             "elevation_mask_deg": 7.5}})
    epochs = simulate.gnss_raw_stream(sc, sc.trajectory())
    assert all(e.locked.all() for e in epochs)
    assert all(e.fix is not None for e in epochs)


def test_plot_command_writes_one_png_per_scenario(tmp_path):
    for name in ("default", "seed003"):
        path = plot_scenario(name, tmp_path, step_s=2.0)
        assert path.exists() and path.stat().st_size > 20000


@pytest.mark.slow
def test_error_free_imu_stays_on_the_seed003_truth_for_790_s():
    """Issue #3: error-free sensors through the ENU mechanization of #2 drift
    < 1 m over the 790 s seed 003 flight (100 Hz, incl. the 4 g U-turn)."""
    from hyper_nav_gnss import earth
    from hyper_nav_filter.core import mechanization
    from hyper_nav_filter.core.nav_state import ImuSample, NavState
    sc = load_scenario("seed003")
    traj = sc.trajectory()
    imu = simulate.imu_stream(sc, traj, error_free=True)
    s0 = traj.truth([0.0])
    st = NavState(0.0, s0.lat_rad[0], s0.lon_rad[0], s0.alt_m[0], s0.vel_enu_mps[0], s0.C_b_n[0])
    prev = v_prev = None
    for k in range(len(imu.t_s)):
        sample = ImuSample(imu.t_s[k], imu.dt_s, imu.dtheta_b_rad[k], imu.dvel_b_mps[k])
        v_before = st.vel_enu_mps
        st = mechanization.propagate(st, sample, prev, v_prev)
        prev, v_prev = sample, v_before
    tr = traj.truth([imu.t_s[-1]])
    d = earth.position_error_enu_m(st.lat_rad, st.lon_rad, st.alt_m, tr.lat_rad[0], tr.lon_rad[0], tr.alt_m[0])
    print(f"seed003 error-free drift after 790 s: {np.linalg.norm(d):.3f} m")
    assert np.linalg.norm(d) < 1.0


def test_extends_merges_onto_the_base_scenario(tmp_path):
    """``extends: <name>``: mappings merge key by key, lists and values replace."""
    from hyper_nav_sim.core.scenario import ScenarioError
    base = load_scenario("seed004").data
    tight = load_scenario("seed004_tight").data
    assert tight["flight"] == base["flight"] and tight["imu"] == base["imu"]
    assert tight["gnss"]["raw"]["lock"]["outages"] == [] and base["gnss"]["raw"]["lock"]["outages"] == [[30.0, 500.0]]
    assert tight["gnss"]["raw"]["lock"]["doppler_limit_hz"] == base["gnss"]["raw"]["lock"]["doppler_limit_hz"]
    assert tight["filter"]["config"]["state_blocks"] == ["att", "vel", "pos", "bg", "ba", "clk"]
    assert tight["filter"]["config"]["gyro_bias_tau_s"] == base["filter"]["config"]["gyro_bias_tau_s"]
    f = tmp_path / "child.yaml"
    f.write_text("extends: default\nname: child\nduration_s: 12.5\n")
    sc = load_scenario(str(f))
    assert sc["duration_s"] == 12.5 and sc["imu.rate_hz"] == load_scenario("default")["imu.rate_hz"]
    f.write_text("extends: no_such_scenario\n")
    with pytest.raises(ScenarioError, match="extends: scenario 'no_such_scenario' not found"):
        load_scenario(str(f))
    f.write_text("extends: [default]\n")
    with pytest.raises(ScenarioError, match="extends: expected a scenario name"):
        load_scenario(str(f))
    g = tmp_path / "loop.yaml"
    g.write_text(f"extends: {f}\n")
    f.write_text(f"extends: {g}\n")
    with pytest.raises(ScenarioError, match="circular"):
        load_scenario(str(f))


def test_imu_mounting_reaches_the_fusion_node_and_must_be_a_unit_quaternion(tmp_path):
    """``imu.mounting_b_xyzw`` (import_data prints it) becomes the fusion
    node's ``tf.imu_rotation_b_xyzw`` (base_link -> imu_link on /tf_static);
    the default is no rotation; a quaternion that is not unit is refused by
    name; the simulated IMU's error model ignores the field."""
    from hyper_nav_filter.output import static_transform_fields
    from hyper_nav_sim.core.imu_model import ImuErrors
    from hyper_nav_sim.core.scenario import ScenarioError
    from hyper_nav_workbench.graph import fusion_parameters
    assert fusion_parameters(load_scenario("default"))["tf.imu_rotation_b_xyzw"] == [0.0, 0.0, 0.0, 1.0]
    q = [0.5, -0.5, 0.5, 0.5]
    f = tmp_path / "mounted.yaml"
    f.write_text(f"extends: default\nname: mounted\nimu: {{mounting_b_xyzw: {q}}}\n")
    sc = load_scenario(str(f))
    assert fusion_parameters(sc)["tf.imu_rotation_b_xyzw"] == q
    a, b = ImuErrors.from_config(sc.data["imu"]), ImuErrors.from_config(load_scenario("default").data["imu"])
    assert all(np.array_equal(getattr(a, k), getattr(b, k)) for k in vars(a))
    d = static_transform_fields(1.5, "base_link", "imu_link", [0.1, 0.0, 0.0], q)
    assert [d[f"transform.rotation.{k}"] for k in "xyzw"] == q and d["transform.translation.x"] == 0.1
    f.write_text("extends: default\nname: mounted\nimu: {mounting_b_xyzw: [0.5, 0.5, 0.5, 0.6]}\n")
    with pytest.raises(ScenarioError, match=r"imu.mounting_b_xyzw: must be a unit quaternion .*norm 1.05"):
        load_scenario(str(f))
