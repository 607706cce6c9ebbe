"""ROS installs: the whole cell,

    ros2 launch impurity_bringup cell.launch.py [cell:=sim|real] [config:=...] [calibration:=...]

cell:=sim (default): the PyBullet cell with config/cell.yaml. cell:=real: the UR5 driver on
ur-rtde instead of the simulator, with config/real_cell.yaml read over cell.yaml; start the
camera driver apart (README, "Running on a real cell"). Every node reads the cell's files (`config`
replaces the cell's own; '' its default), then `calibration` (the camera pose; '' none). The files are
impurity_bringup's installed share/impurity_bringup/config/*.yaml.
The pip environment (no launch/launch_ros wheels) uses `launch_cell` (impurity_bringup.launch_cell) with
the same node lists and parameter files (impurity_bringup.cell_nodes).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from impurity_bringup.cell_nodes import CELLS, calibration_file, nodes_of, parameter_files


def cell_nodes(context):
    """The nodes of the chosen cell, each with the cell's parameter files (cell_nodes.parameter_files) and
    then the calibration."""
    cell = LaunchConfiguration("cell").perform(context)
    files = [str(path) for path in parameter_files(cell, LaunchConfiguration("config").perform(context),
                                                   LaunchConfiguration("calibration").perform(context))]
    return [Node(package=package, executable=executable, parameters=files, output="screen")
            for package, executable in nodes_of(cell)]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument("cell", default_value="sim", choices=list(CELLS),
                              description="sim: the PyBullet cell; real: the UR5 driver (camera apart)"),
        DeclareLaunchArgument("config", default_value="",
                              description="The cell's own parameter file ('' = config/cell.yaml, or "
                              "config/real_cell.yaml, read over config/cell.yaml, for cell:=real)"),
        DeclareLaunchArgument("calibration", default_value=str(calibration_file()),
                              description="Camera calibration (camera pose), read after config"),
        OpaqueFunction(function=cell_nodes),
    ])
