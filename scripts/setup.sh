#!/usr/bin/env bash
# One-time (and idempotent) set-up: .venv with the pinned dependencies, the ROS-wheel CMake fix,
# and `colcon build` of ros2_ws (the packages of src/ and impurity_bringup in bringup/). Called by
# `make setup`; each step is skipped when its inputs did not change since it last succeeded. Prints how
# long it took.
#
#   bash scripts/setup.sh               check the host, then set up what is out of date
#   bash scripts/setup.sh --check-only  only check the host prerequisites (exit 0 ok, 1 missing)
#
# Environment: PYTHON is the CPython that makes .venv: 3.11 for everything, or 3.12 for the runtime only
# (the nodes of a real cell and their tests: the simulator's PyBullet 3.2.7 has cp311 wheels only).
# Default: python3.11 when there is one, else python3. TORCH_INDEX_URL,
# when set, is the package index torch is installed from (e.g. https://download.pytorch.org/whl/cpu
# for the CPU-only wheel); unset, pip's own indexes decide (PyPI: the CUDA build on x86_64 Linux).
set -euo pipefail
# Builtins only up to the host check: it must report even on a bare PATH.
case $0 in */*) cd "${0%/*}/.." ;; *) cd .. ;; esac
top=$(pwd)
SECONDS=0
if [ -z "${PYTHON:-}" ]; then
  if command -v python3.11 >/dev/null 2>&1; then PYTHON=python3.11; else PYTHON=python3; fi
fi
python_version=""  # X.Y.Z of $PYTHON, set by check_host
# Printed by every run on CPython 3.12: what it leaves out, and how to get a 3.11.
RUNTIME_ONLY_NOTE="setup: CPython 3.12 sets up the runtime only (the nodes of a real cell, their tests). \
The simulator needs CPython 3.11 (PyBullet 3.2.7 has no cp312 wheel), and so do make demo, train, eval \
and soak. Ubuntu 24.04: sudo add-apt-repository ppa:deadsnakes/ppa && sudo apt-get install python3.11 \
python3.11-venv python3.11-dev (or: uv python install 3.11); then mv .venv .venv-3.12 && \
PYTHON=python3.11 make setup"
TORCH_INDEX_URL=${TORCH_INDEX_URL:-}
CMAKE_MIN=3.20 # rosidl's generated CMake files: cmake_minimum_required(VERSION 3.20)
venv=$top/.venv
venv_stamp=$venv/.requirements.sha
build_stamp=$top/ros2_ws/install/.build-inputs.sha
did=()

# Host prerequisites. Prints one line per item when verbose (--check-only), one line per missing
# item always, then the Debian/Ubuntu packages to install. Returns 1 when anything is missing.
check_host() {
  local verbose=$1 missing=() pkgs=() found py_info cm_version info=() p apt=""
  local -A seen=()
  ok() { [ "$verbose" = 1 ] && printf 'setup: %-13s %s\n' "$1" "$2"; return 0; }
  # lack WHAT HINT PACKAGE...: one line saying what is missing and which Debian/Ubuntu packages fix it.
  lack() {
    missing+=("setup: missing $1${2:+ ($2)}${3:+; Debian/Ubuntu: sudo apt-get install ${*:3}}")
    pkgs+=("${@:3}")
  }
  # version_ge A B: dotted version A >= B (numeric parts, pure bash).
  version_ge() {
    local IFS=. i a b
    read -ra a <<<"$1"; read -ra b <<<"$2"
    for i in 0 1 2; do
      ((10#${a[i]:-0} > 10#${b[i]:-0})) && return 0
      ((10#${a[i]:-0} < 10#${b[i]:-0})) && return 1
    done
    return 0
  }

  # The ROS 2 Jazzy wheels pinned in requirements.txt are cp311 and cp312, manylinux_2_28_x86_64 only.
  if [[ "${OSTYPE:-}" == linux* && "${HOSTTYPE:-}" == x86_64 ]]; then ok platform "Linux ${HOSTTYPE}"
  else lack "Linux x86_64" "this is ${OSTYPE:-?} ${HOSTTYPE:-?}; the pinned ROS 2 Jazzy wheels exist for x86_64 Linux only"; fi

  if found=$(command -v "$PYTHON"); then
    # One interpreter start for: version, implementation, venv + ensurepip, Python.h.
    py_info=$("$PYTHON" - <<'PY' 2>/dev/null || true
import importlib.util, os, platform, sys, sysconfig
print(platform.python_implementation(), platform.python_version(), sys.executable, sep="\n")
print("venv" if all(importlib.util.find_spec(m) for m in ("venv", "ensurepip")) else "-")
include = sysconfig.get_paths()["include"]
print(os.path.join(include, "Python.h") if os.path.isfile(os.path.join(include, "Python.h")) else "-")
print(include)
PY
)
    [ -n "$py_info" ] && mapfile -t info <<<"$py_info"
    local impl=${info[0]:-} ver=${info[1]:-} exe=${info[2]:-} venv_ok=${info[3]:-} header=${info[4]:--} include=${info[5]:-}
    if [ "${impl:-}" != CPython ] || [[ "${ver:-}" != 3.1[12].* ]]; then
      lack "CPython 3.11" "$found is ${impl:-?} ${ver:-?}; the ROS 2 Jazzy wheels are cp311 and cp312 (3.12: the runtime only); or set PYTHON=/path/to/python3.11" \
        python3.11 python3.11-venv python3.11-dev
    else
      local xy=${ver%.*}
      python_version=$ver
      ok python "$exe (CPython $ver)"
      if [ "$venv_ok" = venv ]; then ok venv "venv + ensurepip"
      else lack "Python $xy venv/ensurepip" "$exe cannot make a venv" "python$xy-venv"; fi
      if [ "$header" != - ]; then ok Python.h "$header"
      else lack "Python $xy headers" "no Python.h in ${include:-?}, colcon/rosidl builds need it" "python$xy-dev"; fi
    fi
  else
    lack "$PYTHON" "CPython 3.11 (3.12: the runtime only) for the ROS 2 Jazzy wheels; or set PYTHON=/path/to/python3.11; Ubuntu 24.04: deadsnakes PPA" \
      python3.11 python3.11-venv python3.11-dev
  fi

  if found=$(command -v cmake); then
    cm_version=$(cmake --version 2>/dev/null) || true
    cm_version=${cm_version%%$'\n'*}      # "cmake version 3.25.1"
    cm_version=${cm_version##* }           # "3.25.1"
    cm_version=${cm_version%%[!0-9.]*}     # drop "-rc1" and the like
    if [ -n "$cm_version" ] && version_ge "$cm_version" "$CMAKE_MIN"; then
      ok cmake "$found ($cm_version)"
    else
      lack "cmake >= $CMAKE_MIN" "$found is ${cm_version:-of unknown version}; Ubuntu 22.04+ and Debian 12 ship a newer one, or pip install cmake" cmake
    fi
  else
    lack cmake "$CMAKE_MIN or newer" cmake
  fi

  # CMake takes CC/CXX when set, else the first of cc, gcc, ..., clang (c++, g++, ..., clang++).
  if [ -n "${CC:-}" ]; then found=$(command -v "${CC%% *}" || true)
  else found=$(command -v cc || command -v gcc || command -v clang || true); fi
  if [ -n "$found" ]; then ok "C compiler" "$found"
  else lack "C compiler" "${CC:+CC=$CC not found; }cc or gcc" gcc; fi
  if [ -n "${CXX:-}" ]; then found=$(command -v "${CXX%% *}" || true)
  else found=$(command -v c++ || command -v g++ || command -v clang++ || true); fi
  if [ -n "$found" ]; then ok "C++ compiler" "$found"
  else lack "C++ compiler" "${CXX:+CXX=$CXX not found; }c++ or g++" g++; fi

  if found=$(command -v git); then ok git "$found"; else lack git "" git; fi
  if found=$(command -v flock); then ok flock "$found"; else lack flock "used by this script to run one set-up at a time" util-linux; fi

  if [ ${#missing[@]} -eq 0 ]; then
    ok "host" "prerequisites ok"
    return 0
  fi
  printf '%s\n' "${missing[@]}" >&2
  for p in "${pkgs[@]+"${pkgs[@]}"}"; do
    [ -n "${seen[$p]:-}" ] || apt+=" $p"
    seen[$p]=1
  done
  [ -z "$apt" ] || echo "setup: on Debian/Ubuntu: sudo apt-get install$apt" >&2
  return 1
}

case "${1:-}" in
  --check-only) check=0; check_host 1 || check=1 ;;
  "") check_host 0 || exit 1 ;;
  *) echo "usage: bash scripts/setup.sh [--check-only]" >&2; exit 2 ;;
esac
[[ "$python_version" != 3.12.* ]] || echo "$RUNTIME_ONLY_NOTE"
[ "${1:-}" != --check-only ] || exit "$check"

# One set-up at a time: parallel `make` targets must not run pip or colcon over each other.
mkdir -p "$top/.setup-lock.d"
exec 9>"$top/.setup-lock.d/lock"
flock 9

# .venv is made once, by one Python: another PYTHON needs a .venv of its own.
if [ -x "$venv/bin/python" ]; then
  venv_version=$("$venv/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null) || venv_version="?"
  if [ "$venv_version" != "${python_version%.*}" ]; then
    echo "setup: .venv is Python $venv_version but $PYTHON is $python_version: move .venv away" \
      "(mv .venv .venv-$venv_version) and run make setup again, or set PYTHON to a Python $venv_version" >&2
    exit 1
  fi
fi

req_sha=$( (sha256sum requirements.txt scripts/setup.sh scripts/fix_ros_wheel_cmake.py scripts/check_torch.py;
  echo "TORCH_INDEX_URL=$TORCH_INDEX_URL") | sha256sum | cut -d' ' -f1)
if [ ! -x "$venv/bin/python" ] || [ "$(cat "$venv_stamp" 2>/dev/null)" != "$req_sha" ]; then
  echo "setup: creating .venv and installing requirements.txt (a few minutes on a cold machine)"
  [ -x "$venv/bin/python" ] || "$PYTHON" -m venv "$venv"
  # The machine's pip config names local mirrors that lack most packages; hide those warnings only.
  # A failing pip stops the set-up (pipefail; grep's "no lines left" is not a failure).
  pip_quiet() {
    "$venv/bin/python" -m pip install --quiet "$@" 2>&1 | { grep -v 'is ignored: it is neither' || true; } \
      || { echo "setup: pip install $* failed" >&2; return 1; }
  }
  pip_quiet --upgrade pip
  if [ -n "$TORCH_INDEX_URL" ]; then
    # torch (and its few pure-Python dependencies) from that index first; requirements.txt then
    # finds the pin already satisfied. An existing torch of the pinned version is kept as it is.
    torch_pin=$("$venv/bin/python" scripts/check_torch.py --print-pin)
    echo "setup: torch==$torch_pin from $TORCH_INDEX_URL"
    pip_quiet --index-url "$TORCH_INDEX_URL" "torch==$torch_pin"
  fi
  pip_quiet -r requirements.txt
  # The pinned torch version, CPU or CUDA build (a CUDA build says so and how to get the CPU one).
  "$venv/bin/python" scripts/check_torch.py
  "$venv/bin/python" scripts/fix_ros_wheel_cmake.py
  echo "$req_sha" > "$venv_stamp"
  did+=("venv")
fi

# Interface packages the ROS environment may lack (ros2_ws/fallback/README.md): each is built only when
# the venv's Python cannot import it without this workspace; where the real one exists, a fallback
# built earlier is removed so it never shadows it.
fallback=()
for dir in ros2_ws/fallback/*/; do
  pkg=${dir%/}; pkg=${pkg##*/}
  if env -u PYTHONPATH -u AMENT_PREFIX_PATH "$venv/bin/python" -c "import $pkg.msg" >/dev/null 2>&1; then
    rm -rf "ros2_ws/build/$pkg" "ros2_ws/install/$pkg"
  else
    fallback+=("fallback/$pkg")
  fi
done

# bringup's launch and config files are installed as symlinks (--symlink-install): their names, not
# their contents, decide what is installed.
build_sha=$( (echo "$req_sha"; echo "fallback: ${fallback[*]+${fallback[*]}}";
  find src bringup ros2_ws/fallback -type f \( -name package.xml -o -name setup.py -o -name setup.cfg \
  -o -name CMakeLists.txt -o -name '*.msg' -o -name '*.srv' -o -name '*.action' \
  -o -path '*/checkpoints/*' \) -print0 \
  | sort -z | xargs -0 sha256sum; find bringup/launch bringup/config -type f | sort) | sha256sum | cut -d' ' -f1)
if [ "$(cat "$build_stamp" 2>/dev/null)" != "$build_sha" ]; then
  echo "setup: colcon build in ros2_ws/"
  (
    # shellcheck disable=SC1091
    source "$venv/bin/activate"
    export AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv
    cd ros2_ws
    # Explicit base paths: the cell's packages (src, and impurity_bringup in the top-level bringup/), and
    # a fallback only when the environment lacks it.
    colcon --log-base log build --symlink-install --event-handlers console_direct- \
      --base-paths src ../bringup ${fallback[@]+"${fallback[@]}"} \
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
