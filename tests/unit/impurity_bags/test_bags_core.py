"""Bag core without ROS: typestore, split writer, checked reader (rosbags and mcap readers), replay timing,
which topics a replay plays, partial replays, edited QoS metadata, the QoS a recorder requests."""

import json
import pathlib

import pytest
import yaml
from bag_helpers import (
    COLOR,
    GADGET,
    GADGET_TYPE,
    INFO,
    PRIMITIVE,
    STRING,
    TF,
    TF_TYPE,
    garbled_qos,
    primitive_cdr,
    read_with_mcap_library,
    set_offered_qos,
    string_cdr,
    unlist_split,
    write_camera_bag,
    write_sample_bag,
)
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from impurity_bags.bags import (
    BagError,
    BagMessage,
    BagReader,
    BagWriter,
    ClockTick,
    PassCounter,
    ReplayTiming,
    cell_typestore,
    header_stamp_ns,
    interface_msg_dir,
    message_type_problem,
    replay_plan,
    request_misses,
    run_replay,
    select_topics,
    subscription_request,
    weakened_request,
    with_clock,
)


@pytest.fixture(scope="module")
def typestore():
    return cell_typestore()


# ---------------------------------------------------------------------------------------- types
def test_our_types_are_registered_with_the_hashes_rosidl_generated(typestore):
    """Same RIHS01 as the installed .json type descriptions: `ros2 bag` on a ROS install accepts them."""
    msg_dir = interface_msg_dir()
    names = sorted(p.stem for p in msg_dir.glob("*.msg"))
    assert {"Heightmap", "AttentionResult", "Primitive", "EpisodeStep"} <= set(names)
    for name in names:
        description = json.loads((msg_dir / f"{name}.json").read_text())
        expected = description["type_hashes"][0]["hash_string"]
        assert typestore.hash_rihs01(f"impurity_interfaces/msg/{name}") == expected, name
    assert "sensor_msgs/msg/Image" in typestore.fielddefs


# ---------------------------------------------------------------------------------- round trips
def test_written_bag_reads_back_with_rosbags_and_the_mcap_library(tmp_path, typestore):
    bag = tmp_path / "sample"
    written = write_sample_bag(bag, typestore, count=30, split_duration_ns=100_000_000)

    with BagReader(bag, typestore) as reader:
        assert reader.message_count == 30
        assert reader.ros_distro == "jazzy"
        assert reader.topics["/chatter"].message_count == 15
        assert reader.topics["/policy/primitive"].msgtype == PRIMITIVE
        assert (reader.start_ns, reader.end_ns) == (written[0].timestamp_ns, written[-1].timestamp_ns)
        assert list(reader.messages()) == written
        assert [m.data for m in reader.messages(["/chatter"])] == [m.data for m in written[::2]]

    assert read_with_mcap_library(bag) == written
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["version"] == 9 and metadata["storage_identifier"] == "mcap"
    assert len(metadata["relative_file_paths"]) == 3  # 300 ms of messages in 100 ms splits
    assert metadata["relative_file_paths"][0] == "sample_0.mcap"


def test_messages_deserialize_to_what_was_written(tmp_path, typestore):
    bag = tmp_path / "sample"
    write_sample_bag(bag, typestore, count=4)
    with BagReader(bag, typestore) as reader:
        decoded = [typestore.deserialize_cdr(m.data, m.msgtype) for m in reader.messages()]
    assert decoded[0].data == "hello 0"
    assert decoded[1].pixel_col == 111 and decoded[1].header.frame_id == "base_link"


def test_a_writer_that_is_never_closed_leaves_a_valid_bag_of_its_closed_splits(tmp_path, typestore):
    """What a SIGKILL leaves: the open split is lost, everything before it reads back."""
    bag = tmp_path / "killed"
    writer = BagWriter(bag, typestore, split_duration_ns=50)
    writer.add_topic("/chatter", STRING)
    for i in range(10):
        writer.write("/chatter", 1000 + 20 * i, string_cdr(typestore, str(i)))
    # no close(): 10 messages over 180 ns in 50 ns splits -> splits [0..2], [3..5], [6..8] closed, [9] open
    with BagReader(bag, typestore) as reader:
        assert [typestore.deserialize_cdr(m.data, STRING).data for m in reader.messages()] == \
            [str(i) for i in range(9)]
    assert len(read_with_mcap_library(bag)) == 9


