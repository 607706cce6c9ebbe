"""Bag recorder: the cell's topics -> a rosbag2 directory (MCAP, as Jazzy), raw CDR, never re-serialised.

Thin shell around impurity_common.bags.BagWriter. Each wanted topic is subscribed as soon as it
appears in the graph, with the type its publishers announce and a QoS they are compatible with (best
effort if any publisher is best effort); the publishers' offered QoS goes into the bag's metadata.
Timestamps are receive times on the node's clock, as rosbag2 records them.

Stopping: SIGINT (Ctrl-C) and SIGTERM only set a flag, so a signal never interrupts a write; the
open split is then closed and metadata.yaml written. A SIGKILL loses only the open split (at most
`split_duration` s): earlier splits are complete files already listed in metadata.yaml. Exits 1 with
one line when the bag cannot be written, 2 with one line for a bad parameter.

  bag_recorder --ros-args -p output:=/tmp/episode_bag -p topics:="[/heightmap, /policy/primitive]"
"""

import signal
import sys
import threading
import time
from dataclasses import dataclass
from functools import partial

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from impurity_common import names
from impurity_common.bags import BagError, BagWriter, cell_typestore, ros_message_class
from impurity_common.parameters import (
    PARAMETER_ERROR_EXIT_CODE,
    ParameterError,
    absolute_names,
    declare_parameters,
    param,
)


@dataclass(frozen=True)
class BagRecorderParameters:
    topics: tuple[str, ...] = param(names.EPISODE_TOPICS, "Topics to record (absolute names)",
                                    check=absolute_names)
    output: str = param("", "Bag directory to create (must not exist); default bag_<date>_<time> in the "
                        "working directory")
    split_duration: float = param(5.0, "s of messages per split file: what a SIGKILL can lose at most",
                                  low=0.01, high=3600.0)
    qos_depth: int = param(100, "Subscription queue depth", low=1, high=100000)
    discovery_period: float = param(0.2, "s between looks for not yet seen topics", low=0.01, high=60.0)



def _qos_time(duration) -> QosTime:
    sec, nsec = divmod(int(duration.nanoseconds), 1_000_000_000)
    return QosTime(sec, nsec)


def bag_qos(profile: QoSProfile) -> Qos:
    """rclpy's QoS profile -> the rosbags record of it (the enum values are rmw's in both)."""
    return Qos(QosHistory(int(profile.history)), int(profile.depth),
               QosReliability(int(profile.reliability)), QosDurability(int(profile.durability)),
               _qos_time(profile.deadline), _qos_time(profile.lifespan),
               QosLiveliness(int(profile.liveliness)), _qos_time(profile.liveliness_lease_duration),
               bool(profile.avoid_ros_namespace_conventions))


class BagRecorderNode(Node):
    def __init__(self):
        super().__init__("bag_recorder")
        params = self.params = declare_parameters(self, BagRecorderParameters)
        output = params.output or time.strftime("bag_%Y%m%d_%H%M%S")
        self._pending = list(dict.fromkeys(params.topics))
        self._depth = params.qos_depth
        self.writer = BagWriter(output, cell_typestore(), split_duration_ns=int(params.split_duration * 1e9))
        self.create_timer(params.discovery_period, self._subscribe_new_topics)
        self._subscribe_new_topics()
        self.get_logger().info(f"recording {len(self._pending)} topic(s) to {self.writer.path}")

    def _subscribe_new_topics(self) -> None:
        if not self._pending:
            return
        announced = dict(self.get_topic_names_and_types())
        for topic in list(self._pending):
            types = announced.get(topic)
            if not types:
                continue
            self._pending.remove(topic)
            if len(types) > 1:
                self.get_logger().error(f"not recording {topic}: its publishers disagree on the type {types}")
                continue
            publishers = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
            try:
                self.writer.add_topic(topic, types[0], [bag_qos(p) for p in publishers])
                msg_class = ros_message_class(types[0], topic)
            except BagError as error:
                self.get_logger().error(f"not recording {topic}: {error}")
                continue
            best_effort = any(p.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers)
            reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
            qos = QoSProfile(depth=self._depth, durability=DurabilityPolicy.VOLATILE, reliability=reliability)
            self.create_subscription(msg_class, topic, partial(self._record, topic), qos, raw=True)
            self.get_logger().info(f"recording {topic} ({types[0]})")

    def _record(self, topic: str, data: bytes) -> None:
        self.writer.write(topic, self.get_clock().now().nanoseconds, data)

    def close(self) -> None:
        self.writer.close()
        self.get_logger().info(f"bag {self.writer.path} closed: {self.writer.message_count} message(s)")


def main(args=None) -> int:
    """Signals only set `stop`; the loop then leaves spin_once and the bag is closed in `finally`."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    node = None
    code = 0
    try:
        node = BagRecorderNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except BagError as error:
        print(f"bag_recorder: error: {error}", file=sys.stderr, flush=True)
        code = 1
    except ParameterError as error:
        print(error, file=sys.stderr, flush=True)
        code = PARAMETER_ERROR_EXIT_CODE
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
