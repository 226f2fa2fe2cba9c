"""Seed 000 (Yang et al., IEEE Access 2022, RL-DLAC) reproduction."""
