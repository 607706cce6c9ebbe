#!/usr/bin/env python3
"""A 3-D picture of the cell as RViz or Foxglove would show it, drawn with matplotlib: the TF frames, the
UR5's links, the heightmap as a coloured point cloud, and the decision markers (chosen push or grasp,
attended crop).

  python scripts/render_cell_3d.py --live                   # from a running graph (any ROS_DOMAIN_ID)
  python scripts/render_cell_3d.py --bag runs/episode_bag   # from a recorded bag (MCAP, via rosbags)
  python scripts/render_cell_3d.py --bag B --at 12.5        # the state 12.5 s into the bag

Inputs: /tf + /tf_static (cell_state_publisher), /heightmap (or the heightmap inside /attention/result),
/cell/markers (decision_markers). A bag without /tf but with /joint_states is drawn from the joint states
and the robot model (as cell_state_publisher would have); what is missing is said and left out.
Writes docs/images/cell_3d.png unless --output says otherwise. Needs `source scripts/env.sh`.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from impurity_common import cell, names
from impurity_common.conversions import image_to_numpy
from impurity_viz.visualisation import (
    TCP_FRAME,
    RobotTree,
    joint_positions,
    pose_matrix,
    quaternion_matrix,
    robot_description,
)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEFAULT_OUTPUT = ROOT / "docs" / "images" / "cell_3d.png"
ARM_CHAIN = ("base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
             "wrist_3_link", "tool0", TCP_FRAME)
LABELLED_FRAMES = (names.BASE_FRAME, "tool0", TCP_FRAME, names.CAMERA_OPTICAL_FRAME)
AXIS_LENGTH = 0.06  # m, the RGB axes of labelled frames (x red, y green, z blue, as RViz)
SMALL_AXIS_LENGTH = 0.03  # m, the other frames
POINT_STRIDE = 3  # heightmap cells between drawn points
HEIGHTMAP_TOPICS = (names.HEIGHTMAP_TOPIC, names.ATTENTION_TOPIC)
MARKER_ADD, MARKER_DELETE, MARKER_DELETEALL = 0, 2, 3  # visualization_msgs/Marker actions
ARROW, CUBE, SPHERE, LINE_STRIP, LINE_LIST, TEXT = 0, 1, 2, 4, 5, 9  # Marker types drawn here


@dataclass
class CellSnapshot:
    """What is drawn: frame -> (parent, 4 x 4 pose in the parent); a heightmap; markers by (ns, id)."""

    transforms: dict = field(default_factory=dict)
    heightmap: object | None = None  # impurity_interfaces/Heightmap (rclpy or rosbags message)
    markers: dict = field(default_factory=dict)
    sources: list = field(default_factory=list)  # what was found, for the log

    def add_tf(self, msg) -> None:
        for t in msg.transforms:
            tr, r = t.transform.translation, t.transform.rotation
            self.transforms[t.child_frame_id] = (t.header.frame_id,
                                                 pose_matrix((tr.x, tr.y, tr.z), (r.x, r.y, r.z, r.w)))

    def add_joint_states(self, msg, tree: RobotTree) -> None:
        positions = joint_positions(list(msg.name), list(msg.position))
        for parent, child, pose in tree.static_transforms() + tree.moving_transforms(positions):
            self.transforms.setdefault(child, (parent, pose))

    def add_markers(self, msg) -> None:
        for marker in msg.markers:
            if marker.action == MARKER_DELETEALL:
                self.markers.clear()
            elif marker.action == MARKER_DELETE:
                self.markers.pop((marker.ns, marker.id), None)
            elif marker.action == MARKER_ADD:
                self.markers[(marker.ns, marker.id)] = marker

    def pose(self, frame: str) -> np.ndarray | None:
        """The frame's pose in base_link, or None when TF does not connect it to base_link."""
        pose, seen = np.eye(4), set()
        while frame != names.BASE_FRAME:
            if frame not in self.transforms or frame in seen:
                return None
            seen.add(frame)
            parent, relative = self.transforms[frame]
            pose, frame = relative @ pose, parent
        return pose


