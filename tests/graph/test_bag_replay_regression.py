"""Offline regression: each committed episode bag's camera frames, replayed through the real heightmap,
attention and policy executables, give the decisions recorded on /policy/primitive (the same primitive,
pixel, rotation and pose; the Q value to Q_TOLERANCE).

The bags are made by scripts/record_test_bag.py (`make test-bag` records both); their custom_data says
which weights decided. When the checkpoint changes, regenerate them with that one command.
  tests/data/episode_bag          a random scene: the first view's TARGET and its grasp
  tests/data/known_product_bag    an invisible scene: the first view shows no target, so the picking loop
                                  sends it to attention as the known product, which the next view's
                                  decision depends on (replayed after the first decision, as live)
"""

import pathlib

import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Image

from impurity_bags.bags import BagReader, file_sha256
from impurity_common import names
from impurity_interfaces.msg import Primitive
from ros_harness import ros_args, spin_until

ROOT = pathlib.Path(__file__).resolve().parents[2]
BAGS = [ROOT / "tests" / "data" / name for name in ("episode_bag", "known_product_bag")]
CONFIG = ROOT / "bringup" / "config" / "cell.yaml"
COLOR, DEPTH, INFO = names.COLOR_TOPIC, names.DEPTH_TOPIC, names.CAMERA_INFO_TOPIC
PRIMITIVE, ATTENTION = names.PRIMITIVE_TOPIC, names.ATTENTION_TOPIC
REGENERATE = "regenerate it with `make test-bag` (scripts/record_test_bag.py)"


def stamp_ns(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def policy_parameters(bag: pathlib.Path, notes: dict) -> dict:
    """The same weights as in the recording; stale-input checks and the failed-grasp memory off (the
    stamps are from then; the episode's outcomes are not replayed)."""
    parameters = {"max_age": 1e9, "rules_disabled": ["tried_actions"]}
    if notes.get("impurity.policy") == "untrained":
        return {**parameters, "allow_untrained": True, "seed": int(notes["impurity.untrained_seed"]),
                "checkpoint": "/nonexistent/untrained.pt"}
    from impurity_policy.policy_node import default_checkpoint

    checkpoint = pathlib.Path(default_checkpoint())
    if not checkpoint.is_file():
        pytest.fail(f"the bag was decided by a checkpoint, but there is none at {checkpoint}")
    if file_sha256(checkpoint) != notes.get("impurity.checkpoint_sha256"):
        pytest.fail(f"{checkpoint} changed since {bag} was recorded: {REGENERATE}")
    return {**parameters, "checkpoint": str(checkpoint)}


def recorded_decisions(reader: BagReader) -> dict[int, bytes]:
    """Camera stamp -> the recorded decision's bytes, for the frames kept in the bag."""
    frames = set()
    for message in reader.messages([names.absolute(COLOR)]):  # a bag holds absolute names
        frames.add(stamp_ns(deserialize_message(message.data, Image).header.stamp))
    decisions = {}
    for message in reader.messages([names.absolute(PRIMITIVE)]):
        stamp = stamp_ns(deserialize_message(message.data, Primitive).header.stamp)
        if stamp in frames:
            decisions.setdefault(stamp, message.data)
    return decisions


# The network's Q value is float32 arithmetic whose summation order follows the CPU's vector width, so two
# machines may differ in its last bits (seen: 1.062415719 recorded, 1.062415838 replayed elsewhere); the
# decision itself (primitive, pixel, rotation, pose) must be identical.
Q_TOLERANCE = 1e-5  # relative


def same_decision(recorded: bytes, replayed: bytes) -> bool:
    a, b = (deserialize_message(data, Primitive) for data in (recorded, replayed))
    identical = ((a.kind, a.pixel_row, a.pixel_col, a.rotation_index, a.yaw, a.position.x, a.position.y,
                  a.position.z) == (b.kind, b.pixel_row, b.pixel_col, b.rotation_index, b.yaw, b.position.x,
                                    b.position.y, b.position.z))
    return identical and abs(a.q_value - b.q_value) <= Q_TOLERANCE * max(1.0, abs(a.q_value))


def describe(data: bytes) -> str:
    p = deserialize_message(data, Primitive)
    return (f"kind={p.kind} x={p.position.x:.6f} y={p.position.y:.6f} z={p.position.z:.6f} yaw={p.yaw:.6f} "
            f"q={p.q_value:.9f} rot={p.rotation_index} px=({p.pixel_row},{p.pixel_col})")


@pytest.mark.parametrize("bag", BAGS, ids=[bag.name for bag in BAGS])
def test_replayed_frames_give_the_recorded_decisions(bag, ros_node, launch):
    if not (bag / "metadata.yaml").is_file():
        pytest.skip(f"no committed bag at {bag}: record it with `make test-bag` once the cell runs")
    with BagReader(bag) as reader:
        notes = reader.custom_data
        expected = recorded_decisions(reader)
        # an episode whose first view showed no target sent it to attention as the known product: replayed
        # after the decision it answered and before the next frame, as attention heard it
        recorded_known = names.absolute(names.KNOWN_PRODUCT_TOPIC) in reader.topics
        known = [names.KNOWN_PRODUCT_TOPIC] if recorded_known else []
    played = [INFO, DEPTH, COLOR, *known]
    assert expected, f"{bag} holds no camera frame with a recorded decision: {REGENERATE}"

    params = {"params_file": CONFIG}
    nodes = [launch("impurity_attention", "heightmap_node", ros_args(**params)),
             launch("impurity_attention", "attention_node", ros_args(**params)),
             launch("impurity_policy", "policy_node", ros_args(policy_parameters(bag, notes), **params))]
    replayed: dict[int, bytes] = {}

    def on_primitive(data: bytes) -> None:
        replayed.setdefault(stamp_ns(deserialize_message(data, Primitive).header.stamp), data)

    reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    subscription = ros_node.create_subscription(Primitive, PRIMITIVE, on_primitive, reliable, raw=True)
    try:
        spin_until(ros_node, lambda: (ros_node.count_publishers(PRIMITIVE) >= 1
                                      and ros_node.count_subscribers(ATTENTION) >= 1
                                      and ros_node.count_subscribers(names.HEIGHTMAP_TOPIC) >= 1),
                   120.0, "heightmap, attention and policy nodes to connect", nodes)
        # Each colour frame waits for the previous one's attention result (same stamp), re-publishing a
        # frame that got none: the camera subscriptions are best effort, the pipeline may be slow. The
        # delay lets the best-effort subscribers discover the replay before the first camera_info.
        replay = launch("impurity_bags", "bag_replay", ros_args({
            "bag": str(bag), "topics": played, "as_fast_as_possible": True,
            "wait_for_subscribers": 1, "wait_timeout": 60.0, "delay": 2.0,
            "ack_topic": ATTENTION, "ack_before": COLOR, "ack_timeout": 10.0, "ack_retries": 4,
            **({"ack_after": known} if known else {})}))
        spin_until(ros_node, lambda: set(expected) <= set(replayed), 300.0,
                   f"decisions for the {len(expected)} recorded frames", nodes)
        assert replay.process.wait(timeout=60) == 0, replay.output()[-2000:]
    finally:
        ros_node.destroy_subscription(subscription)

    differences = [f"frame {stamp}: recorded {describe(expected[stamp])}\n{'':>{len(str(stamp)) + 8}}"
                   f"replayed {describe(replayed[stamp])}"
                   for stamp in sorted(expected) if not same_decision(expected[stamp], replayed[stamp])]
    assert not differences, "decisions differ from the recording:\n" + "\n".join(differences)
