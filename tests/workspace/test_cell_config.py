"""The cells' parameter files as rcl reads them and as the launchers pass them.

Every node reads config/cell.yaml, on the real cell then real_cell.yaml (only what differs), then
the camera calibration (config/camera_calibration.yaml: the camera pose in a `/**` section, the
only place it lives), then `-p` overrides, which beat both files. rcl lets a node's own section beat
`-p` overrides when a `/**` section comes before it in the same file, so neither cell file has one.
The files read are the installed ones (share/impurity_bringup/config), as the launchers pass them.
"""

import pathlib
import subprocess
import sys

import pytest
import rclpy
import yaml
from launch_stubs import launched_nodes
from parameter_files import as_declared, flatten

from impurity_bringup.cell_nodes import (
    CELLS,
    config_dir,
    node_section,
    parameter_files,
    ros_arguments,
    share_dir,
)
from impurity_bringup.launch_cell import main as launch_cell_main
from impurity_calibration.calibration import read_calibration_file
from impurity_common.parameters import build, parameter_specs

SIM_CONFIG = config_dir() / "cell.yaml"
REAL_CONFIG = config_dir() / "real_cell.yaml"
CALIBRATION = config_dir() / "camera_calibration.yaml"

pytestmark = pytest.mark.usefixtures("rcl_context")  # parameter_as_read's nodes live in it

# executable -> the node name it runs under (its section in the cell's file)
NODE_NAMES = {"sim_cell": "sim_cell", "ur5_driver": "ur5_driver", "heightmap_node": "heightmap",
              "attention_node": "attention", "policy_node": "policy", "episode_node": "episode",
              "cell_state_publisher": "cell_state_publisher", "decision_markers": "decision_markers"}


# node name -> (module, class) of the dataclass of every parameter the node declares
PARAMETER_CLASSES = {
    "sim_cell": ("ur5_driver_sim.sim_cell", "SimCellParameters"),
    "ur5_driver": ("ur5_driver_rtde.ur5_driver_node", "Ur5DriverParameters"),
    "heightmap": ("impurity_attention.heightmap_node", "HeightmapNodeParameters"),
    "attention": ("impurity_attention.attention_node", "AttentionNodeParameters"),
    "policy": ("impurity_policy.policy_node", "PolicyParameters"),
    "episode": ("impurity_policy.episode_node", "EpisodeParameters"),
    "cell_state_publisher": ("impurity_viz.cell_state_publisher", "CellStateParameters"),
    "decision_markers": ("impurity_viz.decision_markers", "DecisionMarkersParameters"),
}


def parameter_class(node_name: str):
    import importlib

    module, name = PARAMETER_CLASSES[node_name]
    return getattr(importlib.import_module(module), name)


def parameter_as_read(node_name: str, name: str, default, *overrides: str, cell="sim",
                      calibration=CALIBRATION):
    """The value node `node_name` gets for `name` when started as the launchers start it: the cell's
    files (parameter_files), then `calibration`, then the `-p` overrides ("name:=value")."""
    args = ros_arguments(parameter_files(cell, None, calibration))
    for override in overrides:
        args += ["-p", override]
    return as_declared(rclpy.get_default_context(), node_name, args, {name: default})[name]


def sections(config: pathlib.Path) -> dict:
    """{node name: section} of a cell file, whose keys are cell_nodes.node_section(node name)."""
    return {key.removeprefix(node_section("")): section
            for key, section in yaml.safe_load(config.read_text()).items()}


# ------------------------------------------------------------------------------------ the camera pose
@pytest.mark.parametrize("cell,node_name", [("sim", "heightmap"), ("sim", "sim_cell"),
                                            ("sim", "cell_state_publisher"), ("real", "heightmap"),
                                            ("real", "cell_state_publisher")])
def test_the_camera_pose_comes_from_the_calibration_file(cell, node_name):
    position, orientation = read_calibration_file(CALIBRATION)
    assert list(parameter_as_read(node_name, "camera_position", [0.0, 0.0, 0.0], cell=cell)) == \
        pytest.approx(position)
    assert list(parameter_as_read(node_name, "camera_orientation", [0.0, 0.0, 0.0, 1.0], cell=cell)) == \
        pytest.approx(orientation)


def test_another_calibration_file_moves_the_camera(tmp_path):
    other = tmp_path / "calibration.yaml"
    other.write_text("/**:\n  ros__parameters:\n    camera_position: [0.41, 0.02, 0.69]\n")
    assert list(parameter_as_read("heightmap", "camera_position", [0.0, 0.0, 0.0], calibration=other)) == \
        [0.41, 0.02, 0.69]


