"""Bags in the rosbag2 format (MCAP storage, metadata version 9, as ROS 2 Jazzy writes them), without ROS.

The PyPI ROS wheels have no rosbag2, so the cell writes and reads bags with the `rosbags` library; a
ROS install opens the same directories with `ros2 bag`. This module is the pure core of the recorder
and replay nodes (it never imports rclpy):

- `cell_typestore()`: Jazzy's standard message types plus ours, registered from the .msg files;
- `BagWriter`: raw CDR in, a rosbag2 directory out, split into files that are each closed (a complete
  MCAP file) before the next starts, with metadata.yaml rewritten after every closed split, so a
  recorder killed at any moment still leaves a valid bag of everything up to its last split;
- `BagReader`: opens and checks a bag (clear `BagError`s for a missing directory, missing or invalid
  metadata, truncated or corrupted files, unknown message types), yields `BagMessage`s in time order;
- `replay_plan()` / `run_replay()`: when each message is due (original timing with a rate factor,
  start offset and loop, or as fast as possible) and the loop that publishes them, with an injectable
  clock so the timing is tested without ROS.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import pathlib
import shutil
import struct
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import yaml
from rosbags.interfaces import Qos
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

METADATA_FILE = "metadata.yaml"
METADATA_VERSION = 9  # what rosbag2 0.26 (Jazzy) writes
ROS_DISTRO = "jazzy"
INTERFACES_PACKAGE = "impurity_interfaces"
CHECKSUM_PREFIX = "sha256:"  # custom_data key prefix: one SHA-256 per split file, checked on open


class BagError(Exception):
    """A bag cannot be written or read; the message names the bag and what is wrong with it."""


class BagMessage(NamedTuple):
    topic: str
    msgtype: str  # e.g. sensor_msgs/msg/Image
    timestamp_ns: int  # receive time at the recorder (rosbag2's log time)
    data: bytes  # serialized CDR, exactly as it was on the wire


@dataclass(frozen=True)
class TopicInfo:
    msgtype: str
    message_count: int
    qos: tuple[Qos, ...]  # the publishers' offered QoS profiles, as recorded


# ---------------------------------------------------------------------------------------- types
def interface_msg_dir() -> pathlib.Path:
    """Installed .msg definitions of impurity_interfaces (found through the ament index)."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return pathlib.Path(get_package_share_directory(INTERFACES_PACKAGE)) / "msg"
    except PackageNotFoundError as error:
        raise BagError(f"{INTERFACES_PACKAGE} is not installed (source scripts/env.sh after "
                       f"`make setup`): {error}") from error


def cell_typestore(msg_dir: str | os.PathLike | None = None) -> Typestore:
    """Jazzy's standard types plus every impurity_interfaces message, parsed from its .msg file."""
    store = get_typestore(Stores.ROS2_JAZZY)
    directory = pathlib.Path(msg_dir) if msg_dir is not None else interface_msg_dir()
    files = sorted(directory.glob("*.msg"))
    if not files:
        raise BagError(f"no .msg files in {directory}")
    types = {}
    for path in files:
        types.update(get_types_from_msg(path.read_text(), f"{INTERFACES_PACKAGE}/msg/{path.stem}"))
    store.register(types)
    return store


def check_known_type(typestore: Typestore, msgtype: str, topic: str) -> None:
    if msgtype not in typestore.fielddefs:
        raise BagError(f"unknown message type '{msgtype}' on topic {topic}: neither a ROS 2 Jazzy "
                       f"standard type nor one of {INTERFACES_PACKAGE}'s messages")