# ------------------------------------------------------------------------------------ sources
def from_bag(path: pathlib.Path, at: float | None) -> CellSnapshot:
    from impurity_bags.bags import BagReader, cell_typestore

    typestore = cell_typestore()
    snapshot = CellSnapshot()
    wanted = (names.TF_TOPIC, names.TF_STATIC_TOPIC, names.MARKERS_TOPIC, names.JOINT_STATES_TOPIC,
              *HEIGHTMAP_TOPICS)
    with BagReader(path, typestore) as reader:
        local = {names.absolute(t): t for t in wanted}  # as the bag spells it (absolute) -> the cell's name
        present = [t for t in local if t in reader.topics]
        stop = None if at is None else reader.start_ns + int(at * 1e9) + 1
        tree = RobotTree.from_urdf(robot_description())
        has_tf = names.absolute(names.TF_TOPIC) in present
        last_joint_states, heightmaps = None, {}
        unreadable: dict[str, int] = {}
        for message in reader.messages(present, stop_ns=stop):
            try:
                msg = typestore.deserialize_cdr(message.data, message.msgtype)
            except Exception:  # noqa: BLE001 - rosbags' SerdeError and struct errors: skip, say so
                unreadable[message.topic] = unreadable.get(message.topic, 0) + 1
                continue
            topic = local[message.topic]
            if topic in (names.TF_TOPIC, names.TF_STATIC_TOPIC):
                snapshot.add_tf(msg)
            elif topic == names.MARKERS_TOPIC:
                snapshot.add_markers(msg)
            elif topic == names.JOINT_STATES_TOPIC:
                last_joint_states = msg
            elif topic == names.HEIGHTMAP_TOPIC:
                heightmaps[topic] = msg
            elif topic == names.ATTENTION_TOPIC:
                heightmaps[topic] = msg.heightmap
        if not has_tf and last_joint_states is not None:
            snapshot.add_joint_states(last_joint_states, tree)
            snapshot.sources.append(f"{names.JOINT_STATES_TOPIC} through the robot model "
                                    f"(no {names.TF_TOPIC})")
        snapshot.heightmap = next((heightmaps[t] for t in HEIGHTMAP_TOPICS if t in heightmaps), None)
        if unreadable:
            snapshot.sources.append("messages rosbags could not deserialize (skipped): " + ", ".join(
                f"{count} on {topic}" for topic, count in unreadable.items()))
        snapshot.sources.append(f"bag {path}: {', '.join(present) or 'none of the drawn topics'}")
    return snapshot


def from_live(timeout: float) -> CellSnapshot:
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import MarkerArray

    from impurity_interfaces.msg import AttentionResult, Heightmap

    snapshot = CellSnapshot()
    seen: set = set()
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    heightmaps = {}

    def on(topic, handle):
        def callback(msg):
            seen.add(topic)
            handle(msg)
        return callback

    rclpy.init()
    node = rclpy.create_node("render_cell_3d")
    try:
        node.create_subscription(TFMessage, names.TF_TOPIC, on(names.TF_TOPIC, snapshot.add_tf),
                                 QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
        node.create_subscription(TFMessage, names.TF_STATIC_TOPIC, on(names.TF_STATIC_TOPIC, snapshot.add_tf),
                                 QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                                            durability=DurabilityPolicy.TRANSIENT_LOCAL))
        node.create_subscription(MarkerArray, names.MARKERS_TOPIC,
                                 on(names.MARKERS_TOPIC, snapshot.add_markers), latched)

        def keep_heightmap(topic, of):
            return on(topic, lambda msg: heightmaps.update({topic: of(msg)}))

        node.create_subscription(Heightmap, names.HEIGHTMAP_TOPIC,
                                 keep_heightmap(names.HEIGHTMAP_TOPIC, lambda msg: msg), reliable)
        node.create_subscription(AttentionResult, names.ATTENTION_TOPIC,
                                 keep_heightmap(names.ATTENTION_TOPIC, lambda msg: msg.heightmap), reliable)
        needed = {names.TF_TOPIC, names.TF_STATIC_TOPIC, names.MARKERS_TOPIC}
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not (needed <= seen and heightmaps):
            rclpy.spin_once(node, timeout_sec=0.1)
        for _ in range(10):  # a moment more, so every frame of the same instant is in
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    snapshot.heightmap = next((heightmaps[t] for t in HEIGHTMAP_TOPICS if t in heightmaps), None)
    snapshot.sources.append(f"live graph: {', '.join(sorted(seen)) or 'nothing heard'}")
    return snapshot


