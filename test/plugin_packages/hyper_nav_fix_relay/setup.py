from glob import glob

from setuptools import find_packages, setup

package_name = "hyper_nav_fix_relay"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/scenarios", glob("scenarios/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="Test aiding node: relays GNSS fixes to the fusion node through its own declared source type.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": ["fix_relay_node = hyper_nav_fix_relay.node:main"],
        # the node, declared to the launcher and the scenario loader
        "hyper_nav.aiding_nodes": ["fix_relay = hyper_nav_fix_relay.descriptor:FIX_RELAY"],
        # its message -> measurement converter, declared to the fusion node's sources
        "hyper_nav.sources": ["relay_fix = hyper_nav_fix_relay.converter:RelayFixSource"],
    },
)