def test_an_empty_recording_is_a_valid_empty_bag(tmp_path, typestore):
    with BagWriter(tmp_path / "empty", typestore) as writer:
        writer.add_topic("/chatter", STRING)
    with BagReader(tmp_path / "empty", typestore) as reader:
        assert reader.message_count == 0 and list(reader.messages()) == []


def test_writer_refusals(tmp_path, typestore):
    existing = tmp_path / "existing"
    existing.mkdir()
    with pytest.raises(BagError, match="already exists"):
        BagWriter(existing, typestore)
    with BagWriter(tmp_path / "new", typestore) as writer:
        with pytest.raises(BagError, match="unknown message type 'my_pkg/msg/Thing'"):
            writer.add_topic("/thing", "my_pkg/msg/Thing")
        with pytest.raises(BagError, match="was not added"):
            writer.write("/chatter", 1, string_cdr(typestore, "x"))


# ---------------------------------------------------------------------------------- broken bags
@pytest.fixture
def sample_bag(tmp_path, typestore) -> pathlib.Path:
    bag = tmp_path / "sample"
    write_sample_bag(bag, typestore, count=20)
    return bag


def drop_checksums(bag: pathlib.Path) -> None:
    """As if the bag came from another recorder: no SHA-256 to compare with."""
    path = bag / "metadata.yaml"
    metadata = yaml.safe_load(path.read_text())
    metadata["rosbag2_bagfile_information"]["custom_data"] = None
    path.write_text(yaml.safe_dump(metadata))


def test_missing_bag_and_not_a_directory(tmp_path, sample_bag):
    with pytest.raises(BagError, match="does not exist"):
        BagReader(tmp_path / "nowhere")
    with pytest.raises(BagError, match="is a file"):
        BagReader(sample_bag / "sample_0.mcap")


def test_missing_and_invalid_metadata(sample_bag):
    metadata = sample_bag / "metadata.yaml"
    good = metadata.read_text()
    metadata.write_text("rosbag2_bagfile_information: [unclosed")
    with pytest.raises(BagError, match="cannot be opened.*YAML"):
        BagReader(sample_bag)
    metadata.write_text(good.replace("relative_file_paths", "relative_paths"))
    with pytest.raises(BagError, match="cannot be opened.*relative_file_paths"):
        BagReader(sample_bag)
    metadata.unlink()
    with pytest.raises(BagError, match="has no metadata.yaml"):
        BagReader(sample_bag)


def test_missing_storage_file(sample_bag):
    (sample_bag / "sample_0.mcap").unlink()
    with pytest.raises(BagError, match="missing"):
        BagReader(sample_bag)


@pytest.mark.parametrize("keep_checksums", [True, False])
def test_truncated_mcap_file(sample_bag, keep_checksums):
    if not keep_checksums:
        drop_checksums(sample_bag)
    storage = sample_bag / "sample_0.mcap"
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) // 2])
    with pytest.raises(BagError, match="cannot be opened.*end magic"):
        BagReader(sample_bag)


