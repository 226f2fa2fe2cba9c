"""Every command documented in README.md, bags/README.md and docs/*.md runs
and exits 0 (``test/readme_commands.py`` says what counts as a command and
how a long one names its short form).

The commands run in a scratch copy of the checkout (symlinks to the sources,
the venv and the build; a real ``bags/`` with the committed sample bag), so
what they write (bags/<run>/, plots/, make clean) stays out of the checkout,
in bash after ``source tools/env.sh``, one after the other, ``make clean``
last (it removes the scratch copy's links to the build).
"""
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from readme_commands import commands  # noqa: E402

pytestmark = pytest.mark.graph
REPO = pathlib.Path(__file__).resolve().parents[1]
FILES = [REPO / "README.md", REPO / "bags" / "README.md"] + sorted((REPO / "docs").glob("*.md"))
LINKED = ["Makefile", "tools", "src", ".venv", "install", "build", "benchmarks", "requirements.txt",
          "requirements-ros.txt", "constraints.txt", "pytest.ini", "README.md", "docs", "test"]
TIMEOUT_S = 300


def all_commands():
    """Commands of every file, the first occurrence of each (with its marker)."""
    out, seen = [], set()
    for path in FILES:
        for c in commands(path):
            key = " ".join(c.text.split())
            if key not in seen:
                seen.add(key)
                out.append(c)
    return sorted(out, key=lambda c: c.text.strip() == "make clean")      # make clean last


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    root = tmp_path_factory.mktemp("checkout")
    for name in LINKED:
        if (REPO / name).exists():
            link = root / name
            link.symlink_to(REPO / name)
            # old link times: tools/setup.sh's `find src -newer install/.stamp` must not rebuild
            os.utime(link, (0, 0), follow_symlinks=False)
    (root / "bags").mkdir()
    shutil.copytree(REPO / "bags" / "sample_short", root / "bags" / "sample_short")
    return root


def test_readme_commands_are_found():
    cmds = all_commands()
    texts = [c.text for c in cmds]
    assert "make run" in texts and "source tools/env.sh" in texts
    assert any(c.kind == "python" for c in cmds)
    assert all(c.skip for c in cmds if "<" in c.text and c.kind == "bash"), "placeholders must be marked"
    assert texts[-1] == "make clean"


@pytest.mark.parametrize("cmd", all_commands(), ids=lambda c: " ".join(c.text.split())[:60])
def test_readme_command(scratch, cmd):
    if cmd.skip:
        pytest.skip(f"{cmd.source}: {cmd.skip}")
    if cmd.kind == "python":
        script = scratch / "readme_snippet.py"
        script.write_text(cmd.text)
        line = f"python {script}"
    else:
        line = cmd.run or cmd.text
    p = subprocess.run(["bash", "-c", f"source tools/env.sh >/dev/null && {line}"], cwd=scratch,
                       capture_output=True, text=True, timeout=TIMEOUT_S, env=dict(os.environ))
    assert p.returncode == 0, f"{cmd.source}: `{line}` exited {p.returncode}\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}"
    assert "Traceback" not in p.stderr, p.stderr[-3000:]
    if cmd.text == "make clean":
        assert not (scratch / "install").exists() and (REPO / "install").is_dir()     # only the links went
