from setuptools import find_packages, setup

package_name = "hyper_nav_filter"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/params", ["params/loosely_coupled.yaml", "params/tightly_coupled.yaml",
                                                "params/loosely_coupled_aiding.yaml"]),
    ],
    package_data={package_name: ["core/tracking/trained/*.npz", "core/tracking/trained/*.json"]},
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="Strapdown INS and error-state Kalman filter fusion node.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "fusion_node = hyper_nav_filter.nodes.fusion_node:main",
            "tracker_node = hyper_nav_filter.nodes.tracker_node:main",
        ],
    },
)