@pytest.mark.parametrize("config", [SIM_CONFIG, REAL_CONFIG], ids=["cell.yaml", "real_cell.yaml"])
def test_a_cell_file_holds_no_camera_pose_and_no_section_for_every_node(config):
    assert "/**" not in sections(config)
    assert not any("camera_position" in flatten(section) for section in sections(config).values())


def test_a_command_line_override_beats_both_files():
    assert parameter_as_read("policy", "max_age", 1.0) == 5.0  # cell.yaml's value
    assert parameter_as_read("policy", "max_age", 1.0, "max_age:=1000000000.0") == 1e9
    assert list(parameter_as_read("heightmap", "camera_position", [0.0, 0.0, 0.0],
                                  "camera_position:=[0.3,0.1,0.8]")) == [0.3, 0.1, 0.8]


# ------------------------------------------------------------------------------------ the files' sections
def test_cell_yaml_has_a_section_for_every_node_of_the_simulated_cell_and_no_other():
    assert set(sections(SIM_CONFIG)) == {NODE_NAMES[executable] for _, executable in CELLS["sim"]}


def test_real_cell_yaml_holds_only_what_differs_the_arm_driver_and_the_episode_without_truth():
    assert set(sections(REAL_CONFIG)) == {"ur5_driver", "episode"}
    assert parameter_files("real", None, None) == [SIM_CONFIG, REAL_CONFIG]  # read over cell.yaml


def as_read_by(cell: str, node_name: str) -> dict:
    """The node's section as the cell's files give it (later files win, parameter by parameter)."""
    merged = {}
    for path in parameter_files(cell, None, None):
        merged.update(flatten(sections(path).get(node_name, {}).get("ros__parameters", {})))
    return merged


@pytest.mark.parametrize("cell,node_name", [(cell, NODE_NAMES[executable]) for cell in CELLS
                                            for _, executable in CELLS[cell]])
def test_a_cell_names_only_declared_parameters_with_allowed_values(cell, node_name):
    cls = parameter_class(node_name)
    config = as_read_by(cell, node_name)
    specs = {spec.name: spec for spec in parameter_specs(cls)}
    assert set(config) <= set(specs), f"{node_name} declares no {sorted(set(config) - set(specs))}"
    build(node_name, cls, {**{name: spec.default for name, spec in specs.items()}, **config})


def test_the_real_cell_needs_no_simulator_truth_and_first_runs_dry():
    assert parameter_as_read("episode", "use_ground_truth", True, cell="real") is False
    assert parameter_as_read("episode", "scene_service_timeout", 3.0, cell="real") == 0.0  # never asks a sim
    assert parameter_as_read("episode", "use_ground_truth", False, cell="sim") is True
    real = sections(REAL_CONFIG)
    assert real["ur5_driver"]["ros__parameters"]["dry_run"] is True
    assert real["ur5_driver"]["ros__parameters"]["speed_scale"] <= 0.25


def test_perception_and_policy_are_configured_alike_on_both_cells():
    for node_name in ("heightmap", "attention", "policy"):
        assert as_read_by("real", node_name) == as_read_by("sim", node_name)
    assert parameter_as_read("attention", "min_relative_contrast", 0.0, cell="real") == \
        parameter_as_read("attention", "min_relative_contrast", 0.0, cell="sim")


# ------------------------------------------------------------------------------------ the launchers
def printed_commands(capsys, *argv) -> list[list[str]]:
    assert launch_cell_main(["--print", *argv]) == 0
    return [line.split() for line in capsys.readouterr().out.splitlines()]


def test_the_launcher_starts_the_simulated_cell_by_default(capsys):
    commands = printed_commands(capsys)
    assert [pathlib.Path(c[0]).name for c in commands] == [executable for _, executable in CELLS["sim"]]
    files = ["--params-file", str(SIM_CONFIG), "--params-file", str(CALIBRATION)]
    assert all(command[1:] == ["--ros-args", *files] for command in commands)


