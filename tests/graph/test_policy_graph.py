"""Graph test: the policy_node executable answers an attention result with a valid primitive, and
refuses stale, malformed and NONE inputs with a log line (then keeps answering)."""

import math
import time

import numpy as np
import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from impurity_common import cell
from impurity_common.conversions import ns_to_time, numpy_to_image, time_to_ns
from impurity_interfaces.msg import AttentionResult, EpisodeStep, Primitive
from impurity_learning.trainer import Trainer
from impurity_policy.core.rules import RULE_ORDER
from ros_harness import TopicRecorder, publish_until_answered, ros_args, spin_until, wait_for_subscribers

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
CROP = cell.CROP_SIZE


def attention_message(stamp_ns, mode=AttentionResult.MODE_TARGET, crop_origin=(40, 50), crop_size=CROP,
                      frame_id=cell.BASE_FRAME):
    """A scene with a few blocks; the crop around one of them, as the attention node would send it."""
    height = np.zeros((224, 224), np.float32)
    color = np.full((224, 224, 3), 150, np.uint8)
    for r, c, colour in ((95, 105, (220, 60, 40)), (95, 122, (40, 120, 200)), (70, 80, (40, 120, 200))):
        height[r - 8:r + 8, c - 8:c + 8] = 0.035
        color[r - 8:r + 8, c - 8:c + 8] = colour
    r0, c0 = crop_origin
    msg = AttentionResult()
    msg.header.stamp = ns_to_time(stamp_ns)
    msg.header.frame_id = frame_id
    msg.mode = mode
    msg.crop_row0, msg.crop_col0 = r0, c0
    msg.center_row, msg.center_col = r0 + CROP // 2, c0 + CROP // 2
    mask = np.zeros((224, 224), np.uint8)
    mask[87:103, 97:113] = 255
    if mode == AttentionResult.MODE_OCCLUDED_REGION:
        mask[:] = 255
    header = msg.header
    msg.color_crop = numpy_to_image(color[r0:r0 + crop_size, c0:c0 + crop_size], "rgb8", header)
    msg.height_crop = numpy_to_image(height[r0:r0 + crop_size, c0:c0 + crop_size], "32FC1", header)
    msg.mask = numpy_to_image(mask[r0:r0 + crop_size, c0:c0 + crop_size], "mono8", header)
    msg.heightmap.header = header
    msg.heightmap.resolution = cell.HEIGHTMAP_RESOLUTION
    msg.heightmap.origin.x, msg.heightmap.origin.y = cell.WORKSPACE_X[0], cell.WORKSPACE_Y[0]
    msg.heightmap.origin.z = cell.TABLE_Z
    msg.heightmap.color = numpy_to_image(color, "rgb8", header)
    msg.heightmap.height = numpy_to_image(height, "32FC1", header)
    return msg


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    path = tmp_path_factory.mktemp("policy") / "policy.pt"
    Trainer(seed=0).save(path)
    return path


