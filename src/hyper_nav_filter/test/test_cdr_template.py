"""cdr_template: the message as CDR bytes with its numbers written in place
equals the message rclpy serializes, for every type the fusion node
publishes, through changes of strings and sequence lengths."""
import numpy as np
import pytest
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import NavSatFix
from tf2_msgs.msg import TFMessage

from hyper_nav_filter.cdr_template import CdrTemplate
from scipy.spatial.transform import Rotation

from hyper_nav_filter.core.fusion import Solution
from hyper_nav_filter.core.nav_state import NavState as CoreState
from hyper_nav_filter.core.state_layout import StateLayout
from hyper_nav_filter.output import (OutputFrames, map_pose, navsatfix_fields, navstate_fields, odometry_fields,
                                     transform_fields)
from hyper_nav_filter.ros_util import assign_fields
from hyper_nav_msgs.msg import NavState

rng = np.random.default_rng(7)


def _navstate(dim: int, blocks: list) -> dict:
    return {"header.stamp.sec": int(rng.integers(0, 2**31)), "header.stamp.nanosec": int(rng.integers(0, 10**9)),
            "header.frame_id": "enu", "child_frame_id": "base_link", "mode": int(rng.integers(0, 6)),
            "mechanization_frame": "ENU", "lat_rad": rng.normal(), "lon_rad": rng.normal(), "alt_m": rng.normal(),
            "vel_enu_mps": rng.normal(size=3).tolist(), "q_b_enu.x": rng.normal(), "q_b_enu.w": rng.normal(),
            "roll_rad": rng.normal(), "omega_ib_b_radps": rng.normal(size=3), "state_blocks": blocks,
            "state_dim": dim, "covariance": rng.normal(size=dim * dim), "n_updates": int(rng.integers(0, 2**32)),
            "n_rejected": 3, "last_nis": float(rng.normal())}


def _same(tpl: CdrTemplate, cls, fields: dict, stamp=None):
    """The template's bytes decode to the message ``assign_fields`` builds
    (decoded, not byte-compared: the serializer leaves CDR padding bytes
    unset)."""
    tpl.fill(fields)
    msg = cls()
    assign_fields(msg, fields)
    if stamp is not None:
        tpl.set_stamp("header.stamp", *stamp)
        msg.header.stamp.sec, msg.header.stamp.nanosec = stamp
    assert deserialize_message(tpl.bytes(), cls) == msg


def test_navstate_numbers_strings_and_lengths():
    tpl = CdrTemplate(NavState)
    blocks15 = ["att:3", "vel:3", "pos:3", "bg:3", "ba:3"]
    for dim, blocks in [(15, blocks15), (15, blocks15), (15, blocks15), (21, blocks15 + ["sa:3", "sg:3"]),
                        (21, blocks15 + ["sa:3", "sg:3"]), (0, []), (9, ["att:3", "vel:3", "pos:3"])]:
        _same(tpl, NavState, _navstate(dim, blocks))
    assert tpl.n_builds == 4        # built again only when a string or a length changed
    f = _navstate(15, blocks15)
    f["mechanization_frame"] = "LCI"
    _same(tpl, NavState, f, stamp=(12, 345))
    assert tpl.n_builds == 5


def test_output_messages_of_a_solution():
    """Odometry, NavSatFix and the TF of real output fields, and a wrong
    array size refused."""
    lay = StateLayout(("att", "vel", "pos", "bg", "ba"))
    frames = OutputFrames("map", "enu", "base_link", 0.6, 0.1, 100.0)
    tpls = {Odometry: CdrTemplate(Odometry), NavSatFix: CdrTemplate(NavSatFix),
            TFMessage: CdrTemplate(TFMessage, lambda f: TFMessage(transforms=[_ts(f)]), prefix="transforms.0.")}
    for k in range(3):
        sol = _solution(lay, k)
        pose = map_pose(sol, frames)
        _same(tpls[Odometry], Odometry, odometry_fields(sol, lay, frames, pose), stamp=(k, 10 * k))
        _same(tpls[NavSatFix], NavSatFix, navsatfix_fields(sol, lay, frames))
        f = transform_fields(sol, frames, pose)
        tpls[TFMessage].fill(f)
        assert deserialize_message(tpls[TFMessage].bytes(), TFMessage) == TFMessage(transforms=[_ts(f)])
        _same(CdrTemplate(NavState), NavState, navstate_fields(sol, lay, frames))
    with pytest.raises(ValueError, match="position_covariance: 9 values expected, 4 given"):
        tpls[NavSatFix].fill({"position_covariance": np.zeros(4)})


def _ts(fields):
    t = TransformStamped()
    assign_fields(t, fields)
    return t


def _solution(lay, k):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    s = CoreState(t_s=10.0 + k, lat_rad=0.6 + 1e-4 * k, lon_rad=0.1, alt_m=1000.0 * k, vel_enu_mps=rng.normal(size=3) * 100,
                  C_b_n=Rotation.from_quat(q).as_matrix(), gyro_bias_b_radps=rng.normal(size=3) * 1e-5,
                  accel_bias_b_mps2=rng.normal(size=3) * 1e-3)
    A = rng.normal(size=(lay.dim, lay.dim))
    return Solution(t_s=10.0 + k, state=s, P=A @ A.T, mode=3, omega_ib_b_radps=rng.normal(size=3),
                    f_b_mps2=rng.normal(size=3), n_updates=k, n_rejected=0, last_nis=float("nan"))
