"""Modules that moved when the packages were arranged by role (issue 34):
an import of an old name gives the module at its new home, with a
FutureWarning naming it (a deprecation period), instead of a bare
``No module named``; a module split in several fails naming its parts. Installed by ``hyper_nav_filter``, ``hyper_nav_sim``
and ``hyper_nav_aiding`` on import (only names, no import of the new
homes: the floors stay as they are). The table is the rename list of the
move (``git diff --name-status -M`` over it) and a few hand entries where
a module was split or merged."""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings

MOVED = {
    'hyper_nav_aiding.build_geomag_map': 'hyper_nav_aiding.geomag.build_map',
    'hyper_nav_aiding.conversions': 'hyper_nav_aiding.virtual_gnss.conversions',
    'hyper_nav_aiding.core.alpha_beta': 'hyper_nav_aiding.virtual_gnss.core.alpha_beta',
    'hyper_nav_aiding.core.ekf_intensity': 'hyper_nav_aiding.geomag.core.ekf_intensity',
    'hyper_nav_aiding.core.fused_extrapolation': 'hyper_nav_aiding.virtual_gnss.core.fused_extrapolation',
    'hyper_nav_aiding.core.geomag_aiding': 'hyper_nav_aiding.geomag.core.geomag_aiding',
    'hyper_nav_aiding.core.geomag_config': 'hyper_nav_aiding.geomag.core.geomag_config',
    'hyper_nav_aiding.core.geomag_map': 'hyper_nav_aiding.geomag.core.geomag_map',
    'hyper_nav_aiding.core.iccp': 'hyper_nav_aiding.geomag.core.iccp',
    'hyper_nav_aiding.core.lever_arm': 'hyper_nav_aiding.lever_arm.core',
    'hyper_nav_aiding.core.lever_arm.config': 'hyper_nav_aiding.lever_arm.core.config',
    'hyper_nav_aiding.core.lever_arm.crb': 'hyper_nav_aiding.lever_arm.core.crb',
    'hyper_nav_aiding.core.lever_arm.ddpg': 'hyper_nav_aiding.lever_arm.core.ddpg',
    'hyper_nav_aiding.core.lever_arm.env': 'hyper_nav_aiding.lever_arm.core.env',
    'hyper_nav_aiding.core.lever_arm.identifiers': 'hyper_nav_aiding.lever_arm.core.identifiers',
    'hyper_nav_aiding.core.lever_arm.monitor': 'hyper_nav_aiding.lever_arm.core.monitor',
    'hyper_nav_aiding.core.lever_arm.reestimate': 'hyper_nav_aiding.lever_arm.core.reestimate',
    'hyper_nav_aiding.core.lever_arm.replay': 'hyper_nav_aiding.lever_arm.core.replay',
    'hyper_nav_aiding.core.lever_arm.trigger': 'hyper_nav_aiding.lever_arm.core.trigger',
    'hyper_nav_aiding.core.lever_arm.window': 'hyper_nav_aiding.lever_arm.core.window',
    'hyper_nav_aiding.core.lever_arm.worker': 'hyper_nav_aiding.lever_arm.core.worker',
    'hyper_nav_aiding.core.mag_input': 'hyper_nav_aiding.geomag.core.mag_input',
    'hyper_nav_aiding.core.magcom': 'hyper_nav_aiding.geomag.core.magcom',
    'hyper_nav_aiding.core.map_epoch': 'hyper_nav_aiding.geomag.core.map_epoch',
    'hyper_nav_aiding.core.matching': 'hyper_nav_aiding.geomag.core.matching',
    'hyper_nav_aiding.core.nav_reference': 'hyper_nav_aiding.geomag.core.nav_reference',
    'hyper_nav_aiding.core.pcrb': 'hyper_nav_aiding.geomag.core.pcrb',
    'hyper_nav_aiding.core.siman': 'hyper_nav_aiding.geomag.core.siman',
    'hyper_nav_aiding.core.virtual_gnss': 'hyper_nav_aiding.virtual_gnss.core.virtual_gnss',
    'hyper_nav_aiding.core.virtual_gnss_config': 'hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config',
    'hyper_nav_aiding.core.virtual_pseudoranges': 'hyper_nav_aiding.virtual_gnss.core.virtual_pseudoranges',
    'hyper_nav_aiding.descriptors': 'hyper_nav_aiding.geomag.descriptor, hyper_nav_aiding.virtual_gnss.descriptor, hyper_nav_aiding.lever_arm.descriptor',
    'hyper_nav_aiding.geomag_conversions': 'hyper_nav_aiding.geomag.conversions',
    'hyper_nav_aiding.lever_arm_conversions': 'hyper_nav_aiding.lever_arm.conversions',
    'hyper_nav_aiding.mc_geomag': 'hyper_nav_aiding.geomag.mc_feed',
    'hyper_nav_aiding.nodes.geomag_node': 'hyper_nav_aiding.geomag.node',
    'hyper_nav_aiding.nodes.lever_arm_node': 'hyper_nav_aiding.lever_arm.node',
    'hyper_nav_aiding.nodes.virtual_gnss_node': 'hyper_nav_aiding.virtual_gnss.node',
    'hyper_nav_aiding.offline': 'hyper_nav_aiding.virtual_gnss.offline',
    'hyper_nav_aiding.parameters': 'hyper_nav_aiding.virtual_gnss.parameters',
    'hyper_nav_aiding.sim_windows': 'hyper_nav_aiding.lever_arm.sim_windows',
    'hyper_nav_aiding.virtual_input': 'hyper_nav_aiding.virtual_gnss.input',
    'hyper_nav_filter.core.earth': 'hyper_nav_gnss.earth',
    'hyper_nav_filter.core.gnss': 'hyper_nav_gnss',
    'hyper_nav_filter.core.gnss.combinations': 'hyper_nav_gnss.corrections.combinations',
    'hyper_nav_filter.core.gnss.constants': 'hyper_nav_gnss.constants',
    'hyper_nav_filter.core.gnss.ephemeris': 'hyper_nav_gnss.orbits.ephemeris',
    'hyper_nav_filter.core.gnss.geometry': 'hyper_nav_gnss.geometry',
    'hyper_nav_filter.core.gnss.navmsg': 'hyper_nav_gnss.formats.navmsg',
    'hyper_nav_filter.core.gnss.navmsg.bds_d1': 'hyper_nav_gnss.formats.navmsg.bds_d1',
    'hyper_nav_filter.core.gnss.navmsg.bits': 'hyper_nav_gnss.formats.navmsg.bits',
    'hyper_nav_filter.core.gnss.navmsg.gal_inav': 'hyper_nav_gnss.formats.navmsg.gal_inav',
    'hyper_nav_filter.core.gnss.navmsg.gps_lnav': 'hyper_nav_gnss.formats.navmsg.gps_lnav',
    'hyper_nav_filter.core.gnss.propagation': 'hyper_nav_gnss.corrections.propagation',
    'hyper_nav_filter.core.gnss.raim': 'hyper_nav_gnss.positioning.raim',
    'hyper_nav_filter.core.gnss.raw_to_pseudoranges': 'hyper_nav_filter.core.raw_to_pseudoranges',
    'hyper_nav_filter.core.gnss.receiver_model': 'hyper_nav_gnss.corrections.receiver_model',
    'hyper_nav_filter.core.gnss.rinex_file': 'hyper_nav_gnss.formats.rinex_file',
    'hyper_nav_filter.core.gnss.rinex_nav': 'hyper_nav_gnss.formats.rinex_nav',
    'hyper_nav_filter.core.gnss.rinex_obs': 'hyper_nav_gnss.formats.rinex_obs',
    'hyper_nav_filter.core.gnss.signal_delays': 'hyper_nav_gnss.corrections.signal_delays',
    'hyper_nav_filter.core.gnss.signals': 'hyper_nav_gnss.signals',
    'hyper_nav_filter.core.gnss.spp': 'hyper_nav_gnss.positioning.spp',
    'hyper_nav_filter.core.gnss.ubx': 'hyper_nav_gnss.formats.ubx',
    'hyper_nav_filter.core.gnss.weighting': 'hyper_nav_gnss.corrections.weighting',
    'hyper_nav_gnss.positioning.weighting': 'hyper_nav_gnss.corrections.weighting',   # the error model: below positioning
    'hyper_nav_filter.core.tracking': 'hyper_nav_filter.core.target_tracking',
    'hyper_nav_filter.core.tracking.aekf': 'hyper_nav_filter.core.target_tracking.aekf',
    'hyper_nav_filter.core.tracking.augmented': 'hyper_nav_filter.core.target_tracking.augmented',
    'hyper_nav_filter.core.tracking.config': 'hyper_nav_filter.core.target_tracking.config',
    'hyper_nav_filter.core.tracking.ekf': 'hyper_nav_filter.core.target_tracking.ekf',
    'hyper_nav_filter.core.tracking.filters': 'hyper_nav_filter.core.target_tracking.filters',
    'hyper_nav_filter.core.tracking.flight_bounds': 'hyper_nav_filter.core.target_tracking.flight_bounds',
    'hyper_nav_filter.core.tracking.glide_model': 'hyper_nav_filter.core.target_tracking.glide_model',
    'hyper_nav_filter.core.tracking.imm': 'hyper_nav_filter.core.target_tracking.imm',
    'hyper_nav_filter.core.tracking.lekf': 'hyper_nav_filter.core.target_tracking.lekf',
    'hyper_nav_filter.core.tracking.params_store': 'hyper_nav_filter.core.target_tracking.params_store',
    'hyper_nav_filter.core.tracking.pcrb': 'hyper_nav_filter.core.target_tracking.pcrb',
    'hyper_nav_filter.core.tracking.tracker': 'hyper_nav_filter.core.target_tracking.tracker',
    'hyper_nav_filter.core.tracking.training': 'hyper_nav_filter.core.target_tracking.training',
    'hyper_nav_sim.campaign': 'hyper_nav_workbench.campaign',
    'hyper_nav_sim.core.aiding_nodes': 'hyper_nav_filter.aiding_nodes',
    'hyper_nav_sim.core.allan': 'hyper_nav_workbench.core.allan',
    'hyper_nav_sim.core.array_io': 'hyper_nav_workbench.core.array_io',
    'hyper_nav_sim.core.bag': 'hyper_nav_workbench.core.bag',
    'hyper_nav_sim.core.bag_arrays': 'hyper_nav_workbench.core.bag_arrays',
    'hyper_nav_sim.core.fields': 'hyper_nav_filter.core.params',
    'hyper_nav_sim.core.gnss.acquisition': 'hyper_nav_gnss.receiver.acquisition',
    'hyper_nav_sim.core.gnss.aiding': 'hyper_nav_gnss.receiver.aiding',
    'hyper_nav_sim.core.gnss.constellation': 'hyper_nav_gnss.orbits.constellation',
    'hyper_nav_sim.core.gnss.lock': 'hyper_nav_gnss.receiver.lock',
    'hyper_nav_sim.core.gnss.nominal': 'hyper_nav_gnss.orbits.nominal',
    'hyper_nav_sim.core.gnss.pvt': 'hyper_nav_gnss.positioning.pvt',
    'hyper_nav_sim.core.gnss.tracking': 'hyper_nav_gnss.receiver.tracking',
    'hyper_nav_sim.core.importer': 'hyper_nav_workbench.core.importer',
    'hyper_nav_sim.core.importer.bag_columns': 'hyper_nav_workbench.core.importer.bag_columns',
    'hyper_nav_sim.core.importer.columns': 'hyper_nav_workbench.core.importer.columns',
    'hyper_nav_sim.core.importer.gnss_raw': 'hyper_nav_workbench.core.importer.gnss_raw',
    'hyper_nav_sim.core.importer.kfgins': 'hyper_nav_workbench.core.importer.kfgins',
    'hyper_nav_sim.core.importer.messages': 'hyper_nav_workbench.core.importer.messages',
    'hyper_nav_sim.core.importer.rtklib_pos': 'hyper_nav_workbench.core.importer.rtklib_pos',
    'hyper_nav_sim.core.importer.score': 'hyper_nav_workbench.core.importer.score',
    'hyper_nav_sim.core.importer.time_tags': 'hyper_nav_workbench.core.importer.time_tags',
    'hyper_nav_sim.core.lincov_check': 'hyper_nav_workbench.core.lincov_check',
    'hyper_nav_sim.core.lincov_setup': 'hyper_nav_workbench.core.lincov_setup',
    'hyper_nav_sim.core.live_view': 'hyper_nav_workbench.core.live_view',
    'hyper_nav_sim.core.liveness': 'hyper_nav_workbench.core.liveness',
    'hyper_nav_sim.core.mc_sources': 'hyper_nav_workbench.core.mc_sources',
    'hyper_nav_sim.core.montecarlo': 'hyper_nav_workbench.core.montecarlo',
    'hyper_nav_sim.core.noise_check': 'hyper_nav_workbench.core.noise_check',
    'hyper_nav_sim.core.rtklib_reference': 'hyper_nav_workbench.core.rtklib_reference',
    'hyper_nav_sim.core.run_check': 'hyper_nav_workbench.core.run_check',
    'hyper_nav_sim.core.scoring': 'hyper_nav_workbench.core.scoring',
    'hyper_nav_sim.core.spp_output': 'hyper_nav_workbench.core.spp_output',
    'hyper_nav_sim.core.spp_run': 'hyper_nav_workbench.core.spp_run',
    'hyper_nav_sim.core.verdict_rules': 'hyper_nav_workbench.core.verdict_rules',
    'hyper_nav_sim.core.wmm': 'hyper_nav_filter.core.wmm',
    'hyper_nav_sim.foxglove_client': 'hyper_nav_workbench.foxglove_client',
    'hyper_nav_sim.foxglove_view': 'hyper_nav_workbench.foxglove_view',
    'hyper_nav_sim.graph': 'hyper_nav_workbench.graph',
    'hyper_nav_sim.import_data': 'hyper_nav_workbench.import_data',
    'hyper_nav_sim.imu_allan_fit': 'hyper_nav_workbench.imu_allan_fit',
    'hyper_nav_sim.load_harness': 'hyper_nav_workbench.load_harness',
    'hyper_nav_sim.mc_campaign': 'hyper_nav_workbench.mc_campaign',
    'hyper_nav_sim.nodes.foxglove_view': 'hyper_nav_workbench.nodes.foxglove_view',
    'hyper_nav_sim.nodes.monitor': 'hyper_nav_workbench.nodes.monitor',
    'hyper_nav_sim.nodes.player': 'hyper_nav_workbench.nodes.player',
    'hyper_nav_sim.nodes.recorder': 'hyper_nav_workbench.nodes.recorder',
    'hyper_nav_sim.offline_fly': 'hyper_nav_workbench.offline_fly',
    'hyper_nav_sim.progress': 'hyper_nav_workbench.progress',
    'hyper_nav_sim.pytest_plugin': 'hyper_nav_workbench.pytest_plugin',
    'hyper_nav_sim.replay_filter': 'hyper_nav_workbench.replay_filter',
    'hyper_nav_sim.report': 'hyper_nav_workbench.report',
    'hyper_nav_sim.repro_walk': 'hyper_nav_repro.walk.reproduce',
    'hyper_nav_sim.run_plots': 'hyper_nav_workbench.run_plots',
    'hyper_nav_sim.spp': 'hyper_nav_workbench.spp',
    'hyper_nav_sim.testing': 'hyper_nav_workbench.testing',
}


