from setuptools import find_packages, setup

package_name = "hyper_nav_repro"

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
    description="Paper reproductions (seeds 000-004) over the filter, simulator and aiding packages.",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        # one executable per seed: repro_seed<NNN> (the Makefile's repro-seed<NNN>)
        "repro_seed000 = hyper_nav_repro.seed000.reproduce:main",
        "repro_seed001 = hyper_nav_repro.seed001.reproduce:main",
        "repro_seed002 = hyper_nav_repro.seed002.reproduce:main",
        "repro_seed003 = hyper_nav_repro.seed003.reproduce:main",
        "repro_seed004 = hyper_nav_repro.seed004.reproduce:main",
        # seed 004's tightly coupled covariance with and without range-bias states (issue 20)
        "tc_consistency = hyper_nav_repro.seed004.tc_consistency:main",
        # issue 23: unaided vs INS-aided receiver tracking through a plasma blackout
        "repro_aided_tracking = hyper_nav_repro.aided_tracking.reproduce:main",
        "repro_aided_blackout = hyper_nav_repro.aided_tracking.reproduce_blackout:main",
        # seed 002's L-EKF parameter set (make train-lekf)
        "train_lekf = hyper_nav_repro.seed002.train_lekf:main",
        # the walk_0827 recording: TC / LC / SPP against RTK (make repro-walk)
        "repro_walk = hyper_nav_repro.walk.reproduce:main",
        # issue 39: design studies (LinCov error budget and grade sweep; LinCov vs Monte Carlo)
        "study_lincov = hyper_nav_repro.studies.lincov_budget:main",
        "study_lincov_mc = hyper_nav_repro.studies.lincov_mc:main",
    ]},
)
