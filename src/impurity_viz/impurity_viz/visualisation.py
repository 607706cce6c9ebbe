"""What RViz and Foxglove draw of the cell, without rclpy: the robot model's transforms (as
robot_state_publisher computes them from a URDF and joint positions), the camera's pose, and markers for
the chosen primitive and the attended region.

Conventions: every pose is a 4 x 4 homogeneous matrix in metres; quaternions are (x, y, z, w) as in
geometry_msgs; frames follow REP-103 (impurity_common.names). The robot model is
ur5_kinematics.urdf_text(ros_frames=True), generated from the UR5's DH table, so the TF tree here and
the kinematics the simulator and the motion plan use cannot disagree (tests/unit/impurity_viz/
test_visualisation.py walks the URDF and compares with ur5_kinematics.joint_frames).

Nodes: cell_state_publisher (TF, /robot_description) and decision_markers (MarkerArray).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import Point, TransformStamped
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker

from impurity_common import cell, names
from impurity_common.conversions import image_to_numpy
from impurity_common.enums import AttentionMode, PrimitiveKind
from ur5_motion import ur5_kinematics

TCP_FRAME = "gripper_tcp"  # the URDF's TCP link: centre between the fingertips' lower ends, z up the wrist
TOOL_FRAME = "tool0"  # the UR flange frame, z out of the flange (REP-199 / ur_description)


def robot_description() -> str:
    """The URDF published on /robot_description: the UR5 with UR-driver link names (base_link,
    base_link_inertia, base, shoulder_link .. wrist_3_link, flange, tool0) and the RG2-like gripper
    (gripper_tcp, coupling, left_finger, right_finger)."""
    return ur5_kinematics.urdf_text(ros_frames=True)


# ------------------------------------------------------------------------------------ rotations
def quaternion_matrix(quaternion) -> np.ndarray:
    """3 x 3 rotation of a quaternion (x, y, z, w), normalised first. ValueError when it is not four
    finite numbers of non-zero norm."""
    q = np.asarray(quaternion, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)):
        raise ValueError(f"a quaternion is four finite numbers (x, y, z, w), got {quaternion!r}")
    norm = float(np.linalg.norm(q))
    if norm < 1e-9:
        raise ValueError(f"quaternion {list(q)} has zero norm")
    x, y, z, w = q / norm
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_quaternion(rotation) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w), w >= 0, of a 3 x 3 rotation matrix (Shepperd's method)."""
    r = np.asarray(rotation, dtype=float)[:3, :3]
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = ((r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s)
    else:
        i = int(np.argmax([r[0, 0], r[1, 1], r[2, 2]]))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(max(1.0 + r[i, i] - r[j, j] - r[k, k], 1e-12))
        v = [0.0, 0.0, 0.0]
        v[i] = 0.25 * s
        v[j] = (r[j, i] + r[i, j]) / s
        v[k] = (r[k, i] + r[i, k]) / s
        q = (*v, (r[k, j] - r[j, k]) / s)
    q = np.array(q) / np.linalg.norm(q)
    if q[3] < 0:
        q = -q
    return tuple(float(v) for v in q)


def pose_matrix(position, quaternion) -> np.ndarray:
    """4 x 4 pose from a position (m, 3 finite numbers) and a quaternion (x, y, z, w). ValueError on
    bad input (a camera pose parameter, for instance)."""
    p = np.asarray(position, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"a position is three finite numbers (x, y, z) in m, got {position!r}")
    pose = np.eye(4)
    pose[:3, :3] = quaternion_matrix(quaternion)
    pose[:3, 3] = p
    return pose


def axis_angle_matrix(axis, angle: float) -> np.ndarray:
    """3 x 3 rotation by `angle` (rad) about the unit vector `axis` (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


# ------------------------------------------------------------------------------------ robot model
class UrdfError(ValueError):
    """The URDF cannot be read as a tree of links and joints."""


def _floats(text: str | None, count: int, default: float, what: str) -> tuple:
    if text is None:
        return (default,) * count
    values = tuple(float(v) for v in text.split())
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise UrdfError(f"{what}: expected {count} finite numbers, got {text!r}")
    return values


@dataclass(frozen=True)
class UrdfJoint:
    """One URDF joint: `origin` is the child's pose in the parent at position 0 (4 x 4); a revolute or
    continuous joint then turns about `axis` (unit, child frame) by its position (rad), a prismatic one
    slides along it (m)."""

    name: str
    kind: str  # fixed, revolute, continuous, prismatic
    parent: str
    child: str
    origin: np.ndarray
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower: float = 0.0
    upper: float = 0.0

    @property
    def movable(self) -> bool:
        return self.kind != "fixed"

    def transform(self, position: float = 0.0) -> np.ndarray:
        """Child pose in the parent (4 x 4) at `position` (rad or m; ignored for a fixed joint)."""
        if self.kind in ("revolute", "continuous"):
            motion = np.eye(4)
            motion[:3, :3] = axis_angle_matrix(self.axis, position)
            return self.origin @ motion
        if self.kind == "prismatic":
            motion = np.eye(4)
            motion[:3, 3] = np.asarray(self.axis) * position
            return self.origin @ motion
        return self.origin.copy()


SUPPORTED_JOINTS = ("fixed", "revolute", "continuous", "prismatic")


class RobotTree:
    """The link tree of a URDF, for TF: what robot_state_publisher publishes, computed without it.

    static_transforms(): (parent, child, pose) of each fixed joint, for /tf_static.
    moving_transforms(positions): (parent, child, pose) of each movable joint, for /tf. A joint missing
    from `positions` is drawn at 0 clipped to its limits (sim_cell and the UR driver publish the six arm
    joints only; the fingers are then drawn closed).
    link_poses(positions): every link's pose in the root link.
    """

    def __init__(self, joints: list[UrdfJoint], links: list[str]):
        self.joints = tuple(joints)
        self.links = tuple(links)
        children = [j.child for j in joints]
        roots = [link for link in links if link not in children]
        if len(roots) != 1:
            raise UrdfError(f"a URDF tree has one root link, found {roots or 'none (a cycle)'}")
        self.root = roots[0]
        duplicates = sorted({c for c in children if children.count(c) > 1})
        if duplicates:
            raise UrdfError(f"links with more than one parent joint: {duplicates}")
        unknown = sorted({name for j in joints for name in (j.parent, j.child)} - set(links))
        if unknown:
            raise UrdfError(f"joints name links the URDF does not define: {unknown}")
        self._order = self._topological()

    @classmethod
    def from_urdf(cls, text: str) -> RobotTree:
        """Parse URDF text. UrdfError (a ValueError) names what is wrong: not XML, not a <robot>, a
        joint without parent or child, an unsupported joint type (floating, planar), bad numbers."""
        try:
            root = ElementTree.fromstring(text)
        except ElementTree.ParseError as error:
            raise UrdfError(f"not XML: {error}") from None
        if root.tag != "robot":
            raise UrdfError(f"the root element is <{root.tag}>, not <robot>")
        links = [element.get("name") for element in root.findall("link")]
        joints = []
        for element in root.findall("joint"):
            name, kind = element.get("name"), element.get("type")
            parent, child = element.find("parent"), element.find("child")
            if parent is None or child is None or not parent.get("link") or not child.get("link"):
                raise UrdfError(f"joint {name!r} lacks a parent or child link")
            if kind not in SUPPORTED_JOINTS:
                raise UrdfError(f"joint {name!r} has type {kind!r} "
                                f"(supported: {', '.join(SUPPORTED_JOINTS)})")
            origin_element = element.find("origin")
            xyz = _floats(None if origin_element is None else origin_element.get("xyz"), 3, 0.0,
                          f"joint {name!r} origin xyz")
            rpy = _floats(None if origin_element is None else origin_element.get("rpy"), 3, 0.0,
                          f"joint {name!r} origin rpy")
            origin = np.eye(4)
            origin[:3, :3] = ur5_kinematics.rpy_matrix(*rpy)
            origin[:3, 3] = xyz
            axis_element = element.find("axis")
            axis = _floats(None if axis_element is None else axis_element.get("xyz"), 3, 0.0,
                           f"joint {name!r} axis")
            if axis_element is None:
                axis = (1.0, 0.0, 0.0)  # URDF's default axis
            if kind != "fixed" and np.linalg.norm(axis) < 1e-9:
                raise UrdfError(f"joint {name!r} has a zero axis")
            axis = tuple(float(v) for v in np.asarray(axis) / max(np.linalg.norm(axis), 1e-12))
            limit = element.find("limit")
            lower = float(limit.get("lower", 0.0)) if limit is not None else 0.0
            upper = float(limit.get("upper", 0.0)) if limit is not None else 0.0
            joints.append(UrdfJoint(name, kind, parent.get("link"), child.get("link"), origin, axis,
                                    lower, upper))
        return cls(joints, links)

    def _topological(self) -> list[UrdfJoint]:
        """Joints ordered parents first (each joint after the joint that made its parent link)."""
        by_parent: dict[str, list[UrdfJoint]] = {}
        for joint in self.joints:
            by_parent.setdefault(joint.parent, []).append(joint)
        order, stack = [], [self.root]
        while stack:
            for joint in by_parent.get(stack.pop(), []):
                order.append(joint)
                stack.append(joint.child)
        if len(order) != len(self.joints):
            raise UrdfError("some joints are not reachable from the root link (a cycle)")
        return order

    @property
    def movable_joints(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if j.movable)

    def position_of(self, joint: UrdfJoint, positions: Mapping[str, float]) -> float:
        value = positions.get(joint.name)
        if value is None or not math.isfinite(value):
            value = 0.0
        if joint.kind in ("revolute", "prismatic") and joint.upper > joint.lower:
            value = min(max(value, joint.lower), joint.upper)
        return float(value)

    def static_transforms(self) -> list[tuple[str, str, np.ndarray]]:
        return [(j.parent, j.child, j.transform()) for j in self._order if not j.movable]

    def moving_transforms(self, positions: Mapping[str, float]) -> list[tuple[str, str, np.ndarray]]:
        return [(j.parent, j.child, j.transform(self.position_of(j, positions)))
                for j in self._order if j.movable]

    def link_poses(self, positions: Mapping[str, float]) -> dict[str, np.ndarray]:
        """Pose of every link in the root link (4 x 4)."""
        poses = {self.root: np.eye(4)}
        for joint in self._order:
            poses[joint.child] = poses[joint.parent] @ joint.transform(self.position_of(joint, positions))
        return poses


def joint_positions(names_: list[str], positions: list[float]) -> dict[str, float]:
    """sensor_msgs/JointState's parallel name and position lists -> {name: position}. ValueError when
    their lengths differ (the message is malformed)."""
    if len(names_) != len(positions):
        raise ValueError(f"JointState has {len(names_)} names but {len(positions)} positions")
    return {str(n): float(p) for n, p in zip(names_, positions, strict=True)}


def transform_stamped(parent: str, child: str, pose: np.ndarray, stamp) -> TransformStamped:
    """geometry_msgs/TransformStamped of `child`'s pose (4 x 4) in `parent` at `stamp`
    (builtin_interfaces/Time)."""
    msg = TransformStamped()
    msg.header.frame_id = parent
    msg.header.stamp = stamp
    msg.child_frame_id = child
    t = msg.transform.translation
    t.x, t.y, t.z = (float(v) for v in pose[:3, 3])
    r = msg.transform.rotation
    r.x, r.y, r.z, r.w = matrix_quaternion(pose[:3, :3])
    return msg


def camera_transform(position, orientation) -> tuple[str, str, np.ndarray]:
    """(base_link, camera_color_optical_frame, pose): the camera's optical frame in base_link from the
    cell's camera_position (m) / camera_orientation (quaternion x, y, z, w) parameters, the same pair
    heightmap_node projects with. ValueError on a bad pose."""
    return names.BASE_FRAME, names.CAMERA_OPTICAL_FRAME, pose_matrix(position, orientation)


# ------------------------------------------------------------------------------------ markers
PRIMITIVE_NS = "primitive"
ATTENTION_NS = "attention"
HEIGHTMAP_NS = "heightmap"
HEIGHTMAP_POINTS = 0  # its one marker id
PUSH_COLOR = (0.10, 0.45, 0.95, 0.9)  # blue arrow
GRASP_COLOR = (0.10, 0.80, 0.25, 0.9)  # green jaws
MODE_COLORS = {AttentionMode.NONE: (0.6, 0.6, 0.6, 0.8),  # grey: nothing left to look for
               AttentionMode.TARGET: (0.95, 0.15, 0.10, 0.9),  # red: a visible impurity
               AttentionMode.OCCLUDED_REGION: (1.0, 0.65, 0.0, 0.9)}  # orange: a heap that may hide one
# Marker ids within each namespace (stable, so a new decision replaces the last).
PUSH_ARROW, GRASP_LEFT_JAW, GRASP_RIGHT_JAW, GRASP_AXIS, PRIMITIVE_LABEL = range(5)
CROP_SQUARE, CROP_CENTRE, ATTENTION_LABEL = range(3)
LINE_WIDTH = 0.004  # m
LABEL_HEIGHT = 0.025  # m, text size
LABEL_LIFT = 0.06  # m above the primitive or crop where its label floats


def _color(rgba) -> ColorRGBA:
    return ColorRGBA(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]))


def _marker(ns: str, marker_id: int, kind: int, header, rgba=(1.0, 1.0, 1.0, 1.0)) -> Marker:
    marker = Marker()
    marker.header.frame_id = names.BASE_FRAME
    marker.header.stamp = header.stamp
    marker.ns, marker.id, marker.type, marker.action = ns, marker_id, kind, Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.color = _color(rgba)
    marker.frame_locked = False
    return marker


def _delete(ns: str, marker_id: int, header) -> Marker:
    marker = _marker(ns, marker_id, Marker.CUBE, header)
    marker.action = Marker.DELETE
    return marker


def _yaw_orientation(marker: Marker, yaw: float) -> None:
    marker.pose.orientation.z, marker.pose.orientation.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def _label(ns: str, marker_id: int, header, position, text: str, rgba) -> Marker:
    label = _marker(ns, marker_id, Marker.TEXT_VIEW_FACING, header, rgba)
    label.pose.position.x, label.pose.position.y, label.pose.position.z = (float(v) for v in position)
    label.scale.z = LABEL_HEIGHT
    label.text = text
    return label


def push_end(x: float, y: float, yaw: float, workspace_x=cell.WORKSPACE_X,
             workspace_y=cell.WORKSPACE_Y, length: float = cell.PUSH_LENGTH) -> tuple[float, float]:
    """Where a push from (x, y) along yaw ends (m, base_link): `length` along yaw, clamped onto the
    workspace rectangle as the motion plan clamps the stroke."""
    end_x = x + length * math.cos(yaw)
    end_y = y + length * math.sin(yaw)
    return (min(max(end_x, workspace_x[0]), workspace_x[1]), min(max(end_y, workspace_y[0]), workspace_y[1]))


def primitive_markers(primitive, grasp_opening: float = cell.GRASP_OPENING) -> list[Marker]:
    """Markers of an impurity_interfaces/Primitive (namespace "primitive", frame base_link):

    push: an ARROW from the primitive's position along the stroke (push_end); grasp: the two finger
    pads as CUBEs (FINGER_THICKNESS x FINGER_WIDTH x FINGER_LENGTH), `grasp_opening` (m) apart along
    the closing axis (yaw), from the TCP height up, and a LINE_LIST between them; both: a label with
    the kind and q_value. The other kind's markers are deleted in the same list. ValueError for an
    unknown kind or a non-finite position or yaw.
    """
    kind = PrimitiveKind(int(primitive.kind)) if int(primitive.kind) in tuple(PrimitiveKind) else None
    if kind is None:
        raise ValueError(f"unknown primitive kind {primitive.kind} (expected "
                         f"{', '.join(f'{k.value} ({k.label})' for k in PrimitiveKind)})")
    p = primitive.position
    x, y, z, yaw = float(p.x), float(p.y), float(p.z), float(primitive.yaw)
    if not all(math.isfinite(v) for v in (x, y, z, yaw)):
        raise ValueError(f"primitive position ({x}, {y}, {z}) or yaw {yaw} is not finite")
    header = primitive.header
    markers = []
    if kind is PrimitiveKind.PUSH:
        end = push_end(x, y, yaw)
        arrow = _marker(PRIMITIVE_NS, PUSH_ARROW, Marker.ARROW, header, PUSH_COLOR)
        arrow.points = [Point(x=x, y=y, z=z), Point(x=end[0], y=end[1], z=z)]
        arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.012, 0.03, 0.03  # shaft, head diameter; head length
        markers.append(arrow)
        markers += [_delete(PRIMITIVE_NS, i, header) for i in (GRASP_LEFT_JAW, GRASP_RIGHT_JAW, GRASP_AXIS)]
        color = PUSH_COLOR
    else:
        c, s = math.cos(yaw), math.sin(yaw)
        offset = grasp_opening / 2.0 + cell.FINGER_THICKNESS / 2.0  # pad centre from the TCP
        jaw_z = z + cell.FINGER_LENGTH / 2.0
        for marker_id, side in ((GRASP_LEFT_JAW, 1.0), (GRASP_RIGHT_JAW, -1.0)):
            jaw = _marker(PRIMITIVE_NS, marker_id, Marker.CUBE, header, GRASP_COLOR)
            jaw.pose.position.x, jaw.pose.position.y, jaw.pose.position.z = (
                x + side * offset * c, y + side * offset * s, jaw_z)
            _yaw_orientation(jaw, yaw)
            jaw.scale.x, jaw.scale.y = cell.FINGER_THICKNESS, cell.FINGER_WIDTH
            jaw.scale.z = cell.FINGER_LENGTH
            markers.append(jaw)
        axis = _marker(PRIMITIVE_NS, GRASP_AXIS, Marker.LINE_LIST, header, GRASP_COLOR)
        axis.points = [Point(x=x - offset * c, y=y - offset * s, z=z),
                       Point(x=x + offset * c, y=y + offset * s, z=z)]
        axis.scale.x = LINE_WIDTH
        markers.append(axis)
        markers.append(_delete(PRIMITIVE_NS, PUSH_ARROW, header))
        color = GRASP_COLOR
    markers.append(_label(PRIMITIVE_NS, PRIMITIVE_LABEL, header, (x, y, z + LABEL_LIFT),
                          f"{kind.label} q={float(primitive.q_value):.2f}", color))
    return markers


def crop_corners(attention) -> np.ndarray:
    """The attended crop's corners in base_link (4 x 3, m, closed order), at the table height: the crop
    is color_crop's size (CROP_SIZE when it carries no image) from (crop_row0, crop_col0) of the
    heightmap the result carries (pixel (r, c) covers x = origin.x + c * res .. + res, y likewise)."""
    heightmap = attention.heightmap
    resolution = float(heightmap.resolution) or cell.HEIGHTMAP_RESOLUTION
    rows = int(attention.color_crop.height) or cell.CROP_SIZE
    cols = int(attention.color_crop.width) or cell.CROP_SIZE
    x0 = float(heightmap.origin.x) + int(attention.crop_col0) * resolution
    y0 = float(heightmap.origin.y) + int(attention.crop_row0) * resolution
    x1, y1 = x0 + cols * resolution, y0 + rows * resolution
    z = float(heightmap.origin.z)
    return np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def attention_markers(attention) -> list[Marker]:
    """Markers of an impurity_interfaces/AttentionResult (namespace "attention", frame base_link),
    coloured by mode (MODE_COLORS): the crop square (LINE_STRIP, crop_corners) and its centre (a
    SPHERE at `center`) for TARGET and OCCLUDED_REGION, deleted for NONE; a label with the mode and
    score. ValueError for an unknown mode."""
    mode_value = int(attention.mode)
    if mode_value not in tuple(AttentionMode):
        raise ValueError(f"unknown attention mode {mode_value} (expected "
                         f"{', '.join(f'{m.value} ({m.label})' for m in AttentionMode)})")
    mode = AttentionMode(mode_value)
    header = attention.header
    color = MODE_COLORS[mode]
    markers = []
    if mode is AttentionMode.NONE:
        markers += [_delete(ATTENTION_NS, i, header) for i in (CROP_SQUARE, CROP_CENTRE)]
        hm = attention.heightmap
        where = (sum(cell.WORKSPACE_X) / 2.0, sum(cell.WORKSPACE_Y) / 2.0, float(hm.origin.z) + LABEL_LIFT)
    else:
        corners = crop_corners(attention)
        corners[:, 2] += 0.001  # just above the table, so the square is not hidden in it
        square = _marker(ATTENTION_NS, CROP_SQUARE, Marker.LINE_STRIP, header, color)
        square.points = [Point(x=float(c[0]), y=float(c[1]), z=float(c[2])) for c in (*corners, corners[0])]
        square.scale.x = LINE_WIDTH
        centre = _marker(ATTENTION_NS, CROP_CENTRE, Marker.SPHERE, header, color)
        centre.pose.position.x, centre.pose.position.y, centre.pose.position.z = (
            float(attention.center.x), float(attention.center.y), float(attention.center.z))
        centre.scale.x = centre.scale.y = centre.scale.z = 0.015
        markers += [square, centre]
        where = (float(corners[0, 0]), float(corners[0, 1]), float(corners[0, 2]) + LABEL_LIFT)
    markers.append(_label(ATTENTION_NS, ATTENTION_LABEL, header, where,
                          f"attention: {mode.label} ({float(attention.score):.3f})", color))
    return markers


def heightmap_marker(heightmap, stride: int = 4) -> Marker:
    """The heightmap (impurity_interfaces/Heightmap) as a POINTS marker (namespace "heightmap", frame
    base_link): every `stride`-th cell in rows and columns that the camera saw (colour not black), at
    x = origin.x + (col + 0.5) * resolution, y likewise, z = origin.z + height, in the cell's colour,
    each point `stride` cells wide.
    3-D viewers have no Heightmap display; this shows the scene beside the markers. ValueError for a
    stride below 1 or images that do not fit (conversions.ImageFormatError is a ValueError)."""
    if int(stride) < 1:
        raise ValueError(f"stride must be at least 1, got {stride}")
    colour = image_to_numpy(heightmap.color)
    height = image_to_numpy(heightmap.height)
    if colour.ndim != 3 or colour.shape[:2] != height.shape:
        raise ValueError(f"heightmap colour {colour.shape} and height {height.shape} do not match")
    res, origin = float(heightmap.resolution), heightmap.origin
    rows, cols = np.mgrid[0:height.shape[0]:stride, 0:height.shape[1]:stride]
    seen = colour[rows, cols, :3].astype(int).sum(axis=-1) > 0
    rows, cols = rows[seen], cols[seen]
    xs = float(origin.x) + (cols + 0.5) * res
    ys = float(origin.y) + (rows + 0.5) * res
    zs = float(origin.z) + height[rows, cols].astype(float)
    rgb = colour[rows, cols, :3].astype(float) / 255.0
    marker = _marker(HEIGHTMAP_NS, HEIGHTMAP_POINTS, Marker.POINTS, heightmap.header)
    marker.scale.x = marker.scale.y = res * stride  # m: each drawn point covers its stride of cells
    marker.points = [Point(x=x, y=y, z=z)
                     for x, y, z in zip(xs.tolist(), ys.tolist(), zs.tolist(), strict=True)]
    marker.colors = [ColorRGBA(r=r, g=g, b=b, a=1.0) for r, g, b in rgb.tolist()]
    return marker
