from glob import glob

from setuptools import find_packages, setup

package_name = "hyper_nav_static_port"

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
    description="Test sensor node: a second static-pressure port, declared like the simulator's sensors.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": ["static_port_node = hyper_nav_static_port.node:main"],
        # the node, declared to the launcher, the scenario loader and Monte Carlo
        "hyper_nav.sensor_nodes": ["static_port = hyper_nav_static_port.descriptor:STATIC_PORT"],
    },
)
