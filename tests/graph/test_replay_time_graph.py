"""Replay time through the real executables: bag_replay with clock:=true publishes /clock with the bag's
time; a node started with use_sim_time:=true and no /clock refuses its inputs, says so once, and
publishes nothing."""

import pathlib
import time

import numpy as np
import pytest
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from test_attention_graph import FakeCamera, camera_messages, heightmap_message
from test_policy_graph import attention_message

from impurity_attention.core.synthetic import random_boxes, render_boxes
from impurity_bags.bags import BagReader
from impurity_common import names
from impurity_common.conversions import time_to_ns
from impurity_interfaces.msg import AttentionResult, Heightmap, Primitive
from ros_harness import TopicRecorder, ros_args, spin_until

ROOT = pathlib.Path(__file__).resolve().parents[2]
EPISODE_BAG = ROOT / "tests" / "data" / "episode_bag"
SECOND = 1_000_000_000
RELIABLE = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
CLOCK_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
REFUSAL = "input dropped: use_sim_time is true and no /clock has arrived"


def test_replay_with_clock_publishes_the_bags_time_advancing_to_the_played_stamp(ros_node, launch):
    rate, frequency = 8.0, 20.0
    with BagReader(EPISODE_BAG) as reader:
        start_ns = reader.start_ns
        recorded = reader.messages([names.absolute(names.PRIMITIVE_TOPIC)])  # a bag holds absolute names
        played_ns = [m.timestamp_ns for m in recorded][-1]  # 24.2 s in
    clock = TopicRecorder(ros_node, Clock, "/clock", CLOCK_QOS)
    steps = TopicRecorder(ros_node, Primitive, names.PRIMITIVE_TOPIC, RELIABLE)
    try:
        replay = launch("impurity_bags", "bag_replay", ros_args({
            "bag": str(EPISODE_BAG), "topics": [names.PRIMITIVE_TOPIC], "rate": rate, "clock": True,
            "clock_frequency": frequency, "wait_for_subscribers": 1, "delay": 0.5}))
        spin_until(ros_node, lambda: not replay.alive, 60.0, "bag_replay to play the bag and exit")
        assert replay.process.returncode == 0, replay.output()[-2000:]
        spin_until(ros_node, lambda: steps.messages, 10.0, "the replayed primitive")
    finally:
        clock.destroy()
        steps.destroy()

    values = [time_to_ns(message.clock) for message in clock.messages]
    assert values, "no /clock message"
    assert values == sorted(values)  # never back (no loop)
    assert start_ns <= values[0] <= start_ns + 2 * SECOND  # from the bag's first time
    # up to the played message's timestamp: the tick just before it, or (lost on the best-effort
    # transport) one periodic tick earlier, rate / frequency = 0.4 s of bag time
    assert played_ns - SECOND <= values[-1] <= played_ns
    # 24.2 s of bag time in ~3 s at 20 Hz: the clock runs, it does not jump from the start to the end
    assert len(set(values)) >= 20


# --------------------------------------------------------------------- use_sim_time without /clock
def spin_publishing(node, publish, seconds: float) -> None:
    """Spin `node` for `seconds`, calling publish() about every 0.1 s."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        publish()
        rclpy.spin_once(node, timeout_sec=0.1)


class PolicyInput:
    package, executable = "impurity_policy", "policy_node"
    output = (Primitive, names.PRIMITIVE_TOPIC)
    parameters = {"checkpoint": "/nonexistent/untrained.pt", "allow_untrained": True}

    def __init__(self, node):
        self.node = node
        self.publisher = node.create_publisher(AttentionResult, names.ATTENTION_TOPIC, RELIABLE)

    def publish(self):
        self.publisher.publish(attention_message(self.node.get_clock().now().nanoseconds))

    def destroy(self):
        self.node.destroy_publisher(self.publisher)


class AttentionInput:
    package, executable = "impurity_attention", "attention_node"
    output = (AttentionResult, names.ATTENTION_TOPIC)
    parameters = {}

    def __init__(self, node):
        self.node = node
        self.publisher = node.create_publisher(Heightmap, names.HEIGHTMAP_TOPIC, RELIABLE)
        self.color = np.full((224, 224, 3), 150, np.uint8)
        self.height = np.zeros((224, 224), np.float32)

    def publish(self):
        stamp = self.node.get_clock().now().nanoseconds
        self.publisher.publish(heightmap_message(stamp, self.color, self.height))

    def destroy(self):
        self.node.destroy_publisher(self.publisher)


class CameraInput:
    package, executable = "impurity_attention", "heightmap_node"
    output = (Heightmap, names.HEIGHTMAP_TOPIC)
    parameters = {}

    def __init__(self, node):
        self.node = node
        self.camera = FakeCamera(node)  # publishes the frame shown every 0.2 s while the node spins
        self.frame = render_boxes(random_boxes(3, num_product=20, num_impurities=1))

    def publish(self):
        self.camera.show(*camera_messages(self.frame, self.node.get_clock().now().nanoseconds))

    def destroy(self):
        self.camera.destroy()


@pytest.mark.parametrize("node_input", [PolicyInput, AttentionInput, CameraInput],
                         ids=["policy", "attention", "heightmap"])
def test_a_node_on_sim_time_without_clock_refuses_its_inputs_saying_so_once(ros_node, launch, node_input):
    feed = node_input(ros_node)
    output = TopicRecorder(ros_node, *feed.output, RELIABLE)
    try:
        node = launch(feed.package, feed.executable, ros_args({**feed.parameters, "use_sim_time": True}))
        spin_until(ros_node, lambda: feed.publish() or REFUSAL in node.output(), 60.0,
                   f"{feed.executable}'s refusal", [node])
        spin_publishing(ros_node, feed.publish, 2.0)  # more inputs: no second line, still no output
        assert node.alive
        log = node.output()
    finally:
        feed.destroy()
        output.destroy()
    refusals = [line for line in log.splitlines() if REFUSAL in line]
    assert len(refusals) == 1, log[-2000:]
    assert "use_sim_time:=false" in refusals[0] and "bag_replay -p clock:=true" in refusals[0]
    assert output.messages == []
