"""A new sensor costs its own package and a scenario file, nothing else:
``plugin_packages/hyper_nav_static_port`` (a second static-pressure port: a
model with its messages, a node and a descriptor; the fusion node takes its
pressures through the existing ``baro_height`` source type) is built on its
own into a scratch install, beside the workspace, and

* the scenario loader takes its block, fields and validator, the launcher
  starts it, waits for it, writes its parameters and watches its stream at
  the rate its block gives, Monte Carlo feeds its messages, all from its
  entry point;
* the graph flies with it: every pressure it publishes is recorded and
  processed by the fusion node, and the report passes.

No code of the workspace names it (``git grep static_port`` finds its
package and this test)."""
import json
import pathlib
import sys

import pytest

from hyper_nav_workbench.report import load_run

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from plugin_install import bash as _bash, build  # noqa: E402

pytestmark = pytest.mark.graph
PACKAGE = "hyper_nav_static_port"
SCENARIO = "share/hyper_nav_static_port/scenarios/static_port.yaml"


@pytest.fixture(scope="module")
def install(tmp_path_factory) -> pathlib.Path:
    """The package built by colcon into a scratch prefix (its own install space)."""
    return build(PACKAGE, tmp_path_factory.mktemp("static_port"))


def test_the_new_sensor_is_declared_to_loader_launcher_and_monte_carlo(install):
    script = f"""
import json, pathlib, tempfile
import numpy as np
from hyper_nav_sim.core.scenario import ScenarioError, apply_overrides, load_scenario
from hyper_nav_workbench.core.mc_sources import Feed
from hyper_nav_workbench.graph import Graph, executable
sc = load_scenario("{install}/hyper_nav_static_port/{SCENARIO}")
g = Graph(sc)
mon = g._params("monitor")
out = {{"nodes": list(g.nodes), "port": g._params("static_port"), "exe": executable("static_port"),
        "monitor": mon["nodes"], "streams": dict(zip(mon["streams"], mon["stream_timeouts_s"])),
        "clock_nodes": g._params("truth")["clock_nodes"]}}
g._tmp.cleanup()
for field, value in (("static_port.noise_pa", -2.0), ("static_port.nois_pa", 1.0)):
    try:
        apply_overrides(sc, {{field: value}}, pathlib.Path(tempfile.mkdtemp()))
    except ScenarioError as exc:
        out[field] = str(exc)
# Monte Carlo: the fusion source on static_port/pressure takes the node's own messages
sc = apply_overrides(sc, {{"static_port.rate_hz": 5.0}}, pathlib.Path(tempfile.mkdtemp()))
traj = sc.trajectory()
feed = Feed(sc, traj, sc.filter_config())
port = [e for e in feed.events if e[1] == 2]
class Engine:                                  # takes what the fusion source makes of each message
    def __init__(self):
        self.got = []
    def add_measurement(self, m):
        self.got.append(m)
        return True, None
eng = Engine()
for e in port:
    e[3](eng)
t = np.array([m.t_s for m in eng.got])
err = np.array([m.alt_m for m in eng.got]) - traj.truth(t).alt_m
sig = np.sqrt([m.var_m2 for m in eng.got])
out["mc"] = {{"n": len(port), "fed": len(eng.got), "t_last": float(t[-1]), "kinds": sorted({{m.kind for m in eng.got}}),
             "mean_m": float(err.mean()), "nees": float(np.mean((err / sig) ** 2))}}
print(json.dumps(out))
"""
    p = _bash(f"python - <<'EOF'\n{script}\nEOF", install, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["nodes"] == ["truth", "imu", "gnss", "mag", "static_port", "fusion"]
    # its one topic waits for the recorder-less graph's one consumer: the fusion node's baro_height source
    assert got["port"]["min_subscribers"] == 1 and "wait_topics" not in got["port"]
    assert got["exe"].endswith("lib/hyper_nav_static_port/static_port_node")
    assert "static_port" in got["monitor"] and "static_port" in got["clock_nodes"]
    assert got["streams"]["static_port/pressure"] == pytest.approx(3.0)      # stream_timeout_s 3 > 3 periods
    assert "static_port.noise_pa: expected a number >= 0, got -2.0" in got["static_port.noise_pa"]
    assert "did you mean 'static_port.noise_pa'" in got["static_port.nois_pa"]
    # 300 s at 5 Hz through the baro_height converter: pressure altitudes against the true altitude with
    # the variance the node sends (noise 0.5 Pa, ~3 m at 30 km): mean error within 4 sigma / sqrt(n)
    # (0.3 m), normalised squared error within 0.8-1.2 (its 1500-sample spread is +-0.07)
    mc = got["mc"]
    assert mc["n"] == mc["fed"] == 1500 and mc["t_last"] == pytest.approx(300.0) and mc["kinds"] == ["baro"]
    assert abs(mc["mean_m"]) < 0.3 and 0.8 < mc["nees"] < 1.2


def test_the_new_sensor_flies_in_the_graph(install, tmp_path):
    """12 s of the default flight, 10 Hz pressures: the node publishes all
    120, the recorder takes 120, the fusion node processes 120 through its
    baro_height source, the report passes."""
    bag = tmp_path / "bag"
    p = _bash(f"ros2run hyper_nav_workbench run_graph --scenario {install}/hyper_nav_static_port/{SCENARIO} "
              f"--record {bag} --report --set duration_s=12 --set report.skip_s=4 "
              f"--set monitor.startup_timeout_s=180", install, timeout=900)
    assert p.returncode == 0 and "VERDICT: PASS" in p.stdout, p.stdout[-4000:] + p.stderr[-3000:]
    run = load_run(bag)
    counts = {t.lstrip("/"): n for t, n in run["counts"].items()}
    assert counts["static_port/pressure"] == 120
    port = run["by_node"]["static_port"]
    assert int(port["scheduled static_port/pressure"]) == 120 and int(port["published static_port/pressure"]) == 120
    fusion = run["by_node"]["fusion"]
    assert int(fusion["processed static_port/pressure"]) == 120
    assert int(fusion.get("rejected static_port/pressure", 0)) == 0
    report = json.loads((bag / "report.json").read_text())
    assert report["summary"]["pos_enu_m"]["rms_3d"] < 5.0
