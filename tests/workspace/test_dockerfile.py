"""The deployment Dockerfile installs the runtime only and agrees with requirements.txt.

No Docker engine runs here, so the image is never built in tests: the file is read as text. What it
installs with pip, what it copies from src/ and what colcon builds are checked against the runtime
packages (tests/workspace/test_runtime_imports.py's list), the modules those packages import, and the
pins of requirements.txt (a different pin needs a comment naming it).
"""

import pathlib
import re
import sys

import pytest
from source_scan import imported_top_levels

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCKERFILE = ROOT / "Dockerfile"
SRC = ROOT / "src"
RUNTIME_PACKAGES = {"impurity_interfaces", "impurity_common", "impurity_bags", "impurity_calibration",
                    "impurity_viz", "ur5_motion", "impurity_attention", "impurity_policy", "ur5_driver_rtde"}
BRINGUP = "impurity_bringup"  # the top-level bringup/ folder, copied to the image's src/impurity_bringup
# impurity_bringup's modules a real cell runs (demo and eval_graph drive the simulated cell).
BRINGUP_RUNTIME_MODULES = ("cell_nodes.py", "launch_cell.py", "episode_client.py", "checkout.py")
NEVER_IN_THE_IMAGE = ("pybullet", "ur5_driver_sim", "impurity_learning", "matplotlib", "pytest")
# Distribution that provides an imported module, where the names differ.
DISTRIBUTION_OF_MODULE = {"cv2": "opencv-python-headless", "sklearn": "scikit-learn", "yaml": "PyYAML",
                          "rtde_control": "ur-rtde", "rtde_receive": "ur-rtde",
                          "dashboard_client": "ur-rtde"}
# Python packages of the ros-base image itself (no apt line needed).
ROS_BASE_MODULES = {"rclpy", "builtin_interfaces", "rcl_interfaces", "ament_index_python"}


def canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def instructions() -> list[tuple[str, str]]:
    """(KEYWORD, arguments) of every instruction, continuation lines joined, comments left out."""
    result, current = [], ""
    for line in DOCKERFILE.read_text().splitlines():
        if line.lstrip().startswith("#") and not current:
            continue
        if line.rstrip().endswith("\\"):
            current += line.rstrip()[:-1] + " "
            continue
        current += line
        if current.strip():
            keyword, _, arguments = current.strip().partition(" ")
            result.append((keyword.upper(), arguments.strip()))
        current = ""
    return result


def comments() -> str:
    return "\n".join(line for line in DOCKERFILE.read_text().splitlines() if line.lstrip().startswith("#"))


def run_commands() -> list[str]:
    """Every shell command of every RUN (split at && and ;)."""
    return [command.strip() for keyword, arguments in instructions() if keyword == "RUN"
            for command in re.split(r"&&|;", arguments)]


def pip_pins() -> dict[str, str]:
    """Canonical distribution name -> version of every `pip install name==version` of the image."""
    pins = {}
    for command in run_commands():
        words = command.split()
        if words[:2] != ["pip", "install"]:
            continue
        for word in words[2:]:
            if word.startswith("-") or word.startswith('"'):
                continue
            name, sep, version = word.partition("==")
            assert sep, f"unpinned pip package {word!r} in {command!r}"
            pins[canonical(name)] = version
    return pins


def apt_packages() -> set[str]:
    return {word for command in run_commands() if "apt-get install" in command
            for word in command.split() if word.startswith(("ros-", "python3-"))}


def requirement_pins() -> dict[str, str]:
    pins = {}
    for line in (ROOT / "requirements.txt").read_text().splitlines():
        line = line.split("#")[0].split(";")[0].strip()  # without an environment marker
        if "==" in line:
            name, version = line.split("==")
            pins[canonical(name.split("[")[0])] = version.strip()
    return pins


def copied_sources() -> set[str]:
    """The packages the image copies: each `COPY src/<package>/ ...`, and impurity_bringup for
    `COPY bringup/ .../src/impurity_bringup/`."""
    sources = set()
    for keyword, arguments in instructions():
        if keyword == "COPY":
            *copied, destination = arguments.split()
            for source in copied:
                assert source.rstrip("/") != "src", "COPY src/ would copy the simulator and training code"
                if source.startswith("src/"):
                    sources.add(source.split("/")[1])
                elif source.rstrip("/") == "bringup":
                    assert destination.rstrip("/").endswith("/src/" + BRINGUP), destination
                    sources.add(BRINGUP)
    return sources


