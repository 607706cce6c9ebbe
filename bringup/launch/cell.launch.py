"""ROS installs: the whole cell,

    ros2 launch impurity_bringup cell.launch.py [cell:=sim|real] [namespace:=/cell_a]
        [robot_ip:=192.168.1.10] [dry_run:=true|false] [camera:=true] [rviz:=true]
        [config:=...] [calibration:=...] [security:=true keystore:=DIR]

cell:=sim (default): the PyBullet cell with config/cell.yaml. cell:=real: the UR5 driver on ur-rtde instead
of the simulator, with config/real_cell.yaml read over cell.yaml; robot_ip and dry_run set the driver's
parameters of those names (default: real_cell.yaml's, a dry run that contacts no robot). camera:=true
(cell:=real) includes realsense2_camera's rs_launch.py with the profiles heightmap_node reads
(cell_nodes.CAMERA_LAUNCH_ARGUMENTS). namespace:=/cell_a starts every node, the camera and RViz under
/cell_a: the cell's names are relative (impurity_common.names), so a second cell runs beside the first;
/tf and /tf_static stay global. rviz:=true starts rviz2 with config/cell.rviz.
Every node reads the cell's files (`config` replaces the cell's own; '' its default), then `calibration` (the
camera pose; '' none). The files are impurity_bringup's installed share/impurity_bringup/config/*.yaml.
security:=true runs every node in its SROS2 enclave (--enclave /impurity_cell/<executable>) with security
enforced and the keystore made from config/sros2/policy.xml (keystore:=, default $ROS_SECURITY_KEYSTORE):
docs/real_cell.md, "Security (SROS2)".
The UR5 driver is a lifecycle node: it is configured once its process starts and activated once inactive
(launch_ros LifecycleNode and lifecycle events; docs/real_cell.md, "Lifecycle and diagnostics").
The pip environment (no launch/launch_ros wheels) uses `launch_cell` (impurity_bringup.launch_cell) with
the same node lists, parameter files and namespace (impurity_bringup.cell_nodes).
"""

import os

from launch import LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    GroupAction,
    IncludeLaunchDescription,
    OpaqueFunction,
    RegisterEventHandler,
)
from launch.events import matches_action
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node, PushRosNamespace
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from launch_ros.substitutions import FindPackageShare
from lifecycle_msgs.msg import Transition

from impurity_bringup.cell_nodes import (
    CAMERA_LAUNCH_ARGUMENTS,
    CAMERA_LAUNCH_FILE,
    CAMERA_PACKAGE,
    CELLS,
    DRIVER,
    LIFECYCLE_NODES,
    calibration_file,
    driver_overrides,
    enclave,
    namespace_of,
    nodes_of,
    parameter_files,
    rviz_config,
    security_environment,
)


def managed_node(executable: str, namespace: str | None, **node_options) -> list:
    """A lifecycle node of the cell (cell_nodes.LIFECYCLE_NODES), configured at its start and activated
    once it is inactive (the launch_ros idiom: a ChangeState event, and another on the state transition)."""
    node = LifecycleNode(executable=executable, name=LIFECYCLE_NODES[executable], namespace=namespace or "",
                         **node_options)

    def change(transition: int) -> EmitEvent:
        return EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node),
                                           transition_id=transition))

    activate = RegisterEventHandler(OnStateTransition(target_lifecycle_node=node, goal_state="inactive",
                                                      entities=[change(Transition.TRANSITION_ACTIVATE)]))
    return [activate, node, change(Transition.TRANSITION_CONFIGURE)]


def _argument(context, name: str) -> str:
    return LaunchConfiguration(name).perform(context)


