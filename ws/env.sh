# Source this file (bash) to use the built workspace in the current shell:  source ws/env.sh
# It activates the virtual environment (the ROS 2 underlay) and the colcon install tree (the overlay).
# ws/run and ws/test source it for you.
_ws_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ ! -f "$_ws_dir/install/setup.bash" ]; then
  echo "ws/env.sh: the workspace is not built yet: run ws/setup first" >&2
  return 1 2>/dev/null || exit 1
fi
# shellcheck disable=SC1091
source "$_ws_dir/.venv/bin/activate"
export AMENT_PREFIX_PATH="$_ws_dir/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$_ws_dir/.venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
# numba caches compiled kernels next to the installed modules (ws/install/...): swarm_sim's stale-cache guard
# (swarm_sim/core/_numba_cache.py) looks there, so do not point NUMBA_CACHE_DIR elsewhere.
unset NUMBA_CACHE_DIR
set +u
# shellcheck disable=SC1091
source "$_ws_dir/install/setup.bash"
unset _ws_dir
