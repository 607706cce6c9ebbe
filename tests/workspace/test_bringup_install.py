"""impurity_bringup as colcon installs it: the launch file, the parameter files and package.xml under
share/impurity_bringup, the executables under lib/impurity_bringup, and its modules and launch file
importable from the install alone (a fresh interpreter started outside the checkout, nothing added to
sys.path)."""

import os
import subprocess
import sys
import textwrap

import pytest
from launch_stubs import RECORDED

from ros_harness import INSTALL, ROOT

PACKAGE = "impurity_bringup"
SHARE = INSTALL / PACKAGE / "share" / PACKAGE
LAUNCH_FILE = SHARE / "launch" / "cell.launch.py"
WORKSPACE = ROOT / "ros2_ws"
CONFIG_FILES = sorted(path.name for path in (ROOT / "bringup" / "config").glob("*.yaml"))
# Stand-ins for the launch and launch_ros modules (not among the PyPI wheels): each action is recorded
# (the classes launch_stubs stands in for).
LAUNCH_STUBS = textwrap.dedent(f"""
    import sys, types

    def recorder(kind):
        return lambda *args, **kwargs: (kind, args, kwargs)

    class LaunchConfiguration:
        def __init__(self, name):
            self.name = name

    recorded = {RECORDED!r}
    modules = {{name: types.ModuleType(name) for name in recorded}}
    for name, classes in recorded.items():
        for cls in classes:
            setattr(modules[name], cls, recorder(cls))
    modules["launch.substitutions"].LaunchConfiguration = LaunchConfiguration
    sys.modules.update(modules)
""")


def run_outside_the_checkout(code: str, tmp_path) -> subprocess.CompletedProcess:
    """`code` in a fresh interpreter in `tmp_path`, with the sourced environment only (PYTHONSAFEPATH: not
    even the working directory is put on sys.path)."""
    return subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONSAFEPATH": "1"})


def test_the_launch_file_package_xml_and_index_marker_are_installed():
    assert (SHARE / "launch" / "cell.launch.py").is_file()
    assert (SHARE / "package.xml").is_file()
    assert (INSTALL / PACKAGE / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).is_file()


def test_every_parameter_file_of_bringup_config_is_installed():
    assert {"cell.yaml", "real_cell.yaml", "camera_calibration.yaml"} <= set(CONFIG_FILES)
    assert sorted(path.name for path in (SHARE / "config").glob("*.yaml")) == CONFIG_FILES


@pytest.mark.parametrize("name", ["cell.rviz", "cell.foxglove.json"])
def test_the_rviz_config_and_the_foxglove_layout_are_installed_with_the_parameter_files(name):
    assert (SHARE / "config" / name).read_bytes() == (ROOT / "bringup" / "config" / name).read_bytes()


@pytest.mark.parametrize("executable", ["launch_cell", "episode_client", "demo", "eval_graph"])
def test_the_executables_are_where_ros2_run_finds_them(executable):
    assert os.access(INSTALL / PACKAGE / "lib" / PACKAGE / executable, os.X_OK)


def test_the_config_is_found_through_the_package_share_directory(tmp_path):
    done = run_outside_the_checkout("from impurity_bringup import cell_nodes; print(cell_nodes.config_dir())",
                                    tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(SHARE / "config")


def test_without_the_install_the_config_lookup_says_how_to_install(tmp_path):
    code = textwrap.dedent("""
        import os
        from impurity_bringup import cell_nodes
        os.environ["AMENT_PREFIX_PATH"] = ""
        try:
            cell_nodes.config_dir()
        except cell_nodes.NotInstalledError as error:
            print(error)
    """)
    done = run_outside_the_checkout(code, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "impurity_bringup is not installed" in done.stdout and "make setup" in done.stdout


@pytest.mark.parametrize("module", ["impurity_bringup.launch_cell", "impurity_bringup.demo",
                                    "impurity_bringup.episode_client", "impurity_bringup.eval_graph"])
def test_the_modules_import_from_the_workspace_install(tmp_path, module):
    done = run_outside_the_checkout(f"import {module}; print({module}.__file__)", tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().startswith(str(WORKSPACE) + os.sep), done.stdout  # build/ (symlink-install)


def test_the_installed_launch_file_loads_and_declares_the_cells_arguments(tmp_path):
    code = LAUNCH_STUBS + textwrap.dedent(f"""
        import importlib.util
        spec = importlib.util.spec_from_file_location("cell_launch", {str(LAUNCH_FILE)!r})
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        _, (actions,), _ = module.generate_launch_description()
        print(" ".join(args[0] for kind, args, _ in actions if kind == "DeclareLaunchArgument"))
        print(dict((args[0], kwargs["default_value"]) for kind, args, kwargs in actions
                   if kind == "DeclareLaunchArgument")["calibration"])
    """)
    done = run_outside_the_checkout(code, tmp_path)
    assert done.returncode == 0, done.stderr
    calibration = SHARE / "config" / "camera_calibration.yaml"
    assert done.stdout.splitlines() == [
        "cell namespace robot_ip dry_run camera rviz config calibration security keystore", str(calibration)]


def test_the_pip_launcher_runs_as_a_module_from_anywhere(tmp_path):
    done = subprocess.run([sys.executable, "-m", "impurity_bringup.launch_cell", "--print"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert f"--params-file {SHARE / 'config' / 'cell.yaml'}" in done.stdout
