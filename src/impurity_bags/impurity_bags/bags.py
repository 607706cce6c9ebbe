"""Bags in the rosbag2 format (MCAP storage, metadata version 9, as ROS 2 Jazzy writes them), without ROS.

The PyPI ROS wheels have no rosbag2, so the cell writes and reads bags with the `rosbags` library; a
ROS install opens the same directories with `ros2 bag`. This module is the pure core of the recorder
and replay nodes (it never imports rclpy):

- `cell_typestore()`: Jazzy's standard message types plus ours, registered from the .msg files;
- `BagWriter`: raw CDR in, a rosbag2 directory out, split into files that are each closed (a complete
  MCAP file) before the next starts, with metadata.yaml rewritten after every closed split, so a
  recorder killed at any moment still leaves a valid bag of everything up to its last split;
- `BagReader`: opens and checks a bag (clear `BagError`s for a missing directory, missing or invalid
  metadata, truncated or corrupted files, unknown message types of the topics read), yields
  `BagMessage`s in time order. Storage connections are matched to metadata.yaml's topics by topic and
  type only: its QoS text may be edited or unreadable (then the storage file's QoS, else the default,
  with a warning in `BagReader.warnings`), never a reason to yield nothing;
- `select_topics()`: which topics a replay plays; those whose types this environment lacks are
  refused when selected (or skipped with `allow_partial`), and named in a warning when not;
- `subscription_request()`: the QoS a recorder requests from the publishers' offers (as rosbag2:
  transient local only if every publisher offers it, best effort if any publisher is best effort);
- `replay_plan()` / `run_replay()`: when each message is due (original timing with a rate factor,
  start offset and loop, or as fast as possible) and the loop that publishes them, with an injectable
  clock so the timing is tested without ROS; `PassCounter` and `BagReader.replay_shortfall()` tell
  whether a finished pass played every message the selected topics hold;
- `with_clock()`: the /clock values of a replay (`ClockTick`s interleaved into its plan): the replayed
  bag time, at a given frequency and at each message's timestamp before the message.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import pathlib
import shutil
import struct
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import yaml
from rosbags.interfaces import Qos, QosDurability, QosReliability
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos
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


def message_type_problem(msgtype: str) -> str | None:
    """None when this ROS environment has the generated Python class of 'pkg/msg/Type' (what rclpy needs
    to publish or subscribe, even raw CDR), else why not. The PyPI wheels lack e.g. tf2_msgs."""
    package, separator, name = msgtype.partition("/msg/")
    if not (package and separator and name):
        return f"'{msgtype}' is not a message type name (pkg/msg/Type)"
    try:
        module = importlib.import_module(f"{package}.msg")
    except ImportError as error:
        return f"unknown message type '{msgtype}' in this ROS environment ({error})"
    if not hasattr(module, name):
        return f"unknown message type '{msgtype}' in this ROS environment ({package}.msg has no {name})"
    return None


def ros_message_class(msgtype: str, topic: str):
    """The generated Python class of 'pkg/msg/Type' (rclpy needs it even for raw CDR publishing)."""
    problem = message_type_problem(msgtype)
    if problem is not None:
        raise BagError(f"topic {topic}: {problem}")
    package, _, name = msgtype.partition("/msg/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


# ------------------------------------------------------------------------------------------- QoS
QOS_KEYS = ("history", "depth", "reliability", "durability", "deadline", "lifespan", "liveliness",
            "liveliness_lease_duration", "avoid_ros_namespace_conventions")


def offered_qos_problem(value) -> str | None:
    """None when a topic's offered_qos_profiles (metadata.yaml: a list of dicts, or before version 9 a
    YAML string of one) reads as QoS profiles with a known reliability and durability, else what is
    wrong with it. Empty means "not recorded", which is fine."""
    if value is None or value == "" or value == []:
        return None
    try:
        items = yaml.safe_load(value) if isinstance(value, str) else value
    except yaml.YAMLError as error:
        return f"not YAML ({' '.join(str(error).split())[:120]})"
    if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
        return f"not a list of QoS profiles: {str(value)[:80]!r}"
    for index, item in enumerate(items):
        if missing := [key for key in QOS_KEYS if key not in item]:
            return f"profile {index} lacks {missing}"
    try:
        profiles = parse_qos(items)
    except Exception as error:  # noqa: BLE001 - rosbags raises key, type and value errors alike
        return f"{type(error).__name__}: {error}"
    for index, (item, profile) in enumerate(zip(items, profiles, strict=True)):
        if profile.reliability == QosReliability.UNKNOWN:
            return f"profile {index}: reliability {item['reliability']!r} is not a QoS reliability"
        if profile.durability == QosDurability.UNKNOWN:
            return f"profile {index}: durability {item['durability']!r} is not a QoS durability"
    return None


def qos_words(qos: Sequence[Qos]) -> str:
    """'reliable, transient_local' for the profiles' reliability and durability (each distinct once)."""
    if not qos:
        return "none recorded"
    words = dict.fromkeys(f"{q.reliability.name.lower()}, {q.durability.name.lower()}" for q in qos)
    return " / ".join(words)


