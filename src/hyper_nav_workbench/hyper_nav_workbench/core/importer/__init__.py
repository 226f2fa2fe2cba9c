"""Real data in: recorded IMU/GNSS (and truth) text files from outside the
project -> arrays in the project's frames and SI units (``columns``, column
maps; ``kfgins``, the KF-GINS formats as the first preset) -> a rosbag2/MCAP
bag of standard messages that the fusion node and ``replay_filter`` take
(``messages``). Real GNSS receivers: ``gnss_raw`` (UBX logs, RINEX 3 ->
gnss/raw + gnss/ephemeris, the ``ubx`` / ``rinex`` presets) and
``rtklib_pos`` (RTKLIB .pos reference trajectories). The command is ``import_data`` (hyper_nav_workbench.import_data).
No rclpy here."""
