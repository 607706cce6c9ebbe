"""Bag replay: publishes a rosbag2 bag's messages as raw CDR, bytes exactly as recorded.

Thin shell around impurity_bags.bags (BagReader, replay_plan, run_replay). Timing: the original
one scaled by `rate`, from `start_offset` s, optionally looping; or `as_fast_as_possible`. A bag holds
absolute names and plays them as recorded; the names given in `topics`, `ack_before` and `ack_after`
(relative ones, as impurity_common.names spells the cell's, in the replay's namespace) choose among them.
Topics are renamed with ROS remapping arguments (`-r /heightmap:=/replayed/heightmap`).

Pacing for offline tests: with `ack_topic` set, a message on `ack_before` is published only once
the previous one was answered: a message with its header stamp arrived on `ack_topic`. Without an
answer within `ack_timeout`, every played message with that stamp (the whole frame: colour, depth,
camera_info) is published again, up to `ack_retries` times. E.g. each colour frame waits for the
previous frame's /attention/result, so neither a slow pipeline nor a best-effort subscriber that
lost a big image loses a frame. A message on one of `ack_after` waits in the same way for the answer to
the ack_before message before it, and is not waited for itself: what the live graph sent in reply to a
decision (the picking loop's /attention/known_product after an episode's first view) reaches the
subscribers after the replayed decision, and before the next frame, as it did live.

Replay time: with `clock` true the node publishes /clock (rosgraph_msgs/Clock; best effort, depth 1,
as `ros2 bag play --clock`) with the replayed bag time (bags.with_clock): from the bag's first time (after
`start_offset`) on, `rate` times as fast as wall time, `clock_frequency` times a wall second, and each
message's bag timestamp just before the message is published; as fast as possible (or paced by
`ack_topic`) it steps from message to message and holds between them. Nodes started with
`use_sim_time:=true` then judge input ages on the bag's time.

Big images: Fast DDS's default shared-memory segment (512 KB) cannot hold a 640x480 frame; such a
message falls back to UDP fragments, which a best-effort subscriber (the heightmap node's camera
subscriptions) loses in bursts. Unless a Fast DDS profile or transport is chosen in the environment,
bag_replay gives its own participant a 32 MB segment (it is the writer's segment that matters).

Topics: only the types of the played topics are checked; the bag's other topics are skipped, and
those whose types this environment lacks (a custom package, tf2_msgs without tf2) named in a warning.
A selected topic of such a type, or (with the default: every topic) any topic of such a type, is
refused, unless `allow_partial`. Messages are found by topic and type; an unreadable QoS text in
metadata.yaml falls back to the storage file's QoS or the default (reliable, volatile) with a warning.

Exits 0 when the bag has been played: every message the selected topics hold (from start_offset on)
in the first pass, or fewer when stopped (Ctrl-C) or with `allow_partial` (then with a warning). Exits
1 with one clear line for a missing, truncated or corrupted bag, a type this environment lacks,
missing subscribers, or a pass that played fewer messages than the topics hold (how many of how many,
and why); 2 with one line for a bad parameter; every wait is bounded.

  bag_replay --ros-args -p bag:=tests/data/episode_bag -p rate:=2.0 -p topics:="[heightmap]"
  bag_replay --ros-args -p bag:=tests/data/episode_bag -p clock:=true   # nodes with use_sim_time:=true
"""

import hashlib
import os
import pathlib
import sys
import tempfile
import time
from dataclasses import dataclass

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import QosDurability
from rosgraph_msgs.msg import Clock

from impurity_bags.bags import (
    BagError,
    BagMessage,
    BagReader,
    PassCounter,
    ReplayTiming,
    header_stamp_ns,
    message_type_problem,
    replay_plan,
    ros_message_class,
    run_replay,
    select_topics,
    with_clock,
)
from impurity_common.conversions import ns_to_time
from impurity_common.diagnostics import OK, Diagnostics, Status
from impurity_common.node_main import bound_malloc_arenas, exit_if_help, init_with_stop_event
from impurity_common.parameters import PARAMETER_ERROR_EXIT_CODE, ParameterError, declare_parameters, param

FASTDDS_LARGE_SHM_PROFILE = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <transport_descriptors>
    <transport_descriptor>
      <transport_id>shm_32mb</transport_id>
      <type>SHM</type>
      <segment_size>33554432</segment_size>
    </transport_descriptor>
    <transport_descriptor>
      <transport_id>udp</transport_id>
      <type>UDPv4</type>
    </transport_descriptor>
  </transport_descriptors>
  <participant profile_name="bag_replay_large_shm" is_default_profile="true">
    <rtps>
      <userTransports>
        <transport_id>shm_32mb</transport_id>
        <transport_id>udp</transport_id>
      </userTransports>
      <useBuiltinTransports>false</useBuiltinTransports>
    </rtps>
  </participant>
