"""Small rclpy helpers shared by every hyper-nav node (QoS, readiness, diagnostics)."""
from __future__ import annotations

import array
import gc
import math
import signal
import threading
import time

import numpy as np
import rclpy
import rclpy.executors
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions


def publisher_qos(depth: int) -> QoSProfile:
    """Reliable, keep-last ``depth``: deep enough for the IMU rate so that a
    paced graph loses nothing (see docs/faults-and-timing.md)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.RELIABLE)


def latched_qos(depth: int) -> QoSProfile:
    """Reliable, transient local, keep-last ``depth``: for data a late joiner
    needs (``gnss/ephemeris``: one message per satellite and record, so the
    depth must cover every record in use)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth), reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def subscriber_qos(reliable: bool, depth: int) -> QoSProfile:
    """Configurable subscriber QoS: reliable (default, lossless) or the
    standard sensor-data profile (best effort)."""
    if not reliable:
        return qos_profile_sensor_data
    return publisher_qos(depth)


def all_matched(publishers, min_subscribers: int) -> bool:
    return all(p.get_subscription_count() >= min_subscribers for p in publishers)


_PATHS: dict = {}


def assign_fields(msg, values: dict):
    """Set nested message fields from a flat {'a.b.c': value} dict.

    A list or a numpy array given for an array field goes in as the field's
    own storage type (numpy array of its dtype for fixed-size arrays,
    ``array.array`` for sequences, filled from the array's bytes): the
    generated setters then skip their per-element type and range checks,
    which cost ~30 us for a 15 x 15 covariance as a list, and no Python float
    is made per element (a 49 x 49 covariance: 2,401)."""
    for path, value in values.items():
        parts = _PATHS.get(path)
        if parts is None:
            parts = _PATHS[path] = tuple(path.split("."))
        obj = msg
        for part in parts[:-1]:
            obj = getattr(obj, part)
        tv = type(value)
        if tv is np.ndarray or (tv is list and value and type(value[0]) is float):
            cur = getattr(obj, parts[-1])
            if type(cur) is np.ndarray:
                value = np.asarray(value, dtype=cur.dtype).ravel()
            elif type(cur) is array.array:
                if tv is np.ndarray:
                    buf = array.array(cur.typecode)
                    buf.frombytes(np.ascontiguousarray(value, dtype=cur.typecode).tobytes())
                    value = buf
                else:
                    value = array.array(cur.typecode, value)
            elif tv is np.ndarray:
                value = value.tolist()
        setattr(obj, parts[-1], value)


def diagnostic_array(node, name: str, level_ok: bool, message: str, values: dict) -> DiagnosticArray:
    arr = DiagnosticArray()
    arr.header.stamp = node.get_clock().now().to_msg()
    st = DiagnosticStatus()
    st.level = DiagnosticStatus.OK if level_ok else DiagnosticStatus.WARN
    st.name = name
    st.message = message
    st.hardware_id = node.get_name()
    st.values = [KeyValue(key=str(k), value=str(v)) for k, v in sorted(values.items())]
    arr.status = [st]
    return arr


EXECUTORS = ("single", "events")


def make_executor(kind: str = "single"):
    """The executor a node spins in: ``single`` (rclpy's SingleThreadedExecutor,
    a wait set rebuilt each spin) or ``events`` (rclpy's experimental
    EventsExecutor, Jazzy: callbacks pushed by the middleware, timers in a
    timer manager; measured on this project's fusion node at a 1 kHz IMU:
    45-48 % of a core instead of 76-80 %, benchmarks/current_latency.py). Its
    timers follow ROS time like the other's. ``single`` is the default here;
    the fusion node's own default is ``events`` (its ``executor`` parameter:
    the whole graph suite runs with it)."""
    if kind == "events":
        from rclpy.experimental import EventsExecutor
        return EventsExecutor()
    if kind != "single":
        raise ValueError(f"executor: one of {list(EXECUTORS)}, got {kind!r}")
    return SingleThreadedExecutor()


