"""Bag recorder: the cell's topics -> a rosbag2 directory (MCAP, as Jazzy), raw CDR, never re-serialised.

Thin shell around impurity_bags.bags.BagWriter. Each wanted topic is subscribed as soon as it has
a publisher, with the type its publishers announce and the QoS rosbag2 would request from their offers
(bags.subscription_request, read with get_publishers_info_by_topic): best effort if any publisher is
best effort, transient local if every publisher offers it, so that a latched message published before
the recorder started (/robot_description) is recorded. The publishers' offered QoS goes into the
bag's metadata. Every `discovery_period` the recorder looks again: at topics still without a
publisher, and at new publishers of recorded topics; a new publisher the subscription would receive
nothing from (best effort, or volatile under a transient-local subscription) makes it re-subscribe
with the weaker QoS, and a warning says so. Timestamps are receive times on the node's clock, as
rosbag2 records them.

Stopping: SIGINT (Ctrl-C) and SIGTERM only set a flag, so a signal never interrupts a write; the
open split is then closed and metadata.yaml written. A SIGKILL loses only the open split (at most
`split_duration` s): earlier splits are complete files already listed in metadata.yaml. Exits 1 with
one line when the bag cannot be written, 2 with one line for a bad parameter.

  bag_recorder --ros-args -p output:=/tmp/episode_bag -p topics:="[heightmap, policy/primitive]"
  bag_recorder --ros-args -r __ns:=/cell_a -p output:=/tmp/cell_a_bag   # records /cell_a/heightmap ...
"""

import sys
import time
from dataclasses import dataclass
from functools import partial

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from impurity_bags.bags import (
    BagError,
    BagWriter,
    cell_typestore,
    request_misses,
    ros_message_class,
    subscription_request,
    weakened_request,
)
from impurity_common import names
from impurity_common.diagnostics import ERROR, OK, WARN, Diagnostics, Status
from impurity_common.node_main import bound_malloc_arenas, exit_if_help, init_with_stop_event
from impurity_common.parameters import (
    PARAMETER_ERROR_EXIT_CODE,
    ParameterError,
    declare_parameters,
    param,
    topic_names,
)


@dataclass(frozen=True)
class BagRecorderParameters:
    topics: tuple[str, ...] = param(names.EPISODE_TOPICS, "Topics to record: a relative name in the "
                                    "recorder's namespace (the cell's), an absolute one as it is; the bag "
                                    "holds the resolved, absolute names", check=topic_names)
    output: str = param("", "Bag directory to create (must not exist); default bag_<date>_<time> in the "
                        "working directory")
    split_duration: float = param(5.0, "s of messages per split file: what a SIGKILL can lose at most",
                                  low=0.01, high=3600.0)
    qos_depth: int = param(100, "Subscription queue depth", low=1, high=100000)
    discovery_period: float = param(0.2, "s between looks at the graph: topics without a publisher yet, new "
                                    "publishers of recorded topics", low=0.01, high=60.0)



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


def publisher_name(info) -> str:
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


def request_words(request: tuple[QosReliability, QosDurability]) -> str:
    return f"{request[0].name.lower()}, {request[1].name.lower()}"


