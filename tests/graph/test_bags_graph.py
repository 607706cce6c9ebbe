"""Recorder and replay executables in a live graph: publisher -> bag_recorder (stopped mid-stream) ->
valid bag (rosbags and mcap readers) -> bag_replay -> the same bytes, in order; clear failures; latched
topics recorded; bags that replay partly (types this environment lacks, edited QoS text, missing
messages) played as far as they can and never reported as fully played."""

import signal

import pytest
import yaml
from bag_helpers import (
    COLOR,
    GADGET,
    GADGET_TYPE,
    INFO,
    garbled_qos,
    read_with_mcap_library,
    set_offered_qos,
    unlist_split,
    write_camera_bag,
    write_sample_bag,
)
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import String

from impurity_bags.bags import BagReader, cell_typestore
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


def closed_topic_counts(bag) -> dict[str, int]:
    """Per topic, what the recorder has already made durable."""
    try:
        metadata = yaml.safe_load((bag / "metadata.yaml").read_text())
        return {entry["topic_metadata"]["name"]: entry["message_count"]
                for entry in metadata["rosbag2_bagfile_information"]["topics_with_message_count"]}
    except (FileNotFoundError, TypeError, KeyError):
        return {}


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
    recorder = launch("impurity_bags", "bag_recorder",
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
        replay = launch("impurity_bags", "bag_replay", ros_args(
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
        replay = launch("impurity_bags", "bag_replay", ros_args(
            {"bag": str(bag), "loop": True, "rate": 5.0, "topics": [PRIMITIVE], "wait_for_subscribers": 1}))
        spin_until(ros_node, lambda: len(received) > per_pass, 60.0, "a second pass of the loop", [replay])
        replay.send_signal(signal.SIGINT)
        assert replay.process.wait(timeout=15) == 0
    finally:
        ros_node.destroy_subscription(subscription)


# --------------------------------------------------------------------------------- a namespaced cell
NAMESPACE = "/bagtest_ns"


def test_a_recorder_in_a_namespace_records_relative_topics_under_it_and_a_replay_there_selects_them(
        ros_node, launch, tmp_path):
    """The cell's names are relative: a recorder started in a cell's namespace records that cell's
    topics, under the absolute names a bag holds; a replay in the namespace selects them by the same relative
    names."""
    bag = tmp_path / "namespaced"
    in_namespace = {"__ns": NAMESPACE}
    recorder = launch("impurity_bags", "bag_recorder", ros_args(
        {"topics": ["chatter"], "output": str(bag), "split_duration": 0.2}, remappings=in_namespace))
    chatter = ros_node.create_publisher(String, f"{NAMESPACE}/chatter", RELIABLE)
    try:
        wait_for_subscribers(ros_node, chatter, processes=[recorder])
        published = []

        def publish_one() -> bool:
            published.append(String(data=f"message {len(published)}"))
            chatter.publish(published[-1])
            return closed_topic_counts(bag).get(f"{NAMESPACE}/chatter", 0) >= 3

        spin_until(ros_node, publish_one, 30.0, "the recorder to close a split of the namespaced chatter",
                   [recorder])
        recorder.send_signal(signal.SIGINT)
        assert recorder.process.wait(timeout=15) == 0
    finally:
        ros_node.destroy_publisher(chatter)
    with BagReader(bag) as reader:
        assert list(reader.topics) == [f"{NAMESPACE}/chatter"]
        expected = [m.data for m in reader.messages()]

    received = []
    subscription = ros_node.create_subscription(String, f"{NAMESPACE}/chatter", received.append, RELIABLE,
                                                raw=True)
    try:
        replay = launch("impurity_bags", "bag_replay", ros_args(
            {"bag": str(bag), "topics": ["chatter"], "as_fast_as_possible": True, "wait_for_subscribers": 1},
            remappings=in_namespace))
        spin_until(ros_node, lambda: len(received) >= len(expected), 30.0, "the replayed chatter", [replay])
        assert replay.process.wait(timeout=15) == 0, replay.output()[-2000:]
    finally:
        ros_node.destroy_subscription(subscription)
    assert received == expected


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
    replay = launch("impurity_bags", "bag_replay", ros_args({"bag": str(bag)}))
    assert replay.process.wait(timeout=30) == 1
    assert expected in replay.output()


@pytest.mark.parametrize("pacing, expected", [
    ({"ack_after": ["/chatter"]}, "ack_after ['/chatter'] needs ack_topic"),
    ({"topics": ["/policy/primitive"], "ack_topic": "/rosout", "ack_before": "/policy/primitive",
      "ack_after": ["/chatter"]}, "ack_after ['/chatter'] not among the played topics"),
], ids=["no-ack-topic", "unplayed"])
def test_replay_refuses_ack_after_it_cannot_honour(launch, tmp_path, pacing, expected):
    write_sample_bag(tmp_path / "bag", cell_typestore(), count=3)
    replay = launch("impurity_bags", "bag_replay", ros_args({"bag": str(tmp_path / "bag"), **pacing}))
    assert replay.process.wait(timeout=30) == 1
    assert expected in replay.output()


def test_recorder_refuses_an_existing_output(launch, tmp_path):
    recorder = launch("impurity_bags", "bag_recorder", ros_args({"output": str(tmp_path)}))
    assert recorder.process.wait(timeout=30) == 1
    assert "already exists" in recorder.output()


# ---------------------------------------------------------------------------- latched topics in recordings
ROBOT_DESCRIPTION = "/bagtest/robot_description"
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def recorded(bag, topic) -> list[str]:
    with BagReader(bag) as reader:
        return [deserialize_message(m.data, String).data for m in reader.messages([topic])]


def publish_until_recorded(ros_node, publisher, bag, wanted: dict[str, int], recorder, what: str) -> None:
    """Publish on `publisher` (volatile chatter keeps splits closing) until the recorder made `wanted`
    durable, then stop it with SIGINT."""
    index = 0

    def tick():
        nonlocal index
        publisher.publish(String(data=f"chatter {index}"))
        index += 1
        counts = closed_topic_counts(bag)
        return all(counts.get(topic, 0) >= count for topic, count in wanted.items())

    spin_until(ros_node, tick, 60.0, what, [recorder])
    recorder.send_signal(signal.SIGINT)
    assert recorder.process.wait(timeout=15) == 0


def test_recorder_records_a_latched_topic_published_before_it_started(ros_node, launch, tmp_path):
    """/robot_description (transient local) published once, then bag_recorder starts:
    the message must be in the bag, and the start-up line counts the topics it records."""
    bag = tmp_path / "latched"
    description = ros_node.create_publisher(String, ROBOT_DESCRIPTION, LATCHED)
    chatter = ros_node.create_publisher(String, CHATTER, RELIABLE)
    description.publish(String(data="<robot name='ur5'/>"))
    try:
        recorder = launch("impurity_bags", "bag_recorder", ros_args(
            {"topics": [ROBOT_DESCRIPTION, CHATTER], "output": str(bag), "split_duration": 0.2}))
        wait_for_subscribers(ros_node, description, processes=[recorder])
        wait_for_subscribers(ros_node, chatter, processes=[recorder])
        publish_until_recorded(ros_node, chatter, bag, {ROBOT_DESCRIPTION: 1, CHATTER: 5}, recorder,
                               f"{ROBOT_DESCRIPTION} and 5 chatter messages in closed splits")
    finally:
        ros_node.destroy_publisher(description)
        ros_node.destroy_publisher(chatter)
    assert recorded(bag, ROBOT_DESCRIPTION) == ["<robot name='ur5'/>"]
    output = recorder.output()
    assert "recording 2 topic(s) to" in output
    assert f"recording {ROBOT_DESCRIPTION} (std_msgs/msg/String, reliable, transient_local" in output
    assert f"recording {CHATTER} (std_msgs/msg/String, reliable, volatile" in output


def test_recorder_waits_for_publishers_and_rechecks_when_new_ones_appear(ros_node, launch, tmp_path):
    """A topic that first has only a subscriber is not subscribed blindly (volatile): the recorder
    waits for its publisher, so a latched message published at once is recorded; a volatile publisher
    joining later makes it re-subscribe volatile (a warning says so), and its messages are recorded too,
    the latched message still once."""
    bag = tmp_path / "late"
    listener = ros_node.create_subscription(String, ROBOT_DESCRIPTION, lambda _: None, RELIABLE)
    publishers = []
    try:
        recorder = launch("impurity_bags", "bag_recorder", ros_args(
            {"topics": [ROBOT_DESCRIPTION], "output": str(bag), "split_duration": 0.2}))
        spin_until(ros_node, lambda: "waiting for a publisher of" in recorder.output(), 30.0,
                   "the recorder's start-up line", [recorder])
        assert "recording 1 topic(s) to" in recorder.output()
        publishers.append(ros_node.create_publisher(String, ROBOT_DESCRIPTION, LATCHED))
        publishers[0].publish(String(data="<robot name='ur5'/>"))  # at once: only a latch delivers it
        spin_until(ros_node, lambda: f"recording {ROBOT_DESCRIPTION}" in recorder.output(), 30.0,
                   f"the recorder to subscribe {ROBOT_DESCRIPTION}", [recorder])
        publishers.append(ros_node.create_publisher(String, ROBOT_DESCRIPTION, RELIABLE))
        spin_until(ros_node, lambda: "re-subscribed reliable, volatile" in recorder.output(), 30.0,
                   "the recorder to re-subscribe volatile", [recorder])
        wait_for_subscribers(ros_node, publishers[1], processes=[recorder])
        publish_until_recorded(ros_node, publishers[1], bag, {ROBOT_DESCRIPTION: 6}, recorder,
                               "the latched and 5 volatile messages in closed splits")
    finally:
        ros_node.destroy_subscription(listener)
        for publisher in publishers:
            ros_node.destroy_publisher(publisher)
    texts = recorded(bag, ROBOT_DESCRIPTION)
    assert texts[0] == "<robot name='ur5'/>" and texts.count("<robot name='ur5'/>") == 1
    assert len(texts) >= 6 and all(text.startswith("chatter ") for text in texts[1:])
    assert "offers volatile, the subscription requests transient_local" in recorder.output()


# -------------------------------------------------------------------- bags that replay partly or not at all
CAMERA_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def test_replay_of_the_camera_topics_beside_a_type_this_environment_lacks(ros_node, launch, tmp_path):
    """A bag with a custom type and a tf2_msgs message beside the camera topics: replaying only
    the camera topics plays every frame, and a warning names the topics it leaves out for their types."""
    bag = tmp_path / "camera"
    written = write_camera_bag(bag)
    received = {COLOR: [], INFO: []}
    subscriptions = [
        ros_node.create_subscription(Image, COLOR, received[COLOR].append, CAMERA_QOS, raw=True),
        ros_node.create_subscription(CameraInfo, INFO, received[INFO].append, CAMERA_QOS, raw=True)]
    try:
        replay = launch("impurity_bags", "bag_replay", ros_args(
            {"bag": str(bag), "topics": [COLOR, INFO], "as_fast_as_possible": True,
             "wait_for_subscribers": 1}))
        spin_until(ros_node, lambda: all(len(received[t]) >= len(written[t]) for t in received), 30.0,
                   "every camera message", [replay])
        assert replay.process.wait(timeout=15) == 0, replay.output()[-2000:]
    finally:
        for subscription in subscriptions:
            ros_node.destroy_subscription(subscription)
    for topic, msg_class in ((COLOR, Image), (INFO, CameraInfo)):  # the wire pads the CDR to 4 bytes
        assert [deserialize_message(data, msg_class) for data in received[topic]] == \
            [deserialize_message(data, msg_class) for data in written[topic]]
    output = replay.output()
    assert f"not playing {GADGET} ({GADGET_TYPE}, 1 message(s)): unknown message type '{GADGET_TYPE}'" \
        in output
    assert "played 20 message(s)" in output


@pytest.mark.parametrize("allow_partial", [False, True], ids=["refused", "allow_partial"])
def test_replay_of_every_topic_of_a_bag_with_a_missing_type(launch, tmp_path, allow_partial):
    bag = tmp_path / "camera"
    write_camera_bag(bag)
    replay = launch("impurity_bags", "bag_replay", ros_args(
        {"bag": str(bag), "as_fast_as_possible": True, "allow_partial": allow_partial}))
    code = replay.process.wait(timeout=30)
    output = replay.output()
    assert f"{GADGET} ({GADGET_TYPE}, 1 message(s))" in output
    if allow_partial:
        assert code == 0 and "(allow_partial is true)" in output
    else:
        assert code == 1 and "topics:=[...]" in output and "allow_partial:=true" in output


def test_replay_of_a_bag_whose_qos_text_was_edited_plays_every_message(ros_node, launch, tmp_path):
    """offered_qos_profiles edited into garbage in metadata.yaml: every message is still played."""
    bag = tmp_path / "edited"
    offered = Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE, QosDurability.VOLATILE, QosTime(0, 0),
                  QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)
    written = write_sample_bag(bag, cell_typestore(), count=20, qos=[offered])
    with open(bag / "metadata.yaml") as stream:
        profiles = yaml.safe_load(stream)["rosbag2_bagfile_information"]["topics_with_message_count"][0][
            "topic_metadata"]["offered_qos_profiles"]
    for topic in ("/chatter", "/policy/primitive"):
        set_offered_qos(bag, topic, garbled_qos(profiles))
    classes = {"/chatter": String, "/policy/primitive": Primitive}
    received = {topic: [] for topic in classes}
    subscriptions = [ros_node.create_subscription(msg_class, topic, received[topic].append, RELIABLE)
                     for topic, msg_class in classes.items()]
    try:
        replay = launch("impurity_bags", "bag_replay", ros_args(
            {"bag": str(bag), "as_fast_as_possible": True, "wait_for_subscribers": 1}))
        spin_until(ros_node, lambda: sum(map(len, received.values())) >= len(written), 30.0,
                   "every replayed message", [replay])
        assert replay.process.wait(timeout=15) == 0, replay.output()[-2000:]
    finally:
        for subscription in subscriptions:
            ros_node.destroy_subscription(subscription)
    for topic, msg_class in classes.items():
        expected = [deserialize_message(m.data, msg_class) for m in written if m.topic == topic]
        assert received[topic] == expected
    output = replay.output()
    assert "offered_qos_profiles of /chatter in metadata.yaml cannot be read" in output
    assert "played 20 message(s)" in output


@pytest.mark.parametrize("allow_partial", [False, True], ids=["refused", "allow_partial"])
def test_replay_that_plays_fewer_messages_than_the_bag_holds_fails_unless_allowed(launch, tmp_path,
                                                                                   allow_partial):
    """A split missing from relative_file_paths: 20 of 30 messages readable; never "played" with exit 0
    unless asked for."""
    bag = tmp_path / "gap"
    write_sample_bag(bag, cell_typestore(), count=30, split_duration_ns=100_000_000)
    unlist_split(bag, 1)
    replay = launch("impurity_bags", "bag_replay", ros_args(
        {"bag": str(bag), "as_fast_as_possible": True, "allow_partial": allow_partial}))
    code = replay.process.wait(timeout=30)
    output = replay.output()
    assert "played 20 of the 30 message(s) the selected topic(s) hold" in output
    assert "a split missing from relative_file_paths" in output
    if allow_partial:
        assert code == 0 and "(allow_partial is true)" in output
    else:
        assert code == 1 and "Set allow_partial:=true to accept a partial replay" in output