</profiles>
"""


def use_large_shm_segment() -> None:
    """Point Fast DDS at FASTDDS_LARGE_SHM_PROFILE, unless the environment already chose otherwise."""
    chosen = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE", "FASTDDS_BUILTIN_TRANSPORTS")
    if any(os.environ.get(name) for name in chosen):
        return
    if os.environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp") != "rmw_fastrtps_cpp":
        return
    digest = hashlib.sha256(FASTDDS_LARGE_SHM_PROFILE.encode()).hexdigest()[:12]
    path = pathlib.Path(tempfile.gettempdir()) / f"impurity_bag_replay_fastdds_{digest}.xml"
    if not path.is_file():
        scratch = path.with_suffix(f".{os.getpid()}.tmp")
        scratch.write_text(FASTDDS_LARGE_SHM_PROFILE)
        os.replace(scratch, path)
    os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(path)


CLOCK_TOPIC = "/clock"
# rclcpp::ClockQoS, what ros2 bag play publishes /clock with and every node's time source subscribes with
CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)


@dataclass(frozen=True)
class BagReplayParameters:
    bag: str = param("", "rosbag2 directory to play")
    topics: tuple[str, ...] = param(("",), "Topics to play (default: all in the bag)")
    allow_partial: bool = param(False, "Play what can be played and warn, instead of failing, when topics "
                                "have types this environment lacks or a pass plays fewer messages than "
                                "the selected topics hold")
    rate: float = param(1.0, "Speed factor of the original timing (2.0: twice as fast)",
                        low=0.001, high=1000.0)
    start_offset: float = param(0.0, "s after the bag's first message to start at", low=0.0)
    loop: bool = param(False, "Play the bag again and again (until Ctrl-C)")
    as_fast_as_possible: bool = param(False, "Ignore the original timing (use ack_topic to let subscribers "
                                      "set the pace)")
    wait_for_subscribers: int = param(0, "Before playing, wait until every played topic has this many "
                                      "subscribers", low=0, high=1000)
    wait_timeout: float = param(10.0, "s to wait for subscribers or ack_topic", low=0.0, high=3600.0)
    delay: float = param(0.0, "s to wait before playing (after the subscribers matched): a best-effort "
                         "subscriber drops what arrives before it has discovered the publisher in turn",
                         low=0.0, high=3600.0)
    ack_topic: str = param("", "Topic whose messages acknowledge ack_before messages ('' = no pacing)")
    ack_before: str = param("", "Played topic whose messages wait until ack_topic answered the previous ones")
    ack_after: tuple[str, ...] = param(("",), "Played topics whose messages wait, as ack_before's do, until "
                                       "ack_topic answered the ack_before message before them, without being "
                                       "answered themselves: what the live graph sent in reply to a decision "
                                       "(e.g. /attention/known_product after an episode's first view)")
    ack_timeout: float = param(5.0, "s to wait for one acknowledgement", low=0.001, high=3600.0)
    ack_retries: int = param(3, "Re-publications of a group that got no answer", low=0, high=1000)
    qos_depth: int = param(100, "Publisher queue depth", low=1, high=100000)
    clock: bool = param(False, "Publish /clock with the replayed bag time (for nodes with "
                        "use_sim_time:=true): from the bag's first time on, rate times as fast as wall time, "
                        "and each message's bag timestamp before the message")
    clock_frequency: float = param(40.0, "Hz (of wall time) of /clock between messages (0: only at each "
                                   "message); the clock is also held at its value this often while the "
                                   "replay waits", low=0.0, high=1000.0)


class BagReplayNode(Node):
    def __init__(self):
        super().__init__("bag_replay")
        params = self.params = declare_parameters(self, BagReplayParameters)

        path = params.bag
        if not path:
            raise BagError("parameter bag is empty: give the bag directory (-p bag:=<dir>)")
        if any(params.ack_after) and not params.ack_topic:
            after = [topic for topic in params.ack_after if topic]
            raise BagError(f"ack_after {after} needs ack_topic (what answers a frame)")
        self.timing = ReplayTiming(rate=params.rate, start_offset=params.start_offset, loop=params.loop,
                                   as_fast_as_possible=params.as_fast_as_possible)
        self.reader = BagReader(path)
        self._acked_stamps: set[int] = set()
        self._pending_stamp: int | None = None  # of the last ack_before message, until answered
        self._unanswered: list[BagMessage] = []  # played since, for re-publication
        self._ack_before = self._bag_name(params.ack_before) if params.ack_before else ""
        self._ack_after = {self._bag_name(topic) for topic in params.ack_after if topic}
        self._pacing = bool(params.ack_topic)
        self._clock_publisher = None
        self._replay_time_ns = self.timing.first_ns(self.reader.start_ns)  # the last /clock value
        self._replay_time_sent = -float("inf")  # time.monotonic() it was last published at
        self._published = 0
        try:
            self._select_topics()
            self._topic_publishers = {topic: self._publisher(topic) for topic in self.topics}
            if params.clock:
                self._publish_clock_topic()
            if self._pacing:
                self._subscribe_acks(params.ack_topic)
            self.diagnostics = Diagnostics(self, lambda: Status(OK, f"replaying {self.reader.path}", {
                "bag": str(self.reader.path), "messages": self._published, "topics": len(self.topics)}))
        except BaseException:
            self.reader.close()
            raise

    def _select_topics(self) -> None:
        """Only the played topics' types are checked; what is left out is said (warnings, notes)."""
        logger = self.get_logger()
        for warning in self.reader.warnings:
            logger.warn(warning)
        wanted = [self._bag_name(topic) for topic in self.params.topics if topic]
        selection = select_topics(self.reader.path, self.reader.topics, wanted,
                                  message_type_problem, self.params.allow_partial)
        for warning in selection.warnings:
            logger.warn(warning)
        for note in selection.notes:
            logger.info(note)
        self.topics = list(selection.play)

    def _bag_name(self, topic: str) -> str:
        """A name given in the parameters as the bag spells it: expanded in the replay's namespace, not
        remapped (remapping renames what is published)."""
        return self.resolve_topic_name(topic, only_expand=True)

    def _publisher(self, topic: str):
        info = self.reader.topics[topic]
        latched = bool(info.qos) and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in info.qos)
        durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
        qos = QoSProfile(depth=self.params.qos_depth, reliability=ReliabilityPolicy.RELIABLE,
                         durability=durability)
        return self.create_publisher(ros_message_class(info.msgtype, topic), topic, qos)

    def _publish_clock_topic(self) -> None:
        """/clock's publisher; while the replay waits (subscribers, delay, acknowledgements), the last value
        is published again every 1 / clock_frequency s."""
        if CLOCK_TOPIC in self.topics:
            raise BagError(f"clock is true and the bag's own {CLOCK_TOPIC} is played: leave it out (topics) "
                           "or set clock:=false")
        self._clock_publisher = self.create_publisher(Clock, CLOCK_TOPIC, CLOCK_QOS)
        if self.params.clock_frequency > 0:
            self.create_timer(1.0 / self.params.clock_frequency, self._hold_clock)

    def _publish_clock(self, time_ns: int) -> None:
        self._replay_time_ns = time_ns
        self._replay_time_sent = time.monotonic()
        self._clock_publisher.publish(Clock(clock=ns_to_time(time_ns)))

    def _hold_clock(self) -> None:
        if time.monotonic() - self._replay_time_sent >= 1.0 / self.params.clock_frequency:
            self._publish_clock(self._replay_time_ns)

    def _subscribe_acks(self, topic: str) -> None:
        """The acknowledging topic's type comes from the graph (its publisher must be up)."""
        if self._ack_before not in self.topics:
            raise BagError(f"ack_before '{self._ack_before}' is not one of the played topics {self.topics}")
        unplayed = sorted(self._ack_after - set(self.topics))
        if unplayed:
            raise BagError(f"ack_after {unplayed} not among the played topics {self.topics}")
        resolved = self.resolve_topic_name(topic)
        deadline = time.monotonic() + self.params.wait_timeout
        while not (types := dict(self.get_topic_names_and_types()).get(resolved)):
            if time.monotonic() > deadline:
                raise BagError(f"ack_topic {resolved} has no publisher after {self.params.wait_timeout} s")
            time.sleep(0.05)  # graph queries need no spinning; nothing else runs yet
        self.create_subscription(ros_message_class(types[0], resolved), resolved, self._on_ack,
                                 QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE), raw=True)

    def _on_ack(self, data: bytes) -> None:
        stamp = header_stamp_ns(data)
        if stamp is not None:
            self._acked_stamps.add(stamp)

    def play(self, spin_once, should_stop) -> int:
        """Everything runs in the caller's thread: waiting is spinning (`spin_once(timeout)`)."""
        self._spin_once = spin_once
        self._should_stop = should_stop
        if self._clock_publisher is not None:
            self._publish_clock(self._replay_time_ns)
        self._wait_for_subscribers(should_stop)
        deadline = time.monotonic() + self.params.delay
        while not should_stop() and (remaining := deadline - time.monotonic()) > 0:
            spin_once(min(remaining, 0.05))
        counter = PassCounter(lambda start_ns: self.reader.messages(self.topics, start_ns))
        plan = replay_plan(counter, self.reader.start_ns, self.timing)
        if self._clock_publisher is not None:
            plan = with_clock(plan, self.reader.start_ns, self.timing, self.params.clock_frequency)
        count = run_replay(plan, self._publish, should_stop=should_stop, sleep=spin_once,
                           tick=self._publish_clock)
        if self._pacing and not should_stop():
            self._settle_group()
        for publisher in self._topic_publishers.values():  # reliable subscribers get the last messages too
            publisher.wait_for_all_acked(Duration(seconds=self.params.wait_timeout))
        self._check_first_pass(counter)
        return count

    def _check_first_pass(self, counter: PassCounter) -> None:
        """A finished first pass must have played every message the topics hold (from the offset on)."""
        if not counter.first_pass_done:
            self.get_logger().info(f"stopped during the first pass, after {sum(counter.counts.values())} "
                                   "message(s)")
            return
        shortfall = self.reader.replay_shortfall(self.topics, self.timing.first_ns(self.reader.start_ns),
                                                 counter.counts)
        if shortfall is None:
            return
        if not self.params.allow_partial:
            raise BagError(f"{shortfall}. Set allow_partial:=true to accept a partial replay")
        self.get_logger().warn(f"{shortfall} (allow_partial is true)")

    def _wait_for_subscribers(self, should_stop) -> None:
        wanted = self.params.wait_for_subscribers
        deadline = time.monotonic() + self.params.wait_timeout
        for publisher in self._topic_publishers.values():
            while publisher.get_subscription_count() < wanted and not should_stop():
                if time.monotonic() > deadline:
                    raise BagError(f"{publisher.topic_name} has {publisher.get_subscription_count()} "
                                   f"subscriber(s) after {self.params.wait_timeout} s, wanted {wanted}")
                self._spin_once(0.02)

    def _publish(self, message: BagMessage) -> None:
        if self._pacing:
            if message.topic == self._ack_before:
                self._settle_group()
                self._pending_stamp = header_stamp_ns(message.data)
                if self._pending_stamp is None:
                    raise BagError(f"ack_before {message.topic}: its messages carry no header stamp to match")
            elif message.topic in self._ack_after:
                self._settle_group()
            self._unanswered.append(message)
        self._topic_publishers[message.topic].publish(message.data)
        self._published += 1

    def _settle_group(self) -> None:
        """Wait for the answer to the pending stamp, re-publishing its frame when none comes."""
        stamp = self._pending_stamp
        if stamp is None:
            return
        frame = [m for m in self._unanswered if header_stamp_ns(m.data) == stamp]
        timeout = self.params.ack_timeout
        retries = self.params.ack_retries
        for attempt in range(retries + 1):
            deadline = time.monotonic() + timeout
            while stamp not in self._acked_stamps and not self._should_stop() and time.monotonic() < deadline:
                self._spin_once(0.02)
            if stamp in self._acked_stamps or self._should_stop():
                break
            if attempt < retries:
                self.get_logger().warn(f"no answer on {self.params.ack_topic} for stamp {stamp} within "
                                       f"{timeout} s: publishing its {len(frame)} message(s) again")
                for message in frame:
                    self._topic_publishers[message.topic].publish(message.data)
        else:
            self.get_logger().warn(f"stamp {stamp} got no answer after {retries} retries; going on")
        # keep what already belongs to later frames (e.g. a depth image published before its colour)
        self._unanswered = [m for m in self._unanswered if (header_stamp_ns(m.data) or 0) > stamp]
        self._pending_stamp = None


def main(args=None) -> int:
    exit_if_help(args, BagReplayParameters, __doc__.split("\n\n")[0])
    use_large_shm_segment()
    bound_malloc_arenas()  # as spin_node: flat memory over long recordings
    stop = init_with_stop_event(args)  # Ctrl-C / SIGTERM: stop playing, wait for readers, exit 0
    node = None
    code = 0
    try:
        node = BagReplayNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        count = node.play(lambda timeout: executor.spin_once(timeout_sec=timeout),
                          should_stop=lambda: stop.is_set() or not rclpy.ok())
        node.get_logger().info(f"played {count} message(s) from {node.reader.path}")
    except (BagError, ValueError) as error:
        print(f"bag_replay: error: {error}", file=sys.stderr, flush=True)
        code = 1
    except ParameterError as error:
        print(error, file=sys.stderr, flush=True)
        code = PARAMETER_ERROR_EXIT_CODE
    except ExternalShutdownException:
        pass
    finally:
        if node is not None:
            node.reader.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