def ros_message_class(msgtype: str, topic: str):
    """The generated Python class of 'pkg/msg/Type' (rclpy needs it even for raw CDR publishing)."""
    package, _, name = msgtype.partition("/msg/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except (ImportError, AttributeError, ValueError) as error:
        raise BagError(f"message type '{msgtype}' on topic {topic} is not available in this ROS "
                       f"environment ({error})") from error


# --------------------------------------------------------------------------------------- writing
class BagWriter:
    """Raw CDR messages -> rosbag2 directory `path` (MCAP storage, metadata as Jazzy writes it).

    Split k is written by `rosbags` into the scratch directory `path/<name>_k/` and moved to
    `path/<name>_k.mcap` once complete; metadata.yaml (with the SHA-256 of every split) is then
    replaced atomically. A split starts when `split_duration_ns` of message time has passed since the
    current one began (None: one file, closed by close()). Use as a context manager or call close().
    """

    def __init__(self, path: str | os.PathLike, typestore: Typestore, split_duration_ns: int | None = None,
                 custom_data: dict[str, str] | None = None):
        self.path = pathlib.Path(path)
        if self.path.exists():
            raise BagError(f"bag {self.path} already exists: not overwriting it")
        if split_duration_ns is not None and split_duration_ns <= 0:
            raise BagError(f"split duration must be positive, got {split_duration_ns} ns")
        self.typestore = typestore
        self.split_duration_ns = split_duration_ns
        self.custom_data = {str(k): str(v) for k, v in (custom_data or {}).items()}  # provenance notes
        self._topics: dict[str, tuple[str, tuple[Qos, ...]]] = {}
        self._counts: dict[str, int] = {}
        self._files: list[dict] = []  # closed splits: path, starting_time, duration, message_count
        self._checksums: dict[str, str] = {}
        self._split: Writer | None = None
        self._split_connections: dict = {}
        self._split_first_ns = self._split_last_ns = 0
        self._split_messages = 0
        self._split_count = 0
        self.closed = False
        self.path.mkdir(parents=True)
        self._write_metadata()

    @property
    def message_count(self) -> int:
        return sum(self._counts.values())

    def add_topic(self, topic: str, msgtype: str, qos: Sequence[Qos] = ()) -> None:
        """Declare a topic before writing to it; the type must be known to the typestore."""
        check_known_type(self.typestore, msgtype, topic)
        if topic in self._topics:
            if self._topics[topic][0] != msgtype:
                raise BagError(f"topic {topic} already recorded as {self._topics[topic][0]}, not {msgtype}")
            return
        self._topics[topic] = (msgtype, tuple(qos))
        self._counts[topic] = 0
        if self._split is not None:
            self._add_connection(topic)

    def write(self, topic: str, timestamp_ns: int, data: bytes | memoryview) -> None:
        if self.closed:
            raise BagError(f"bag {self.path} is closed")
        if topic not in self._topics:
            raise BagError(f"topic {topic} was not added to bag {self.path}")
        if (self._split is not None and self.split_duration_ns is not None
                and timestamp_ns - self._split_first_ns >= self.split_duration_ns):
            self._close_split()
        if self._split is None:
            self._open_split(timestamp_ns)
        self._split.write(self._split_connections[topic], timestamp_ns, data)
        self._counts[topic] += 1
        self._split_messages += 1
        self._split_first_ns = min(self._split_first_ns, timestamp_ns)
        self._split_last_ns = max(self._split_last_ns, timestamp_ns)

    def close(self) -> None:
        """Finish the open split and the metadata; safe to call twice."""
        if self.closed:
            return
        if self._split is not None:
            self._close_split()
        self.closed = True

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    # ---- splits
    def _split_name(self, index: int) -> str:
        return f"{self.path.name}_{index}"

    def _open_split(self, timestamp_ns: int) -> None:
        scratch = self.path / self._split_name(self._split_count)
        self._split = Writer(scratch, version=METADATA_VERSION, storage_plugin=StoragePlugin.MCAP)
        self._split.open()
        self._split_connections = {}
        for topic in self._topics:
            self._add_connection(topic)
        self._split_first_ns = self._split_last_ns = timestamp_ns
        self._split_messages = 0

    def _add_connection(self, topic: str) -> None:
        msgtype, qos = self._topics[topic]
        self._split_connections[topic] = self._split.add_connection(
            topic, msgtype, typestore=self.typestore, offered_qos_profiles=list(qos))

    def _close_split(self) -> None:
        split, self._split = self._split, None
        split.close()
        name = self._split_name(self._split_count)
        scratch = self.path / name
        final = self.path / f"{name}.mcap"
        os.replace(scratch / f"{name}.mcap", final)
        shutil.rmtree(scratch)
        self._checksums[final.name] = file_sha256(final)
        self._files.append({
            "path": final.name,
            "starting_time": {"nanoseconds_since_epoch": self._split_first_ns},
            "duration": {"nanoseconds": self._split_last_ns - self._split_first_ns},
            "message_count": self._split_messages,
        })
        self._split_count += 1
        self._write_metadata()

    def _write_metadata(self) -> None:
        """metadata.yaml for the closed splits (called only while no split is open, so the counts
        describe exactly the listed files), in the layout rosbag2 (Jazzy) writes; atomic replace."""
        starts = [f["starting_time"]["nanoseconds_since_epoch"] for f in self._files]
        ends = [start + f["duration"]["nanoseconds"] for start, f in zip(starts, self._files, strict=True)]
        start = min(starts) if starts else 0
        info = {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": (max(ends) - start) if ends else 0},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": sum(f["message_count"] for f in self._files),
            "topics_with_message_count": [self._topic_entry(topic) for topic in self._topics],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f["path"] for f in self._files],
            "files": self._files,
            "custom_data": {**self.custom_data,
                            **{CHECKSUM_PREFIX + name: digest for name, digest in self._checksums.items()}},
            "ros_distro": ROS_DISTRO,
        }
        text = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)
        scratch = self.path / (METADATA_FILE + ".tmp")
        scratch.write_text(text)
        os.replace(scratch, self.path / METADATA_FILE)

    def _topic_entry(self, topic: str) -> dict:
        msgtype, qos = self._topics[topic]
        return {
            "topic_metadata": {
                "name": topic,
                "type": msgtype,
                "serialization_format": "cdr",
                "offered_qos_profiles": dump_qos_v9(list(qos)),
                "type_description_hash": self.typestore.hash_rihs01(msgtype),
            },
            "message_count": self._counts[topic],
        }


