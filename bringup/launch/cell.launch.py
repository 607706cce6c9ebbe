"""ROS installs: `ros2 launch bringup/launch/cell.launch.py` starts the whole cell.

The pip environment (no launch/launch_ros wheels) uses bringup/launch_cell.py with the same node list
and parameters.
"""

import pathlib
import sys

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

BRINGUP = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(BRINGUP))
from cell_nodes import CELL_NODES  # noqa: E402


def generate_launch_description():
    config = LaunchConfiguration("config")
    return LaunchDescription([
        DeclareLaunchArgument("config", default_value=str(BRINGUP / "config" / "cell.yaml"),
                              description="Parameters of every node"),
        *[Node(package=package, executable=executable, parameters=[config], output="screen")
          for package, executable in CELL_NODES],
    ])
