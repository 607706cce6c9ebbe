"""The runtime packages installed the way the deployment image installs them, and started from there.

The image runs apt's colcon, whose interpreter (/usr/bin/python3) is not the one of the venv that holds
torch, OpenCV, scikit-learn, rosbags and ur-rtde (/opt/venv, first on PATH). setuptools writes the first
line of each installed executable from colcon's interpreter unless `[build_scripts] executable` in the
package's setup.cfg names another; `/usr/bin/env python3` (the ROS 2 documentation's idiom for Python
packages in a venv) is the first python3 on PATH when the node starts, the venv's.

Here: a colcon run by a Python of its own (a venv with nothing but the standard library, as
/usr/bin/python3 has none of the venv's packages) builds the packages the Dockerfile's `colcon build`
names, a plain install (no --symlink-install) into a temporary directory. impurity_interfaces and
ros2_ws/fallback's messages come from `make setup`'s install (rosidl takes minutes; in the image they are
built from the same sources, or come from apt). Each runtime executable then starts with --help from that
install alone, with the venv first on PATH as in the image, and the interpreter the executables name
imports every module the runtime packages import (also those a node imports late: torch, ur-rtde).
"""

import ast
import configparser
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from test_dockerfile import BRINGUP, colcon_packages, third_party_imports

from ros_harness import ROOT

