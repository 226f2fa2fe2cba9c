"""The virtual GNSS node's parameters: declared once (name, default,
description), filled from the scenario (``virtual_gnss:`` block, the
receiver's broadcast models of ``gnss.raw``, ``gnss.rate_hz``, the antenna
lever arm, ``seed``), read into one typed object. No rclpy here."""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from hyper_nav_gnss.corrections.propagation import KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT
from hyper_nav_filter.core.params import number
from hyper_nav_filter.core.raw_to_pseudoranges import ReceiverCorrections

from hyper_nav_aiding.virtual_gnss.core.virtual_gnss_config import VirtualGnssConfig, VirtualGnssConfigError

_DESCRIPTIONS = {
    "enabled": "start the virtual GNSS node in the graph",
    "topic": "output topic (hyper_nav_msgs/GnssMeasurements, is_virtual set)",
    "position_source": "vehicle position for the virtual ranges: 'fused' (nav/state + IMU) or 'alpha_beta' (gnss/fix)",
    "elevation_mask_deg": "no virtual range below this elevation [deg]",
    "pseudorange_sigma_m": "sigma written into the virtual ranges: 'elevation' (seed 004 eq. 11) or metres",
    "pseudorange_rate_sigma_mps": "sigma written into the virtual rates [m/s]",
    "add_noise": "draw eq. 11's D_noise into the virtual ranges (the paper)",
    "consistent_covariance": "add the source's position/clock 1-sigma to the written sigmas",
    "max_extrapolation_s": "alpha_beta: no virtual ranges this long after the last fix [s]",
    "max_state_age_s": "fused: no virtual ranges from a nav/state this old without IMU to carry it [s]",
    "fused_state_delay_s": "fused: use the nav/state stamped at or before epoch - this [s]",
    "input_hold_s": "an epoch is processed once the IMU is this far past it: inputs stamped by it and up to "
                    "this late are in, so the output does not depend on their arrival order [s]",
    "alpha_beta_accel_sigma_mps2": "alpha-beta tracker: vehicle acceleration sigma [m/s^2]",
    "alpha_beta_fix_sigma_m": "alpha-beta tracker: fix sigma [m]",
    "clock_drift_rate_sigma_mps2": "receiver clock tracker: drift rate sigma [m/s^2]",
    "clock_sigma_m": "receiver clock tracker: per-epoch clock measurement sigma [m]",
}
# node-level parameters beside the virtual_gnss.* block: name -> (default, description)
NODE_PARAMETERS = {
    "gnss.ionosphere": ("klobuchar", "broadcast ionosphere model the receiver uses: 'klobuchar' | 'off'"),
    "gnss.klobuchar_alpha": (list(KLOBUCHAR_ALPHA_DEFAULT), "broadcast Klobuchar alpha [s, s/sc, s/sc^2, s/sc^3]"),
    "gnss.klobuchar_beta": (list(KLOBUCHAR_BETA_DEFAULT), "broadcast Klobuchar beta [s, s/sc, s/sc^2, s/sc^3]"),
    "gnss.troposphere": ("hopfield", "troposphere model the receiver uses: 'hopfield' | 'off'"),
    "gnss.rate_hz": (1.0, "receiver epoch rate [Hz]"),
    "antenna_lever_arm_b_m": ([0.0, 0.0, 0.0], "GNSS antenna lever arm, body FLU [m]"),
    "seed": (0, "seed of the eq. 10 noise draws"),
    "qos.depth": (2000, "publisher and subscriber queue depth"),
    "min_output_subscribers": (0, "subscriptions the output topic must see before inputs are taken"),
    "frame_id": ("gnss_antenna", "header.frame_id of the output"),
    "clock.deadline_s": (1e9, "while a receiver epoch t waits to be processed, the simulated clock may not pass "
                         "t + this (sim s; /graph/allowance, hyper_nav_filter.clock_gate): run_graph sets the fusion "
                         "output delay minus 0.2 s, so every virtual epoch reaches the filter before its release"),
}


