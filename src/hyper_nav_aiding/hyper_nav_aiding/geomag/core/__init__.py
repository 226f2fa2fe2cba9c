"""Geomagnetic matching cores: pure numpy/scipy, no rclpy."""
