from glob import glob

from setuptools import find_packages, setup

package_name = "hyper_nav_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/scenarios", glob("scenarios/*.yaml")),
        ("share/" + package_name + "/real_data", glob("real_data/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="Hypersonic trajectory and sensor simulation, graph starter, recorder and player.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "truth_node = hyper_nav_sim.nodes.truth_node:main",
            "imu_node = hyper_nav_sim.nodes.imu_node:main",
            "gnss_node = hyper_nav_sim.nodes.gnss_node:main",
            "mag_node = hyper_nav_sim.nodes.mag_node:main",
            "baro_node = hyper_nav_sim.nodes.baro_node:main",
            "radar_node = hyper_nav_sim.nodes.radar_node:main",
            "recorder = hyper_nav_sim.nodes.recorder:main",
            "player = hyper_nav_sim.nodes.player:main",
            "monitor = hyper_nav_sim.nodes.monitor:main",
            "run_graph = hyper_nav_sim.graph:main",
            "load_flight = hyper_nav_sim.load_harness:main",
            "report = hyper_nav_sim.report:main",
            "replay_filter = hyper_nav_sim.replay_filter:main",
            "plot_scenarios = hyper_nav_sim.plot:main",
            "import_data = hyper_nav_sim.import_data:main",
            "foxglove_view = hyper_nav_sim.nodes.foxglove_view:main",
            "mc_campaign = hyper_nav_sim.mc_campaign:main",
            "spp = hyper_nav_sim.spp:main",
            "repro_walk = hyper_nav_sim.repro_walk:main",
            "imu_allan_fit = hyper_nav_sim.imu_allan_fit:main",
        ],
        # pytest fixtures for users' own ROS tests (hyper_nav_graph, hyper_nav_domain_id)
        "pytest11": ["hyper_nav = hyper_nav_sim.pytest_plugin"],
    },
)
