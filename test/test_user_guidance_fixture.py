"""A user's guidance node in the loop with no edit to the project (issue 36):
``plugin_packages/hyper_nav_user_guidance`` (its own node and its own pytest
file using the ``hyper_nav_guidance_loop`` fixture) is built on its own into
a scratch install, and its test suite runs there: the fixture flies the
guidance_glide scenario with the user's node commanding the truth, records
the bag, and returns the miss distance; the live flight equals the flight
its recorded commands give offline, bit for bit."""
import pathlib
import sys

import pytest

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from plugin_install import bash, build  # noqa: E402


pytestmark = [pytest.mark.graph, pytest.mark.slow]
PACKAGE = "hyper_nav_user_guidance"


def test_users_guidance_node_in_the_loop(tmp_path):
    root = tmp_path / "ws"
    install = build(PACKAGE, root)
    # the user's own suite, in their own folder, with the plugin registered by the workspace's build
    p = bash(f"cd {root}/src/{PACKAGE} && python -m pytest -q -s -p no:cacheprovider test/test_my_guidance.py",
             install=install, timeout=900.0)
    assert p.returncode == 0, p.stdout[-5000:] + p.stderr[-3000:]
    assert "1 passed" in p.stdout
    line = next(x for x in p.stdout.splitlines() if "miss {'miss_m'" in x)
    print(line)
