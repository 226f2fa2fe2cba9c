"""An import of a module that moved when the packages were arranged by role
names its new home (``hyper_nav_filter.moved``); the table points only at
modules that exist, and no name in it is still a module of its own."""
import importlib
import importlib.util

import pytest

from hyper_nav_filter.moved import MOVED


@pytest.mark.parametrize("old, new", [("hyper_nav_sim.core.bag", "hyper_nav_workbench.core.bag"),
                                      ("hyper_nav_sim.graph", "hyper_nav_workbench.graph"),
                                      ("hyper_nav_filter.core.gnss.spp", "hyper_nav_gnss"),      # its package moved
                                      ("hyper_nav_sim.core.spp_run", "hyper_nav_workbench.core.spp_run")])
def test_an_old_name_says_where_it_went(old, new):
    with pytest.raises(ModuleNotFoundError, match=f"it moved to {new}"):
        importlib.import_module(old)


def test_a_split_package_names_where_its_modules_went():
    with pytest.raises(ModuleNotFoundError, match=r"its modules moved \(hyper_nav_aiding.core.alpha_beta -> "
                                                  r"hyper_nav_aiding.virtual_gnss.core.alpha_beta"):
        importlib.import_module("hyper_nav_aiding.core.iccp")


def test_every_new_home_exists_and_no_old_name_does():
    for old, new in MOVED.items():
        for target in new.split(", "):
            assert importlib.util.find_spec(target) is not None, (old, target)


def test_a_name_that_never_existed_is_the_usual_error():
    with pytest.raises(ModuleNotFoundError, match="No module named 'hyper_nav_sim.core.nothing_here'$"):
        importlib.import_module("hyper_nav_sim.core.nothing_here")