class _Alias(importlib.abc.Loader):
    """The old name bound to the module at its new home (the same object)."""

    def __init__(self, new: str):
        self.new = new

    def create_module(self, spec):
        return importlib.import_module(self.new)

    def exec_module(self, module) -> None:
        pass


class _SplitPackage(importlib.abc.Loader):
    """An old package whose modules went to several homes: an empty package,
    so that its old submodule names reach their aliases."""

    def create_module(self, spec):
        return None

    def exec_module(self, module) -> None:
        pass


class MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Answers an import of a moved module with the module at its new home
    under the old name (a FutureWarning names the new one: the old names
    are kept for a deprecation period, so that scripts written against the
    earlier layout, e.g. ``shared/regressions/late-fix-order/compare_orders.py``,
    still run), and an old module split in several with a
    ModuleNotFoundError naming where its parts went."""

    def find_spec(self, fullname, path=None, target=None):
        new = MOVED.get(fullname)
        if new is not None:
            if ", " in new:
                raise ModuleNotFoundError(f"No module named {fullname!r}: it was split into {new} (packages by "
                                          "role, docs/architecture.md#packages-by-role)", name=fullname)
            warnings.warn(f"{fullname} moved to {new} (packages by role, docs/architecture.md#packages-by-role); "
                          "the old name is an alias for a deprecation period", FutureWarning, stacklevel=2)
            return importlib.machinery.ModuleSpec(fullname, _Alias(new),
                                                  is_package=importlib.util.find_spec(new).submodule_search_locations
                                                  is not None)
        if any(k.startswith(fullname + ".") for k in MOVED):      # a package that was split up
            return importlib.machinery.ModuleSpec(fullname, _SplitPackage(), is_package=True)
        return None


def install() -> None:
    """Put the finder last on ``sys.meta_path`` (once): it is asked only when no real module answered."""
    if not any(isinstance(f, MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.append(MovedModuleFinder())
