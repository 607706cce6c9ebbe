"""The workspace itself: set-up outputs, interfaces and executables where ROS tools expect them."""

import pathlib
import subprocess

from ros_harness import INSTALL, ROOT

PYTHON_PACKAGES = ["impurity_common", "impurity_bags", "impurity_calibration", "impurity_viz", "ur5_motion",
                   "impurity_attention", "impurity_policy", "ur5_driver_sim"]


def test_interfaces_are_generated_with_documented_constants():
    from impurity_interfaces.action import ExecutePrimitive, RunEpisode
    from impurity_interfaces.msg import AttentionResult, Primitive
    from impurity_interfaces.srv import ResetScene, StartEpisode

    modes = (AttentionResult.MODE_NONE, AttentionResult.MODE_TARGET, AttentionResult.MODE_OCCLUDED_REGION)
    assert modes == (0, 1, 2)
    assert (Primitive.PUSH, Primitive.GRASP) == (0, 1)
    assert hasattr(StartEpisode.Response(), "reason")
    assert hasattr(ResetScene.Request(), "scenario")
    assert hasattr(RunEpisode.Result(), "action_efficiency")
    assert hasattr(ExecutePrimitive.Feedback(), "phase")


def test_python_packages_install_in_ros2_run_layout():
    for package in PYTHON_PACKAGES:
        assert (INSTALL / package / "share" / package / "package.xml").exists(), package
        index = INSTALL / package / "share" / "ament_index" / "resource_index" / "packages"
        assert (index / package).exists()
        setup_cfg = (ROOT / "src" / package / "setup.cfg").read_text()
        assert f"script_dir=$base/lib/{package}" in setup_cfg


def test_nothing_built_is_tracked_by_git():
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout.splitlines()
    built = (".venv/", "ros2_ws/build/", "ros2_ws/install/", "ros2_ws/log/")
    bad = [p for p in tracked if p.startswith(built) or "__pycache__" in p]
    assert bad == []


def test_torch_is_the_pinned_version_cpu_or_cuda_build():
    import importlib.metadata

    pin = next(line.split("==")[1].strip() for line in (ROOT / "requirements.txt").read_text().splitlines()
               if line.startswith("torch=="))
    version = importlib.metadata.version("torch")
    assert version == pin or version.startswith(pin + "+"), f"torch {version}, requirements.txt pins {pin}"


def test_ros2_ws_src_points_at_the_packages():
    assert (ROOT / "ros2_ws" / "src").resolve() == (ROOT / "src").resolve()
    assert pathlib.Path(ROOT / "ros2_ws" / "src" / "impurity_interfaces" / "package.xml").exists()
