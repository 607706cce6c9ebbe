"""Recorder and replay executables in a live graph: publisher -> bag_recorder (stopped mid-stream) ->
valid bag (rosbags and mcap readers) -> bag_replay -> the same bytes, in order; and clear failures."""

import signal

import pytest
import yaml
from bag_helpers import read_with_mcap_library, write_sample_bag
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from std_msgs.msg import String

from impurity_common.bags import BagReader, cell_typestore
from impurity_common.names import BASE_FRAME
from impurity_interfaces.msg import Primitive
from ros_harness import ros_args, spin_until, wait_for_subscribers

CHATTER = "/bagtest/chatter"
PRIMITIVE = "/bagtest/primitive"
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def closed_message_count(bag) -> int:
    """What the recorder has already made durable: metadata.yaml lists only closed splits."""
    try:
        metadata = yaml.safe_load((bag / "metadata.yaml").read_text())
        return metadata["rosbag2_bagfile_information"]["message_count"]
    except (FileNotFoundError, TypeError, KeyError):
        return 0


def make_messages(index: int):
    text = String(data=f"message {index}")
    primitive = Primitive(kind=Primitive.GRASP, yaw=0.25 * index, q_value=0.5, rotation_index=index % 16,
                          pixel_row=index, pixel_col=2 * index)
    primitive.header.frame_id = BASE_FRAME
    primitive.header.stamp.sec = index
    primitive.position.x, primitive.position.y = 0.5, 0.001 * index
    return text, primitive


def record_stream(ros_node, launch, bag, stop_signal):
    """Publish both topics until the recorder has closed a few splits, signal it while still publishing,
    then return what was published (per topic, in order) and the recorder's exit code."""
    recorder = launch("impurity_common", "bag_recorder",
                      ros_args({"topics": [CHATTER, PRIMITIVE], "output": str(bag), "split_duration": 0.2}))
    chatter = ros_node.create_publisher(String, CHATTER, RELIABLE)
    primitives = ros_node.create_publisher(Primitive, PRIMITIVE, RELIABLE)
    published = {CHATTER: [], PRIMITIVE: []}
    try:
        wait_for_subscribers(ros_node, chatter, processes=[recorder])
        wait_for_subscribers(ros_node, primitives, processes=[recorder])
        index = 0

        def publish_one():
            nonlocal index
            text, primitive = make_messages(index)
            chatter.publish(text)
            primitives.publish(primitive)
            published[CHATTER].append(text)
            published[PRIMITIVE].append(primitive)
            index += 1
            return False

        # ~50 messages per second (spin_once's 20 ms wait paces the loop) until 20 are durable
        spin_until(ros_node, lambda: publish_one() or closed_message_count(bag) >= 20, 30.0,
                   "the recorder to close splits with 20 messages", [recorder])
        recorder.send_signal(stop_signal)
        for _ in range(20):  # mid-stream: messages keep coming while the recorder stops
            publish_one()
        code = recorder.process.wait(timeout=15)
    finally:
        ros_node.destroy_publisher(chatter)
        ros_node.destroy_publisher(primitives)
    return published, code


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGKILL], ids=["sigint", "sigkill"])
def test_recorder_stopped_mid_stream_leaves_a_valid_bag(ros_node, launch, tmp_path, stop_signal):
    bag = tmp_path / "stream"
    published, code = record_stream(ros_node, launch, bag, stop_signal)
    assert code == (0 if stop_signal == signal.SIGINT else -signal.SIGKILL)

    with BagReader(bag, cell_typestore()) as reader:
        assert reader.topics[PRIMITIVE].msgtype == "impurity_interfaces/msg/Primitive"
        assert reader.topics[CHATTER].qos[0].reliability.name == "RELIABLE"  # the publisher's offered QoS
        messages = list(reader.messages())
    assert read_with_mcap_library(bag) == messages
    for topic, msg_class in ((CHATTER, String), (PRIMITIVE, Primitive)):
        # wire bytes (with CDR end padding) -> the very messages published, as a gap-free prefix
        recorded = [deserialize_message(m.data, msg_class) for m in messages if m.topic == topic]
        assert len(recorded) >= 10
        assert recorded == published[topic][:len(recorded)]
    assert [m.timestamp_ns for m in messages] == sorted(m.timestamp_ns for m in messages)


