"""``make bench``'s user path (benchmarks/user_path.py) on a short peer-format
set: import_data and replay_filter run as the user runs them (each its own
process), and the array path writes the per-message path's .nav and STD text
(issue 25: the benchmark once named a module the house order had moved and
``make bench`` stopped at its third section)."""
import pathlib
import sys

import pytest

BENCH = pathlib.Path(__file__).resolve().parents[3] / "benchmarks"


@pytest.mark.skipif(not (BENCH / "user_path.py").exists(), reason="benchmarks/ not in this tree")
def test_user_path_runs_and_array_path_equals_per_message_path(tmp_path):
    sys.path.insert(0, str(BENCH))
    try:
        import user_path
    finally:
        sys.path.remove(str(BENCH))
    r = user_path.run(tmp_path / "peer", 60.0, reference_path=True, work=tmp_path / "work", log=lambda *a: None)
    assert r["imu_epochs"] == 12000                         # 60 s at 200 Hz (the report skips 30 s)
    for step in ("import", "replay", "reference_import", "reference_replay"):
        assert r[step]["wall_s"] > 0.0 and r[step]["cpu_s"] > 0.0
    assert r["max_abs_diff_nav"] == 0.0 and r["max_abs_diff_std"] == 0.0
    assert r["position_rms"].startswith("position") and r["position_rms"] == r["position_rms_reference"]
    lines = user_path.report_lines(r, engine_us=20.0)
    assert any("replay / peer" in ln for ln in lines)
