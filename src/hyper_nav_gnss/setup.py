from setuptools import find_packages, setup

package_name = "hyper_nav_gnss"

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
    description="Receiver-side GNSS library: formats, orbits, corrections, positioning, receiver tracking loops.",
    license="Apache-2.0",
)
