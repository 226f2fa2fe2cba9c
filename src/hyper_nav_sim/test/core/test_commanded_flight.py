"""The boost-glide flight stepped with live commands (core/commanded_flight.py,
issue 36): the program flies when no command comes, the flight depends on
the commands' stamps and values only (not on how it is advanced nor on their
arrival order), refused commands change nothing and are counted."""
import copy
import math

import numpy as np
import pytest
import yaml

from hyper_nav_sim.core.boost_glide import DynamicTrajectory
from hyper_nav_sim.core.boost_glide_config import parse_flight
from hyper_nav_sim.core.commanded_flight import CommandedFlight, CommandLoop
from hyper_nav_sim.core.guidance_config import GuidanceConfig
from hyper_nav_sim.core.scenario import ScenarioError, load_scenario

DURATION_S = 12.0


@pytest.fixture(scope="module")
def flight_dict():
    d = dict(load_scenario("guidance_glide").data["flight"])
    d["duration_s"] = DURATION_S
    return d


def _flight(d, **kw):
    return CommandedFlight(**parse_flight(d), step_s=0.1, apply_delay_s=0.1, bank_max_rad=math.radians(85.0), **kw)


def _states(f, t):
    return f.state(t)


COMMANDS = [(1.0, 0.3, 1.2), (1.1, 0.35, 1.25), (3.05, -0.4, 0.9), (4.95, 0.0, 1.5), (5.0, 0.2, 1.4)]


def _commanded(d, order, chunk_s):
    f = _flight(d)
    for i in order:
        assert f.command(*COMMANDS[i]) is None
    t = 0.0
    while not f.finished:
        t += chunk_s
        f.advance(t)
    return f


def test_no_command_flies_the_program(flight_dict):
    """Without commands the stepped flight is the scheduled one (the same _rhs;
    only the integration's step boundaries differ): 1e-4 m, 1e-7 m/s, 1e-9 rad."""
    prog = DynamicTrajectory(**parse_flight(flight_dict))
    f = _flight(flight_dict).run()
    t = np.linspace(0.0, DURATION_S, 121)
    a, b = prog.truth(t), f.truth(t)
    dpos = np.hypot((a.lat_rad - b.lat_rad) * 6.4e6, (a.lon_rad - b.lon_rad) * 6.4e6)
    assert dpos.max() < 1e-4 and np.abs(a.alt_m - b.alt_m).max() < 1e-4
    assert np.abs(a.vel_enu_mps - b.vel_enu_mps).max() < 1e-7
    assert np.abs(a.C_b_n - b.C_b_n).max() < 1e-9
    assert f.commands == [] and sum(f.refused.values()) == 0


def test_same_commands_same_flight_bit_for_bit(flight_dict):
    """Advanced in 0.02 s or 3.7 s chunks, commands given in any order: identical floats."""
    t = np.linspace(0.0, DURATION_S, 241)
    ref = _commanded(flight_dict, [0, 1, 2, 3, 4], 0.02)
    for order, chunk in (([4, 3, 2, 1, 0], 3.7), ([2, 0, 4, 1, 3], 0.1)):
        other = _commanded(flight_dict, order, chunk)
        assert np.array_equal(_states(ref, t), _states(other, t))
        assert ref.commands == other.commands
    # the commands apply at ceil((t_nav + 0.1) / 0.1) steps, the newest stamp of a step winning
    assert [round(c[0], 9) for c in ref.commands] == [1.1, 1.2, 3.2, 5.1]
    assert ref.commands[-1][2:] == (0.2, 1.4)
    # and they steer: the bank follows the command through the actuator lag (tau 1 s, 30 deg/s)
    # (dsigma/dt = r tanh(e / (tau r)) ~ e / tau for |e| << tau r = 0.52 rad: a first-order lag)
    fl = ref.flight(np.array([1.2, 3.15, 3.2, 5.05]))
    s = fl["sigma"]
    assert abs(s[1] - (0.35 + (s[0] - 0.35) * math.exp(-1.95))) < 0.005
    assert s[3] < s[2] - 0.5                             # turning to the -0.4 rad command
    prog = _flight(flight_dict).run()
    assert np.abs(ref.state(DURATION_S)[:3] - prog.state(DURATION_S)[:3]).max() > 1e-4


