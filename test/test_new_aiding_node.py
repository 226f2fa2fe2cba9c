"""A new aiding node costs its own package and a scenario file, nothing else:
``plugin_packages/hyper_nav_fix_relay`` (a descriptor, a converter and a
node; it relays ``gnss/fix`` to the fusion node through its own source type
``relay_fix``) is built on its own into a scratch install, beside the
workspace, and

* the scenario loader takes its block and validator, the launcher starts
  it, waits for it and writes its parameters, the fusion node takes its
  converter, all from its entry points;
* the graph flies with it: every fix it relays is processed by the fusion
  node, and the report passes.

No code of the workspace names it (``git grep fix_relay`` finds its
package, this test and the documentation that points to them)."""
import json
import pathlib
import sys

import pytest

from hyper_nav_workbench.report import load_run

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from plugin_install import bash as _bash, build  # noqa: E402

pytestmark = pytest.mark.graph
PACKAGE = "hyper_nav_fix_relay"
SCENARIO = "share/hyper_nav_fix_relay/scenarios/fix_relay.yaml"


@pytest.fixture(scope="module")
def install(tmp_path_factory) -> pathlib.Path:
    """The package built by colcon into a scratch prefix (its own install space)."""
    return build(PACKAGE, tmp_path_factory.mktemp("fix_relay"))


def test_the_new_node_is_declared_to_loader_launcher_and_fusion(install):
    script = f"""
import json, pathlib, tempfile
from hyper_nav_filter.sources import load_plugins
from hyper_nav_filter import aiding_nodes
from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, fusion_inputs, load_scenario
from hyper_nav_workbench.graph import Graph, executable
sc = load_scenario("{install}/hyper_nav_fix_relay/{SCENARIO}")
g = Graph(sc)
out = {{"nodes": list(g.nodes), "relay": g._params("fix_relay"), "gnss": g._params("gnss"),
        "inputs": sorted(fusion_inputs(sc)), "types": sorted(load_plugins()), "exe": executable("fix_relay"),
        "monitor": g._params("monitor")["nodes"]}}
g._tmp.cleanup()
try:
    apply_overrides(sc, {{"fix_relay.sigma_scale": -2.0}}, pathlib.Path(tempfile.mkdtemp()))
except ScenarioError as exc:
    out["error"] = str(exc)
print(json.dumps(out))
"""
    p = _bash(f"python - <<'EOF'\n{script}\nEOF", install, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["nodes"] == ["truth", "imu", "gnss", "mag", "fusion", "fix_relay"]
    assert got["relay"] == {"fix_relay.topic": "relay/fix", "fix_relay.sigma_scale": 1.0, "qos.depth": 2000,
                            "min_output_subscribers": 1}
    # gnss/fix waits for the relay, gnss/vel for the fusion node: one subscriber each (each topic
    # counts its own consumers; counting the node's consumers over both topics, 2, would never come)
    assert got["gnss"]["min_subscribers"] == 1 and "wait_topics" not in got["gnss"]
    assert "relay/fix" in got["inputs"] and "gnss/fix" not in got["inputs"]
    assert "relay_fix" in got["types"] and got["exe"].endswith("lib/hyper_nav_fix_relay/fix_relay_node")
    assert "fix_relay" in got["monitor"]
    assert "fix_relay.sigma_scale: expected a number > 0, got -2.0" in got["error"]


def test_the_new_node_flies_in_the_graph(install, tmp_path):
    """12 s of the default flight, 10 Hz fixes: the relay takes and publishes
    all 120, the fusion node processes all 120, the report passes (measured:
    position RMS 3D 1.1 m after 4 s)."""
    bag = tmp_path / "bag"
    p = _bash(f"ros2run hyper_nav_workbench run_graph --scenario {install}/hyper_nav_fix_relay/{SCENARIO} "
              f"--record {bag} --report --set duration_s=12 --set report.skip_s=4 "
              f"--set monitor.startup_timeout_s=180", install, timeout=900)
    assert p.returncode == 0 and "VERDICT: PASS" in p.stdout, p.stdout[-4000:] + p.stderr[-3000:]
    run = load_run(bag)
    counts = {t.lstrip("/"): n for t, n in run["counts"].items()}
    assert counts["gnss/fix"] == 120 and counts["relay/fix"] == 120
    relay = run["by_node"]["fix_relay"]
    assert int(relay["received gnss/fix"]) == 120 and int(relay["published relay/fix"]) == 120
    fusion = run["by_node"]["fusion"]
    assert int(fusion["processed relay/fix"]) == 120 and int(fusion.get("rejected relay/fix", 0)) == 0
    report = json.loads((bag / "report.json").read_text())
    assert report["summary"]["pos_enu_m"]["rms_3d"] < 5.0
