"""Every reproduction is a campaign (hyper_nav_workbench.campaign on dask): the
same tables with 1 and 2 workers (short modes), and a per-run JSON file
for every run."""
import json

import pytest


def _figures(x):
    """The result without what depends on the machine (wall and compute times)."""
    if isinstance(x, dict):
        return {k: _figures(v) for k, v in x.items()
                if not any(w in k for w in ("wall", "time_s", "cpu"))}
    if isinstance(x, list):
        return [_figures(v) for v in x]
    return x


def _run(main, args, out, capsys):
    assert main(args + ["--out", str(out)]) == 0
    return capsys.readouterr().out


@pytest.mark.slow          # two local clusters and four short flights each: minutes on 2 cores
@pytest.mark.parametrize("workers", [2])
def test_seed004_same_tables_on_1_and_2_workers(tmp_path, capsys, workers):
    from hyper_nav_repro.seed004.reproduce import main
    one = _run(main, ["--short", "--seeds", "2", "--workers", "1"], tmp_path / "one", capsys)
    two = _run(main, ["--short", "--seeds", "2", "--workers", str(workers)], tmp_path / "two", capsys)
    table = [ln for ln in one.splitlines() if "+-" in ln]
    assert len(table) > 10 and table == [ln for ln in two.splitlines() if "+-" in ln]
    a, b = (json.loads((d / "seed004_tables.json").read_text()) for d in (tmp_path / "one", tmp_path / "two"))
    assert a["seeds"] == [1, 2] and _figures(a) == _figures(b)
    assert sorted(p.name for p in (tmp_path / "two" / "runs").iterdir()) == ["realistic_seed001.json",
                                                                             "realistic_seed002.json"]


@pytest.mark.slow
def test_seed003_same_tables_on_1_and_2_workers(tmp_path, capsys):
    from hyper_nav_repro.seed003.reproduce import main
    _run(main, ["--short", "--workers", "1"], tmp_path / "one", capsys)
    _run(main, ["--short", "--workers", "2"], tmp_path / "two", capsys)
    a, b = (json.loads((d / "table3.json").read_text()) for d in (tmp_path / "one", tmp_path / "two"))
    assert len(a["per_seed"]) == 2 and _figures(a) == _figures(b)
    assert sorted(p.name for p in (tmp_path / "two" / "runs").iterdir()) == ["seed001.json", "seed002.json"]