def file_sha256(path: pathlib.Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# --------------------------------------------------------------------------------------- reading
class BagReader:
    """An opened, checked rosbag2 directory. Every problem is a BagError naming the bag.

    Checks on open: the directory and metadata.yaml exist and parse, every listed file is a complete
    MCAP file (rosbags checks the magic, footer and summary), the SHA-256 recorded by BagWriter
    matches (bit flips anywhere), and with a typestore, every topic's type is known to it.
    """

    def __init__(self, path: str | os.PathLike, typestore: Typestore | None = None):
        self.path = pathlib.Path(path)
        if not self.path.exists():
            raise BagError(f"bag {self.path} does not exist")
        if not self.path.is_dir():
            raise BagError(f"bag {self.path} is a file; a rosbag2 bag is a directory with {METADATA_FILE}")
        if not (self.path / METADATA_FILE).is_file():
            raise BagError(f"bag {self.path} has no {METADATA_FILE} (not a rosbag2 directory, or the "
                           "recorder was killed before it closed its first split)")
        reader = Reader(self.path)
        try:
            reader.open()
        except Exception as error:  # noqa: BLE001 - rosbags raises ReaderError, struct/OS/key errors
            raise BagError(f"bag {self.path} cannot be opened: {type(error).__name__}: {error}") from error
        self._reader = reader
        try:
            self._check_checksums()
            self.topics = {
                topic: TopicInfo(info.msgtype, info.msgcount,
                                 tuple(q for c in info.connections for q in c.ext.offered_qos_profiles))
                for topic, info in self._reader.topics.items()}
            if typestore is not None:
                for topic, info in self.topics.items():
                    check_known_type(typestore, info.msgtype, topic)
        except BaseException:
            self.close()
            raise

    @property
    def message_count(self) -> int:
        return self._reader.message_count

    @property
    def start_ns(self) -> int:
        return self._reader.start_time if self.message_count else 0

    @property
    def end_ns(self) -> int:
        """Timestamp of the last message (inclusive)."""
        return self._reader.end_time - 1 if self.message_count else 0

    @property
    def ros_distro(self) -> str | None:
        return self._reader.ros_distro

    @property
    def custom_data(self) -> dict[str, str]:
        return dict(self._reader.storage.metadata.custom or {})

    def messages(self, topics: Iterable[str] | None = None,
                 start_ns: int | None = None) -> Iterator[BagMessage]:
        """Messages in time order, optionally only some topics and only from `start_ns` on."""
        wanted = None if topics is None else set(topics)
        connections = [c for c in self._reader.connections if wanted is None or c.topic in wanted]
        if not connections:
            return
        try:
            for connection, timestamp, data in self._reader.messages(connections, start=start_ns):
                yield BagMessage(connection.topic, connection.msgtype, timestamp, bytes(data))
        except Exception as error:  # noqa: BLE001 - a damaged chunk surfaces as any parsing error
            raise BagError(f"bag {self.path} is damaged: {type(error).__name__}: {error}") from error

    def close(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _check_checksums(self) -> None:
        for key, expected in self.custom_data.items():
            if not key.startswith(CHECKSUM_PREFIX):
                continue
            name = key[len(CHECKSUM_PREFIX):]
            actual = file_sha256(self.path / name)
            if actual != expected:
                raise BagError(f"bag {self.path}: {name} is corrupted (SHA-256 {actual[:12]}… differs from "
                               f"the recorded {expected[:12]}…)")


# ---------------------------------------------------------------------------------------- replay
def header_stamp_ns(data: bytes) -> int | None:
    """Header stamp of a message whose first field is a std_msgs/Header (images, our results), read
    straight from its CDR bytes; None if the bytes are too short or not plain CDR."""
    if len(data) < 12 or data[0] != 0 or data[1] not in (0, 1):
        return None
    sec, nanosec = struct.unpack("<iI" if data[1] == 1 else ">iI", data[4:12])
    return sec * 1_000_000_000 + nanosec


@dataclass(frozen=True)
class ReplayTiming:
    """How a bag is replayed: original timing scaled by `rate` (2.0 = twice as fast), from
    `start_offset` s after the bag's first message, repeated if `loop`; or every message due at once
    when `as_fast_as_possible` (the publisher then sets the pace)."""

    rate: float = 1.0
    start_offset: float = 0.0
    loop: bool = False
    as_fast_as_possible: bool = False

    def __post_init__(self):
        if not (self.rate > 0 and self.rate < float("inf")):
            raise ValueError(f"rate must be a positive number, got {self.rate}")
        if not self.start_offset >= 0:
            raise ValueError(f"start_offset must be >= 0 s, got {self.start_offset}")


def replay_plan(read_messages: Callable[[int], Iterable[BagMessage]], bag_start_ns: int,
                timing: ReplayTiming) -> Iterator[tuple[float, BagMessage]]:
    """(due time in s after the replay started, message), in order; endless when looping.

    `read_messages(start_ns)` gives the bag's messages from start_ns on (called once per pass). A
    loop pass starts where the previous one ended; a pass with no message ends the plan, so an
    empty bag or an offset past its end never loops forever.
    """
    first_ns = bag_start_ns + int(round(timing.start_offset * 1e9))
    pass_begins = 0.0
    while True:
        last_due = None
        for message in read_messages(first_ns):
            due = 0.0 if timing.as_fast_as_possible else \
                pass_begins + (message.timestamp_ns - first_ns) * 1e-9 / timing.rate
            last_due = due
            yield due, message
        if last_due is None or not timing.loop:
            return
        pass_begins = last_due


def run_replay(plan: Iterable[tuple[float, BagMessage]], publish: Callable[[BagMessage], None],
               should_stop: Callable[[], bool] = lambda: False, clock: Callable[[], float] = time.monotonic,
               sleep: Callable[[float], None] = time.sleep, max_sleep: float = 0.05) -> int:
    """Publish each planned message when it is due; returns how many were published. Sleeps in
    slices of at most `max_sleep` so that a stop request is seen promptly."""
    started = clock()
    published = 0
    for due, message in plan:
        while not should_stop():
            remaining = started + due - clock()
            if remaining <= 0:
                break
            sleep(min(remaining, max_sleep))
        if should_stop():
            break
        publish(message)
        published += 1
    return published
