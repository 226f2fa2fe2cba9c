"""Verdict rules on the filter's use of each source (core/verdict_rules.py):
each rule fails or warns with the source and the rule named; the fusion
node's /diagnostics values give the same counts; the Monte Carlo summary
applies them per run; and a forced divergence through the user's path
(import_data -> replay_filter, gate on, a 100x optimistic IMU) fails."""
import pathlib
import sys

import pytest
import yaml

from hyper_nav_workbench.core import run_check, verdict_rules
from hyper_nav_workbench.core.verdict_rules import SourceStats

sys.path.insert(0, str(pathlib.Path(__file__).parent / "importer"))


def outcome(**stats):
    out = run_check.Outcome()
    verdict_rules.check({k: SourceStats(k, *v) for k, v in stats.items()}, out)
    return out


def test_each_rule_names_the_source_and_the_rule():
    assert not outcome(gnss_pos=(1000, 0, 1.1, 0, 0)).failures
    out = outcome(gnss_pos=(192, 1846, 0.4, 1900, 0))
    assert any(f.startswith("source gnss_pos: rule 'gated': 1846 of 2038") for f in out.failures)
    assert any("rule 'departure'" in f for f in out.failures)
    out = outcome(gnss_vel=(2000, 0, 4.0, 0, 0))
    assert not out.failures and any("source gnss_vel: rule 'nis': mean NIS/dof 4" in w for w in out.warnings)
    out = outcome(gnss_vel=(2000, 0, 40.0, 0, 0))
    assert any("source gnss_vel: rule 'nis'" in f for f in out.failures)
    out = outcome(gnss_pos=(2000, 30, 1.0, 0, 2))
    assert not out.failures and any("rule 'lockout': 2 lock-out recoveries" in w for w in out.warnings)
    out = outcome(gnss_pos=(2000, 300, 1.0, 0, 60))
    assert any("source gnss_pos: rule 'lockout'" in f for f in out.failures)
    assert not outcome(baro=(5, 10, 30.0, 10, 0)).failures     # too few updates: counts only
    table = verdict_rules.format_table({"gnss_pos": SourceStats("gnss_pos", 192, 1846, 4.0, 1900, 3)})
    assert "gnss_pos" in table and "1846" in table and "sigma x" in table


def test_the_diagnostics_values_give_the_same_counts():
    values = {"gnss_pos_accepted": 192, "gnss_pos_gated": 1846, "gnss_pos_mean_nis_per_dof": "0.400",
              "gnss_pos_far": 1900, "gnss_pos_lockout_recoveries": 0, "imu_accepted": 5000, "heartbeat": 3}
    s = verdict_rules.from_values(values)
    assert list(s) == ["gnss_pos"]
    assert s["gnss_pos"] == SourceStats("gnss_pos", 192, 1846, 0.4, 1900, 0)


def test_the_monte_carlo_summary_fails_on_a_run_that_fails_a_rule():
    from hyper_nav_workbench.mc_campaign import run_verdicts
    good = {"k": 0, "accepted": {"gnss_pos": 3000}, "gated": {"gnss_pos": 1}, "mean_nis_per_dof": {"gnss_pos": 1.0}}
    bad = {"k": 1, "accepted": {"gnss_pos": 300}, "gated": {"gnss_pos": 2700}, "mean_nis_per_dof": {"gnss_pos": 1.0},
           "far": {"gnss_pos": 2800}, "recoveries": {"gnss_pos": 0}}
    v = run_verdicts([good, bad])
    assert v["verdict"] == "FAIL" and v["failed_runs"] == [1]
    assert any(f.startswith("run 1: source gnss_pos: rule 'gated'") for f in v["failures"])
    assert run_verdicts([good])["verdict"] == "PASS"


TRUE_ARW, TRUE_VRW = 3.0, 1000.0


@pytest.fixture(scope="module")
def optimistic_import(tmp_path_factory):
    """A simulated flight (noisy IMU, 2 cm / 2 cm/s fixes) in KF-GINS files, imported with the IMU's
    densities 100x below the truth and the gate on (the data sheet of a vibrating car)."""
    from kfgins_files import filter_block_of, write_import_file, write_kfgins_set

    from hyper_nav_workbench import import_data
    from hyper_nav_sim.core.scenario import apply_overrides, load_scenario
    d = tmp_path_factory.mktemp("diverge")
    sc = apply_overrides(load_scenario("default"), {
        "duration_s": 90.0, "imu.gyro_arw_deg_per_sqrt_hr": TRUE_ARW, "imu.accel_vrw_ug_per_sqrt_hz": TRUE_VRW,
        "gnss.pos_sigma_enu_m": [0.02, 0.02, 0.02], "gnss.vel_sigma_enu_mps": [0.02, 0.02, 0.02]}, d)
    write_kfgins_set(sc, d)
    block = filter_block_of(sc)
    block["config"].update({"gyro_arw_deg_per_sqrt_hr": [TRUE_ARW / 100] * 3,
                            "accel_vrw_ug_per_sqrt_hz": [TRUE_VRW / 100] * 3, "gate_probability": 0.9999})
    bags = {}
    for name, extra in (("default", {}), ("off", {"lockout_recovery": "off"})):
        sub = d / name
        sub.mkdir()
        for f in ("imu.txt", "gnss.txt", "truth.nav"):
            (sub / f).write_bytes((d / f).read_bytes())
        b = yaml.safe_load(yaml.safe_dump(block))
        b["config"].update(extra)
        write_import_file(sub, b, report={"skip_s": 5.0})
        assert import_data.main([str(sub / "import.yaml"), "--out", str(sub / "bag")]) == 0
        bags[name] = sub
    return bags


@pytest.mark.parametrize("name, rule", [("off", "gated"), ("default", "lockout")])
def test_a_forced_divergence_fails_naming_the_source_and_the_rule(optimistic_import, capsys, name, rule):
    from hyper_nav_workbench import replay_filter
    d = optimistic_import[name]
    code = replay_filter.main([str(d / "bag"), "--truth", str(d / "truth.nav")])
    text = capsys.readouterr().out
    assert code == 1, text[-3000:]
    assert f"FAIL: source gnss_pos: rule '{rule}'" in text or f"FAIL: source gnss_vel: rule '{rule}'" in text, \
        text[-3000:]
    assert "VERDICT: FAIL" in text and "source gnss_" in text.split("VERDICT: FAIL")[1]
    assert "per source (filter updates" in text
