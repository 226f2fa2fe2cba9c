"""Virtual GNSS cores: pure numpy, no rclpy."""