def colcon_packages() -> set[str]:
    builds = [command for command in run_commands() if command.startswith("colcon build")]
    assert len(builds) == 1, builds
    words = builds[0].split()
    assert "--packages-select" in words, "colcon build names the runtime packages (--packages-select)"
    selected = words[words.index("--packages-select") + 1:]
    return set(selected[:next((i for i, w in enumerate(selected) if w.startswith("-")), len(selected))])


def third_party_imports(package: str) -> set[str]:
    """Top-level modules the package's modules import that are neither stdlib nor a cell package
    (impurity_bringup: its modules a real cell runs)."""
    if package == BRINGUP:
        found = set().union(*(imported_top_levels(ROOT / "bringup" / BRINGUP / name)
                              for name in BRINGUP_RUNTIME_MODULES))
    else:
        found = imported_top_levels(SRC / package / package)
    cell_packages = {p.name for p in SRC.iterdir() if (p / "package.xml").is_file()} | {BRINGUP}
    return {m for m in found if m not in sys.stdlib_module_names and m not in cell_packages | {"__future__"}}


# ------------------------------------------------------------------------------------ the specification
def test_the_image_starts_from_ros_jazzy():
    assert [arguments for keyword, arguments in instructions() if keyword == "FROM"] == ["ros:jazzy-ros-base"]


def test_the_image_copies_and_builds_the_runtime_packages_only():
    assert copied_sources() == RUNTIME_PACKAGES | {BRINGUP}
    assert colcon_packages() == RUNTIME_PACKAGES | {BRINGUP}


def test_nothing_of_the_simulator_or_of_training_is_installed_or_copied():
    text = " ".join(arguments for keyword, arguments in instructions() if keyword in ("RUN", "COPY"))
    for name in NEVER_IN_THE_IMAGE:
        assert name not in text.lower(), f"the runtime image installs or copies {name}"


def test_pip_pins_equal_requirements_or_say_why_not():
    required = requirement_pins()
    for name, version in pip_pins().items():
        assert name in required, f"{name} is not in requirements.txt: every Python dependency is pinned there"
        if version != required[name]:
            said = rf"{re.escape(name)}=={re.escape(version)}.*{re.escape(required[name])}"
            assert re.search(said, comments(), re.IGNORECASE), \
                f"{name}=={version} differs from requirements.txt's {required[name]}: no comment says why"


def test_every_module_the_runtime_imports_is_installed():
    pins, apt = pip_pins(), apt_packages()
    for package in sorted(RUNTIME_PACKAGES - {"impurity_interfaces"} | {BRINGUP}):
        for module in sorted(third_party_imports(package)):
            ros_apt = "ros-jazzy-" + module.replace("_", "-")
            installed = (canonical(DISTRIBUTION_OF_MODULE.get(module, module)) in pins or ros_apt in apt
                         or module in ROS_BASE_MODULES)
            assert installed, f"{package} imports {module}, which the image installs neither with pip nor apt"


def test_the_venv_sees_apts_ros_packages_and_comes_first_on_path():
    # The node executables start on `/usr/bin/env python3` (setup.cfg's [build_scripts]): the venv's
    # python3 only while the venv's bin comes first on PATH (tests/workspace/test_image_install.py).
    venvs = [command.split() for command in run_commands() if "-m venv" in command]
    assert len(venvs) == 1 and "--system-site-packages" in venvs[0], venvs
    environment = " ".join(arguments for keyword, arguments in instructions() if keyword == "ENV")
    assert f"PATH={venvs[0][-1]}/bin:$PATH" in environment.split(), environment


def test_colcon_installs_plain_files_not_symlinks_into_the_checkout():
    builds = [command for command in run_commands() if command.startswith("colcon build")]
    assert builds and "--symlink-install" not in builds[0]


def test_the_torch_pin_is_the_cpu_build_by_default():
    arguments = {a.split("=")[0]: a.partition("=")[2] for k, a in instructions() if k == "ARG"}
    assert arguments.get("TORCH_INDEX_URL") == "https://download.pytorch.org/whl/cpu"
    assert pip_pins()["torch"] == requirement_pins()["torch"]


@pytest.mark.parametrize("text,expected", [
    ('RUN pip install a==1 \\\n    b==2', [("RUN", "pip install a==1      b==2")]),
    ("# a comment\nFROM x", [("FROM", "x")]),
])
def test_the_reader_joins_continuation_lines_and_skips_comments(tmp_path, monkeypatch, text, expected):
    dockerfile = tmp_path / "Dockerfile"
    dockerfile.write_text(text)
    monkeypatch.setattr(sys.modules[__name__], "DOCKERFILE", dockerfile)
    assert instructions() == expected
