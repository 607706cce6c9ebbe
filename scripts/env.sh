# Source me: the venv, the built workspace, and ROS settings for a single machine.
# Usage: source scripts/env.sh
_top=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# shellcheck disable=SC1091
source "$_top/.venv/bin/activate"
# colcon's setup scripts read unset variables; source them without nounset.
case $- in *u*) _had_u=1; set +u ;; *) _had_u=0 ;; esac
# shellcheck disable=SC1091
source "$_top/ros2_ws/install/setup.bash"
[ "$_had_u" = 1 ] && set -u
export ROS_AUTOMATIC_DISCOVERY_RANGE=${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
export RCUTILS_COLORIZED_OUTPUT=${RCUTILS_COLORIZED_OUTPUT:-0}
export IMPURITY_CELL_ROOT=$_top
unset _top _had_u
