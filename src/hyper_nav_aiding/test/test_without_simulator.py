"""The aiding nodes run without the simulator installed (issue 34 item 3):
their node modules, and every module of this package they load, import no
``hyper_nav_sim`` module, not even inside a function. The one exception is
the launcher's side of a descriptor (``virtual_gnss.parameters.from_scenario``
reads a simulated scenario's receiver block; it runs in the launcher, which
has the simulator)."""
import ast
import json
import pathlib
import subprocess
import sys

NODES = ("hyper_nav_aiding.geomag.node", "hyper_nav_aiding.virtual_gnss.node", "hyper_nav_aiding.lever_arm.node")
LAUNCHER_SIDE = {("hyper_nav_aiding.virtual_gnss.parameters", "from_scenario")}

PROBE = """
import importlib, json, sys
class Uninstalled:                      # the simulator is not installed: any import of it fails
    def find_spec(self, name, path=None, target=None):
        if name == "hyper_nav_sim" or name.startswith("hyper_nav_sim."):
            raise ModuleNotFoundError(f"No module named {name!r}")
        return None
sys.meta_path.insert(0, Uninstalled())
for m in sys.argv[1:]:
    importlib.import_module(m)
print(json.dumps({k: getattr(v, "__file__", None) for k, v in sys.modules.items()
                  if k.startswith(("hyper_nav_aiding", "hyper_nav_sim"))}))
"""


def _sim_imports(path: pathlib.Path):
    """(enclosing function or None, line) of every import of hyper_nav_sim in a file."""
    tree = ast.parse(path.read_text())
    out = []

    def visit(node, fn):
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else fn
            if isinstance(child, ast.ImportFrom) and (child.module or "").split(".")[0] == "hyper_nav_sim" or \
                    isinstance(child, ast.Import) and any(a.name.split(".")[0] == "hyper_nav_sim" for a in child.names):
                out.append((fn, child.lineno))
            visit(child, name)
    visit(tree, None)
    return out


def test_the_aiding_nodes_load_with_the_simulator_uninstalled():
    p = subprocess.run([sys.executable, "-c", PROBE, *NODES], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-3000:]
    loaded = json.loads(p.stdout.strip().splitlines()[-1])
    assert not [m for m in loaded if m.startswith("hyper_nav_sim")]
    assert set(NODES) <= set(loaded)
    found = []
    for mod, f in loaded.items():
        if f:
            found += [(mod, fn, line) for fn, line in _sim_imports(pathlib.Path(f)) if (mod, fn) not in LAUNCHER_SIDE]
    assert not found, f"aiding modules the nodes load import the simulator: {found}"


def test_the_probe_sees_a_simulator_import():
    """The check can fail: a module that imports the simulator is refused by the probe."""
    p = subprocess.run([sys.executable, "-c", PROBE, "hyper_nav_aiding.virtual_gnss.offline"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode != 0 and "No module named 'hyper_nav_sim" in p.stderr
