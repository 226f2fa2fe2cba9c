"""State blocks, registered by name. Adding a block = one module defining a
``Block`` subclass (see ``base``) + one line in ``REGISTRY`` below.

  att vel pos   navigation errors (frame axes)          blocks.nav
  bg ba gm      gyro bias, accel bias, Markov gyro drift blocks.imu_errors
  sg sa         gyro / accel scale factors              blocks.imu_errors
  clk           receiver clock bias and drift           blocks.clock
  lev           elastic lever-arm modes                 blocks.lever_arm
  rb rb32       GNSS range biases (16 / 32 satellite slots) blocks.range_bias
  isb           GNSS inter-system biases (E, C, J vs GPS)  blocks.range_bias
"""
from __future__ import annotations

from .base import COUPLING_TERMS, Block, BodyCoupling, NoiseInput
from .clock import ReceiverClock
from .imu_errors import AccelBias, AccelScaleFactor, GyroBias, GyroMarkov, GyroScaleFactor
from .lever_arm import ElasticLeverArm
from .nav import Attitude, Position, Velocity
from .range_bias import InterSystemBias, RangeBiases, RangeBiases32

REGISTRY: dict[str, Block] = {b.name: b for b in (
    Attitude(), Velocity(), Position(), GyroBias(), AccelBias(), GyroMarkov(), GyroScaleFactor(),
    AccelScaleFactor(), ReceiverClock(), ElasticLeverArm(), RangeBiases(), RangeBiases32(), InterSystemBias())}
NAV_BLOCKS = ("att", "vel", "pos")


def block(name: str) -> Block:
    return REGISTRY[name]


__all__ = ["REGISTRY", "NAV_BLOCKS", "block", "Block", "BodyCoupling", "NoiseInput", "COUPLING_TERMS"]
