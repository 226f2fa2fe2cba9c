"""RINEX 3.04 observation files written (formats/rinex_obs_write.py), read
back by the project's reader: same values, header and layout."""
import numpy as np

from hyper_nav_gnss.formats.rinex_obs import read_rinex_obs
from hyper_nav_gnss.formats.rinex_obs_write import epoch_lines, write_rinex3_obs
from hyper_nav_gnss.orbits.ephemeris import calendar_to_system_s

TYPES = {"G": ["C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W", "C5Q", "L5Q", "D5Q", "S5Q", "C1W", "L1W"],
         "E": ["C1X", "L1X", "S1X", "C7X", "L7X", "S7X"]}
XYZ = (4627852.5264, 119640.5140, 4372994.8358)


def _epochs(n=3):
    t0 = calendar_to_system_s("G", 2024, 1, 1, 23, 59, 30.0)
    rng = np.random.default_rng(1)
    out = []
    for k in range(n):
        sats = {"G05": {"C1C": 2.1e7 + k, "L1C": 1.1e8 + k, "S1C": 45.25, "C2W": 2.1e7 + k + 3.0,
                        "C1W": 2.1e7 + 0.5},
                "G13": {c: float(rng.uniform(2.0e7, 2.5e7)) for c in ("C1C", "C2W", "C5Q")},
                "E11": {"C1X": 2.4e7 - k, "C7X": 2.4e7 - k + 1.25, "S7X": 40.0}}
        out.append((t0 + 30.0 * k, sats))
    return out


def test_round_trip_values_header_and_continuation(tmp_path):
    eps = _epochs()
    path = tmp_path / "sim.rnx"
    assert write_rinex3_obs(path, eps, TYPES, XYZ, 30.0, marker="SIM1", comments=["simulated"]) == 3
    text = path.read_text().splitlines()
    assert sum("SYS / # / OBS TYPES" in ln for ln in text) == 3          # G's 14 types take two lines
    obs = read_rinex_obs(path, signals={"G": ["1C", "2W", "5Q"], "E": ["1X", "7X"]})
    assert not obs.errors, obs.errors
    assert np.allclose(obs.header["approx_xyz_m"], XYZ, atol=1e-4)
    assert obs.header["obs_types"]["G"] == TYPES["G"] and obs.header["interval_s"] == 30.0
    assert [e.t_rx_gpst_s for e in obs.epochs] == [t for t, _ in eps]      # across midnight, GPS time
    for ep, (_, sats) in zip(obs.epochs, eps):
        got = {}
        for sysc, prn, code, pr in zip(ep.system, ep.prn, ep.signal, ep.pseudorange_m):
            got.setdefault(f"{sysc}{int(prn):02d}", {})[code] = pr
        assert set(got) == set(sats)
        for sid, vals in sats.items():
            for code, v in vals.items():
                if code[0] == "C" and code[1:] in got[sid]:
                    assert abs(got[sid][code[1:]] - v) < 1e-3, (sid, code)


def test_missing_values_are_blank_fields():
    line = epoch_lines(0.0, {"G01": {"C1C": 2.0e7, "S1C": 40.0}}, {"G": ["C1C", "L1C", "S1C"]})[1]
    assert line[3:19] == "  20000000.000  " and line[19:35] == " " * 16 and line[35:].strip() == "40.000"
