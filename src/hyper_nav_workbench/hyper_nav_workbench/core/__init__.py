"""Cores of the workbench: pure Python (no rclpy) - bags, import, scoring, Monte Carlo, live view."""
