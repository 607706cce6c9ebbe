#!/usr/bin/env bash
# Source ROS and the workspace, then run whatever the container was asked to run, e.g.
#   ros2 launch impurity_bringup cell.launch.py cell:=real
set -e
# shellcheck disable=SC1091
source /opt/ros/jazzy/setup.bash
# shellcheck disable=SC1091
source /ws/install/setup.bash
exec "$@"
