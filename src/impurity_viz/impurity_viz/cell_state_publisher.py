"""Cell state publisher: what RViz and Foxglove need for a 3-D view of the cell, from /joint_states and
the camera pose parameters.

  /joint_states (sensor_msgs/JointState)  ->  /tf         (tf2_msgs/TFMessage): the arm's joints
                                              /tf_static  (transient local): fixed joints and the camera
                                              /robot_description (std_msgs/String URDF, transient local)

The robot_state_publisher of this cell (which has none: it is a C++ package outside the PyPI wheels):
the URDF is visualisation.robot_description() (UR5 from its DH table + the RG2-like gripper) and the
latest /joint_states message becomes one /tf message of every movable joint's transform (parent ->
child link, stamped as the joint states) at most `publish_frequency` times a second (a UR driver
publishes joint states at 500 Hz; one /tf message costs ~0.6 ms of Python). TF then holds base_link ->
base_link_inertia -> shoulder_link .. wrist_3_link -> flange -> tool0 -> gripper_tcp. Joints absent
from /joint_states (the fingers: the UR driver and sim_cell publish the six arm joints) are drawn at 0.
The camera's optical frame is published as a static base_link -> camera_color_optical_frame from
camera_position / camera_orientation, the same parameters (bringup/config/camera_calibration.yaml,
read after the cell's file) heightmap_node projects with. On a real cell, start the RealSense driver
with publish_tf:=false so that frame has one parent.
"""

from dataclasses import dataclass

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from impurity_common import names
from impurity_common.conversions import time_to_ns
from impurity_common.diagnostics import OK, WARN, Diagnostics, RateMeter, Status
from impurity_common.node_main import spin_node
from impurity_common.parameters import (
    camera_orientation_param,
    camera_position_param,
    declare_parameters,
    param,
)
from impurity_viz.visualisation import (
    RobotTree,
    camera_transform,
    joint_positions,
    robot_description,
    transform_stamped,
)

TF_DEPTH = 100  # tf2's TransformBroadcaster queue depth
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)  # late joiners get the last message


@dataclass(frozen=True)
class CellStateParameters:
    """Every parameter of the node (cell.yaml / real_cell.yaml; the camera pose: camera_calibration.yaml)."""

    camera_position: tuple[float, ...] = camera_position_param()
    camera_orientation: tuple[float, ...] = camera_orientation_param()
    publish_camera_transform: bool = param(
        True, "Publish base_link -> camera_color_optical_frame on /tf_static (false when another node, e.g. "
        "the RealSense driver with a calibrated parent, already does)")
    publish_frequency: float = param(30.0, "Most /tf messages per second: the latest joint states are "
                                     "published at this rate when new ones arrived (Hz)",
                                     low=0.1, high=1000.0)
    log_throttle: float = param(5.0, "s between repeated warnings about bad joint states", low=0.0,
                                high=3600.0)


class CellStatePublisher(Node):
    def __init__(self):
        super().__init__("cell_state_publisher")
        params = self.params = declare_parameters(self, CellStateParameters)
        self._description = robot_description()
        self._tree = RobotTree.from_urdf(self._description)
        self._tf_pub = self.create_publisher(
            TFMessage, names.TF_TOPIC, QoSProfile(depth=TF_DEPTH, reliability=ReliabilityPolicy.RELIABLE))
        self._static_pub = self.create_publisher(TFMessage, names.TF_STATIC_TOPIC, LATCHED)
        self._description_pub = self.create_publisher(String, names.ROBOT_DESCRIPTION_TOPIC, LATCHED)
        self._latest: JointState | None = None  # joint states not yet published on /tf
        self.create_subscription(JointState, names.JOINT_STATES_TOPIC, self._on_joint_states, 10)
        self.create_timer(1.0 / params.publish_frequency, self._publish_tf)

        stamp = self.get_clock().now().to_msg()
        static = [transform_stamped(parent, child, pose, stamp)
                  for parent, child, pose in self._tree.static_transforms()]
        if params.publish_camera_transform:
            static.append(transform_stamped(*camera_transform(params.camera_position,
                                                              params.camera_orientation), stamp))
        self._static_pub.publish(TFMessage(transforms=static))
        self._description_pub.publish(String(data=self._description))
        self._joint_states = RateMeter()
        self._static_count = len(static)
        self.diagnostics = Diagnostics(self, self._status)
        camera = (f"camera at {list(params.camera_position)}" if params.publish_camera_transform
                  else "no camera")
        self.get_logger().info(
            f"ready: {names.JOINT_STATES_TOPIC} -> {names.TF_TOPIC} "
            f"({len(self._tree.movable_joints)} joints); "
            f"{len(static)} static transforms ({camera}) on {names.TF_STATIC_TOPIC}; URDF of "
            f"{len(self._tree.links)} links on {names.ROBOT_DESCRIPTION_TOPIC}")

    def _status(self) -> Status:
        """Joint states received per second (each becomes /tf); WARN while none arrives."""
        rate = self._joint_states.rate()
        values = {"joint state rate (Hz)": rate, "joint states": self._joint_states.count,
                  "static transforms": self._static_count}
        if rate == 0.0:
            return Status(WARN, f"no joint states on {names.JOINT_STATES_TOPIC}: /tf shows no arm motion",
                          values)
        return Status(OK, f"{values['joint state rate (Hz)']:.0f} joint states/s", values)

    def _on_joint_states(self, msg: JointState) -> None:
        self._joint_states.tick()
        self._latest = msg

    def _publish_tf(self) -> None:
        msg, self._latest = self._latest, None
        if msg is None:
            return
        try:
            positions = joint_positions(list(msg.name), list(msg.position))
        except ValueError as error:
            self.get_logger().warning(f"joint states dropped: {error}",
                                      throttle_duration_sec=self.params.log_throttle)
            return
        unknown = sorted(set(positions) - set(self._tree.movable_joints))
        if unknown:
            self.get_logger().warning(f"joint states name joints the robot model lacks (ignored): {unknown}",
                                      throttle_duration_sec=self.params.log_throttle)
        stamp = msg.header.stamp if time_to_ns(msg.header.stamp) > 0 else self.get_clock().now().to_msg()
        self._tf_pub.publish(TFMessage(transforms=[
            transform_stamped(parent, child, pose, stamp)
            for parent, child, pose in self._tree.moving_transforms(positions)]))


def main(args=None):
    spin_node(CellStatePublisher, args=args)


if __name__ == "__main__":
    main()