def test_policy_node_answers_with_a_valid_primitive(ros_node, launch, checkpoint):
    proc = launch("impurity_policy", "policy_node", ros_args({"checkpoint": str(checkpoint), "threads": 1}))
    publisher = ros_node.create_publisher(AttentionResult, "/attention/result", RELIABLE)
    primitives = TopicRecorder(ros_node, Primitive, "/policy/primitive", RELIABLE)
    q_maps = TopicRecorder(ros_node, Image, "/policy/q_maps_image", RELIABLE)
    clock = ros_node.get_clock()
    publish_until_answered(ros_node, publisher, lambda: attention_message(clock.now().nanoseconds),
                           primitives, processes=[proc])
    now = clock.now().nanoseconds

    # refused, each with its log line (one at a time: the subscription keeps the last 5 only)
    refusals = (
        (attention_message(now - 30_000_000_000), "stale attention result"),
        (attention_message(now + 1, crop_size=100), "malformed attention result"),
        (attention_message(now + 2, mode=AttentionResult.MODE_NONE), "attention mode NONE"),
        (attention_message(now + 3, frame_id="camera_color_optical_frame"), "expected 'base_link'"),
    )
    for message, log_line in refusals:
        publisher.publish(message)
        spin_until(ros_node, lambda line=log_line: line in proc.output(), 30.0, f"the log line '{log_line}'",
                   [proc])
    # then one good target and one occluded region
    publisher.publish(attention_message(now + 4))
    publisher.publish(attention_message(now + 5, mode=AttentionResult.MODE_OCCLUDED_REGION))
    answers = primitives.wait_for(2, timeout=60.0, processes=[proc],
                                  predicate=lambda m: time_to_ns(m.header.stamp) > now)

    assert [a.header.stamp for a in answers] == [ns_to_time(now + 4), ns_to_time(now + 5)]
    for answer in answers:
        assert answer.header.frame_id == "base_link"
        assert answer.kind in (Primitive.PUSH, Primitive.GRASP)
        assert cell.in_workspace(answer.position.x, answer.position.y)
        assert cell.TABLE_Z <= answer.position.z < cell.TABLE_Z + 0.1
        assert 0 <= answer.rotation_index < 16
        turn = (answer.yaw - answer.rotation_index * 2 * math.pi / 16 + math.pi) % (2 * math.pi) - math.pi
        if answer.kind == Primitive.PUSH:  # the network's rotation; a grasp may turn onto a target's face
            assert turn == pytest.approx(0.0, abs=1e-5)  # (rules: grasp_square_to_faces, at most 22.5 deg)
        else:
            assert abs(turn) <= math.radians(22.5) + 1e-5
        assert 40 <= answer.pixel_row < 40 + CROP and 50 <= answer.pixel_col < 50 + CROP
        assert math.isfinite(answer.q_value)
        x, y = cell.pixel_to_base(answer.pixel_row, answer.pixel_col)
        assert (answer.position.x, answer.position.y) == pytest.approx((x, y), abs=1e-6)
    assert answers[1].kind == Primitive.PUSH  # no visible target: pushes only
    images = q_maps.wait_for(1, timeout=30.0, processes=[proc])
    assert images[0].encoding == "rgb8" and images[0].width == 16 * 56

    assert proc.alive
    ros_node.destroy_publisher(publisher)
    primitives.destroy()
    q_maps.destroy()


def test_policy_node_without_checkpoint_exits_with_a_clear_message(ros_node, launch, tmp_path):
    proc = launch("impurity_policy", "policy_node", ros_args({"checkpoint": str(tmp_path / "missing.pt")}))
    spin_until(ros_node, lambda: not proc.alive, 60.0, "policy_node to exit")
    assert proc.process.returncode != 0
    assert "does not exist" in proc.output() and "allow_untrained" in proc.output()


def test_policy_node_does_not_repeat_an_executed_grasp_in_an_unchanged_scene(ros_node, launch, checkpoint):
    # The memory alone (the cell preset without its other rules): the seeded network grasps first here.
    only_memory = [name for name in RULE_ORDER if name != "tried_actions"]
    proc = launch("impurity_policy", "policy_node",
                  ros_args({"checkpoint": str(checkpoint), "threads": 1, "rules": "cell",
                            "rules_disabled": only_memory}))
    publisher = ros_node.create_publisher(AttentionResult, "/attention/result", RELIABLE)
    steps = ros_node.create_publisher(EpisodeStep, "/episode/steps", 10)
    primitives = TopicRecorder(ros_node, Primitive, "/policy/primitive", RELIABLE)
    clock = ros_node.get_clock()
    scene = attention_message
    failed = publish_until_answered(ros_node, publisher, lambda: scene(clock.now().nanoseconds), primitives,
                                    processes=[proc])
    assert failed.kind == Primitive.GRASP  # the seeded network's choice in this scene
    wait_for_subscribers(ros_node, steps, processes=[proc])
    steps.publish(EpisodeStep(episode_id="e1", step=1, attention_mode="TARGET", primitive=failed,
                              success=False))

    def same_grasp(answer) -> bool:
        distance = math.dist((answer.pixel_row, answer.pixel_col), (failed.pixel_row, failed.pixel_col))
        return (answer.kind == Primitive.GRASP and answer.rotation_index % 8 == failed.rotation_index % 8
                and distance <= 10)

    # the same scene again (new stamps) until an answer comes that is not the failed grasp
    deadline, answer = time.monotonic() + 30.0, failed
    while same_grasp(answer):
        assert time.monotonic() < deadline, "the policy node kept choosing the grasp it saw executed"
        stamp = clock.now().nanoseconds
        publisher.publish(attention_message(stamp))
        answer = primitives.wait_for(1, 30.0, lambda m, s=stamp: time_to_ns(m.header.stamp) == s, [proc])[0]
    assert proc.alive
    ros_node.destroy_publisher(publisher)
    ros_node.destroy_publisher(steps)
    primitives.destroy()