WORKSPACE = ROOT / "ros2_ws"
# Not built here, taken from `make setup`'s install: the interfaces and the fallback messages.
UNDERLAY = {"impurity_interfaces"} | {p.name for p in (WORKSPACE / "fallback").iterdir() if p.is_dir()}
IMAGE_PACKAGES = sorted(colcon_packages() - UNDERLAY)
# impurity_bringup's executables that drive the simulated cell, whose packages the image leaves out.
SIMULATED_CELL_EXECUTABLES = {"demo", "eval_graph"}
# The idiom of "Using Python Packages with ROS 2" (ROS 2 documentation) for nodes run from a venv.
VENV_SHEBANG = "/usr/bin/env python3"
# Variables that colcon's setup files extend: the environment keeps only the underlay's entries in them.
PATH_VARIABLES = ("PYTHONPATH", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH", "LD_LIBRARY_PATH")


def source_dir(package: str) -> Path:
    return ROOT / "bringup" if package == BRINGUP else ROOT / "src" / package


def console_scripts(package: str) -> list[str]:
    """The executable names of the package's setup.py (entry_points={"console_scripts": [...]})."""
    tree = ast.parse((source_dir(package) / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == "entry_points":
            scripts = ast.literal_eval(node.value).get("console_scripts", [])
            return [script.split("=")[0].strip() for script in scripts]
    return []


RUNTIME_EXECUTABLES = [(package, name) for package in IMAGE_PACKAGES for name in console_scripts(package)
                       if name not in SIMULATED_CELL_EXECUTABLES]
EXECUTABLE_IDS = [f"{package}/{name}" for package, name in RUNTIME_EXECUTABLES]
# Every package of the tree that installs an executable (the simulator's too: any venv install).
PYTHON_PACKAGES = sorted([p.name for p in (ROOT / "src").iterdir() if (p / "setup.py").is_file()] + [BRINGUP])
PACKAGES_WITH_EXECUTABLES = [package for package in PYTHON_PACKAGES if console_scripts(package)]


def underlay_environment() -> dict[str, str]:
    """This environment without ros2_ws's packages other than the underlay's (and no colcon prefix chain),
    the venv's bin first on PATH (the image: ENV PATH=/opt/venv/bin:$PATH)."""
    keep = {str(WORKSPACE / "install" / name) for name in UNDERLAY}

    def kept(entry: str) -> bool:
        inside = entry == str(WORKSPACE) or entry.startswith(str(WORKSPACE) + os.sep)
        return not inside or any(entry == k or entry.startswith(k + os.sep) for k in keep)

    env = {k: v for k, v in os.environ.items() if k not in ("COLCON_PREFIX_PATH", "PYTHONSAFEPATH")}
    for name in PATH_VARIABLES:
        env[name] = os.pathsep.join(e for e in os.environ.get(name, "").split(os.pathsep) if e and kept(e))
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    env["IMPURITY_CELL"] = "real"  # as the Dockerfile's ENV
    return env


@pytest.fixture(scope="module")
def image_install(tmp_path_factory) -> Path:
    """The install directory of a plain colcon build of IMAGE_PACKAGES by a colcon whose interpreter is
    not the venv's."""
    top = tmp_path_factory.mktemp("image_ws")
    colcon_python = top / "colcon-python"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(colcon_python)], check=True,
                   timeout=120)
    env = underlay_environment()
    # colcon and setuptools themselves come from the venv's site-packages, as apt's colcon comes with
    # /usr/bin/python3's; the packages it builds run without them.
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [sysconfig.get_paths()["purelib"], env["PYTHONPATH"]]))
    command = [str(colcon_python / "bin" / "python"), "-m", "colcon", "--log-base", str(top / "log"), "build",
               "--build-base", str(top / "build"), "--install-base", str(top / "install"),
               "--base-paths", *sorted({str(source_dir(p)) for p in IMAGE_PACKAGES}),
               "--packages-select", *IMAGE_PACKAGES, "--event-handlers", "console_direct-"]
    done = subprocess.run(command, cwd=top, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, (done.stdout + done.stderr)[-4000:]
    return top / "install"


def run_from(install: Path, *command: str) -> subprocess.CompletedProcess:
    """`command` after sourcing the install's local_setup.bash (its own packages; the underlay is already
    in the environment), as the image's entrypoint sources its workspace."""
    script = 'source "$0/local_setup.bash" && exec "$@"'
    return subprocess.run(["bash", "-c", script, str(install), *command], env=underlay_environment(),
                          cwd=install.parent, capture_output=True, text=True, timeout=120)


def first_line(path: Path) -> str:
    with path.open() as file:
        return file.readline().strip()


# ------------------------------------------------------------------------------------ the specification
@pytest.mark.parametrize("package", PACKAGES_WITH_EXECUTABLES)
def test_every_package_with_executables_names_the_venv_idiom_in_setup_cfg(package):
    config = configparser.ConfigParser()
    config.read(source_dir(package) / "setup.cfg")
    assert config.get("build_scripts", "executable", fallback=None) == VENV_SHEBANG, \
        f"{package}/setup.cfg: [build_scripts] executable = {VENV_SHEBANG} (else its executables name " \
        "colcon's interpreter, which in the image is not the venv's)"


def test_every_runtime_executable_is_installed(image_install):
    for package, name in RUNTIME_EXECUTABLES:
        assert os.access(image_install / package / "lib" / package / name, os.X_OK), f"{package}/{name}"
    assert ("impurity_policy", "policy_node") in RUNTIME_EXECUTABLES
    assert ("ur5_driver_rtde", "ur5_driver") in RUNTIME_EXECUTABLES


@pytest.mark.parametrize("package,name", RUNTIME_EXECUTABLES, ids=EXECUTABLE_IDS)
def test_each_runtime_executable_starts_from_the_install(image_install, package, name):
    done = run_from(image_install, str(image_install / package / "lib" / package / name), "--help")
    assert done.returncode == 0, f"{package}/{name} --help:\n{done.stderr[-3000:]}"
    assert done.stdout.startswith("usage:"), done.stdout[:500]


def test_the_interpreter_of_the_executables_imports_every_module_the_runtime_imports(image_install):
    modules = sorted(set().union(*(third_party_imports(p) for p in IMAGE_PACKAGES)))
    assert {"torch", "cv2", "sklearn", "rosbags", "rtde_control"} <= set(modules)
    interpreters = {first_line(image_install / p / "lib" / p / n) for p, n in RUNTIME_EXECUTABLES}
    for interpreter in sorted(interpreters):
        assert interpreter.startswith("#!"), interpreter
        done = run_from(image_install, *interpreter[2:].split(), "-c", f"import {', '.join(modules)}")
        assert done.returncode == 0, f"{interpreter}: {done.stderr[-2000:]}"
