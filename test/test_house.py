"""The plan of the house (issue 34, docs/architecture.md#packages-by-role): packages on floors, each importing only
from the floors below it (imports inside functions count too), no package importing one on its own floor, and no
import circle between the modules of a package. Read from the code's own import statements (tests excluded)."""
import ast
import pathlib

import pytest

SRC = pathlib.Path(__file__).resolve().parents[1] / "src"

FLOORS = {
    "hyper_nav_msgs": 0,
    "hyper_nav_gnss": 1,
    "hyper_nav_filter": 2,
    "hyper_nav_sim": 3,
    "hyper_nav_workbench": 4,
    "hyper_nav_aiding": 4,
    "hyper_nav_guidance": 5,
    "hyper_nav_repro": 6,
}


def modules(package: str) -> dict[str, pathlib.Path]:
    root = SRC / package / package
    out = {}
    for f in root.rglob("*.py"):
        parts = list(f.relative_to(SRC / package).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def imports_of(name: str, path: pathlib.Path) -> set[str]:
    """Absolute names of the modules (or packages) ``path`` imports, relative imports resolved."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
    return out


def test_every_package_has_its_floor():
    assert {p.parent.name for p in SRC.glob("*/package.xml")} - {"tf2_msgs"} == set(FLOORS)


@pytest.mark.parametrize("package", [p for p in FLOORS if p != "hyper_nav_msgs"])
def test_no_import_goes_up_or_sideways(package):
    wrong = []
    for name, path in modules(package).items():
        for imp in imports_of(name, path):
            other = imp.split(".")[0]
            if other in FLOORS and other != package and FLOORS[other] >= FLOORS[package]:
                wrong.append(f"{path.relative_to(SRC)} imports {imp} (floor {FLOORS[other]} >= {FLOORS[package]})")
    assert not wrong, "\n".join(sorted(wrong))


def _circles(graph: dict) -> list:
    """The strongly connected components of more than one node (Tarjan)."""
    index, low, stack, on, circles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return circles


def _module_graph(package: str) -> dict:
    mods = modules(package)
    graph = {m: {i for i in imports_of(m, p) if i in mods and i != m} for m, p in mods.items()}
    # a package's __init__ importing its own modules is not an edge back (Python imports the package first)
    for m in graph:
        graph[m] = {i for i in graph[m] if not m.startswith(i + ".")}
    return graph


@pytest.mark.parametrize("package", [p for p in FLOORS if p != "hyper_nav_msgs"])
def test_no_import_circle_inside_a_package(package):
    assert not _circles(_module_graph(package))


@pytest.mark.parametrize("package", [p for p in FLOORS if p != "hyper_nav_msgs"])
def test_no_import_circle_between_the_rooms_of_a_package(package):
    """A package's rooms (each folder below its root, each module at its root) import in one direction: a
    folder-level loop (orbits -> geometry -> orbits) is a circle of rooms even without one of modules."""
    def room(m):
        parts = m.split(".")
        return ".".join(parts[:2])
    rooms: dict = {}
    for m, deps in _module_graph(package).items():
        rooms.setdefault(room(m), set()).update(room(d) for d in deps if room(d) != room(m))
    assert not _circles(rooms)


def test_no_simulator_command_simulates_nothing():
    """The simulator's executables are its nodes and the scenario plots: every other command is the workbench's."""
    import re
    setup = (SRC / "hyper_nav_sim" / "setup.py").read_text()
    scripts = setup.split('"console_scripts"', 1)[1].split("]", 1)[0]
    exes = set(re.findall(r'"(\w+) = hyper_nav_sim\.', scripts))
    assert exes == {"truth_node", "imu_node", "gnss_node", "mag_node", "baro_node", "radar_node", "plot_scenarios"}

