"""ROS installs: `ros2 launch bringup/launch/cell.launch.py [cell:=sim|real] [config:=...] [calibration:=...]`
starts the whole cell.

cell:=sim (default): the PyBullet cell with bringup/config/cell.yaml. cell:=real: the UR5 driver on
ur-rtde instead of the simulator, with bringup/config/real_cell.yaml read over cell.yaml; start the
camera driver apart (README, "Running on a real cell"). Every node reads the cell's files (`config`
replaces the cell's own), then `calibration` (the camera pose).
The pip environment (no launch/launch_ros wheels) uses bringup/launch_cell.py with the same node lists
and parameter files (bringup/cell_nodes.py).
"""

import pathlib
import sys

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

BRINGUP = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(BRINGUP))
from cell_nodes import CALIBRATION, CELLS, nodes_of, parameter_files  # noqa: E402


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
        DeclareLaunchArgument("calibration", default_value=str(CALIBRATION),
                              description="Camera calibration (camera pose), read after config"),
        OpaqueFunction(function=cell_nodes),
    ])