def test_the_real_cell_runs_the_ur5_driver_instead_of_the_simulator(capsys):
    commands = printed_commands(capsys, "--cell", "real", "--param", "ur5_driver:robot_ip:=10.0.0.2",
                                "--record-dir", "/tmp/records")
    by_name = {pathlib.Path(c[0]).name: c for c in commands}
    assert list(by_name) == ["ur5_driver", "heightmap_node", "attention_node", "policy_node", "episode_node",
                             "cell_state_publisher", "decision_markers"]
    assert pathlib.Path(by_name["ur5_driver"][0]).parent.name == "ur5_driver_rtde"
    files = ["--params-file", str(SIM_CONFIG), "--params-file", str(REAL_CONFIG), "--params-file",
             str(CALIBRATION)]
    assert by_name["ur5_driver"][1:] == ["--ros-args", *files, "-p", "robot_ip:=10.0.0.2"]
    assert by_name["episode_node"][1:] == ["--ros-args", *files, "-p", "record_dir:=/tmp/records"]
    assert by_name["heightmap_node"][1:] == ["--ros-args", *files]


def test_the_launcher_takes_another_config_and_calibration(capsys, tmp_path):
    config, calibration = tmp_path / "my_cell.yaml", tmp_path / "my_calibration.yaml"
    config.write_text(REAL_CONFIG.read_text())
    calibration.write_text(CALIBRATION.read_text())
    commands = printed_commands(capsys, "--cell", "real", "--config", str(config), "--calibration",
                                str(calibration), "--only", "heightmap_node")
    assert [c[1:] for c in commands] == [["--ros-args", "--params-file", str(SIM_CONFIG), "--params-file",
                                         str(config), "--params-file", str(calibration)]]


@pytest.mark.parametrize("argv,says", [
    (["--cell", "real", "--only", "sim_cell"], "unknown node(s) of the real cell: sim_cell"),
    (["--param", "ur5_driver:dry_run:=false"], "ur5_driver is not a node of the sim cell"),
    (["--param", "policy_node:rules=none"], "expected EXECUTABLE:NAME:=VALUE"),
    (["--calibration", "/nonexistent/calibration.yaml"],
     "calibration /nonexistent/calibration.yaml not found"),
])
def test_the_launcher_refuses_what_it_cannot_start_and_says_why(capsys, argv, says):
    with pytest.raises(SystemExit) as stop:
        launch_cell_main(["--print", *argv])
    assert stop.value.code == 2 and says in capsys.readouterr().err


def test_the_launch_file_reads_the_same_files_in_the_same_order():
    assert parameter_files("sim") == [SIM_CONFIG, CALIBRATION]
    assert parameter_files("real") == [SIM_CONFIG, REAL_CONFIG, CALIBRATION]
    # the launch file's config:='' means the cell's own file
    assert parameter_files("real", "", str(CALIBRATION)) == [SIM_CONFIG, REAL_CONFIG, CALIBRATION]
    with pytest.raises(ValueError, match="unknown cell 'lab'"):
        parameter_files("lab")


def test_the_launcher_runs_from_the_command_line():
    done = subprocess.run([sys.executable, "-m", "impurity_bringup.launch_cell", "--print", "--cell", "real"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert pathlib.Path(done.stdout.split()[0]).name == "ur5_driver"


# ------------------------------------------------------------------------------------ the ROS launch file
class FakeLaunch:
    """cell.launch.py (installed) run on stand-ins for the launch modules (launch_stubs) with `arguments`."""

    def __init__(self, arguments: dict):
        self.arguments = arguments

    def nodes(self, monkeypatch) -> list[tuple[str, str, list[str]]]:
        """(package, executable, parameter files) of every Node the launch file starts."""
        return [(kwargs["package"], kwargs["executable"], kwargs["parameters"]) for kwargs in
                launched_nodes(monkeypatch, share_dir() / "launch" / "cell.launch.py", self.arguments)]


@pytest.mark.parametrize("arguments,cell,configs", [({}, "sim", [SIM_CONFIG]),
                                                    ({"cell": "real"}, "real", [SIM_CONFIG, REAL_CONFIG])])
def test_the_launch_file_starts_the_cells_nodes_with_its_files_then_the_calibration(monkeypatch, arguments,
                                                                                    cell, configs):
    nodes = FakeLaunch(arguments).nodes(monkeypatch)
    assert [(package, executable) for package, executable, _ in nodes] == list(CELLS[cell])
    assert all(files == [*map(str, configs), str(CALIBRATION)] for _, _, files in nodes)


def test_the_launch_file_takes_another_config_and_calibration(monkeypatch):
    nodes = FakeLaunch({"cell": "real", "config": "/cells/a.yaml", "calibration": "/cells/a_cal.yaml"}
                       ).nodes(monkeypatch)
    expected = (str(SIM_CONFIG), "/cells/a.yaml", "/cells/a_cal.yaml")  # its own file, over cell.yaml
    assert {tuple(files) for _, _, files in nodes} == {expected}
