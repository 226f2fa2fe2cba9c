# Source this file (bash) to get the project's environment: the venv and the
# colcon install space, as `ros2 run` would see it on a full ROS install.
_hn_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck disable=SC1091
source "$_hn_root/.venv/bin/activate"
export AMENT_PREFIX_PATH="$_hn_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$_hn_root/.venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
set +u
# shellcheck disable=SC1091
source "$_hn_root/install/setup.bash"
export PATH="$_hn_root/tools:$PATH"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
unset _hn_root