def test_corrupted_bytes_are_caught_by_the_checksum(sample_bag):
    storage = sample_bag / "sample_0.mcap"
    data = bytearray(storage.read_bytes())
    data[len(data) // 3] ^= 0xFF  # one flipped byte inside a message: invisible to MCAP's structure
    storage.write_bytes(bytes(data))
    with pytest.raises(BagError, match="sample_0.mcap is corrupted"):
        BagReader(sample_bag)


def test_corrupted_structure_without_checksums(sample_bag):
    drop_checksums(sample_bag)
    storage = sample_bag / "sample_0.mcap"
    data = bytearray(storage.read_bytes())
    data[:8] = b"NOTMCAP!"
    storage.write_bytes(bytes(data))
    with pytest.raises(BagError, match="cannot be opened.*magic"):
        BagReader(sample_bag)


def test_unknown_message_type_in_a_bag(tmp_path, typestore):
    foreign = get_typestore(Stores.ROS2_JAZZY)
    foreign.register(get_types_from_msg("int32 value", "other_pkg/msg/Gadget"))
    bag = tmp_path / "foreign"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/gadget", "other_pkg/msg/Gadget", typestore=foreign)
        writer.write(connection, 5, b"\x00\x01\x00\x00\x07\x00\x00\x00")
    with pytest.raises(BagError, match="unknown message type 'other_pkg/msg/Gadget' on topic /gadget"):
        BagReader(bag, typestore)
    with BagReader(bag) as reader:  # without a typestore, only the structure is checked
        assert reader.message_count == 1


# ---------------------------------------------------------------------------------------- replay
def stamped(*times_ms) -> list[BagMessage]:
    return [BagMessage("/t", STRING, 1_000_000_000 + int(t * 1e6), b"") for t in times_ms]


def reader_of(messages):
    return lambda start_ns: [m for m in messages if m.timestamp_ns >= start_ns]


def dues(plan, limit=100):
    out = []
    for due, _ in plan:
        out.append(round(due, 6))
        if len(out) >= limit:
            break
    return out


def test_original_timing_scaled_by_rate():
    messages = stamped(0, 100, 300)
    bag_start = messages[0].timestamp_ns
    assert dues(replay_plan(reader_of(messages), bag_start, ReplayTiming())) == [0.0, 0.1, 0.3]
    assert dues(replay_plan(reader_of(messages), bag_start, ReplayTiming(rate=2.0))) == [0.0, 0.05, 0.15]


def test_start_offset_skips_the_beginning_and_loop_repeats_from_the_offset():
    messages = stamped(0, 100, 300)
    plan = replay_plan(reader_of(messages), messages[0].timestamp_ns,
                       ReplayTiming(start_offset=0.1, loop=True))
    assert dues(plan, limit=6) == [0.0, 0.2, 0.2, 0.4, 0.4, 0.6]


def test_as_fast_as_possible_is_all_due_at_once():
    messages = stamped(0, 100, 300)
    plan = replay_plan(reader_of(messages), messages[0].timestamp_ns, ReplayTiming(as_fast_as_possible=True))
    assert dues(plan) == [0.0, 0.0, 0.0]


def test_looping_an_empty_selection_ends():
    messages = stamped(0, 100)
    timing = ReplayTiming(start_offset=5.0, loop=True)
    plan = replay_plan(reader_of(messages), messages[0].timestamp_ns, timing)
    assert dues(plan) == []


@pytest.mark.parametrize("bad", [dict(rate=0.0), dict(rate=-1.0), dict(rate=float("nan")),
                                 dict(start_offset=-1.0)])
def test_bad_timing_is_refused(bad):
    with pytest.raises(ValueError):
        ReplayTiming(**bad)


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now

    def sleep(self, seconds):
        assert seconds > 0
        self.now += seconds


def test_run_replay_publishes_each_message_when_due():
    clock = FakeClock()
    published = []
    messages = stamped(0, 100, 300)
    plan = replay_plan(reader_of(messages), messages[0].timestamp_ns, ReplayTiming(rate=0.5))
    count = run_replay(plan, lambda m: published.append((round(clock.now - 100.0, 6), m)),
                       clock=clock, sleep=clock.sleep)
    assert count == 3
    assert published == [(0.0, messages[0]), (0.2, messages[1]), (0.6, messages[2])]


def test_run_replay_stops_promptly_when_asked():
    clock = FakeClock()
    published = []
    messages = stamped(0, 100, 10_000)
    plan = replay_plan(reader_of(messages), messages[0].timestamp_ns, ReplayTiming(loop=True))
    count = run_replay(plan, published.append, should_stop=lambda: clock.now > 100.5,
                       clock=clock, sleep=clock.sleep, max_sleep=0.05)
    assert count == 2 and clock.now < 100.6


# ---------------------------------------------------------------------------------------- /clock
SECOND = 1_000_000_000
BAG_START = SECOND  # stamped()'s first time


def clock_schedule(messages, timing, frequency, limit=100):
    """with_clock's plan as (due s, "clock", bag time ns offset from BAG_START) and (due s, "message",
    its timestamp offset from BAG_START)."""
    out = []
    plan = with_clock(replay_plan(reader_of(messages), messages[0].timestamp_ns, timing),
                      messages[0].timestamp_ns, timing, frequency)
    for due, item in plan:
        if isinstance(item, ClockTick):
            out.append((round(due, 6), "clock", item.time_ns - BAG_START))
        else:
            out.append((round(due, 6), "message", item.timestamp_ns - BAG_START))
        if len(out) >= limit:
            break
    return out


def test_the_clock_starts_at_the_bags_time_and_runs_rate_times_as_fast_as_the_replay():
    ms = 1_000_000
    schedule = clock_schedule(stamped(0, 100, 300), ReplayTiming(rate=2.0), frequency=20.0)
    assert schedule == [
        (0.0, "clock", 0), (0.0, "message", 0),
        (0.05, "clock", 100 * ms), (0.05, "message", 100 * ms),
        (0.1, "clock", 200 * ms),  # 0.05 s of replay after the message at 100 ms: 100 ms of bag time
        (0.15, "clock", 300 * ms), (0.15, "message", 300 * ms),
    ]


def test_every_clock_value_is_the_replayed_bag_time_and_never_goes_back():
    messages = stamped(0, 130, 170, 420, 1000)
    schedule = clock_schedule(messages, ReplayTiming(rate=0.5), frequency=100.0, limit=1000)
    ticks = [(due, value) for due, kind, value in schedule if kind == "clock"]
    assert len(ticks) > 150  # 2 s of replay at 100 Hz
    for due, value in ticks:
        assert value == pytest.approx(due * 0.5 * SECOND, abs=1000)
    values = [value for _, value in ticks]
    assert values == sorted(values) and len(set(values)) == len(values)


def test_each_message_is_preceded_by_a_tick_of_its_own_timestamp():
    schedule = clock_schedule(stamped(0, 130, 170, 420), ReplayTiming(rate=3.0), frequency=7.0)
    for index, (_, kind, value) in enumerate(schedule):
        if kind == "message":
            clock_before = [v for _, k, v in schedule[:index] if k == "clock"][-1]
            assert clock_before == value


def test_the_clock_starts_at_the_start_offset():
    schedule = clock_schedule(stamped(0, 100, 300), ReplayTiming(start_offset=0.05), frequency=0.0)
    assert schedule[0] == (0.0, "clock", 50_000_000)
    assert schedule[1] == (0.05, "clock", 100_000_000)  # the first message played


def test_as_fast_as_possible_the_clock_steps_to_each_message_before_it():
    ms = 1_000_000
    schedule = clock_schedule(stamped(0, 100, 300), ReplayTiming(as_fast_as_possible=True), frequency=40.0)
    assert schedule == [(0.0, "clock", 0), (0.0, "message", 0),
                        (0.0, "clock", 100 * ms), (0.0, "message", 100 * ms),
                        (0.0, "clock", 300 * ms), (0.0, "message", 300 * ms)]


def test_without_a_frequency_the_clock_ticks_only_at_the_messages():
    schedule = clock_schedule(stamped(0, 100, 300), ReplayTiming(), frequency=0.0)
    assert [kind for _, kind, _ in schedule] == ["clock", "message"] * 3


def test_a_looped_pass_takes_the_clock_back_to_its_first_timestamp():
    schedule = clock_schedule(stamped(0, 100), ReplayTiming(loop=True), frequency=0.0, limit=8)
    assert [value for _, kind, value in schedule if kind == "clock"] == [0, 100_000_000, 0, 100_000_000]


def test_a_negative_clock_frequency_is_refused():
    with pytest.raises(ValueError):
        list(clock_schedule(stamped(0, 100), ReplayTiming(), frequency=-1.0))


def test_run_replay_gives_the_ticks_to_the_clock_and_counts_only_messages():
    clock = FakeClock()
    published, ticks = [], []
    messages = stamped(0, 100)
    timing = ReplayTiming()
    plan = with_clock(replay_plan(reader_of(messages), BAG_START, timing), BAG_START, timing, 20.0)
    count = run_replay(plan, published.append, clock=clock, sleep=clock.sleep,
                       tick=lambda ns: ticks.append((round(clock.now - 100.0, 6), ns - BAG_START)))
    assert count == 2 and published == messages
    assert ticks == [(0.0, 0), (0.05, 50_000_000), (0.1, 100_000_000)]


def test_header_stamp_is_read_from_the_cdr_bytes(typestore):
    assert header_stamp_ns(primitive_cdr(typestore, 3)) == 3_000_000_007  # sec 3, nanosec 7
    assert header_stamp_ns(b"\x00\x01\x00") is None
    assert header_stamp_ns(b"\x07" * 16) is None


def test_custom_data_is_kept_beside_the_checksums(tmp_path, typestore):
    with BagWriter(tmp_path / "noted", typestore, custom_data={"impurity.policy": "untrained"}) as writer:
        writer.add_topic("/chatter", STRING)
        writer.write("/chatter", 1, string_cdr(typestore, "x"))
    with BagReader(tmp_path / "noted") as reader:
        assert reader.custom_data["impurity.policy"] == "untrained"
        assert "sha256:noted_0.mcap" in reader.custom_data


# ---------------------------------------------------------------- topics of types this environment lacks
@pytest.fixture
def camera_bag(tmp_path):
    bag = tmp_path / "camera"
    return bag, write_camera_bag(bag)


def test_a_reader_checks_only_the_types_of_the_topics_it_reads(camera_bag, typestore):
    bag, written = camera_bag
    with BagReader(bag, typestore, topics=[COLOR, INFO]) as reader:
        assert [m.data for m in reader.messages([COLOR])] == written[COLOR]
        assert [m.data for m in reader.messages([INFO])] == written[INFO]
    with pytest.raises(BagError, match=f"unknown message type '{GADGET_TYPE}' on topic {GADGET}"):
        BagReader(bag, typestore)  # every topic read: the custom type is refused, naming it


def test_replaying_chosen_topics_skips_the_rest_naming_those_whose_types_are_missing(camera_bag):
    bag, _ = camera_bag
    with BagReader(bag) as reader:
        selection = select_topics(bag, reader.topics, [COLOR, INFO])
    assert selection.play == (COLOR, INFO)
    warning = " ".join(selection.warnings)
    assert f"{GADGET} ({GADGET_TYPE}, 1 message(s)): unknown message type '{GADGET_TYPE}'" in warning
    assert "(not in topics)" in warning
    assert (f"{TF} ({TF_TYPE}" in warning) == (message_type_problem(TF_TYPE) is not None)


def test_replaying_every_topic_is_refused_naming_the_missing_types_and_the_options(camera_bag):
    bag, _ = camera_bag
    with BagReader(bag) as reader:
        topics = reader.topics
    with pytest.raises(BagError) as refusal:
        select_topics(bag, topics, [""])  # the parameter's default: every topic
    assert f"{GADGET} ({GADGET_TYPE}" in str(refusal.value)
    assert "topics:=[...]" in str(refusal.value) and "allow_partial:=true" in str(refusal.value)

    selection = select_topics(bag, topics, [""], allow_partial=True)
    assert set(selection.play) == {COLOR, INFO} | ({TF} if message_type_problem(TF_TYPE) is None else set())
    assert GADGET in " ".join(selection.warnings) and "allow_partial is true" in " ".join(selection.warnings)


def test_topic_choice_refusals(camera_bag):
    bag, _ = camera_bag
    with BagReader(bag) as reader:
        topics = reader.topics
    with pytest.raises(BagError, match=r"cannot play 1 of the 2 selected topic\(s\).*leave them out of"):
        select_topics(bag, topics, [COLOR, GADGET])
    assert select_topics(bag, topics, [COLOR, GADGET], allow_partial=True).play == (COLOR,)
    with pytest.raises(BagError, match=f"nothing to play: {GADGET}"):
        select_topics(bag, topics, [GADGET], allow_partial=True)
    with pytest.raises(BagError, match=r"has no topic\(s\) \['/nowhere'\].*\(parameter topics\)"):
        select_topics(bag, topics, ["/nowhere"])


def test_message_type_problem_names_what_is_missing():
    assert message_type_problem("sensor_msgs/msg/Image") is None
    assert "No module named 'other_pkg'" in message_type_problem(GADGET_TYPE)
    assert "sensor_msgs.msg has no Nothing" in message_type_problem("sensor_msgs/msg/Nothing")
    assert "not a message type name" in message_type_problem("garbage")


# ------------------------------------------------------------------------- edited QoS text, partial passes
LATCHED = Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, QosTime(0, 0),
              QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)


