"""The seed 004 Tables 4-5 reproduction command in its short mode (16 s
flight, lock lost from 10 s, one seed, realistic world): it prints the table,
writes the JSON and the PNG, and the four cases are in the order the paper
finds for the uncompensated case (corrupted observations, no gate) and ours
for the others (the full run: docs/seed004-virtual-gnss.md, ``make repro-seed004``)."""
import json

from hyper_nav_repro.seed004.reproduce import PAPER, main


def test_short_mode_writes_table_json_png_and_orders_the_cases(tmp_path, capsys):
    assert main(["--short", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "paper mean/std/max" in printed and "7.821" in printed
    doc = json.loads((tmp_path / "seed004_tables.json").read_text())
    assert (tmp_path / "seed004_errors_realistic.png").stat().st_size > 10_000
    assert doc["paper"]["b"]["pos_h_m"][0] == PAPER["b"]["pos_h_m"][0] == 10.690
    s = {v: d["summary"] for v, d in doc["results"]["realistic"].items()}
    h = {v: s[v]["pos_h_m"]["mean"][0] for v in s}
    print(f"\nshort mode, horizontal position error mean over the 6 s loss: {h}")
    assert h["a"] < 5.0
    assert h["c"] > 10.0 * h["d"]                      # corrupted observations through a gate-less filter
    assert abs(h["b"] - h["d"]) < 0.5 * h["d"]         # virtual ranges: no better than the INS alone
