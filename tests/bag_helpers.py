"""Bags for tests: sample content written with BagWriter, and an independent read with the mcap library."""

import pathlib

import yaml
from mcap.reader import make_reader
from rosbags.typesys import get_types_from_msg

from impurity_bags.bags import BagMessage, BagWriter

STRING = "std_msgs/msg/String"
PRIMITIVE = "impurity_interfaces/msg/Primitive"


def string_cdr(typestore, text: str) -> bytes:
    cls = typestore.types[STRING]
    return bytes(typestore.serialize_cdr(cls(data=text), STRING))


def primitive_cdr(typestore, index: int) -> bytes:
    types = typestore.types
    header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=index, nanosec=7),
                                          frame_id="base_link")
    point = types["geometry_msgs/msg/Point"](x=0.5, y=0.01 * index, z=0.02)
    msg = types[PRIMITIVE](header=header, kind=1, position=point, yaw=0.39, q_value=0.8,
                           rotation_index=index % 16, pixel_row=100, pixel_col=110 + index)
    return bytes(typestore.serialize_cdr(msg, PRIMITIVE))


def write_sample_bag(path, typestore, count=30, split_duration_ns=None, qos=()) -> list[BagMessage]:
    """Two topics interleaved, 10 ms apart, both with the offered QoS profiles `qos`; returns what was
    written."""
    written = []
    with BagWriter(path, typestore, split_duration_ns=split_duration_ns) as writer:
        writer.add_topic("/chatter", STRING, qos)
        writer.add_topic("/policy/primitive", PRIMITIVE, qos)
        for i in range(count):
            topic, msgtype = ("/chatter", STRING) if i % 2 == 0 else ("/policy/primitive", PRIMITIVE)
            data = string_cdr(typestore, f"hello {i}") if i % 2 == 0 else primitive_cdr(typestore, i)
            message = BagMessage(topic, msgtype, 1_700_000_000_000_000_000 + i * 10_000_000, data)
            writer.write(message.topic, message.timestamp_ns, message.data)
            written.append(message)
    return written


def read_with_mcap_library(bag: pathlib.Path) -> list[BagMessage]:
    """Independent of rosbags: the mcap package's own reader over the files metadata.yaml lists."""
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    messages = []
    for name in metadata["relative_file_paths"]:
        with open(bag / name, "rb") as stream:
            reader = make_reader(stream, validate_crcs=True)
            assert reader.get_header().profile == "ros2"
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
                messages.append(BagMessage(channel.topic, schema.name, message.log_time, bytes(message.data)))
    return messages


# ------------------------------------------------------------------- bags that replay partly or not
COLOR = "/bagtest/camera/color/image_raw"
INFO = "/bagtest/camera/color/camera_info"
GADGET, GADGET_TYPE = "/bagtest/gadget", "other_pkg/msg/Gadget"  # a custom package this environment lacks
TF, TF_TYPE = "/tf", "tf2_msgs/msg/TFMessage"  # in rosbags' Jazzy typestore, but the PyPI wheels hold no tf2


def write_camera_bag(path, frames: int = 10) -> dict[str, list[bytes]]:
    """Camera topics (15 Hz) beside one message of a custom type and one /tf: what a cell's own bag
    looks like when it was recorded on a machine with more packages. Returns the bytes per topic."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import CameraInfo, Image

    from impurity_bags.bags import cell_typestore

    store = cell_typestore()
    store.register(get_types_from_msg("int32 value", GADGET_TYPE))
    written: dict[str, list[bytes]] = {COLOR: [], INFO: [], GADGET: [], TF: []}
    start = 1_700_000_000_000_000_000
    with BagWriter(path, store) as writer:
        writer.add_topic(TF, TF_TYPE)
        writer.add_topic(GADGET, GADGET_TYPE)
        writer.add_topic(INFO, "sensor_msgs/msg/CameraInfo")
        writer.add_topic(COLOR, "sensor_msgs/msg/Image")
        tf = bytes(store.serialize_cdr(store.types[TF_TYPE](transforms=[]), TF_TYPE))
        gadget = bytes(store.serialize_cdr(store.types[GADGET_TYPE](value=7), GADGET_TYPE))
        for topic, data in ((TF, tf), (GADGET, gadget)):
            writer.write(topic, start, data)
            written[topic].append(data)
        for frame in range(frames):
            stamp = start + 1_000_000 + frame * 66_666_667
            info = CameraInfo(width=4, height=2, distortion_model="plumb_bob")
            image = Image(width=4, height=2, encoding="rgb8", step=12, data=bytes(range(frame, frame + 24)))
            for message in (info, image):
                message.header.frame_id = "camera_color_optical_frame"
                message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
            for topic, message in ((INFO, info), (COLOR, image)):
                data = serialize_message(message)
                writer.write(topic, stamp, data)
                written[topic].append(data)
    return written


def edit_metadata(bag: pathlib.Path, edit) -> None:
    """Apply edit(info) to metadata.yaml's rosbag2_bagfile_information, as a user with an editor would."""
    path = bag / "metadata.yaml"
    metadata = yaml.safe_load(path.read_text())
    edit(metadata["rosbag2_bagfile_information"])
    path.write_text(yaml.safe_dump(metadata, sort_keys=False))


def set_offered_qos(bag: pathlib.Path, topic: str, value) -> None:
    """Replace one topic's offered_qos_profiles text in metadata.yaml."""
    def edit(info):
        for entry in info["topics_with_message_count"]:
            if entry["topic_metadata"]["name"] == topic:
                entry["topic_metadata"]["offered_qos_profiles"] = value
    edit_metadata(bag, edit)


def garbled_qos(profiles: list) -> list:
    """The instance from the field: the profiles' policies edited into words no ROS knows."""
    return [{**profile, "reliability": "garbage", "durability": "very durable"} for profile in profiles]


def unlist_split(bag: pathlib.Path, index: int) -> None:
    """Drop one split from relative_file_paths (as after deleting a damaged file) and leave the counts."""
    def edit(info):
        name = f"{bag.name}_{index}.mcap"
        info["relative_file_paths"].remove(name)
        info["files"] = [f for f in info["files"] if f["path"] != name]
    edit_metadata(bag, edit)