def recorded_qos(bag) -> list:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"][
        "topics_with_message_count"][0]["topic_metadata"]["offered_qos_profiles"]


@pytest.mark.parametrize("edit", [
    garbled_qos,  # words no ROS knows (rosbags then matches no connection: 0 messages)
    lambda profiles: "- history: [unclosed",  # not YAML
    lambda profiles: "garbage",  # YAML, not profiles
    lambda profiles: [{"reliability": "reliable"}],  # keys missing
], ids=["garbled-policies", "not-yaml", "scalar", "missing-keys"])
def test_unreadable_qos_text_still_reads_every_message_with_the_storage_files_qos(tmp_path, typestore, edit):
    bag = tmp_path / "latched"
    written = write_sample_bag(bag, typestore, count=12, split_duration_ns=30_000_000, qos=[LATCHED])
    set_offered_qos(bag, "/chatter", edit(recorded_qos(bag)))
    with BagReader(bag, typestore) as reader:
        assert list(reader.messages()) == written  # matched by topic and type, not by the QoS text
        assert reader.replay_shortfall(["/chatter"], reader.start_ns, {"/chatter": 6}) is None
        assert [q.durability for q in reader.topics["/chatter"].qos] == [QosDurability.TRANSIENT_LOCAL]
        assert reader.topics["/policy/primitive"].qos == (LATCHED,)
        [warning] = reader.warnings
    assert "offered_qos_profiles of /chatter in metadata.yaml cannot be read" in warning
    assert "using the QoS its storage file records (reliable, transient_local)" in warning
    assert f"Correct it in {bag / 'metadata.yaml'}" in warning


