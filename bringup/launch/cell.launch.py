"""ROS installs: the whole cell,

    ros2 launch impurity_bringup cell.launch.py [cell:=sim|real] [config:=...] [calibration:=...]
                                                [security:=true keystore:=DIR]

cell:=sim (default): the PyBullet cell with config/cell.yaml. cell:=real: the UR5 driver on
ur-rtde instead of the simulator, with config/real_cell.yaml read over cell.yaml; start the
camera driver apart (README, "Running on a real cell"). Every node reads the cell's files (`config`
replaces the cell's own; '' its default), then `calibration` (the camera pose; '' none). The files are
impurity_bringup's installed share/impurity_bringup/config/*.yaml.
security:=true runs every node in its SROS2 enclave (--enclave /impurity_cell/<executable>) with security
enforced and the keystore made from config/sros2/policy.xml (keystore:=, default $ROS_SECURITY_KEYSTORE):
docs/real_cell.md, "Security (SROS2)".
The UR5 driver is a lifecycle node: it is configured once its process starts and activated once inactive
(launch_ros LifecycleNode and lifecycle events; docs/real_cell.md, "Lifecycle and diagnostics").
The pip environment (no launch/launch_ros wheels) uses `launch_cell` (impurity_bringup.launch_cell) with
the same node lists and parameter files (impurity_bringup.cell_nodes).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, EmitEvent, OpaqueFunction, RegisterEventHandler
from launch.events import matches_action
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from lifecycle_msgs.msg import Transition

from impurity_bringup.cell_nodes import (
    CELLS,
    LIFECYCLE_NODES,
    calibration_file,
    enclave,
    nodes_of,
    parameter_files,
    security_environment,
)


def managed_node(executable: str, **node_options) -> list:
    """A lifecycle node of the cell (cell_nodes.LIFECYCLE_NODES), configured at its start and activated
    once it is inactive (the launch_ros idiom: a ChangeState event, and another on the state transition)."""
    node = LifecycleNode(executable=executable, name=LIFECYCLE_NODES[executable], namespace="",
                         **node_options)

    def change(transition: int) -> EmitEvent:
        return EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node),
                                           transition_id=transition))

    activate = RegisterEventHandler(OnStateTransition(target_lifecycle_node=node, goal_state="inactive",
                                                      entities=[change(Transition.TRANSITION_ACTIVATE)]))
    return [activate, node, change(Transition.TRANSITION_CONFIGURE)]


def cell_nodes(context):
    """The nodes of the chosen cell, each with the cell's parameter files (cell_nodes.parameter_files) and
    then the calibration; with security:=true each in its enclave, with the keystore's environment."""
    cell = LaunchConfiguration("cell").perform(context)
    files = [str(path) for path in parameter_files(cell, LaunchConfiguration("config").perform(context),
                                                   LaunchConfiguration("calibration").perform(context))]
    secure = LaunchConfiguration("security").perform(context).lower() == "true"
    env = security_environment(LaunchConfiguration("keystore").perform(context)) if secure else None
    actions = []
    for package, executable in nodes_of(cell):
        options = dict(package=package, parameters=files, output="screen", additional_env=env,
                       ros_arguments=["--enclave", enclave(executable)] if secure else None)
        if executable in LIFECYCLE_NODES:
            actions += managed_node(executable, **options)
        else:
            actions.append(Node(executable=executable, **options))
    return actions


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("cell", default_value="sim", choices=list(CELLS),
                              description="sim: the PyBullet cell; real: the UR5 driver (camera apart)"),
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
