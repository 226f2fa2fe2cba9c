"""Sensor streams of a commanded flight (core/flown_streams.py, issue 36):
drawn as the flight is flown, the same samples bit for bit however far and
however often the flight was advanced between draws (the live sensor nodes
and the offline loop draw at different moments), the scenario's outages
honoured, and the models that need the whole trajectory refused by name."""
import copy
import math

import numpy as np
import pytest

from hyper_nav_sim.core.commanded_flight import CommandLoop, flight_of_scenario, is_commanded
from hyper_nav_sim.core.flown_streams import FlownFixes, FlownImu, FlownMag, FlownRaw, refuse_commanded
from hyper_nav_sim.core.scenario import Scenario, load_scenario

DURATION_S = 4.0


def _scenario(**changes):
    sc = load_scenario("guidance_glide")
    data = copy.deepcopy(sc.data)
    data["duration_s"] = DURATION_S
    data["flight"]["duration_s"] = DURATION_S
    for dotted, v in changes.items():
        d = data
        *head, last = dotted.split(".")
        for k in head:
            d = d.setdefault(k, {})
        d[last] = v
    return Scenario(sc.path, data)


def _commanded(sc):
    _, f = flight_of_scenario(sc)
    for j in range(5, 35):                       # a bank reversal program as commands
        f.command(j * 0.1, math.radians(40.0 if (j // 10) % 2 else -40.0), 1.2)
    return f


def _draw(sc, stride_s):
    """Advance the flight stride_s at a time, drawing after each advance."""
    f = _commanded(sc)
    imu, fixes, mag = FlownImu(sc, f), FlownFixes(sc, f), FlownMag(sc, f)
    out = {"imu": [], "fix": [], "mag": []}
    t = 0.0
    while not (imu.done and fixes.done and mag.done):
        t += stride_s
        f.advance(t)
        out["imu"].append(np.column_stack(imu.until_flown()))
        out["fix"] += [(g.t_s[0], g.lat_rad[0], g.lon_rad[0], g.alt_m[0], *g.vel_enu_mps[0])
                       for g in fixes.until(math.inf)]
        tm, b = mag.until_flown()
        out["mag"].append(np.column_stack([tm, b]))
    return {"imu": np.vstack(out["imu"]), "fix": np.array(out["fix"]), "mag": np.vstack(out["mag"])}


def test_the_draw_does_not_depend_on_how_the_flight_was_advanced():
    sc = _scenario()
    a, b, c = _draw(sc, 0.1), _draw(sc, 0.7), _draw(sc, 10.0)
    n_imu = int(round(DURATION_S * sc["imu.rate_hz"]))
    assert a["imu"].shape == (n_imu, 7) and len(a["fix"]) == int(round(DURATION_S * sc["gnss.rate_hz"]))
    for other in (b, c):
        for k in a:
            assert np.array_equal(a[k], other[k]), k
    # the samples are those of the steered flight (increments within the sensor errors: 1 mg bias,
    # 100 ug/sqrt(Hz) over 20 ms), not those of the program flown without the commands
    dt = 1.0 / sc["imu.rate_hz"]
    _, dv = _commanded(sc).run().imu_increments(a["imu"][:, 0], dt)
    _, dv_prog = flight_of_scenario(sc)[1].run().imu_increments(a["imu"][:, 0], dt)
    assert np.abs(a["imu"][:, 4:] - dv).max() < 1e-3
    assert np.abs(a["imu"][:, 4:] - dv_prog).max() > 0.05


def test_outages_drop_fixes_but_not_their_draws():
    with_out = _draw(_scenario(**{"gnss.outages_s": [[1.0, 2.0]]}), 0.1)["fix"]
    full = _draw(_scenario(), 0.1)["fix"]
    keep = ~((full[:, 0] >= 1.0 - 1e-9) & (full[:, 0] < 2.0 - 1e-9))
    assert len(with_out) == keep.sum() == len(full) - 10
    assert np.array_equal(with_out, full[keep])          # the other epochs' noise is unchanged


def test_models_that_need_the_whole_trajectory_are_refused_by_name():
    sc = _scenario()
    assert is_commanded(sc)
    _, f = flight_of_scenario(sc)
    with pytest.raises(ValueError, match="lever_arm"):
        FlownImu(_scenario(**{"lever_arm": {"enabled": True}}), f)
    with pytest.raises(ValueError, match="gnss.raw"):
        FlownFixes(_scenario(**{"gnss.raw": {}}), f)
    with pytest.raises(ValueError, match="no gnss.raw block"):
        FlownRaw(sc, f)
    with pytest.raises(ValueError, match="white_uniform"):
        FlownMag(_scenario(**{"magnetometer.map_error_model": "white_uniform",
                              "magnetometer.map_error_rms_nT": 50.0}), f)
    with pytest.raises(ValueError, match="the barometer node is not simulated on a commanded flight"):
        refuse_commanded(sc, "the barometer node")
    refuse_commanded(load_scenario("default"), "the barometer node")       # a scheduled flight: no objection


def test_no_command_is_awaited_after_the_navigation_ends():
    sc = _scenario()
    cfg, f = flight_of_scenario(sc)
    loop = CommandLoop(f, cfg.t_start_s, expect=True, t_end_s=2.0)
    for j in range(10, 21):                      # commands for the stamps 1.0 .. 2.0 s
        loop.receive(j * 0.1, 0.0, 1.0)
    assert loop.advance(DURATION_S) == pytest.approx(DURATION_S)          # nothing awaited after 2.0 s
    _, f2 = flight_of_scenario(sc)
    loop2 = CommandLoop(f2, cfg.t_start_s, expect=True)                   # without an end: waits for 2.1 s
    for j in range(10, 21):
        loop2.receive(j * 0.1, 0.0, 1.0)
    assert loop2.advance(DURATION_S) == pytest.approx(2.2)
    assert loop2.waiting_for_s() == pytest.approx(2.1)


def _raw_draw(sc, stride_s, outages=()):
    f = _commanded(sc)
    raw = FlownRaw(sc, f, outages)
    out, t = [], 0.0
    while not raw.done:
        t += stride_s
        f.advance(t)
        for e in raw.until(math.inf):
            fix = (np.nan,) * 3 if e.fix is None else (e.fix.lat_rad, e.fix.lon_rad, e.fix.alt_m)
            out.append((e.t_s, len(e.prn), *fix, float(np.sum(e.pseudorange_m))))
    return np.array(out)


def test_the_receiver_epochs_do_not_depend_on_how_the_flight_was_advanced():
    """FlownRaw (the raw-GNSS receiver, realistic world): the same epochs, measurements and fixes
    whether the flight is advanced 0.1 or 1.3 s at a time; the epochs inside an outage have no fix."""
    sc = _scenario()
    data = copy.deepcopy(load_scenario("guidance_glide_realistic").data)
    data.update(duration_s=DURATION_S, flight={**data["flight"], "duration_s": DURATION_S})
    sc = Scenario(sc.path, data)
    a, b = _raw_draw(sc, 0.1), _raw_draw(sc, 1.3)
    # every epoch but the last (its antenna truth needs the flight 0.05 s past the end)
    assert len(a) == int(round(DURATION_S * sc["gnss.rate_hz"])) - 1
    assert np.array_equal(a, b, equal_nan=True) and np.isfinite(a[:, 2]).all() and (a[:, 1] >= 6).all()
    c = _raw_draw(sc, 0.1, outages=((1.0, 2.0),))
    inside = (c[:, 0] >= 1.0 - 1e-9) & (c[:, 0] < 2.0 - 1e-9)
    assert inside.sum() == 10 and np.isnan(c[inside, 2]).all() and np.isfinite(c[c[:, 0] < 1.0, 2]).all()
    with pytest.raises(ValueError, match="tracking"):
        data2 = copy.deepcopy(data)
        data2["gnss"]["raw"]["tracking"] = {}
        FlownRaw(Scenario(sc.path, data2), flight_of_scenario(sc)[1])
