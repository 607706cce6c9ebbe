"""Graph tests: cell_state_publisher and decision_markers (real processes) give RViz and Foxglove a 3-D
view: /robot_description and /tf_static reach a viewer that joins late, /tf follows /joint_states with
the UR5's kinematics, and /cell/markers shows the chosen primitive and the attended crop."""

import math

import numpy as np
import pytest
from geometry_msgs.msg import Point
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from impurity_common import cell, names
from impurity_common.conversions import ns_to_time, numpy_to_image
from impurity_interfaces.msg import AttentionResult, Primitive
from impurity_viz import visualisation as vis
from ros_harness import TopicRecorder, publish_until_answered, ros_args, spin_until
from ur5_motion import ur5_kinematics as kin

WAIT = 60.0  # s for any one thing to show up
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
CAMERA_POSITION = (0.45, 0.05, 0.8)
CAMERA_ORIENTATION = (0.99, 0.02, 0.0, 0.1)  # not normalised: the node normalises it
JOINTS = (0.3, -1.6, 1.4, -1.2, -1.57, 0.4)


def ready(ros_node, process):
    """Wait for the node's "ready:" line: it is logged after the latched topics were published."""
    spin_until(ros_node, lambda: "ready:" in process.output(), WAIT, f"{process.name} to be ready", [process])


def pose_of(transform) -> np.ndarray:
    t, r = transform.transform.translation, transform.transform.rotation
    return vis.pose_matrix((t.x, t.y, t.z), (r.x, r.y, r.z, r.w))


@pytest.fixture
def cell_state(ros_node, launch):
    process = launch("impurity_viz", "cell_state_publisher",
                     ros_args({"camera_position": list(CAMERA_POSITION),
                               "camera_orientation": list(CAMERA_ORIENTATION), "log_throttle": 0.1}))
    ready(ros_node, process)
    return process


def test_a_late_viewer_gets_the_robot_description_and_the_static_frames(ros_node, cell_state):
    description = TopicRecorder(ros_node, String, names.ROBOT_DESCRIPTION_TOPIC, LATCHED)
    static = TopicRecorder(ros_node, TFMessage, names.TF_STATIC_TOPIC, LATCHED)
    urdf = description.wait_for(1, WAIT, processes=[cell_state])[0].data
    tree = vis.RobotTree.from_urdf(urdf)
    assert [j.name for j in tree.joints if j.kind == "revolute"] == list(kin.JOINT_NAMES)
    assert {"base_link_inertia", "tool0", "flange", vis.TCP_FRAME} <= set(tree.links)

    transforms = {t.child_frame_id: t for t in static.wait_for(1, WAIT, processes=[cell_state])[0].transforms}
    camera = transforms[names.CAMERA_OPTICAL_FRAME]
    assert camera.header.frame_id == names.BASE_FRAME
    expected = vis.pose_matrix(CAMERA_POSITION, CAMERA_ORIENTATION)
    np.testing.assert_allclose(pose_of(camera), expected, atol=1e-6)
    assert {"base", "base_link_inertia", "flange", "tool0", vis.TCP_FRAME} <= set(transforms)
    for frame in ("shoulder_link", "wrist_3_link"):  # moving links are never static
        assert frame not in transforms


def test_tf_follows_joint_states_with_the_ur5_kinematics(ros_node, cell_state):
    static = TopicRecorder(ros_node, TFMessage, names.TF_STATIC_TOPIC, LATCHED)
    tf = TopicRecorder(ros_node, TFMessage, names.TF_TOPIC, QoSProfile(depth=100,
                                                                      reliability=ReliabilityPolicy.RELIABLE))
    publisher = ros_node.create_publisher(JointState, names.JOINT_STATES_TOPIC, 10)
    stamp = ns_to_time(1_700_000_000_123_000_000)

    def joint_states():
        msg = JointState(name=list(kin.JOINT_NAMES), position=list(JOINTS))
        msg.header.stamp = stamp
        return msg

    moving = publish_until_answered(ros_node, publisher, joint_states, tf, WAIT, processes=[cell_state])
    assert all((t.header.stamp.sec, t.header.stamp.nanosec) == (stamp.sec, stamp.nanosec)
               for t in moving.transforms)
    parents = {t.child_frame_id: (t.header.frame_id, pose_of(t)) for t in moving.transforms}
    parents.update({t.child_frame_id: (t.header.frame_id, pose_of(t))
                    for t in static.wait_for(1, WAIT, processes=[cell_state])[0].transforms})

    def in_base(frame):
        pose = np.eye(4)
        while frame != names.BASE_FRAME:
            parent, relative = parents[frame]
            pose, frame = relative @ pose, parent
        return pose

    frames = kin.joint_frames(JOINTS)
    np.testing.assert_allclose(in_base("tool0"), frames[6], atol=1e-6)
    np.testing.assert_allclose(in_base(vis.TCP_FRAME), frames[7], atol=1e-6)
    ros_node.destroy_publisher(publisher)


