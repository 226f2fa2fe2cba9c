from setuptools import find_packages, setup

package_name = "hyper_nav_aiding"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="Navigation aiding: geomagnetic matching, virtual pseudoranges, lever-arm learning.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        "geomag_node = hyper_nav_aiding.nodes.geomag_node:main",
        "reproduce_seed003 = hyper_nav_aiding.reproduce_seed003:main",
        "build_geomag_map = hyper_nav_aiding.build_geomag_map:main",
        "virtual_gnss_node = hyper_nav_aiding.nodes.virtual_gnss_node:main",
        "reproduce_seed004 = hyper_nav_aiding.reproduce_seed004:main",
            "tc_consistency = hyper_nav_aiding.tc_consistency:main",
        "lever_arm_node = hyper_nav_aiding.nodes.lever_arm_node:main",
        "reproduce_seed000 = hyper_nav_aiding.reproduce_seed000:main",
    ]},
)