class BagRecorderNode(Node):
    def __init__(self):
        super().__init__("bag_recorder")
        params = self.params = declare_parameters(self, BagRecorderParameters)
        output = params.output or time.strftime("bag_%Y%m%d_%H%M%S")
        self._wanted = list(dict.fromkeys(self.resolve_topic_name(topic) for topic in params.topics))
        self._pending = list(self._wanted)  # no publisher seen yet
        self._refused: list[str] = []
        self._recorded: dict[str, dict] = {}  # topic -> msg_class, request, subscription, publisher gids
        self._depth = params.qos_depth
        self.writer = BagWriter(output, cell_typestore(), split_duration_ns=int(params.split_duration * 1e9))
        self.create_timer(params.discovery_period, self._look_at_graph)
        self.diagnostics = Diagnostics(self, self._status)
        self._look_at_graph()
        waiting = f"; waiting for a publisher of {self._pending}" if self._pending else ""
        refused = f"; not recording {self._refused} (see the errors above)" if self._refused else ""
        self.get_logger().info(f"recording {len(self._wanted)} topic(s) to {self.writer.path}: "
                               f"{len(self._recorded)} subscribed{waiting}{refused}")

    def _status(self) -> Status:
        """Messages written; WARN while a topic has no publisher yet, ERROR for a topic it cannot record."""
        values = {"bag": str(self.writer.path), "messages": self.writer.message_count,
                  "topics recorded": len(self._recorded), "topics waiting": len(self._pending)}
        if self._refused:
            return Status(ERROR, f"not recording {', '.join(self._refused)} (see the log)", values)
        if self._pending:
            return Status(WARN, f"waiting for a publisher of {', '.join(self._pending)}", values)
        return Status(OK, f"recording {len(self._recorded)} topic(s)", values)

    def _look_at_graph(self) -> None:
        for topic in list(self._pending):
            self._subscribe_new_topic(topic)
        for topic in self._recorded:
            self._check_new_publishers(topic)

    def _subscribe_new_topic(self, topic: str) -> None:
        """Once the topic has a publisher (a subscriber alone says nothing of the QoS to request)."""
        publishers = self.get_publishers_info_by_topic(topic)
        if not publishers:
            return
        self._pending.remove(topic)
        types = sorted({info.topic_type for info in publishers})
        if len(types) > 1:
            self._refused.append(topic)
            self.get_logger().error(f"not recording {topic}: its publishers disagree on the type {types}")
            return
        offers = [bag_qos(info.qos_profile) for info in publishers]
        try:
            self.writer.add_topic(topic, types[0], offers)
            msg_class = ros_message_class(types[0], topic)
        except BagError as error:
            self._refused.append(topic)
            self.get_logger().error(f"not recording {topic}: {error}")
            return
        request = subscription_request(offers)
        self._recorded[topic] = {"msg_class": msg_class, "request": request, "subscription": None,
                                 "publishers": {bytes(info.endpoint_gid) for info in publishers}}
        self._subscribe(topic)
        self.get_logger().info(f"recording {topic} ({types[0]}, {request_words(request)}; offered by "
                               f"{sorted(publisher_name(info) for info in publishers)})")

    def _subscribe(self, topic: str) -> None:
        """(Re-)subscribe with the topic's request. On re-subscription the new subscription is made
        first, and what the old one received but the executor has not taken yet is recorded before it
        goes (taken as the executor takes it), so the swap loses nothing."""
        entry = self._recorded[topic]
        reliability, durability = entry["request"]
        qos = QoSProfile(depth=self._depth, reliability=ReliabilityPolicy(reliability.value),
                         durability=DurabilityPolicy(durability.value))
        old, entry["subscription"] = entry["subscription"], self.create_subscription(
            entry["msg_class"], topic, partial(self._record, topic), qos, raw=True)
        if old is not None:
            with old.handle:
                while (taken := old.handle.take_message(old.msg_type, old.raw)) is not None:
                    self._record(topic, taken[0])
            self.destroy_subscription(old)

    def _check_new_publishers(self, topic: str) -> None:
        """A publisher that appeared since: if the subscription would receive nothing from it, weaken the
        request and re-subscribe; if it offers transient local to a volatile subscription, say that what
        it published before it matched is not recorded."""
        entry = self._recorded[topic]
        publishers = self.get_publishers_info_by_topic(topic)
        new = [info for info in publishers if bytes(info.endpoint_gid) not in entry["publishers"]]
        if not new:
            return
        entry["publishers"].update(bytes(info.endpoint_gid) for info in new)
        logger = self.get_logger()
        old_request = entry["request"]
        offers = [(publisher_name(info), bag_qos(info.qos_profile)) for info in new]
        misses = [f"{name}: {', '.join(reasons)}" for name, offer in offers
                  if (reasons := request_misses(old_request, offer))]
        if misses:
            entry["request"] = weakened_request(old_request, [offer for _, offer in offers])
            self._subscribe(topic)
            logger.warn(f"{topic}: the {request_words(old_request)} subscription would receive nothing from "
                        f"new publisher(s) ({'; '.join(misses)}): re-subscribed "
                        f"{request_words(entry['request'])}")
        if entry["request"][1] == QosDurability.VOLATILE:
            latched = [name for name, offer in offers if offer.durability == QosDurability.TRANSIENT_LOCAL]
            if latched:
                logger.warn(f"{topic}: new publisher(s) {latched} offer transient_local, but {topic} is "
                            "recorded volatile (not every publisher offers transient_local): what they "
                            "published before the recorder matched them is not in the bag")

    def _record(self, topic: str, data: bytes) -> None:
        self.writer.write(topic, self.get_clock().now().nanoseconds, data)

    def close(self) -> None:
        self.writer.close()
        self.get_logger().info(f"bag {self.writer.path} closed: {self.writer.message_count} message(s)")


def main(args=None) -> int:
    """Signals only set `stop`; the loop then leaves spin_once and the bag is closed in `finally`."""
    exit_if_help(args, BagRecorderParameters, __doc__.split("\n\n")[0])
    bound_malloc_arenas()  # as spin_node: flat memory over long recordings
    stop = init_with_stop_event(args)
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
