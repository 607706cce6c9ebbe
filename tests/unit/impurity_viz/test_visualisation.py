"""What RViz and Foxglove draw: the URDF's TF tree is the UR5's DH kinematics, transforms and the camera
pose become messages faithfully, and markers land where the primitive and the attended crop are."""

import math

import numpy as np
import pytest
from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker

from impurity_common import cell, names
from impurity_common.conversions import numpy_to_image
from impurity_interfaces.msg import AttentionResult, Heightmap, Primitive
from impurity_viz import visualisation as vis
from ur5_motion import ur5_kinematics as kin

UR_LINKS = ("base_link", "base_link_inertia", "base", "shoulder_link", "upper_arm_link", "forearm_link",
            "wrist_1_link", "wrist_2_link", "wrist_3_link", "flange", "tool0")


@pytest.fixture(scope="module")
def tree():
    return vis.RobotTree.from_urdf(vis.robot_description())


def random_joints(rng) -> np.ndarray:
    return np.array(kin.HOME_JOINTS) + rng.uniform(-1.5, 1.5, 6)


def rz(angle: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = vis.axis_angle_matrix((0, 0, 1), angle)
    return pose


# ------------------------------------------------------------------------------------ robot model
def test_the_robot_description_names_the_ur_links_the_six_joints_and_the_gripper(tree):
    assert tree.root == names.BASE_FRAME
    assert set(UR_LINKS) | {vis.TCP_FRAME, "left_finger", "right_finger"} <= set(tree.links)
    revolute = [j.name for j in tree.joints if j.kind == "revolute"]
    assert revolute == list(kin.JOINT_NAMES)
    assert set(tree.movable_joints) == set(kin.JOINT_NAMES) | {"left_finger_joint", "right_finger_joint"}


@pytest.mark.parametrize("seed", range(5))
def test_urdf_walk_equals_the_dh_forward_kinematics(tree, seed):
    """tool0 is DH frame 6, the TCP is tcp_pose, link i is DH frame i-1 turned by q_i, for any angles."""
    rng = np.random.default_rng(seed)
    for _ in range(20):
        q = random_joints(rng)
        poses = tree.link_poses(dict(zip(kin.JOINT_NAMES, q, strict=True)))
        frames = kin.joint_frames(q)
        np.testing.assert_allclose(poses["tool0"], frames[6], atol=1e-9)
        np.testing.assert_allclose(poses[vis.TCP_FRAME], frames[7], atol=1e-9)
        np.testing.assert_allclose(poses["base"], frames[0], atol=1e-12)
        for i, link in enumerate(UR_LINKS[3:9]):
            np.testing.assert_allclose(poses[link], frames[i] @ rz(q[i]), atol=1e-9)


def test_flange_sits_at_tool0_with_x_out_of_the_flange(tree):
    poses = tree.link_poses(dict(zip(kin.JOINT_NAMES, kin.HOME_JOINTS, strict=True)))
    np.testing.assert_allclose(poses["flange"][:3, 3], poses["tool0"][:3, 3], atol=1e-12)
    np.testing.assert_allclose(poses["flange"][:3, 0], poses["tool0"][:3, 2], atol=1e-12)


def test_static_and_moving_transforms_compose_to_the_link_poses(tree):
    q = dict(zip(kin.JOINT_NAMES, np.random.default_rng(7).uniform(-2, 2, 6), strict=True))
    transforms = tree.static_transforms() + tree.moving_transforms(q)
    parents = {child: (parent, pose) for parent, child, pose in transforms}
    assert set(parents) == set(tree.links) - {tree.root}
    static_children = {child for _, child, _ in tree.static_transforms()}
    assert {"base", "base_link_inertia", "flange", "tool0", vis.TCP_FRAME} <= static_children
    assert not static_children & set(tree.links[3:9]) - {"coupling"}  # the arm links move
    expected = tree.link_poses(q)
    for link in ("wrist_3_link", vis.TCP_FRAME, "right_finger"):
        pose, frame = np.eye(4), link
        while frame != tree.root:
            parent, relative = parents[frame]
            pose, frame = relative @ pose, parent
        np.testing.assert_allclose(pose, expected[link], atol=1e-9)


def test_joints_missing_from_the_states_are_drawn_at_zero_clipped_to_their_limits(tree):
    poses = tree.link_poses({})
    closed = [cell.FINGER_THICKNESS / 2, 0, cell.FINGER_LENGTH / 2]  # in the TCP frame: pads touching
    np.testing.assert_allclose(poses["left_finger"][:3, 3] - poses[vis.TCP_FRAME][:3, 3],
                               poses[vis.TCP_FRAME][:3, :3] @ closed, atol=1e-12)
    opened = tree.link_poses({"left_finger_joint": 5.0})  # beyond the stroke: clipped to the upper limit
    travel = np.linalg.norm(opened["left_finger"][:3, 3] - poses["left_finger"][:3, 3])
    assert travel == pytest.approx(cell.GRIPPER_MAX_OPENING / 2)


@pytest.mark.parametrize("text,problem", [
    ("<robot", "not XML"),
    ("<model/>", "not <robot>"),
    ('<robot><link name="a"/><link name="b"/></robot>', "one root link"),
    ('<robot><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/></joint></robot>',
     "lacks a parent or child"),
    ('<robot><link name="a"/><link name="b"/><joint name="j" type="floating"><parent link="a"/>'
     '<child link="b"/></joint></robot>', "type 'floating'"),
    ('<robot><link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/>'
     '<child link="b"/><origin xyz="0 1"/></joint></robot>', "origin xyz: expected 3 finite numbers"),
    ('<robot><link name="a"/><joint name="j" type="fixed"><parent link="a"/><child link="c"/>'
     '</joint></robot>', "does not define"),
])
def test_an_unreadable_urdf_is_refused_with_what_is_wrong(text, problem):
    with pytest.raises(vis.UrdfError, match=problem):
        vis.RobotTree.from_urdf(text)


def test_joint_states_with_unequal_lists_are_refused():
    assert vis.joint_positions(["a", "b"], [1.0, 2.0]) == {"a": 1.0, "b": 2.0}
    with pytest.raises(ValueError, match="2 names but 1 positions"):
        vis.joint_positions(["a", "b"], [1.0])


# ------------------------------------------------------------------------------------ transforms
@pytest.mark.parametrize("seed", range(3))
def test_quaternions_round_trip_through_matrices(seed):
    rng = np.random.default_rng(seed)
    for _ in range(100):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q *= np.sign(q[3])
        np.testing.assert_allclose(vis.matrix_quaternion(vis.quaternion_matrix(q)), q, atol=1e-9)


def test_transform_stamped_carries_frames_stamp_and_pose():
    pose = vis.pose_matrix((0.1, -0.2, 0.3), (0.0, 0.0, math.sin(0.35), math.cos(0.35)))
    stamp = Primitive().header.stamp
    stamp.sec = 12
    msg = vis.transform_stamped("base_link", "tool0", pose, stamp)
    assert (msg.header.frame_id, msg.child_frame_id, msg.header.stamp.sec) == ("base_link", "tool0", 12)
    t, r = msg.transform.translation, msg.transform.rotation
    assert (t.x, t.y, t.z) == pytest.approx((0.1, -0.2, 0.3))
    assert (r.x, r.y, r.z, r.w) == pytest.approx((0.0, 0.0, math.sin(0.35), math.cos(0.35)))


def test_the_camera_transform_is_the_cells_camera_pose():
    parent, child, pose = vis.camera_transform(cell.CAMERA_POSITION, cell.CAMERA_ORIENTATION)
    assert (parent, child) == (names.BASE_FRAME, names.CAMERA_OPTICAL_FRAME)
    np.testing.assert_allclose(pose[:3, 3], cell.CAMERA_POSITION)
    np.testing.assert_allclose(pose[:3, 2], [0, 0, -1], atol=1e-12)  # optical z looks down at the table


@pytest.mark.parametrize("position,orientation,problem", [
    ((0.5, 0.0, 0.75), (0, 0, 0, 0), "zero norm"),
    ((0.5, 0.0), (1, 0, 0, 0), "three finite numbers"),
    ((0.5, math.nan, 0.75), (1, 0, 0, 0), "three finite numbers"),
    ((0.5, 0.0, 0.75), (1, 0, 0), "four finite numbers"),
])
def test_a_bad_camera_pose_is_refused(position, orientation, problem):
    with pytest.raises(ValueError, match=problem):
        vis.camera_transform(position, orientation)


# ------------------------------------------------------------------------------------ markers
def primitive(kind, x=0.5, y=0.05, z=0.02, yaw=0.6, q=1.25) -> Primitive:
    msg = Primitive(kind=kind, yaw=yaw, q_value=q)
    msg.position = Point(x=x, y=y, z=z)
    msg.header.frame_id = names.BASE_FRAME
    return msg


def by_id(markers) -> dict:
    return {(m.ns, m.id): m for m in markers}


def test_a_push_is_an_arrow_along_its_stroke_and_clears_the_grasp():
    markers = by_id(vis.primitive_markers(primitive(Primitive.PUSH)))
    arrow = markers[(vis.PRIMITIVE_NS, vis.PUSH_ARROW)]
    assert (arrow.type, arrow.action, arrow.header.frame_id) == (Marker.ARROW, Marker.ADD, names.BASE_FRAME)
    start, end = arrow.points
    assert (start.x, start.y, start.z) == pytest.approx((0.5, 0.05, 0.02))
    assert (end.x, end.y, end.z) == pytest.approx((0.5 + cell.PUSH_LENGTH * math.cos(0.6),
                                                   0.05 + cell.PUSH_LENGTH * math.sin(0.6), 0.02))
    for marker_id in (vis.GRASP_LEFT_JAW, vis.GRASP_RIGHT_JAW, vis.GRASP_AXIS):
        assert markers[(vis.PRIMITIVE_NS, marker_id)].action == Marker.DELETE
    assert markers[(vis.PRIMITIVE_NS, vis.PRIMITIVE_LABEL)].text == "push q=1.25"


def test_a_push_towards_the_edge_ends_on_the_workspace_border():
    arrow = by_id(vis.primitive_markers(primitive(Primitive.PUSH, x=0.70, yaw=0.0)))[(vis.PRIMITIVE_NS,
                                                                                      vis.PUSH_ARROW)]
    assert arrow.points[1].x == pytest.approx(cell.WORKSPACE_X[1])


@pytest.mark.parametrize("yaw", [0.0, 0.6, -2.0])
def test_a_grasp_puts_the_jaws_across_its_closing_axis_and_clears_the_push(yaw):
    markers = by_id(vis.primitive_markers(primitive(Primitive.GRASP, yaw=yaw), grasp_opening=0.08))
    offset = 0.04 + cell.FINGER_THICKNESS / 2
    for marker_id, side in ((vis.GRASP_LEFT_JAW, 1), (vis.GRASP_RIGHT_JAW, -1)):
        jaw = markers[(vis.PRIMITIVE_NS, marker_id)]
        assert jaw.type == Marker.CUBE
        p = jaw.pose.position
        assert (p.x, p.y, p.z) == pytest.approx((0.5 + side * offset * math.cos(yaw),
                                                 0.05 + side * offset * math.sin(yaw),
                                                 0.02 + cell.FINGER_LENGTH / 2))
        o = jaw.pose.orientation
        assert 2 * math.atan2(o.z, o.w) == pytest.approx(yaw)
        assert (jaw.scale.x, jaw.scale.y, jaw.scale.z) == pytest.approx(
            (cell.FINGER_THICKNESS, cell.FINGER_WIDTH, cell.FINGER_LENGTH))
    assert markers[(vis.PRIMITIVE_NS, vis.PUSH_ARROW)].action == Marker.DELETE
    assert markers[(vis.PRIMITIVE_NS, vis.PRIMITIVE_LABEL)].text.startswith("grasp")


def test_an_undrawable_primitive_is_refused():
    with pytest.raises(ValueError, match="unknown primitive kind 7"):
        vis.primitive_markers(primitive(7))
    with pytest.raises(ValueError, match="not finite"):
        vis.primitive_markers(primitive(Primitive.GRASP, yaw=math.nan))


def attention(mode, row0=-20, col0=30, size=cell.CROP_SIZE) -> AttentionResult:
    msg = AttentionResult(mode=mode, score=0.5, crop_row0=row0, crop_col0=col0)
    msg.heightmap.resolution = cell.HEIGHTMAP_RESOLUTION
    msg.heightmap.origin = Point(x=cell.WORKSPACE_X[0], y=cell.WORKSPACE_Y[0], z=cell.TABLE_Z)
    msg.color_crop.height = msg.color_crop.width = size
    msg.center = Point(x=0.4, y=-0.1, z=cell.TABLE_Z)
    return msg


@pytest.mark.parametrize("mode", [AttentionResult.MODE_TARGET, AttentionResult.MODE_OCCLUDED_REGION])
def test_the_attended_crop_is_a_square_on_the_table_coloured_by_mode(mode):
    markers = by_id(vis.attention_markers(attention(mode)))
    square = markers[(vis.ATTENTION_NS, vis.CROP_SQUARE)]
    assert square.type == Marker.LINE_STRIP and len(square.points) == 5
    side = cell.CROP_SIZE * cell.HEIGHTMAP_RESOLUTION
    x0 = cell.WORKSPACE_X[0] + 30 * cell.HEIGHTMAP_RESOLUTION
    y0 = cell.WORKSPACE_Y[0] - 20 * cell.HEIGHTMAP_RESOLUTION
    corners = [(p.x, p.y) for p in square.points]
    expected = [(x0, y0), (x0 + side, y0), (x0 + side, y0 + side), (x0, y0 + side), (x0, y0)]
    np.testing.assert_allclose(corners, expected, atol=1e-12)
    centre = markers[(vis.ATTENTION_NS, vis.CROP_CENTRE)]
    assert (centre.pose.position.x, centre.pose.position.y) == pytest.approx((0.4, -0.1))
    color = (square.color.r, square.color.g, square.color.b, square.color.a)
    assert color == pytest.approx(vis.MODE_COLORS[mode])


def test_target_and_occluded_region_are_told_apart_by_colour():
    colors = vis.MODE_COLORS
    assert colors[AttentionResult.MODE_TARGET] != colors[AttentionResult.MODE_OCCLUDED_REGION]


def test_attention_none_removes_the_crop_and_says_none():
    markers = by_id(vis.attention_markers(attention(AttentionResult.MODE_NONE)))
    assert markers[(vis.ATTENTION_NS, vis.CROP_SQUARE)].action == Marker.DELETE
    assert markers[(vis.ATTENTION_NS, vis.CROP_CENTRE)].action == Marker.DELETE
    assert markers[(vis.ATTENTION_NS, vis.ATTENTION_LABEL)].text.startswith("attention: none")


def test_an_unknown_attention_mode_is_refused():
    with pytest.raises(ValueError, match="unknown attention mode 9"):
        vis.attention_markers(attention(9))


def small_heightmap(rows=6, cols=8) -> Heightmap:
    colour = np.zeros((rows, cols, 3), np.uint8)
    colour[2, 4] = (200, 30, 20)  # one red cell seen, 5 cm high; the rest unseen (black)
    colour[4, 0] = (90, 90, 90)  # one table cell
    height = np.zeros((rows, cols), np.float32)
    height[2, 4] = 0.05
    msg = Heightmap(resolution=0.002)
    msg.origin = Point(x=0.3, y=-0.2, z=0.01)
    msg.color = numpy_to_image(colour, "rgb8")
    msg.height = numpy_to_image(height, "32FC1")
    return msg


def test_the_heightmap_is_drawn_as_the_seen_cells_in_their_colour_at_their_height():
    marker = vis.heightmap_marker(small_heightmap(), stride=2)
    assert (marker.ns, marker.type) == (vis.HEIGHTMAP_NS, Marker.POINTS)
    assert marker.header.frame_id == names.BASE_FRAME
    points = sorted((p.x, p.y, p.z) for p in marker.points)
    np.testing.assert_allclose(points, [(0.3 + 0.5 * 0.002, -0.2 + 4.5 * 0.002, 0.01),
                                        (0.3 + 4.5 * 0.002, -0.2 + 2.5 * 0.002, 0.06)], atol=1e-6)
    red = [c for c, p in zip(marker.colors, marker.points, strict=True) if p.z > 0.05][0]
    assert (red.r, red.g, red.b) == pytest.approx((200 / 255, 30 / 255, 20 / 255))
    assert marker.scale.x == pytest.approx(0.004)  # two cells wide at stride 2


def test_a_stride_skips_cells():
    assert len(vis.heightmap_marker(small_heightmap(), stride=1).points) == 2
    # at stride 4 the drawn rows and columns are 0 and 4: cell (4, 0) is drawn, (2, 4) is not
    assert len(vis.heightmap_marker(small_heightmap(), stride=4).points) == 1


def test_an_undrawable_heightmap_is_refused():
    with pytest.raises(ValueError, match="stride must be at least 1"):
        vis.heightmap_marker(small_heightmap(), stride=0)
    mismatched = small_heightmap()
    mismatched.height = numpy_to_image(np.zeros((3, 3), np.float32), "32FC1")
    with pytest.raises(ValueError, match="do not match"):
        vis.heightmap_marker(mismatched)
