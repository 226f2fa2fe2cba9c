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
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hyper-nav maintainers",
    maintainer_email="maintainers@hyper-nav.org",
    description="The simulated world: boost-glide truth, sensor models and sensor nodes, the GNSS world, scenarios.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "truth_node = hyper_nav_sim.nodes.truth_node:main",
            "imu_node = hyper_nav_sim.nodes.imu_node:main",
            "gnss_node = hyper_nav_sim.nodes.gnss_node:main",
            "mag_node = hyper_nav_sim.nodes.mag_node:main",
            "baro_node = hyper_nav_sim.nodes.baro_node:main",
            "radar_node = hyper_nav_sim.nodes.radar_node:main",
            "plot_scenarios = hyper_nav_sim.plot:main",
        ],
        # the sensor nodes, declared to the launcher, the scenario loader and Monte Carlo (hyper_nav_sim.sensors)
        "hyper_nav.sensor_nodes": [
            "imu = hyper_nav_sim.nodes.descriptors:IMU",
            "gnss = hyper_nav_sim.nodes.descriptors:GNSS",
            "mag = hyper_nav_sim.nodes.descriptors:MAG",
            "baro = hyper_nav_sim.nodes.descriptors:BARO",
            "radar = hyper_nav_sim.nodes.descriptors:RADAR",
        ],
    },
)
