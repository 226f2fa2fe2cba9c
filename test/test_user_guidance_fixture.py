"""A user's guidance node in the loop with no edit to the project (issue 36):
``plugin_packages/hyper_nav_user_guidance`` (its own node and its own pytest
file using the ``hyper_nav_guidance_loop`` fixture) is built on its own into
a scratch install, and its test suite runs there: the fixture flies the
guidance_glide scenario with the user's node commanding the truth, records
the bag, and returns the miss distance; the live flight equals the flight
its recorded commands give offline, bit for bit."""
import pathlib
import shutil
import subprocess

import pytest

pytestmark = [pytest.mark.graph, pytest.mark.slow]
REPO = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = REPO / "test" / "plugin_packages" / "hyper_nav_user_guidance"


def _bash(command: str, install: pathlib.Path | None = None, timeout: float = 900.0):
    extra = f" && source {install}/local_setup.bash" if install else ""
    return subprocess.run(["bash", "-c", f"source tools/env.sh >/dev/null{extra} && {command}"], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def test_users_guidance_node_in_the_loop(tmp_path):
    root = tmp_path / "ws"
    shutil.copytree(PACKAGE, root / "src" / PACKAGE.name)
    p = _bash(f"colcon --log-base {root}/log build --base-paths {root}/src --build-base {root}/build "
              f"--install-base {root}/install --event-handlers console_cohesion- summary-")
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    # the user's own suite, in their own folder, with the plugin registered by the workspace's build
    p = _bash(f"cd {root}/src/{PACKAGE.name} && python -m pytest -q -s -p no:cacheprovider test/test_my_guidance.py",
              install=root / "install")
    assert p.returncode == 0, p.stdout[-5000:] + p.stderr[-3000:]
    assert "1 passed" in p.stdout
    line = next(x for x in p.stdout.splitlines() if "miss {'miss_m'" in x)
    print(line)