def test_a_burst_of_joint_states_ends_on_tf_with_the_latest_at_a_bounded_rate(ros_node, cell_state):
    """A UR driver publishes joint states at 500 Hz: /tf carries the latest ones, not every one."""
    tf = TopicRecorder(ros_node, TFMessage, names.TF_TOPIC, QoSProfile(depth=100,
                                                                      reliability=ReliabilityPolicy.RELIABLE))
    publisher = ros_node.create_publisher(JointState, names.JOINT_STATES_TOPIC, 1000)

    def joint_states(i):
        msg = JointState(name=list(kin.JOINT_NAMES), position=[0.001 * i] * 6)
        msg.header.stamp = ns_to_time(1_800_000_000_000_000_000 + i)
        return msg

    publish_until_answered(ros_node, publisher, lambda: joint_states(0), tf, WAIT, processes=[cell_state])
    heard = len(tf.messages)
    burst = 300
    for i in range(1, burst + 1):
        publisher.publish(joint_states(i))

    def last_stamp_ns(msg):
        return msg.transforms[0].header.stamp.sec * 1_000_000_000 + msg.transforms[0].header.stamp.nanosec

    tf.wait_for(1, WAIT, processes=[cell_state],
                predicate=lambda m: last_stamp_ns(m) == 1_800_000_000_000_000_000 + burst)
    assert len(tf.messages) - heard < burst  # at most publish_frequency (30 Hz), not one per message
    ros_node.destroy_publisher(publisher)


def test_malformed_joint_states_are_dropped_with_a_reason_and_the_node_goes_on(ros_node, cell_state):
    tf = TopicRecorder(ros_node, TFMessage, names.TF_TOPIC, RELIABLE)
    publisher = ros_node.create_publisher(JointState, names.JOINT_STATES_TOPIC, 10)
    bad = JointState(name=list(kin.JOINT_NAMES), position=[0.0, 1.0])
    good = JointState(name=list(kin.JOINT_NAMES), position=list(JOINTS))
    publish_until_answered(ros_node, publisher, lambda: good, tf, WAIT, processes=[cell_state])
    heard = len(tf.messages)
    publisher.publish(bad)
    spin_until(ros_node, lambda: "joint states dropped: JointState has 6 names but 2 positions"
               in cell_state.output(), WAIT, "the warning about the malformed joint states", [cell_state])
    assert len(tf.messages) == heard  # nothing was published for it
    publisher.publish(good)
    tf.wait_for(heard + 1, WAIT, processes=[cell_state])
    ros_node.destroy_publisher(publisher)


# ------------------------------------------------------------------------------------ markers
def grasp(x=0.52, y=-0.04, yaw=0.7) -> Primitive:
    msg = Primitive(kind=Primitive.GRASP, yaw=yaw, q_value=2.0)
    msg.position = Point(x=x, y=y, z=0.015)
    msg.header.frame_id = names.BASE_FRAME
    return msg


def push(x=0.40, y=0.10, yaw=-0.5) -> Primitive:
    msg = grasp(x, y, yaw)
    msg.kind = Primitive.PUSH
    return msg