def run_node(node_factory, args=None, linger_s: float = 0.3, exit_grace_s: float = 10.0) -> None:
    """Jazzy-style main: init, spin until shutdown or SIGINT/SIGTERM, clean up.
    The node spins in the executor its ``executor_kind`` names (``make_executor``;
    default ``single``).

    SIGINT/SIGTERM only set a flag (rclpy's own handlers would invalidate the
    context at once): the loop ends, ``node.on_shutdown()`` (if any) still
    publishes with a valid context (e.g. the fusion node's final
    /diagnostics), and the node waits up to ``linger_s`` for reliable DDS to
    deliver it before the process exits. It does not spin again: a callback
    run after the final status would publish messages its counts miss."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()

    def on_signal(_signum, _frame):
        if not stop.is_set():
            # the orderly stop below takes well under a second; a process still there after
            # exit_grace_s (a callback or the middleware's teardown blocked: an IMU node left behind a
            # killed launcher spun for 27 min) is ended by the kernel (SIGALRM, default action: no
            # Python, no GIL needed): a stopped graph, a killed launcher, a test never leave a node behind
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(max(1, math.ceil(exit_grace_s)))
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    node = None
    try:
        node = node_factory()
        executor = make_executor(getattr(node, "executor_kind", "single"))
        executor.add_node(node)
        gc.collect()
        gc.freeze()
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
        if rclpy.ok() and hasattr(node, "on_shutdown"):
            node.on_shutdown()
            t_end = time.monotonic() + linger_s
            for pub in node.publishers:
                left = t_end - time.monotonic()
                if left <= 0 or not pub.wait_for_all_acked(Duration(seconds=left)):
                    break
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


def declare_params(node, specs, prefix: str = "", where: str = "") -> dict:
    """Declare ROS parameters from ``core.params.ParamSpec`` declarations,
    with descriptors (type, range, description), and return their values
    checked and coerced by the same specs ({name: value}). A wrong type or
    value raises ``ConfigError`` naming the parameter."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
    from rclpy.parameter import Parameter

    from .core.params import BOOL, FLOAT, FLOATS, INT, STR, STRS, ConfigError

    ptypes = {FLOAT: Parameter.Type.DOUBLE, INT: Parameter.Type.INTEGER, BOOL: Parameter.Type.BOOL,
              STR: Parameter.Type.STRING, FLOATS: Parameter.Type.DOUBLE_ARRAY, STRS: Parameter.Type.STRING_ARRAY}
    out = {}
    for s in specs:
        d = ParameterDescriptor(description=s.description + (f" [{s.range_text()}]" if s.range_text() else ""),
                                type=ptypes[s.type].value)
        if s.type in (FLOAT, FLOATS) and s.lo is not None and s.hi is not None:
            d.floating_point_range = [FloatingPointRange(from_value=float(s.lo), to_value=float(s.hi), step=0.0)]
        elif s.type == INT and s.lo is not None and s.hi is not None:
            d.integer_range = [IntegerRange(from_value=int(s.lo), to_value=int(s.hi), step=0)]
        default = s.ros_default()
        try:
            if isinstance(default, list) and not default:       # rclpy cannot infer the type of []
                node.declare_parameter(prefix + s.name, ptypes[s.type], d)
                value = node.get_parameter_or(prefix + s.name, Parameter(prefix + s.name, value=[])).value
            else:
                value = node.declare_parameter(prefix + s.name, default, d).value
        except InvalidParameterValueException as exc:     # the descriptor's range refused it
            raise ConfigError(f"{where or prefix}{s.name}: expected {s.range_text()} ({exc.args[0]})") from None
        except InvalidParameterTypeException as exc:
            raise ConfigError(f"{where or prefix}{s.name}: {exc.args[0]}") from None
        out[s.name] = s.check(value if not isinstance(value, (list, tuple)) or s.type in (FLOATS, STRS)
                              else list(value), where or prefix)
    return out