def test_replay_publishes_the_recorded_bytes_in_order_with_remapping(ros_node, launch, tmp_path):
    bag = tmp_path / "stream"
    record_stream(ros_node, launch, bag, signal.SIGINT)
    with BagReader(bag) as reader:
        expected = {topic: [m.data for m in reader.messages([topic])] for topic in (CHATTER, PRIMITIVE)}

    replayed_chatter = "/bagtest/replayed/chatter"
    received = {CHATTER: [], PRIMITIVE: []}
    subscriptions = [
        ros_node.create_subscription(String, replayed_chatter, received[CHATTER].append, RELIABLE, raw=True),
        ros_node.create_subscription(Primitive, PRIMITIVE, received[PRIMITIVE].append, RELIABLE, raw=True)]
    try:
        replay = launch("impurity_common", "bag_replay", ros_args(
            {"bag": str(bag), "as_fast_as_possible": True, "wait_for_subscribers": 1},
            remappings={CHATTER: replayed_chatter}))
        total = sum(len(v) for v in expected.values())
        spin_until(ros_node, lambda: sum(len(v) for v in received.values()) >= total, 30.0,
                   f"{total} replayed messages")
        assert replay.process.wait(timeout=15) == 0
    finally:
        for subscription in subscriptions:
            ros_node.destroy_subscription(subscription)
    assert received == expected


def test_looping_replay_stops_on_sigint(ros_node, launch, tmp_path):
    bag = tmp_path / "stream"
    record_stream(ros_node, launch, bag, signal.SIGINT)
    with BagReader(bag) as reader:
        per_pass = len(list(reader.messages([PRIMITIVE])))
    received = []
    subscription = ros_node.create_subscription(Primitive, PRIMITIVE, received.append, RELIABLE, raw=True)
    try:
        replay = launch("impurity_common", "bag_replay", ros_args(
            {"bag": str(bag), "loop": True, "rate": 5.0, "topics": [PRIMITIVE], "wait_for_subscribers": 1}))
        spin_until(ros_node, lambda: len(received) > per_pass, 60.0, "a second pass of the loop", [replay])
        replay.send_signal(signal.SIGINT)
        assert replay.process.wait(timeout=15) == 0
    finally:
        ros_node.destroy_subscription(subscription)


# --------------------------------------------------------------------------------- clear failures
def foreign_type_bag(path):
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg("int32 value", "other_pkg/msg/Gadget"))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/gadget", "other_pkg/msg/Gadget", typestore=store)
        writer.write(connection, 5, b"\x00\x01\x00\x00\x07\x00\x00\x00")


def truncated_bag(path):
    write_sample_bag(path, cell_typestore(), count=10)
    storage = path / f"{path.name}_0.mcap"
    storage.write_bytes(storage.read_bytes()[:300])


def corrupted_bag(path):
    write_sample_bag(path, cell_typestore(), count=10)
    storage = path / f"{path.name}_0.mcap"
    data = bytearray(storage.read_bytes())
    data[len(data) // 3] ^= 0xFF
    storage.write_bytes(bytes(data))


@pytest.mark.parametrize("make_bag, expected", [
    (lambda path: None, "does not exist"),
    (truncated_bag, "cannot be opened"),
    (corrupted_bag, "is corrupted"),
    (foreign_type_bag, "unknown message type 'other_pkg/msg/Gadget'"),
], ids=["missing", "truncated", "corrupted", "unknown-type"])
def test_replay_of_a_bad_bag_exits_non_zero_with_a_clear_message(launch, tmp_path, make_bag, expected):
    bag = tmp_path / "bad"
    make_bag(bag)
    replay = launch("impurity_common", "bag_replay", ros_args({"bag": str(bag)}))
    assert replay.process.wait(timeout=30) == 1
    assert expected in replay.output()


def test_recorder_refuses_an_existing_output(launch, tmp_path):
    recorder = launch("impurity_common", "bag_recorder", ros_args({"output": str(tmp_path)}))
    assert recorder.process.wait(timeout=30) == 1
    assert "already exists" in recorder.output()