def attended() -> AttentionResult:
    msg = AttentionResult(mode=AttentionResult.MODE_TARGET, score=0.4, crop_row0=40, crop_col0=60)
    msg.header.frame_id = names.BASE_FRAME
    msg.heightmap.resolution = cell.HEIGHTMAP_RESOLUTION
    msg.heightmap.origin = Point(x=cell.WORKSPACE_X[0], y=cell.WORKSPACE_Y[0], z=cell.TABLE_Z)
    msg.center = Point(x=0.45, y=-0.02, z=cell.TABLE_Z)
    colour = np.full((8, 8, 3), 120, np.uint8)  # a small heightmap, every cell seen
    msg.heightmap.color = numpy_to_image(colour, "rgb8")
    msg.heightmap.height = numpy_to_image(np.full((8, 8), 0.02, np.float32), "32FC1")
    return msg


def active(array: MarkerArray) -> dict:
    return {(m.ns, m.id): m for m in array.markers if m.action == Marker.ADD}


def test_markers_show_the_chosen_primitive_and_the_attended_crop(ros_node, launch):
    process = launch("impurity_viz", "decision_markers")
    ready(ros_node, process)
    markers = TopicRecorder(ros_node, MarkerArray, names.MARKERS_TOPIC, LATCHED)
    primitives = ros_node.create_publisher(Primitive, names.PRIMITIVE_TOPIC, RELIABLE)
    attention = ros_node.create_publisher(AttentionResult, names.ATTENTION_TOPIC,
                                          QoSProfile(depth=2, reliability=ReliabilityPolicy.RELIABLE))

    shown = active(publish_until_answered(ros_node, primitives, grasp, markers, WAIT, processes=[process]))
    jaw = shown[(vis.PRIMITIVE_NS, vis.GRASP_LEFT_JAW)].pose.position
    offset = cell.GRASP_OPENING / 2 + cell.FINGER_THICKNESS / 2
    assert (jaw.x, jaw.y) == pytest.approx((0.52 + offset * math.cos(0.7), -0.04 + offset * math.sin(0.7)))
    assert (vis.PRIMITIVE_NS, vis.PUSH_ARROW) not in shown

    shown = active(publish_until_answered(ros_node, attention, attended, markers, WAIT, processes=[process]))
    square = shown[(vis.ATTENTION_NS, vis.CROP_SQUARE)]
    resolution = cell.HEIGHTMAP_RESOLUTION
    corner = (cell.WORKSPACE_X[0] + 60 * resolution, cell.WORKSPACE_Y[0] + 40 * resolution)
    assert (square.points[0].x, square.points[0].y) == pytest.approx(corner)
    assert (vis.PRIMITIVE_NS, vis.GRASP_LEFT_JAW) in shown  # the picture holds both
    cloud = shown[(vis.HEIGHTMAP_NS, vis.HEIGHTMAP_POINTS)]  # heightmap_stride 4: 2 x 2 of the 8 x 8 cells
    assert len(cloud.points) == 4 and cloud.points[0].z == pytest.approx(cell.TABLE_Z + 0.02)

    latest = publish_until_answered(ros_node, primitives, push, markers, WAIT, processes=[process])
    shown = active(latest)
    start, end = shown[(vis.PRIMITIVE_NS, vis.PUSH_ARROW)].points
    assert (start.x, start.y) == pytest.approx((0.40, 0.10))
    assert (end.x, end.y) == pytest.approx((0.40 + cell.PUSH_LENGTH * math.cos(-0.5),
                                            0.10 + cell.PUSH_LENGTH * math.sin(-0.5)))
    deleted = {(m.ns, m.id) for m in latest.markers if m.action == Marker.DELETE}
    assert {(vis.PRIMITIVE_NS, vis.GRASP_LEFT_JAW), (vis.PRIMITIVE_NS, vis.GRASP_RIGHT_JAW)} <= deleted

    late = TopicRecorder(ros_node, MarkerArray, names.MARKERS_TOPIC, LATCHED)  # a viewer opened now
    picture = active(late.wait_for(1, WAIT, processes=[process])[0])
    assert {(vis.PRIMITIVE_NS, vis.PUSH_ARROW), (vis.ATTENTION_NS, vis.CROP_SQUARE)} <= set(picture)
    for publisher in (primitives, attention):
        ros_node.destroy_publisher(publisher)
