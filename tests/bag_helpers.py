"""Bags for tests: sample content written with BagWriter, and an independent read with the mcap library."""

import pathlib

import yaml
from mcap.reader import make_reader

from impurity_common.bags import BagMessage, BagWriter

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


def write_sample_bag(path, typestore, count=30, split_duration_ns=None) -> list[BagMessage]:
    """Two topics interleaved, 10 ms apart; returns what was written."""
    written = []
    with BagWriter(path, typestore, split_duration_ns=split_duration_ns) as writer:
        writer.add_topic("/chatter", STRING)
        writer.add_topic("/policy/primitive", PRIMITIVE)
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