def cell_nodes(context):
    """The nodes of the chosen cell in `namespace`, each with the cell's parameter files
    (cell_nodes.parameter_files) and then the calibration, the driver with robot_ip and dry_run after them
    (a lifecycle node: configured and activated, managed_node); with security:=true each in its enclave,
    with the keystore's environment; the camera driver (camera:=true) and rviz2 (rviz:=true) in the same
    namespace."""
    cell = _argument(context, "cell")
    namespace = namespace_of(_argument(context, "namespace")) or None
    files = [str(path) for path in parameter_files(cell, _argument(context, "config"),
                                                   _argument(context, "calibration"))]
    driver = driver_overrides(_argument(context, "robot_ip"), _argument(context, "dry_run"))
    camera = _argument(context, "camera").lower() == "true"
    if (driver or camera) and cell != "real":
        raise ValueError("robot_ip, dry_run and camera:=true are the real cell's: add cell:=real "
                         "(the simulated cell has its own arm and camera)")
    secure = _argument(context, "security").lower() == "true"
    env = security_environment(_argument(context, "keystore")) if secure else None
    actions = []
    for package, executable in nodes_of(cell):
        options = dict(package=package, output="screen", additional_env=env,
                       parameters=files + ([driver] if executable == DRIVER and driver else []),
                       ros_arguments=["--enclave", enclave(executable)] if secure else None)
        if executable in LIFECYCLE_NODES:
            actions += managed_node(executable, namespace, **options)
        else:
            actions.append(Node(executable=executable, namespace=namespace, **options))
    if camera:
        rs_launch = PathJoinSubstitution([FindPackageShare(CAMERA_PACKAGE), "launch", CAMERA_LAUNCH_FILE])
        include = IncludeLaunchDescription(PythonLaunchDescriptionSource(rs_launch),
                                           launch_arguments=list(CAMERA_LAUNCH_ARGUMENTS.items()))
        actions.append(GroupAction([PushRosNamespace(namespace), include]) if namespace else include)
    if _argument(context, "rviz").lower() == "true":
        actions.append(Node(package="rviz2", executable="rviz2", namespace=namespace, output="screen",
                            arguments=["-d", str(rviz_config())]))
    return actions


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("cell", default_value="sim", choices=list(CELLS),
                              description="sim: the PyBullet cell; real: the UR5 driver (camera:=true "
                              "for the RealSense)"),
        DeclareLaunchArgument("namespace", default_value="",
                              description="ROS namespace of the whole cell ('' = the root), e.g. /cell_a: "
                              "/cell_a/heightmap, /cell_a/episode/start, ...; /tf stays global"),
        DeclareLaunchArgument("robot_ip", default_value="",
                              description="cell:=real: the UR controller's address ('' = real_cell.yaml's)"),
        DeclareLaunchArgument("dry_run", default_value="", choices=["", "true", "false"],
                              description="cell:=real: true records the commands and contacts no robot; "
                              "false moves the robot ('' = real_cell.yaml's: true)"),
        DeclareLaunchArgument("camera", default_value="false", choices=["true", "false"],
                              description="cell:=real: include realsense2_camera's rs_launch.py with the "
                              "cell's profiles (640x480 at 30 Hz, depth aligned to colour, no TF)"),
        DeclareLaunchArgument("rviz", default_value="false", choices=["true", "false"],
                              description="true: rviz2 with config/cell.rviz in the cell's namespace"),
        DeclareLaunchArgument("config", default_value="",
                              description="The cell's own parameter file ('' = config/cell.yaml, or "
                              "config/real_cell.yaml, read over config/cell.yaml, for cell:=real)"),
        DeclareLaunchArgument("calibration", default_value=str(calibration_file()),
                              description="Camera calibration (camera pose), read after config"),
        DeclareLaunchArgument("security", default_value="false", choices=["true", "false"],
                              description="true: SROS2, each node in its enclave "
                              "/impurity_cell/<executable>"),
        DeclareLaunchArgument("keystore", default_value=os.environ.get("ROS_SECURITY_KEYSTORE", ""),
                              description="The SROS2 keystore made from config/sros2/policy.xml "
                              "(security:=true)"),
        OpaqueFunction(function=cell_nodes),
    ])
