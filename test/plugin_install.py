"""A user's package beside the workspace, as the plugin tests try it: built
by colcon on its own into a scratch install space, and commands run in bash
with the workspace's environment and that install's setup sourced."""
import pathlib
import shutil
import subprocess

REPO = pathlib.Path(__file__).resolve().parents[1]
PLUGINS = REPO / "test" / "plugin_packages"


def bash(command: str, install: pathlib.Path | None = None, timeout: float = 600.0):
    """``command`` in bash after ``source tools/env.sh`` (and the scratch install's setup)."""
    extra = f" && source {install}/local_setup.bash" if install else ""
    return subprocess.run(["bash", "-c", f"source tools/env.sh >/dev/null{extra} && {command}"], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def build(package: str, root: pathlib.Path) -> pathlib.Path:
    """``test/plugin_packages/<package>`` built by colcon under ``root``; its install space."""
    shutil.copytree(PLUGINS / package, root / "src" / package)
    p = bash(f"colcon --log-base {root}/log build --base-paths {root}/src --build-base {root}/build "
             f"--install-base {root}/install --event-handlers console_cohesion- summary-", timeout=900.0)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return root / "install"