def declarations() -> list[tuple[str, object, str]]:
    """(name, default, description) of every parameter the node declares;
    ``virtual_gnss.pseudorange_sigma_m`` is a string ('elevation' or a number)."""
    out = []
    for f in fields(VirtualGnssConfig):
        default = str(f.default) if f.name == "pseudorange_sigma_m" else f.default
        out.append((f"virtual_gnss.{f.name}", default, _DESCRIPTIONS[f.name]))
    out += [(k, d, desc) for k, (d, desc) in NODE_PARAMETERS.items()]
    return out


@dataclass(frozen=True)
class VirtualGnssNodeParams:
    config: VirtualGnssConfig
    corrections: ReceiverCorrections
    rate_hz: float
    lever_arm_b_m: np.ndarray
    seed: int
    qos_depth: int
    min_output_subscribers: int
    frame_id: str
    clock_deadline_s: float = 1e9

    @classmethod
    def from_values(cls, values: dict) -> "VirtualGnssNodeParams":
        """From {name: value} of :func:`declarations`; VirtualGnssConfigError names a bad one."""
        block = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("virtual_gnss.")}
        sig = block.get("pseudorange_sigma_m", "elevation")
        if isinstance(sig, str) and sig != "elevation":
            try:
                block["pseudorange_sigma_m"] = float(sig)
            except ValueError:
                raise VirtualGnssConfigError(f"virtual_gnss.pseudorange_sigma_m: expected 'elevation' or a number, "
                                             f"got {sig!r}") from None
        cfg = VirtualGnssConfig.from_config(block)
        v = {k: values.get(k, d) for k, (d, _) in NODE_PARAMETERS.items()}
        try:
            corr = ReceiverCorrections.from_params(v["gnss.ionosphere"], v["gnss.klobuchar_alpha"],
                                                   v["gnss.klobuchar_beta"], v["gnss.troposphere"])
        except ValueError as exc:
            raise VirtualGnssConfigError(str(exc)) from None
        lever = np.asarray(v["antenna_lever_arm_b_m"], float)
        if lever.shape != (3,) or not np.all(np.isfinite(lever)):
            raise VirtualGnssConfigError(f"antenna_lever_arm_b_m: expected 3 numbers, got {v['antenna_lever_arm_b_m']!r}")
        rate = number("gnss.rate_hz", v["gnss.rate_hz"], 0.0, lo_open=True, error=VirtualGnssConfigError)
        return cls(cfg, corr, rate, lever, int(v["seed"]), int(v["qos.depth"]),
                   int(v["min_output_subscribers"]), str(v["frame_id"]), float(v["clock.deadline_s"]))


def from_scenario(sc) -> dict:
    """The node's parameters from a scenario (``hyper_nav_sim`` Scenario)."""
    from hyper_nav_filter.aiding_nodes import flat_parameters
    cfg = VirtualGnssConfig.from_config(sc.data.get("virtual_gnss"))
    # every field of the validated block (defaults filled); the sigma is a string parameter ('elevation' or metres)
    out = flat_parameters({f.name: str(getattr(cfg, f.name)) if f.name == "pseudorange_sigma_m" else getattr(cfg, f.name)
                           for f in fields(cfg)}, "virtual_gnss")
    # the receiver's broadcast models: those of the scenario's (first) gnss_raw source, which
    # default to the gnss.raw block's (the Klobuchar set its satellites broadcast)
    from hyper_nav_sim.core.gnss.receiver import GnssReceiverConfig
    raw = next((e for e in sc.filter_sources().values() if e.get("type") == "gnss_raw"), {})
    rx = GnssReceiverConfig.from_dict(sc.data.get("gnss", {}).get("raw"))
    out.update({"gnss.ionosphere": raw.get("ionosphere", rx.ionosphere),
                "gnss.klobuchar_alpha": [float(x) for x in raw.get("klobuchar_alpha", rx.klobuchar_alpha)],
                "gnss.klobuchar_beta": [float(x) for x in raw.get("klobuchar_beta", rx.klobuchar_beta)],
                "gnss.troposphere": raw.get("troposphere", rx.troposphere)})
    out.update({"gnss.rate_hz": float(sc["gnss.rate_hz"]),
                "antenna_lever_arm_b_m": [float(x) for x in sc["gnss.antenna_lever_arm_b_m"]],
                "seed": int(sc["seed"]), "qos.depth": int(sc["graph.qos_depth"])})
    return out
