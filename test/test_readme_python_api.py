"""The two Python examples of docs/python-api.md, run verbatim: the Graph/TopicCollector
snippet (it used to hang: the fusion node waited for subscribers on all
three outputs while the snippet subscribes one), and the pytest-fixture
example, in a fresh pytest that finds the fixture through the installed
``pytest11`` entry point."""
import os
import pathlib
import re
import subprocess
import sys

import pytest

pytestmark = pytest.mark.graph
REPO = pathlib.Path(__file__).resolve().parents[1]


def python_blocks() -> list[str]:
    text = (REPO / "docs" / "python-api.md").read_text()
    section = text[text.index("# Python API for your own ROS tests"):]
    section = section[:section.index("\n## ", 5)]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_python_api_snippet_runs_verbatim(capsys):
    snippet = python_blocks()[0]
    assert "Graph(" in snippet and "TopicCollector(" in snippet
    exec(compile(snippet, "docs/python-api.md", "exec"), {"__name__": "readme_snippet"})
    n = int(capsys.readouterr().out.strip().splitlines()[-1])
    # 10 s at 50 Hz; the collector subscribes after the graph starts, so the first few may be missed
    assert 400 <= n <= 500, n


def test_pytest_fixture_example_runs_verbatim_in_a_users_pytest(tmp_path):
    example = python_blocks()[1]
    assert "def test_" in example and "hyper_nav_graph" in example
    (tmp_path / "test_my_flight.py").write_text(example)
    p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_my_flight.py"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600, env=dict(os.environ))
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    assert "1 passed" in p.stdout
