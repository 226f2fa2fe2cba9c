"""Seed 002 (Zheng, Yao, He 2020, L-EKF trajectory estimation) reproduction."""