def test_unreadable_qos_text_without_qos_in_the_storage_falls_back_to_the_default(tmp_path, typestore):
    bag = tmp_path / "plain"
    written = write_sample_bag(bag, typestore, count=6)  # recorded without QoS profiles
    set_offered_qos(bag, "/chatter", "- history: [unclosed")
    with BagReader(bag) as reader:
        assert list(reader.messages()) == written and reader.topics["/chatter"].qos == ()
        assert "default (reliable, volatile)" in reader.warnings[0]


def test_a_pass_that_plays_fewer_messages_than_the_topics_hold_is_described(tmp_path, typestore):
    """A split removed from relative_file_paths (the file stays, counts unchanged): 20 of 30 readable."""
    bag = tmp_path / "gap"
    write_sample_bag(bag, typestore, count=30, split_duration_ns=100_000_000)
    unlist_split(bag, 1)
    topics = ["/chatter", "/policy/primitive"]
    with BagReader(bag, typestore) as reader:
        counter = PassCounter(lambda start_ns: reader.messages(topics, start_ns))
        assert len(list(replay_plan(counter, reader.start_ns, ReplayTiming(as_fast_as_possible=True)))) == 20
        assert counter.first_pass_done and counter.counts == {"/chatter": 10, "/policy/primitive": 10}
        shortfall = reader.replay_shortfall(topics, reader.start_ns, counter.counts)
    assert shortfall == (
        f"bag {bag}: played 20 of the 30 message(s) the selected topic(s) hold (/chatter 10 of 15, "
        "/policy/primitive 10 of 15): the storage file(s) listed in metadata.yaml hold 10 of the 15 "
        "message(s) it counts for /chatter (a split missing from relative_file_paths, or edited counts); "
        "the storage file(s) listed in metadata.yaml hold 10 of the 15 message(s) it counts for "
        "/policy/primitive (a split missing from relative_file_paths, or edited counts)")


