"""A GNC team's own guidance node, written against the messages only (no
hyper-nav code): pure pursuit of the target in azimuth and elevation, with
its own exponential atmosphere to turn loads into a lift coefficient. It reads
the target from the scenario's ``guidance:`` block (parameter ``scenario``:
the file the loop gives it) and answers every navigation state on the 0.1 s
grid with a GlideCommand stamped with that state's stamp."""
import math

import rclpy
import yaml
from hyper_nav_msgs.msg import GlideCommand, NavState
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

A, E2, G0 = 6378137.0, 6.69437999014e-3, 9.80665
QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def ecef(lat, lon, h):
    n = A / math.sqrt(1 - E2 * math.sin(lat) ** 2)
    return ((n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
            (n * (1 - E2) + h) * math.sin(lat))


class UserGuidance(Node):
    def __init__(self):
        super().__init__("user_guidance")
        path = self.declare_parameter("scenario", "").value
        data = yaml.safe_load(open(path))
        tg, fl = data["guidance"]["target"], data["flight"]
        self.target = (math.radians(tg["lat_deg"]), math.radians(tg["lon_deg"]), float(tg.get("alt_m", 0.0)))
        self.mass, self.s_ref = fl["mass_kg"], fl["s_ref_m2"]
        self.cl_star = math.sqrt(fl["cd0"] / fl["k_induced"])
        self.pub = self.create_publisher(GlideCommand, "guidance/command", QOS)
        self.create_subscription(NavState, "truth/state", self.on_state, QOS)

    def on_state(self, m):
        t = m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
        if abs(t * 10 - round(t * 10)) > 1e-5 or t < 1.0 - 1e-9:
            return
        lat, lon, h = m.lat_rad, m.lon_rad, m.alt_m
        p, q = ecef(lat, lon, h), ecef(*self.target)
        d = [q[i] - p[i] for i in range(3)]
        sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
        e = -so * d[0] + co * d[1]
        n = -sl * co * d[0] - sl * so * d[1] + cl * d[2]
        u = cl * co * d[0] + cl * so * d[1] + sl * d[2]
        vE, vN, vU = m.vel_enu_mps
        V = math.sqrt(vE * vE + vN * vN + vU * vU)
        psi, gam = math.atan2(vE, vN), math.asin(vU / V)
        d_psi = (math.atan2(e, n) - psi + math.pi) % (2 * math.pi) - math.pi
        lam_v = math.atan2(u, math.hypot(e, n))
        n_lat = 0.08 * V * d_psi / G0
        n_vert = max(0.05, math.cos(gam) * (1 - V * V / (G0 * 6.4e6)) + 0.15 * V * (lam_v - gam) / G0)
        rho = 1.225 * math.exp(-h / 7200.0)
        c_l = math.hypot(n_lat, n_vert) * self.mass * G0 / (0.5 * rho * V * V * self.s_ref * self.cl_star)
        c = GlideCommand()
        c.header.stamp = m.header.stamp
        c.bank_rad = max(-1.4, min(1.4, math.atan2(n_lat, n_vert)))
        c.c_l = max(0.0, min(3.5, c_l))
        self.pub.publish(c)


def main():
    rclpy.init()
    node = UserGuidance()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
