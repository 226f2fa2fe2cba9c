"""Seed 001 (SINS/BDS in the launch-centred inertial frame) reproduction."""
