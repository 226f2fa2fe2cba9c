"""Hypersonic target trajectory estimation from early-warning radar (seed 002):
parametric glide model (eq. 21), EKF, adaptive EKF, IMM, learnable EKF
(L-EKF), posterior Cramer-Rao bound. Pure JAX/numpy, no rclpy."""