def test_a_complete_pass_from_an_offset_has_no_shortfall(tmp_path, typestore):
    bag = tmp_path / "offset"
    write_sample_bag(bag, typestore, count=30, split_duration_ns=100_000_000)
    timing = ReplayTiming(start_offset=0.095, as_fast_as_possible=True)
    with BagReader(bag, typestore) as reader:
        counter = PassCounter(lambda start_ns: reader.messages(["/chatter"], start_ns))
        assert len(list(replay_plan(counter, reader.start_ns, timing))) == 10  # 100 ms .. 280 ms, every 20 ms
        assert reader.replay_shortfall(["/chatter"], timing.first_ns(reader.start_ns), counter.counts) is None
        assert "played 9 of the 10" in reader.replay_shortfall(["/chatter"], timing.first_ns(reader.start_ns),
                                                                {"/chatter": 9})


def test_a_missing_unlisted_split_is_not_a_checksum_error(tmp_path, typestore):
    bag = tmp_path / "gap"
    write_sample_bag(bag, typestore, count=30, split_duration_ns=100_000_000)
    unlist_split(bag, 1)
    (bag / "gap_1.mcap").unlink()
    with BagReader(bag, typestore) as reader:
        assert len(list(reader.messages())) == 20


def test_pass_counter_counts_only_a_first_pass_read_to_its_end():
    messages = stamped(0, 100, 300)
    looping = PassCounter(reader_of(messages))
    plan = replay_plan(looping, messages[0].timestamp_ns, ReplayTiming(loop=True))
    assert dues(plan, limit=5) and looping.first_pass_done and looping.counts == {"/t": 3}
    stopped = PassCounter(reader_of(messages))
    plan = replay_plan(stopped, messages[0].timestamp_ns, ReplayTiming())
    next(plan), next(plan)
    assert not stopped.first_pass_done and stopped.counts == {"/t": 2}