# ------------------------------------------------------------------------------------ drawing
def heightmap_points(heightmap) -> tuple[np.ndarray, np.ndarray]:
    """(N x 3 points in base_link, N x 3 colours 0..1) of every POINT_STRIDE-th cell that was seen."""
    colour = image_to_numpy(heightmap.color).astype(float) / 255.0
    height = image_to_numpy(heightmap.height).astype(float)
    res, origin = float(heightmap.resolution), heightmap.origin
    rows, cols = np.mgrid[0:height.shape[0]:POINT_STRIDE, 0:height.shape[1]:POINT_STRIDE]
    seen = colour[rows, cols].sum(axis=-1) > 0
    x = origin.x + (cols + 0.5) * res
    y = origin.y + (rows + 0.5) * res
    z = origin.z + height[rows, cols]
    return np.stack([x[seen], y[seen], z[seen]], axis=1), colour[rows, cols][seen]


def draw_axes(ax, pose: np.ndarray, length: float, label: str | None) -> None:
    origin = pose[:3, 3]
    for column, colour in zip(range(3), ("red", "green", "blue"), strict=True):
        tip = origin + length * pose[:3, column]
        ax.plot(*zip(origin, tip, strict=True), color=colour, linewidth=1.5)
    if label:
        ax.text(*(origin + np.array([0.0, 0.0, 0.015])), label, fontsize=7)


def cube_edges(marker) -> list:
    o = marker.pose.orientation
    rotation = quaternion_matrix((o.x, o.y, o.z, o.w))
    centre = np.array([marker.pose.position.x, marker.pose.position.y, marker.pose.position.z])
    half = np.array([marker.scale.x, marker.scale.y, marker.scale.z]) / 2
    corners = {(i, j, k): centre + rotation @ (half * np.array([i, j, k]))
               for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)}
    return [(corners[a], corners[b]) for a in corners for b in corners
            if a < b and sum(x != y for x, y in zip(a, b, strict=True)) == 1]


def draw_marker(ax, marker) -> None:
    colour = (marker.color.r, marker.color.g, marker.color.b, max(marker.color.a, 0.3))
    points = [np.array([p.x, p.y, p.z]) for p in marker.points]
    position = np.array([marker.pose.position.x, marker.pose.position.y, marker.pose.position.z])
    if marker.type == ARROW and len(points) == 2:
        start, end = points
        ax.quiver(*start, *(end - start), color=colour, linewidth=4, arrow_length_ratio=0.35)
    elif marker.type == CUBE:
        for a, b in cube_edges(marker):
            ax.plot(*zip(a, b, strict=True), color=colour, linewidth=2.5)
    elif marker.type == SPHERE:
        ax.scatter(*position, color=colour, s=40, depthshade=False)
    elif marker.type == LINE_STRIP and points:
        ax.plot(*np.array(points).T, color=colour, linewidth=2)
    elif marker.type == LINE_LIST:
        for a, b in zip(points[0::2], points[1::2], strict=False):
            ax.plot(*zip(a, b, strict=True), color=colour, linewidth=2)
    elif marker.type == TEXT:
        ax.text(*position, marker.text, color=colour[:3], fontsize=8)


