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
    entry_points={
        "console_scripts": [
            "geomag_node = hyper_nav_aiding.geomag.node:main",
            "build_geomag_map = hyper_nav_aiding.geomag.build_map:main",
            "virtual_gnss_node = hyper_nav_aiding.virtual_gnss.node:main",
            "lever_arm_node = hyper_nav_aiding.lever_arm.node:main",
        ],
        # the aiding nodes, declared to the launcher and the scenario loader (hyper_nav_filter.aiding_nodes)
        "hyper_nav.aiding_nodes": [
            "geomag = hyper_nav_aiding.geomag.descriptor:GEOMAG",
            "lever_arm = hyper_nav_aiding.lever_arm.descriptor:LEVER_ARM",
            "virtual_gnss = hyper_nav_aiding.virtual_gnss.descriptor:VIRTUAL_GNSS",
        ],
    },
)
