"""What a state block is (STYLE pattern 15, OpenVINS's types).

A block owns, in one place and for every mechanization frame:
  * its size, units and parameters (``PARAMS``, declared once, see core.params);
  * its prior (initial 1-sigma) and its nominal initial value;
  * its error dynamics: the self-dynamics A (d/dt dx_blk = A dx_blk + ...) and
    how its error enters the attitude and velocity error rates. Every sensor
    error the filter carries is a body-axis quantity, so it enters any frame
    x through the body-to-frame rotation C_b_x (``BodyCoupling``); this is
    what makes a block frame-neutral;
  * its driving noise (``NoiseInput``);
  * its nominal propagation between updates and its injection (nominal minus
    the error estimate, errors being estimate minus truth);
  * its role in correcting the raw IMU increments (``imu_role``), or an IMU
    pre-processing hook (the elastic lever arm).

The navigation blocks att/vel/pos are coupled through the strapdown error
equations of each frame; their 9 x 9 core is the frame's (``core.frames``),
the rest (prior, white-noise inputs) is theirs. The filter composes blocks
(``core.system_model``) and never asks which one it holds.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Names of the runtime bases of a BodyCoupling term, in kernel order.
COUPLING_TERMS = ("const", "diag_w", "diag_f", "skew_w", "skew_wdot", "skew_w2")


@dataclass(frozen=True)
class BodyCoupling:
    """How a block's error enters the attitude ("att", gyro-like) or velocity
    ("vel", accelerometer-like) error rate, in any frame x:

        d/dt dx_target += C_b_x K(w, f, wdot) dx_block,
        K = K0 + diag(w) Kw + diag(f) Kf + [w x] Kwx + [wdot x] Kwdx + [w x][w x] Kww

    with w = omega_ib_b (rad/s), f = f_b (m/s^2), wdot its rate, all the
    filter's compensated body quantities. Each term is a constant 3 x size
    matrix (None when absent), so the composition is data, not code."""
    target: str
    const: np.ndarray | None = None
    diag_w: np.ndarray | None = None
    diag_f: np.ndarray | None = None
    skew_w: np.ndarray | None = None
    skew_wdot: np.ndarray | None = None
    skew_w2: np.ndarray | None = None

    def terms(self):
        """(term name, matrix) of the present terms."""
        return [(t, getattr(self, t)) for t in COUPLING_TERMS if getattr(self, t) is not None]


@dataclass(frozen=True)
class NoiseInput:
    """One white driving noise of a block: ``psd`` (k,) in SI, entering the
    rows of ``target`` ("self" = the block's own rows, "att" or "vel") as
    ``M`` w, or as C_b_x M w when ``via_body`` (a body-axis sensor noise)."""
    name: str
    psd: np.ndarray
    target: str
    M: np.ndarray
    via_body: bool = False


class Block:
    """Base class; see the module docstring. Subclasses set the class
    attributes and override what differs from a random constant."""
    name: str = ""
    size: int = 0
    description: str = ""          # frame and unit of the error, for readers and NavState.state_blocks
    nav: bool = False               # att/vel/pos: the frame owns the coupled 9 x 9 core
    imu_role: str | None = None     # "gyro_bias" | "accel_bias" | "gyro_scale" | "accel_scale" | None
    nav_state_field: str | None = None   # NavState attribute holding the value (else NavState.extra[name])
    exact_discretization: bool = False   # needs Phi = expm(F dt) (fast modes), not the 2nd-order series
    PARAMS: tuple = ()

    def prior_sigma(self, cfg) -> np.ndarray:
        raise NotImplementedError

    def initial_value(self, cfg) -> np.ndarray:
        """Nominal value at start (non-navigation blocks)."""
        return np.zeros(self.size)

    def self_dynamics(self, cfg) -> np.ndarray | None:
        """A (size x size) of d/dt dx_blk = A dx_blk; None = random constant."""
        return None

    def couplings(self, cfg) -> tuple[BodyCoupling, ...]:
        return ()

    def noise(self, cfg) -> tuple[NoiseInput, ...]:
        return ()

    def propagate(self, value: np.ndarray, dt_s: float, cfg) -> np.ndarray:
        """Nominal value over dt_s between updates, as the error model says
        (a random constant stays)."""
        return value

    # Optional IMU pre-processing (see blocks.lever_arm): a block with
    # ``preprocess(value, dtheta_c, dvel_c, w_prev, dt, cfg, fast, load_f_b_mps2)`` returns
    # (velocity increment to remove from the raw one, new value); ``load_f_b_mps2`` is the
    # sample's structural load (``ImuSample.load_f_b_mps2``, None when no source gives it).
    preprocess = None


def gauss_markov_psd(sigma, tau_s: float) -> np.ndarray:
    """Driving-noise PSD 2 sigma^2 / tau of a first-order Gauss-Markov process."""
    return 2.0 * np.asarray(sigma, float) ** 2 / tau_s