def subscription_request(offers: Sequence[Qos]) -> tuple[QosReliability, QosDurability]:
    """The reliability and durability a recorder requests so that it receives from every offering
    publisher, as rosbag2 adapts them: reliable unless a publisher is best effort (a reliable request
    matches no best-effort publisher), transient local only if every publisher offers it (a
    transient-local request matches no volatile publisher) so that a latched message published
    before the recorder subscribed is still delivered. No offers: reliable, volatile."""
    reliable = all(q.reliability == QosReliability.RELIABLE for q in offers)
    latched = bool(offers) and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in offers)
    return (QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
            QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE)


def weakened_request(request: tuple[QosReliability, QosDurability],
                     offers: Sequence[Qos]) -> tuple[QosReliability, QosDurability]:
    """`request` weakened just enough to receive from `offers` too, never strengthened (a volatile
    subscription turned transient local would record a latched history a second time)."""
    reliability, durability = subscription_request(offers)
    return (request[0] if reliability == QosReliability.RELIABLE else QosReliability.BEST_EFFORT,
            request[1] if durability == QosDurability.TRANSIENT_LOCAL else QosDurability.VOLATILE)


def request_misses(request: tuple[QosReliability, QosDurability], offer: Qos) -> list[str]:
    """Why a subscription with `request` receives nothing from a publisher offering `offer` ([] if it
    does): DDS matches a request only with an offer at least as strong."""
    reliability, durability = request
    reasons = []
    if reliability == QosReliability.RELIABLE and offer.reliability != QosReliability.RELIABLE:
        reasons.append(f"it offers {offer.reliability.name.lower()}, the subscription requests reliable")
    if durability == QosDurability.TRANSIENT_LOCAL and offer.durability != QosDurability.TRANSIENT_LOCAL:
        reasons.append(f"it offers {offer.durability.name.lower()}, the subscription requests "
                       "transient_local")
    return reasons


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

    Checks on open: the directory and metadata.yaml exist and parse, every listed file exists and is a
    complete MCAP file (rosbags checks the magic, footer and summary), the SHA-256 recorded by BagWriter
    matches (bit flips anywhere), and with a typestore, the types of `topics` (all when None) are known.

    A topic's offered_qos_profiles in metadata.yaml that cannot be read (edited, not YAML, unknown
    policies) never stops the bag from opening or playing: the topic's QoS is then the one the storage
    file records for its channel, else none (a replay's default), and `warnings` says so. Messages are
    read by topic and type; the QoS text takes no part in finding them.
    """

    def __init__(self, path: str | os.PathLike, typestore: Typestore | None = None,
                 topics: Iterable[str] | None = None):
        self.path = pathlib.Path(path)
        self.warnings: list[str] = []  # what the reader worked around; a node logs them
        self._reader = None
        self._view: tempfile.TemporaryDirectory | None = None
        if not self.path.exists():
            raise BagError(f"bag {self.path} does not exist")
        if not self.path.is_dir():
            raise BagError(f"bag {self.path} is a file; a rosbag2 bag is a directory with {METADATA_FILE}")
        if not (self.path / METADATA_FILE).is_file():
            raise BagError(f"bag {self.path} has no {METADATA_FILE} (not a rosbag2 directory, or the "
                           "recorder was killed before it closed its first split)")
        try:
            metadata = self._load_metadata()
            qos_problems = self._qos_problems(metadata)
            self._open(metadata, qos_problems)
            self._check_checksums(metadata)
            self.topics = {
                topic: TopicInfo(info.msgtype, info.msgcount,
                                 tuple(q for c in info.connections for q in c.ext.offered_qos_profiles))
                for topic, info in self._reader.topics.items()}
            for topic, problem in qos_problems.items():
                self._fall_back_qos(topic, problem)
            if typestore is not None:
                for topic in (self.topics if topics is None else topics):
                    if topic in self.topics:
                        check_known_type(typestore, self.topics[topic].msgtype, topic)
        except BaseException:
            self.close()
            raise

    # ---- opening
    def _load_metadata(self) -> dict | None:
        """metadata.yaml's rosbag2_bagfile_information, or None when it does not parse (rosbags then
        reports what is wrong when it opens the bag)."""
        try:
            info = yaml.safe_load((self.path / METADATA_FILE).read_text())["rosbag2_bagfile_information"]
        except (yaml.YAMLError, TypeError, KeyError):
            return None
        return info if isinstance(info, dict) else None

    def _qos_problems(self, metadata: dict | None) -> dict[str, str]:
        """topic -> what is wrong with its offered_qos_profiles in metadata.yaml."""
        problems = {}
        entries = (metadata or {}).get("topics_with_message_count")
        for entry in entries if isinstance(entries, list) else []:
            try:
                topic_metadata = entry["topic_metadata"]
                problem = offered_qos_problem(topic_metadata.get("offered_qos_profiles"))
                if problem is not None:
                    problems[str(topic_metadata["name"])] = problem
            except (TypeError, KeyError, AttributeError):
                continue  # a malformed entry: rosbags names it when it opens the bag
        return problems

    def _open(self, metadata: dict | None, qos_problems: dict[str, str]) -> None:
        """Open with rosbags; with unreadable QoS text, through a view of the bag (a scratch directory:
        metadata.yaml without that text, links to the storage files), never changing the bag."""
        if metadata is not None and isinstance(metadata.get("relative_file_paths"), list):
            missing = [name for name in metadata["relative_file_paths"]
                       if not (self.path / pathlib.PurePath(str(name)).name).exists()]
            if missing:
                raise BagError(f"bag {self.path} cannot be opened: storage file(s) {missing} listed in "
                               f"{METADATA_FILE} are missing")
        source = self.path
        if qos_problems and isinstance(metadata.get("relative_file_paths"), list):
            self._view = tempfile.TemporaryDirectory(prefix="bag_view_")
            source = pathlib.Path(self._view.name)
            for entry in metadata["topics_with_message_count"]:
                if str(entry["topic_metadata"]["name"]) in qos_problems:
                    entry["topic_metadata"]["offered_qos_profiles"] = []
            (source / METADATA_FILE).write_text(
                yaml.safe_dump({"rosbag2_bagfile_information": metadata}, sort_keys=False))
            for name in metadata["relative_file_paths"]:
                name = pathlib.PurePath(str(name)).name
                (source / name).symlink_to((self.path / name).resolve())
        reader = Reader(source)
        try:
            reader.open()
        except Exception as error:  # noqa: BLE001 - rosbags raises ReaderError, struct/OS/key errors
            raise BagError(f"bag {self.path} cannot be opened: {type(error).__name__}: {error}") from error
        self._reader = reader

    def _fall_back_qos(self, topic: str, problem: str) -> None:
        if topic not in self.topics:
            return
        stored = tuple(dict.fromkeys(q for c in self._storage_connections([topic])
                                     for q in c.ext.offered_qos_profiles))
        usable = bool(stored) and all(q.reliability != QosReliability.UNKNOWN
                                      and q.durability != QosDurability.UNKNOWN for q in stored)
        info = self.topics[topic]
        self.topics[topic] = TopicInfo(info.msgtype, info.message_count, stored if usable else ())
        fallback = (f"using the QoS its storage file records ({qos_words(stored)})" if usable else
                    "no QoS recorded elsewhere: a replay publishes it with its default (reliable, volatile)")
        self.warnings.append(f"bag {self.path}: offered_qos_profiles of {topic} in {METADATA_FILE} cannot be "
                             f"read ({problem}); {fallback}. Correct it in {self.path / METADATA_FILE} "
                             "to change this")

    # ---- what the bag holds
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

    def _storage_connections(self, topics: Iterable[str], same_type: bool = True) -> list:
        """The storage files' connections (MCAP channels) of `topics`, matched by topic and, with
        `same_type`, by the type metadata.yaml gives (without: the channels of any other type)."""
        wanted = set(topics)
        return [connection for storage in self._reader.storage.storages for connection in storage.connections
                if connection.topic in wanted and connection.topic in self.topics
                and (connection.msgtype == self.topics[connection.topic].msgtype) == same_type]

    def storage_counts(self, topics: Iterable[str] | None = None) -> dict[str, int]:
        """Messages per topic that the storage files' indexes list (metadata.yaml may say otherwise)."""
        selected = list(self.topics if topics is None else topics)
        counts = dict.fromkeys(selected, 0)
        for connection in self._storage_connections(selected):
            counts[connection.topic] += connection.msgcount
        return counts

    def messages(self, topics: Iterable[str] | None = None, start_ns: int | None = None,
                 stop_ns: int | None = None) -> Iterator[BagMessage]:
        """Messages in time order, optionally only some topics and only in [start_ns, stop_ns)."""
        connections = self._storage_connections(self.topics if topics is None else topics)
        if not connections:  # rosbags reads every connection when given none
            return
        try:
            for connection, timestamp, data in self._reader.messages(connections, start_ns, stop_ns):
                yield BagMessage(connection.topic, connection.msgtype, timestamp, bytes(data))
        except Exception as error:  # noqa: BLE001 - a damaged chunk surfaces as any parsing error
            raise BagError(f"bag {self.path} is damaged: {type(error).__name__}: {error}") from error

    def replay_shortfall(self, topics: Sequence[str], first_ns: int, played: Mapping[str, int]) -> str | None:
        """None when a pass from `first_ns` on played (`played`: messages per topic) every message that
        metadata.yaml counts for `topics` from there on; else how many of how many, per topic, and why."""
        before = Counter(m.topic for m in self.messages(topics, stop_ns=first_ns)) \
            if self.message_count and first_ns > self.start_ns else Counter()
        held = {topic: max(self.topics[topic].message_count - before[topic], 0) for topic in topics}
        short = [topic for topic in topics if played.get(topic, 0) < held[topic]]
        if not short:
            return None
        stored = self.storage_counts(short)
        reasons = []
        for topic in short:
            counted = self.topics[topic].message_count
            other_types = sorted({c.msgtype for c in self._storage_connections([topic], same_type=False)})
            if other_types:
                reasons.append(f"{topic} is recorded as {other_types} in the storage file(s) but as "
                               f"{self.topics[topic].msgtype} in {METADATA_FILE}")
            elif stored[topic] < counted:
                reasons.append(f"the storage file(s) listed in {METADATA_FILE} hold {stored[topic]} of the "
                               f"{counted} message(s) it counts for {topic} (a split missing from "
                               "relative_file_paths, or edited counts)")
            else:
                reasons.append(f"{topic}: the storage file(s) list its messages but {played.get(topic, 0)} "
                               f"of {held[topic]} could be read")
        total_played = sum(min(played.get(topic, 0), held[topic]) for topic in topics)
        per_topic = ", ".join(f"{topic} {played.get(topic, 0)} of {held[topic]}" for topic in short)
        return (f"bag {self.path}: played {total_played} of the {sum(held.values())} message(s) the selected "
                f"topic(s) hold ({per_topic}): {'; '.join(reasons)}")

    def close(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()
        view, self._view = self._view, None
        if view is not None:
            view.cleanup()

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _check_checksums(self, metadata: dict | None) -> None:
        """Every listed storage file whose SHA-256 BagWriter recorded (other recorders record none)."""
        names = (metadata or {}).get("relative_file_paths") or []
        listed = {pathlib.PurePath(str(name)).name for name in names}
        for key, expected in self.custom_data.items():
            if not key.startswith(CHECKSUM_PREFIX) or key[len(CHECKSUM_PREFIX):] not in listed:
                continue
            name = key[len(CHECKSUM_PREFIX):]
            actual = file_sha256(self.path / name)
            if actual != expected:
                raise BagError(f"bag {self.path}: {name} is corrupted (SHA-256 {actual[:12]}… differs from "
                               f"the recorded {expected[:12]}…)")


# ------------------------------------------------------------------------------------ topic choice
@dataclass(frozen=True)
class TopicSelection:
    """What a replay plays, and what it says about the rest."""

    play: tuple[str, ...]
    warnings: tuple[str, ...] = ()  # topics left out that someone may have wanted
    notes: tuple[str, ...] = ()  # topics left out on purpose (not in `topics`)


def select_topics(bag: str | os.PathLike, topics: Mapping[str, TopicInfo], wanted: Sequence[str],
                  type_problem: Callable[[str], str | None] = message_type_problem,
                  allow_partial: bool = False) -> TopicSelection:
    """The topics to play: `wanted` (all the bag's when empty). Only the types of those are checked
    (`type_problem(msgtype)`: None, or why this environment cannot publish it). A chosen topic that
    cannot be played is refused, or skipped with a warning when `allow_partial`; an unchosen one whose
    type is missing here is named in a warning; BagError when nothing is left to play."""
    chosen = list(dict.fromkeys(topic for topic in wanted if topic))
    explicit = bool(chosen)
    if explicit:
        missing = [topic for topic in chosen if topic not in topics]
        if missing:
            raise BagError(f"bag {bag} has no topic(s) {missing}; it has {sorted(topics)} (parameter topics)")
    else:
        chosen = list(topics)
    problems = {topic: problem for topic in topics if (problem := type_problem(topics[topic].msgtype))}

    def described(names: Sequence[str]) -> str:
        return "; ".join(f"{topic} ({topics[topic].msgtype}, {topics[topic].message_count} message(s)): "
                         f"{problems[topic]}" for topic in names)

    unplayable = [topic for topic in chosen if topic in problems]
    play = [topic for topic in chosen if topic not in problems]
    if not play:
        raise BagError(f"bag {bag}: nothing to play: {described(unplayable) or 'it has no topics'}")
    warnings, notes = [], []
    if unplayable:
        if not allow_partial:
            choose = "leave them out of topics" if explicit else \
                "choose the topics to play with topics:=[...]"
            raise BagError(f"bag {bag}: cannot play {len(unplayable)} of the {len(chosen)} selected "
                           f"topic(s): {described(unplayable)}. {choose}, or set allow_partial:=true to play "
                           f"the other {len(play)} without them")
        warnings.append(f"not playing {described(unplayable)} (allow_partial is true)")
    others = [topic for topic in topics if topic not in chosen]
    if unknown := [topic for topic in others if topic in problems]:
        warnings.append(f"not playing {described(unknown)} (not in topics)")
    if rest := [topic for topic in others if topic not in problems]:
        notes.append(f"not playing {rest} (not in topics)")
    return TopicSelection(tuple(play), tuple(warnings), tuple(notes))


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

    def first_ns(self, bag_start_ns: int) -> int:
        """Timestamp of the first message a pass plays (from the start offset on)."""
        return bag_start_ns + int(round(self.start_offset * 1e9))


def replay_plan(read_messages: Callable[[int], Iterable[BagMessage]], bag_start_ns: int,
                timing: ReplayTiming) -> Iterator[tuple[float, BagMessage]]:
    """(due time in s after the replay started, message), in order; endless when looping.

    `read_messages(start_ns)` gives the bag's messages from start_ns on (called once per pass). A
    loop pass starts where the previous one ended; a pass with no message ends the plan, so an
    empty bag or an offset past its end never loops forever.
    """
    first_ns = timing.first_ns(bag_start_ns)
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


class PassCounter:
    """Wraps replay_plan's `read_messages`: counts per topic the messages of the first pass, and knows
    whether that pass was read to its end (not stopped half way), so that it can be checked."""

    def __init__(self, read_messages: Callable[[int], Iterable[BagMessage]]):
        self._read_messages = read_messages
        self.counts: Counter[str] = Counter()
        self.first_pass_done = False
        self._passes = 0

    def __call__(self, start_ns: int) -> Iterable[BagMessage]:
        self._passes += 1
        messages = self._read_messages(start_ns)
        return self._count(messages) if self._passes == 1 else messages

    def _count(self, messages: Iterable[BagMessage]) -> Iterator[BagMessage]:
        for message in messages:
            self.counts[message.topic] += 1
            yield message
        self.first_pass_done = True


class ClockTick(NamedTuple):
    """A /clock value in a replay plan: the replayed bag time, ns since the epoch."""

    time_ns: int


def with_clock(plan: Iterable[tuple[float, BagMessage]], bag_start_ns: int, timing: ReplayTiming,
               frequency: float) -> Iterator[tuple[float, BagMessage | ClockTick]]:
    """`plan` (replay_plan's, same timing) with the /clock values of the replay interleaved, in due order.

    The clock starts at the replay's first time (`timing.first_ns(bag_start_ns)`) at due 0 and advances
    `timing.rate` s of bag time per s of replay from the last message's timestamp, a tick every
    1 / `frequency` s of replay (none between messages when `frequency` is 0; never past the next
    message's timestamp); each message is preceded by a tick of its own timestamp, so a node on this
    clock has reached a message's time when the message arrives. As fast as possible (every message
    due at 0, acknowledgements setting the pace) the clock thus steps from message to message; a
    loop's next pass takes it back to the pass's first timestamp, as `ros2 bag play --clock --loop`.
    A value equal to the tick before it is not repeated.
    """
    if not frequency >= 0:
        raise ValueError(f"clock frequency must be >= 0 Hz, got {frequency}")
    period = 1.0 / frequency if frequency > 0 else float("inf")
    last_due, last_ns = 0.0, timing.first_ns(bag_start_ns)
    yield 0.0, ClockTick(last_ns)
    ticked_ns = last_ns
    index = 1  # of the next periodic tick, due at index * period
    for due, message in plan:
        while index * period < due:
            value = last_ns + round((index * period - last_due) * timing.rate * 1e9)
            if message.timestamp_ns >= last_ns:
                value = min(value, message.timestamp_ns)
            if value != ticked_ns:
                yield index * period, ClockTick(value)
                ticked_ns = value
            index += 1
        if message.timestamp_ns != ticked_ns:
            yield due, ClockTick(message.timestamp_ns)
            ticked_ns = message.timestamp_ns
        yield due, message
        last_due, last_ns = due, message.timestamp_ns


def run_replay(plan: Iterable[tuple[float, BagMessage | ClockTick]], publish: Callable[[BagMessage], None],
               should_stop: Callable[[], bool] = lambda: False, clock: Callable[[], float] = time.monotonic,
               sleep: Callable[[float], None] = time.sleep, max_sleep: float = 0.05,
               tick: Callable[[int], None] | None = None) -> int:
    """Publish each planned message when it is due, and give each `ClockTick` (with_clock's) to `tick`
    (its time in ns); returns how many messages were published. Sleeps in slices of at most
    `max_sleep` so that a stop request is seen promptly."""
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
        if isinstance(message, ClockTick):
            if tick is None:
                raise ValueError("a plan with clock ticks needs `tick`")
            tick(message.time_ns)
            continue
        publish(message)
        published += 1
    return published