# --------------------------------------------------------------------- the QoS a recorder subscribes with
def offer(reliability: QosReliability, durability: QosDurability) -> Qos:
    return Qos(QosHistory.UNKNOWN, 0, reliability, durability, QosTime(0, 0), QosTime(0, 0),
               QosLiveliness.AUTOMATIC, QosTime(0, 0), False)


RELIABLE, BEST_EFFORT = QosReliability.RELIABLE, QosReliability.BEST_EFFORT
LATCH, VOLATILE = QosDurability.TRANSIENT_LOCAL, QosDurability.VOLATILE


@pytest.mark.parametrize("offers, expected", [
    ([offer(RELIABLE, LATCH)], (RELIABLE, LATCH)),  # /robot_description: its latched message is delivered
    ([offer(RELIABLE, LATCH), offer(RELIABLE, LATCH)], (RELIABLE, LATCH)),
    ([offer(RELIABLE, LATCH), offer(RELIABLE, VOLATILE)], (RELIABLE, VOLATILE)),  # else one publisher is lost
    ([offer(BEST_EFFORT, VOLATILE), offer(RELIABLE, VOLATILE)], (BEST_EFFORT, VOLATILE)),
    ([offer(BEST_EFFORT, LATCH)], (BEST_EFFORT, LATCH)),
    ([], (RELIABLE, VOLATILE)),
])
def test_a_recorder_requests_transient_local_only_where_every_publisher_offers_it(offers, expected):
    request = subscription_request(offers)
    assert request == expected
    assert all(request_misses(request, o) == [] for o in offers)  # it receives from every publisher


def test_a_new_publisher_weakens_the_request_just_enough_and_never_strengthens_it():
    assert request_misses((RELIABLE, LATCH), offer(RELIABLE, VOLATILE)) == [
        "it offers volatile, the subscription requests transient_local"]
    assert weakened_request((RELIABLE, LATCH), [offer(RELIABLE, VOLATILE)]) == (RELIABLE, VOLATILE)
    assert weakened_request((RELIABLE, LATCH), [offer(BEST_EFFORT, LATCH)]) == (BEST_EFFORT, LATCH)
    assert weakened_request((BEST_EFFORT, VOLATILE), [offer(RELIABLE, LATCH)]) == (BEST_EFFORT, VOLATILE)
