"""A recorded-like bag without running the graph: the default scenario's IMU
and GNSS streams as rosbag2/MCAP (the message mapping of imu_node/gnss_node),
for timing the offline replay."""
from __future__ import annotations

import numpy as np

from hyper_nav_sim.core import simulate
from hyper_nav_workbench.core.bag import BagWriter, serialize, typestore


def write_sensor_bag(sc, path) -> None:
    T = typestore().types
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    V3 = T["geometry_msgs/msg/Vector3"]

    def hdr(t, frame):
        ns = int(round(t * 1e9))
        return Header(stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame)

    traj = sc.trajectory()
    imu, g = simulate.imu_stream(sc, traj), simulate.gnss_stream(sc, traj)
    recs = []
    for k in range(len(imu.t_s)):
        w, a = imu.dtheta_b_rad[k] / imu.dt_s, imu.dvel_b_mps[k] / imu.dt_s
        m = T["sensor_msgs/msg/Imu"](hdr(imu.t_s[k], "base_link"), T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0),
                                     np.array([-1.0] + [0.0] * 8), V3(*map(float, w)), np.zeros(9),
                                     V3(*map(float, a)), np.zeros(9))
        recs.append((imu.t_s[k], "/imu/data_raw", "sensor_msgs/msg/Imu", m))
    for i in range(len(g.t_s)):
        fix = T["sensor_msgs/msg/NavSatFix"](hdr(g.t_s[i], "base_link"), T["sensor_msgs/msg/NavSatStatus"](0, 1),
                                             float(np.rad2deg(g.lat_rad[i])), float(np.rad2deg(g.lon_rad[i])),
                                             float(g.alt_m[i]), np.diag(g.pos_sigma_enu_m**2).ravel(), 3)
        vcov = np.zeros((6, 6))
        vcov[:3, :3] = np.diag(g.vel_sigma_enu_mps**2)
        vcov[3:, 3:] = np.eye(3) * 1e6
        Tw, Twc = T["geometry_msgs/msg/Twist"], T["geometry_msgs/msg/TwistWithCovariance"]
        vel = T["geometry_msgs/msg/TwistWithCovarianceStamped"](
            hdr(g.t_s[i], "enu"), Twc(Tw(V3(*map(float, g.vel_enu_mps[i])), V3(0.0, 0.0, 0.0)), vcov.ravel()))
        recs.append((g.t_s[i] + 1e-6, "/gnss/fix", "sensor_msgs/msg/NavSatFix", fix))
        recs.append((g.t_s[i] + 2e-6, "/gnss/vel", "geometry_msgs/msg/TwistWithCovarianceStamped", vel))
    recs.sort(key=lambda r: r[0])
    with BagWriter(path) as w:
        for t, topic, typ, m in recs:
            w.write(topic, typ, int(round(t * 1e9)), serialize(m, typ))
