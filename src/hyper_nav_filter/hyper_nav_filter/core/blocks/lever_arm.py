"""Elastic lever-arm block ``lev`` = [dq (3), dq' (3)]: errors of the modal
coordinates of the three bending modes and their rates (seed 000 eqs. 9-13,
17-23; the structural model is ``core.elastic_lever_arm.ModalModel``).

Error dynamics (eq. 18): d/dt [dq; dq'] = [[0, I], [K2, K1]] [dq; dq'] + [0; w_q].
The lever-arm specific force nabla = r'' + 2 w x r' + w' x r + w x (w x r) with
r = r0 + Y q is removed from the measured increments (``preprocess``), so its
error enters the velocity error rate of any frame as (eq. 20's F4 blocks)
    dv_dot -= C_b_x (A_q dq + A_qd dq'),
    A_q = Y K2 + [w' x] Y + [w x][w x] Y,   A_qd = Y K1 + 2 [w x] Y,
written as a BodyCoupling. The natural frequencies are updatable at run time
(``core.model_update``): a re-estimated structure takes effect at its epoch.
The modes reach w dt ~ 2 at 50 Hz, so the filter discretises exactly.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..elastic_lever_arm import (TABLE2_FREQ_RADPS, LeverArmCompensator, ModalModel,
                                 free_free_beam_mode_shapes)
from ..fast import lever as fast_lever
from ..params import FLOAT, FLOATS, ParamSpec, nonneg, positive
from .base import Block, BodyCoupling, NoiseInput

_MODE_SHAPE_IMU = tuple(float(x) for x in free_free_beam_mode_shapes(0.30))
_LOAD_PARTICIPATION = tuple(float(x) for x in free_free_beam_mode_shapes(0.55))
Z3, I3 = np.zeros((3, 3)), np.eye(3)


@lru_cache(maxsize=32)
def modal_model(cfg) -> ModalModel:
    """The filter's structural model of a configuration (cached: configs are frozen)."""
    return ModalModel.from_config(cfg)


@lru_cache(maxsize=32)
def _fast_model(cfg) -> tuple:
    """The compiled compensation's model argument (``core.fast.lever.model_args``) of a configuration."""
    return fast_lever.model_args(modal_model(cfg))


_ZERO3 = np.zeros(3)


