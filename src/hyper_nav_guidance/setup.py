from setuptools import find_packages, setup

package_name = "hyper_nav_guidance"

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
    description="Glide guidance in the loop: a guidance law flown on the navigation output.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "guidance_node = hyper_nav_guidance.nodes.guidance_node:main",
            "repro_guidance = hyper_nav_guidance.repro_guidance:main",
        ],
        # pytest fixture for a user's guidance node in the loop (hyper_nav_guidance_loop)
        "pytest11": ["hyper_nav_guidance = hyper_nav_guidance.pytest_plugin"],
    },
)
