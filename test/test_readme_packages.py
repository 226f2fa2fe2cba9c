"""The README's packages table is the map of what is installed: every package
of ``src/`` has its row, and the row lists exactly the executables the
package installs (``<prefix>/lib/<pkg>/``, where ``ros2 run`` finds them)."""
import os
import pathlib
import re

from ament_index_python.packages import get_package_prefix

REPO = pathlib.Path(__file__).resolve().parents[1]


def readme_table() -> dict[str, set[str]]:
    """{package: executables} of the README's ``## Packages`` table (last column; '–' = none)."""
    text = (REPO / "README.md").read_text()
    section = text[text.index("## Packages"):]
    section = section[:section.index("\n## ", 5)]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not re.fullmatch(r"`[a-z0-9_]+`", cells[0]):
            continue
        rows[cells[0].strip("`")] = set(re.findall(r"`([A-Za-z0-9_]+)`", cells[-1]))
    return rows


def installed(package: str) -> set[str]:
    lib = pathlib.Path(get_package_prefix(package)) / "lib" / package
    if not lib.is_dir():
        return set()
    return {p.name for p in lib.iterdir() if p.is_file() and os.access(p, os.X_OK)}


def test_every_package_has_its_row():
    packages = {p.parent.name for p in (REPO / "src").glob("*/package.xml")}
    assert set(readme_table()) == packages


def test_every_installed_executable_is_listed_and_nothing_else():
    table = readme_table()
    assert table["hyper_nav_repro"] >= {"repro_seed000", "repro_seed004"}       # the table was read
    for package, listed in table.items():
        assert installed(package) == listed, (package, sorted(installed(package) ^ listed))