class ElasticLeverArm(Block):
    name, size, exact_discretization = "lev", 6, True
    description = "elastic lever-arm modal coordinates q (m) and rates q' (m/s), seed 000 eqs. 9-13"
    PARAMS = (
        ParamSpec("lever_arm_r0_b_m", FLOATS, (0.0, 0.0, 0.0), "rigid IMU lever arm from the CG, body FLU (m)",
                  length=3),
        positive("lever_arm_natural_freq_radps", FLOATS, TABLE2_FREQ_RADPS,
                 "natural frequencies of the three bending modes (rad/s), seed 000 Table 2", length=3,
                 updatable=True),
        ParamSpec("lever_arm_damping_ratio", FLOATS, (0.02, 0.02, 0.02),
                  "modal damping ratios (under-damped: [0, 1))", lo=0.0, hi=1.0, hi_open=True, length=3),
        ParamSpec("lever_arm_mode_shape_at_imu", FLOATS, _MODE_SHAPE_IMU,
                  "mode shapes W_i at the IMU station (free-free beam at x/l 0.30)", length=3),
        ParamSpec("lever_arm_deflection_axis_b", FLOATS, (0.0, 0.0, 1.0),
                  "body axis of the bending deflection (FLU, non-zero)", length=3),
        ParamSpec("lever_arm_load_participation", FLOATS, _LOAD_PARTICIPATION,
                  "mode shapes at the centre of pressure (load participation)", length=3),
        positive("lever_arm_generalized_mass_kg", FLOATS, (1000.0, 1000.0, 1000.0), "generalized modal masses (kg)",
                 length=3),
        positive("lever_arm_vehicle_mass_kg", FLOAT, 1000.0, "vehicle mass (kg) for the normal load"),
        # the nominal modes are driven by the measured load, so these are small (seed 000,
        # 10 Hz GNSS: 10x larger values let velocity noise leak into the modes and raise
        # the vertical velocity error by 40 %)
        positive("lever_arm_q_sigma_m", FLOAT, 1e-3, "initial 1-sigma of the modal coordinates q (m)"),
        positive("lever_arm_qdot_sigma_mps", FLOAT, 1e-2, "initial 1-sigma of the modal rates q' (m/s)"),
        nonneg("lever_arm_modal_psd", FLOAT, 1e-6, "PSD of the modal noise w_q on q'' ((m/s^2)^2/Hz)"),
    )

    def prior_sigma(self, cfg):
        return np.concatenate([np.full(3, cfg.lever_arm_q_sigma_m), np.full(3, cfg.lever_arm_qdot_sigma_mps)])

    def initial_value(self, cfg):
        """Unset (NaN): the first IMU interval starts the modes at their static deflection."""
        return np.full(6, np.nan)

    def self_dynamics(self, cfg):
        m = modal_model(cfg)
        return np.block([[Z3, I3], [m.K2, m.K1]])

    def couplings(self, cfg):
        m = modal_model(cfg)
        Y = m.Y
        return (BodyCoupling("vel", const=-np.hstack([Y @ m.K2, Y @ m.K1]), skew_w=-np.hstack([Z3, 2.0 * Y]),
                             skew_wdot=-np.hstack([Y, Z3]), skew_w2=-np.hstack([Y, Z3])),)

    def noise(self, cfg):
        return (NoiseInput("w_lev", np.full(3, cfg.lever_arm_modal_psd), "self", np.vstack([Z3, I3])),)

    def preprocess(self, value, dtheta_c_b_rad, dvel_c_b_mps, w_prev_radps, dt_s, cfg, fast: bool = True,
                   load_f_b_mps2=None):
        """Dynamic lever-arm compensation (seed 000 Fig. 3) of one IMU interval:
        step the nominal modes under the load and return (the lever-arm
        velocity increment to remove from the raw increment, modes at the end).
        ``dtheta_c``/``dvel_c`` are bias-corrected; ``w_prev`` the corrected mean
        rate of the previous interval (None at the first). ``load_f_b_mps2``: the
        lever-arm-free specific force loading the structure (eqs. 4-6, the known
        input of eq. 22; ``ImuSample.load_f_b_mps2``: the interval mean (3,) or
        the load sensor's n sub-interval means (n, 3), each held over its
        sub-interval), else None: the measured
        one (``LeverArmCompensator``'s doc says what that costs). ``fast``: the
        compiled form (core.fast.lever), else the reference ``LeverArmCompensator``."""
        load = None if load_f_b_mps2 is None else np.asarray(load_f_b_mps2, dtype=np.float64)
        if fast:        # the compiled form starts unset (NaN) modes at the static deflection itself
            f_load = (dvel_c_b_mps / float(dt_s) if load is None else load).reshape(-1, 3)
            return fast_lever.compensate(np.ascontiguousarray(value), dtheta_c_b_rad,
                                         np.ascontiguousarray(f_load), float(dt_s),
                                         _ZERO3 if w_prev_radps is None else w_prev_radps, w_prev_radps is not None,
                                         _fast_model(cfg))
        m = modal_model(cfg)
        if not np.all(np.isfinite(value)):          # first interval: static deflection
            value = m.equilibrium(dvel_c_b_mps / dt_s if load is None else load)
        dv_cg, lev1, _, _ = LeverArmCompensator(m).compensate(value, dtheta_c_b_rad, dvel_c_b_mps, dt_s, w_prev_radps,
                                                              load)
        return dvel_c_b_mps - dv_cg, lev1
