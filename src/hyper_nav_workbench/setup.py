from glob import glob

from setuptools import find_packages, setup

package_name = "hyper_nav_workbench"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/real_data", glob("real_data/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="The workbench: graph launcher, recorder/player/monitor, bags, real-data import, spp, report and "
                "scoring, Monte Carlo, live view, pytest fixtures.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "recorder = hyper_nav_workbench.nodes.recorder:main",
            "player = hyper_nav_workbench.nodes.player:main",
            "monitor = hyper_nav_workbench.nodes.monitor:main",
            "run_graph = hyper_nav_workbench.graph:main",
            "load_flight = hyper_nav_workbench.load_harness:main",
            "report = hyper_nav_workbench.report:main",
            "replay_filter = hyper_nav_workbench.replay_filter:main",
            "import_data = hyper_nav_workbench.import_data:main",
            "foxglove_view = hyper_nav_workbench.nodes.foxglove_view:main",
            "mc_campaign = hyper_nav_workbench.mc_campaign:main",
            "spp = hyper_nav_workbench.spp:main",
            "imu_allan_fit = hyper_nav_workbench.imu_allan_fit:main",
        ],
        # pytest fixtures for users' own ROS tests (hyper_nav_graph, hyper_nav_domain_id)
        "pytest11": ["hyper_nav = hyper_nav_workbench.pytest_plugin"],
    },
)
