"""scripts/render_cell_3d.py reads a bag as a viewer would: the state at a time, TF from /tf or from
/joint_states through the robot model, the latest markers; and draws it, saying what it could not."""

import importlib.util
import pathlib
import sys

import numpy as np
import pytest
from geometry_msgs.msg import Point
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from impurity_bags.bags import BagWriter, cell_typestore
from impurity_common import cell, names
from impurity_common.conversions import numpy_to_image
from impurity_interfaces.msg import Heightmap, Primitive
from impurity_viz import visualisation as vis
from ur5_motion import ur5_kinematics as kin

SCRIPT = pathlib.Path(__file__).resolve().parents[3] / "scripts" / "render_cell_3d.py"
JOINTS = (0.2, -1.5, 1.3, -1.3, -1.57, 0.1)
SECOND = 1_000_000_000


@pytest.fixture(scope="module")
def render():
    spec = importlib.util.spec_from_file_location("render_cell_3d", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up while it loads
    spec.loader.exec_module(module)
    return module


def heightmap() -> Heightmap:
    msg = Heightmap(resolution=cell.HEIGHTMAP_RESOLUTION)
    msg.origin = Point(x=cell.WORKSPACE_X[0], y=cell.WORKSPACE_Y[0], z=cell.TABLE_Z)
    msg.color = numpy_to_image(np.full((20, 20, 3), 150, np.uint8), "rgb8")
    msg.height = numpy_to_image(np.zeros((20, 20), np.float32), "32FC1")
    return msg


def grasp_markers() -> MarkerArray:
    primitive = Primitive(kind=Primitive.GRASP, yaw=0.3)
    primitive.position = Point(x=0.5, y=0.0, z=0.02)
    return MarkerArray(markers=vis.primitive_markers(primitive))


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """1 s: heightmap, camera on /tf_static, joint states (no /tf); 2 s: a grasp's markers."""
    path = tmp_path_factory.mktemp("render") / "bag"
    parent, child, pose = vis.camera_transform(cell.CAMERA_POSITION, cell.CAMERA_ORIENTATION)
    camera = TFMessage(transforms=[vis.transform_stamped(parent, child, pose, JointState().header.stamp)])
    messages = [(names.HEIGHTMAP_TOPIC, "impurity_interfaces/msg/Heightmap", SECOND, heightmap()),
                (names.TF_STATIC_TOPIC, "tf2_msgs/msg/TFMessage", SECOND, camera),
                (names.JOINT_STATES_TOPIC, "sensor_msgs/msg/JointState", SECOND,
                 JointState(name=list(kin.JOINT_NAMES), position=list(JOINTS), velocity=[0.0] * 6,
                            effort=[0.0] * 6)),  # rosbags refuses rclpy's CDR with empty arrays (size)
                (names.MARKERS_TOPIC, "visualization_msgs/msg/MarkerArray", 2 * SECOND, grasp_markers())]
    with BagWriter(path, cell_typestore()) as writer:  # under the absolute names a recording holds
        for topic, msgtype, _, _ in messages:
            writer.add_topic(names.absolute(topic), msgtype)
        for topic, _, stamp, msg in messages:
            writer.write(names.absolute(topic), stamp, serialize_message(msg))
    return path


def test_a_bag_without_tf_is_drawn_through_the_robot_model(render, bag):
    snapshot = render.from_bag(bag, None)
    np.testing.assert_allclose(snapshot.pose("tool0"), kin.joint_frames(JOINTS)[6], atol=1e-9)
    np.testing.assert_allclose(snapshot.pose(names.CAMERA_OPTICAL_FRAME)[:3, 3], cell.CAMERA_POSITION)
    assert any("through the robot model" in line for line in snapshot.sources)
    assert (vis.PRIMITIVE_NS, vis.GRASP_LEFT_JAW) in snapshot.markers
    assert (vis.PRIMITIVE_NS, vis.PUSH_ARROW) not in snapshot.markers  # deleted by the grasp's array
    assert snapshot.heightmap is not None


def test_the_state_at_a_time_holds_only_what_came_before(render, bag):
    snapshot = render.from_bag(bag, 0.5)  # 0.5 s after the first message: the markers came at 1 s after
    assert snapshot.markers == {}
    assert snapshot.pose("tool0") is not None


def test_the_picture_is_written_and_says_what_is_missing(render, bag, tmp_path):
    output = tmp_path / "cell.png"
    assert render.render(render.from_bag(bag, None), output, "test") == []
    assert output.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    empty = render.CellSnapshot()
    missing = render.render(empty, tmp_path / "empty.png", "empty")
    assert missing[0] == "heightmap" and any("camera" in item for item in missing) and "markers" in missing