@pytest.mark.parametrize("cmd,why", [((1.0, math.radians(86.0), 1.0), "bank_out_of_range"),
                                     ((1.0, 0.1, 3.6), "c_l_out_of_range"),
                                     ((1.0, 0.1, -0.1), "c_l_out_of_range"),
                                     ((1.0, float("nan"), 1.0), "not_finite"),
                                     ((float("inf"), 0.1, 1.0), "not_finite")])
def test_out_of_range_refused_and_counted(flight_dict, cmd, why):
    f = _flight(flight_dict)
    assert f.command(*cmd) == why
    assert f.refused == {why: 1} and f.accepted == 0
    f.run()
    prog = _flight(flight_dict).run()
    t = np.linspace(0.0, DURATION_S, 25)
    assert np.array_equal(f.state(t), prog.state(t))


def test_late_command_refused(flight_dict):
    f = _flight(flight_dict)
    f.advance(2.0)
    assert f.command(1.75, 0.1, 1.0) == "late"          # applies at step 19 (1.9 s): flown already
    assert f.command(1.85, 0.1, 1.0) is None             # step 20 (2.0 s): not yet
    assert f.refused == {"late": 1}


def test_command_loop_waits_for_due_commands(flight_dict):
    """With a guidance in the loop, step k needs every command j <= k - m; a
    refused one counts as arrived, a given-up one as missed."""
    f = _flight(flight_dict)
    loop = CommandLoop(f, t_start_s=1.0, expect=True)
    assert loop.m == 1 and loop.flyable_s() == pytest.approx(1.1)
    assert loop.advance(5.0) == pytest.approx(1.1) and loop.waiting_for_s() == pytest.approx(1.0)
    assert loop.receive(1.1, 0.2, 1.0) is None           # j = 11 early: still waiting for j = 10
    assert loop.advance(5.0) == pytest.approx(1.1)
    assert loop.receive(1.0, 0.2, 9.0) == "c_l_out_of_range"
    assert loop.advance(5.0) == pytest.approx(1.3)
    loop.give_up()
    assert loop.missed == 1 and loop.advance(5.0) == pytest.approx(1.4)
    loop.expect = False
    assert loop.advance(5.0) == pytest.approx(5.0)


def test_guidance_block_validated(tmp_path):
    ok = {"target": {"lat_deg": 30.0, "lon_deg": 121.0}}
    assert GuidanceConfig.from_config(ok).target_alt_m == 0.0
    with pytest.raises(ValueError, match="guidance.navigation_constnt: unknown field; did you mean 'navigation_constant'"):
        GuidanceConfig.from_config({**ok, "navigation_constnt": 3})
    with pytest.raises(ValueError, match="guidance.target.lat_dg: unknown field; did you mean 'lat_deg'"):
        GuidanceConfig.from_config({"target": {"lat_dg": 30.0, "lon_deg": 121.0}})
    with pytest.raises(ValueError, match="guidance.target: missing"):
        GuidanceConfig.from_config({})
    with pytest.raises(ValueError, match="guidance.apply_delay_s: must be >= period_s"):
        GuidanceConfig.from_config({**ok, "period_s": 0.2, "apply_delay_s": 0.1})
    with pytest.raises(ValueError, match="guidance.nav_type"):
        GuidanceConfig.from_config({**ok, "nav_type": "imu"})
    # in a scenario: validated with the rest, and only with a flight to steer
    data = copy.deepcopy(load_scenario("guidance_glide").data)
    data["guidance"]["navigation_constnt"] = 3.0
    path = tmp_path / "g.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError, match="navigation_constnt: unknown field; did you mean 'navigation_constant'"):
        load_scenario(str(path))
    data = copy.deepcopy(load_scenario("default").data)
    data["guidance"] = ok
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError, match="guidance: needs a 'flight' block"):
        load_scenario(str(path))
