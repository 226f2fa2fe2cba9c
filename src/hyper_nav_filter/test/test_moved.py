"""An import of a module that moved when the packages were arranged by role
gives the new module and names its new home (``hyper_nav_filter.moved``); the table points only at
modules that exist, and no name in it is still a module of its own."""
import importlib
import importlib.util
import sys

import pytest

from hyper_nav_filter.moved import MOVED


@pytest.mark.parametrize("old, new", [("hyper_nav_sim.core.bag", "hyper_nav_workbench.core.bag"),
                                      ("hyper_nav_sim.graph", "hyper_nav_workbench.graph"),
                                      ("hyper_nav_filter.core.gnss.spp", "hyper_nav_gnss.positioning.spp"),
                                      ("hyper_nav_sim.core.spp_run", "hyper_nav_workbench.core.spp_run"),
                                      ("hyper_nav_aiding.core.iccp", "hyper_nav_aiding.geomag.core.iccp")])
def test_an_old_name_is_the_new_module_and_says_where_it_went(old, new):
    """A deprecation period: the old name answers with the module at its new
    home (the same object) and a FutureWarning naming it; under a package
    that was split up too (hyper_nav_aiding.core)."""
    sys.modules.pop(old, None)
    with pytest.warns(FutureWarning, match=f"{old} moved to {new}"):
        mod = importlib.import_module(old)
    assert mod is importlib.import_module(new)


def test_a_module_split_in_several_names_its_parts():
    with pytest.raises(ModuleNotFoundError, match=r"it was split into hyper_nav_aiding.geomag.descriptor, "):
        importlib.import_module("hyper_nav_aiding.descriptors")


def test_every_new_home_exists_and_no_old_name_does():
    for old, new in MOVED.items():
        for target in new.split(", "):
            assert importlib.util.find_spec(target) is not None, (old, target)


def test_a_name_that_never_existed_is_the_usual_error():
    with pytest.raises(ModuleNotFoundError, match="No module named 'hyper_nav_sim.core.nothing_here'$"):
        importlib.import_module("hyper_nav_sim.core.nothing_here")