def render(snapshot: CellSnapshot, output: pathlib.Path, title: str, elev: float = 30.0,
           azim: float = -60.0) -> list[str]:
    """Draw the snapshot into `output` (PNG); returns what could not be drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    missing = []
    fig = plt.figure(figsize=(9, 7.5), dpi=110)
    ax = fig.add_subplot(projection="3d", computed_zorder=False)  # drawn in order: markers on top
    (x0, x1), (y0, y1) = cell.WORKSPACE_X, cell.WORKSPACE_Y
    ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], [cell.TABLE_Z] * 5, color="0.4", linewidth=1)
    if snapshot.heightmap is not None:
        points, colours = heightmap_points(snapshot.heightmap)
        on_table = points[:, 2] - cell.TABLE_Z < 0.003
        for subset, size in ((on_table, 1.5), (~on_table, 6)):
            ax.scatter(points[subset, 0], points[subset, 1], points[subset, 2], c=colours[subset], s=size,
                       depthshade=False, linewidths=0)
    else:
        missing.append("heightmap")
    chain = [snapshot.pose(frame) for frame in ARM_CHAIN]
    known = [pose[:3, 3] for pose in chain if pose is not None]
    if len(known) >= 2:
        ax.plot(*np.array(known).T, color="0.55", linewidth=6, solid_capstyle="round", alpha=0.85)
        ax.scatter(*np.array(known).T, color="0.25", s=18, depthshade=False)
    else:
        missing.append("arm (no TF from base_link to the UR5 links)")
    for frame in sorted(set(snapshot.transforms) | {names.BASE_FRAME}):
        pose = snapshot.pose(frame)
        if pose is None:
            continue
        labelled = frame in LABELLED_FRAMES
        if labelled or frame in ARM_CHAIN:
            draw_axes(ax, pose, AXIS_LENGTH if labelled else SMALL_AXIS_LENGTH, frame if labelled else None)
    camera = snapshot.pose(names.CAMERA_OPTICAL_FRAME)
    if camera is not None:  # the optical axis down to the table
        origin, axis = camera[:3, 3], camera[:3, 2]
        reach = (origin[2] - cell.TABLE_Z) / -axis[2] if axis[2] < -1e-6 else 0.3
        ax.plot(*zip(origin, origin + reach * axis, strict=True), color="0.3", linestyle=":", linewidth=1)
    else:
        missing.append(f"{names.CAMERA_OPTICAL_FRAME} (no camera transform)")
    for marker in snapshot.markers.values():
        draw_marker(ax, marker)
    if not snapshot.markers:
        missing.append("markers")
    ax.set_xlim(0.0, 0.80)
    ax.set_ylim(-0.40, 0.30)
    ax.set_zlim(0.0, 0.80)
    ax.set_box_aspect((0.80, 0.70, 0.80))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.view_init(elev=elev, azim=azim)
    ax.set_title(title, fontsize=10)
    fig.subplots_adjust(left=0.0, right=0.97, bottom=0.02, top=0.95)
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output)
    plt.close(fig)
    return missing


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--live", action="store_true", help="listen to the running graph")
    source.add_argument("--bag", type=pathlib.Path, help="a rosbag2 directory (MCAP)")
    parser.add_argument("--at", type=float, default=None, help="bag only: seconds from the bag's start "
                        "(default: its end)")
    parser.add_argument("--timeout", type=float, default=30.0, help="live only: s to wait for the topics")
    parser.add_argument("--output", type=pathlib.Path, default=DEFAULT_OUTPUT)
    parser.add_argument("--elev", type=float, default=30.0, help="view elevation (deg)")
    parser.add_argument("--azim", type=float, default=-60.0, help="view azimuth (deg)")
    parser.add_argument("--title", default="Impurity-picking cell: TF, UR5, heightmap and decision markers")
    args = parser.parse_args(argv)
    if args.at is not None and args.bag is None:
        parser.error("--at applies to --bag only")
    if args.bag is not None:
        from impurity_bags.bags import BagError

        try:
            snapshot = from_bag(args.bag, args.at)
        except BagError as error:
            print(f"render_cell_3d: {error}", file=sys.stderr)
            return 1
    else:
        snapshot = from_live(args.timeout)
    missing = render(snapshot, args.output, args.title, args.elev, args.azim)
    for line in snapshot.sources:
        print(f"render_cell_3d: read {line}")
    if missing:
        print(f"render_cell_3d: not drawn: {'; '.join(missing)}")
    print(f"render_cell_3d: wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
