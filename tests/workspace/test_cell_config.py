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
from launch_stubs import declared_arguments, launched_actions, launched_nodes
from lifecycle_msgs.msg import Transition
from parameter_files import as_declared, flatten

from impurity_bringup.cell_nodes import (
    CELLS,
    LIFECYCLE_NODES,
    config_dir,
    namespace_of,
    node_section,
    parameter_files,
    ros_arguments,
    share_dir,
)
from impurity_bringup.launch_cell import main as launch_cell_main
from impurity_calibration.calibration import read_calibration_file
from impurity_common import names
from impurity_common.parameters import build, parameter_specs

ROOT = pathlib.Path(__file__).resolve().parents[2]
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
                      calibration=CALIBRATION, namespace=""):
    """The value node `node_name` gets for `name` when started as the launchers start it: in `namespace`,
    the cell's files (parameter_files), then `calibration`, then the `-p` overrides ("name:=value")."""
    args = ros_arguments(parameter_files(cell, None, calibration), None, namespace)
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


@pytest.mark.parametrize("config", [SIM_CONFIG, REAL_CONFIG], ids=["cell.yaml", "real_cell.yaml"])
def test_every_section_of_a_cell_file_is_keyed_for_its_node_in_any_namespace(config):
    keys = yaml.safe_load(config.read_text())
    assert all(key == node_section(key.rsplit("/", 1)[-1]) for key in keys), list(keys)


@pytest.mark.parametrize("namespace", ["/cell_a", "/plant/line_2"])
def test_a_cell_in_a_namespace_reads_the_same_parameters(namespace):
    assert parameter_as_read("heightmap", "depth_scale", 1.0, namespace=namespace) == 0.001  # cell.yaml's
    assert parameter_as_read("episode", "use_ground_truth", True, cell="real", namespace=namespace) is False
    assert list(parameter_as_read("heightmap", "camera_position", [0.0, 0.0, 0.0], namespace=namespace)) == \
        pytest.approx(read_calibration_file(CALIBRATION)[0])


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
    (["--param", "heightmap_node:camera_position:=[0.5,0.0,1]"],
     "camera_position:=[0.5,0.0,1] mixes integers and floats in one list, which ROS cannot read; write every "
     "number as a float: camera_position:=[0.5,0.0,1.0]"),
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


def test_the_launch_file_configures_the_real_driver_at_its_start_and_activates_it_once_inactive(monkeypatch):
    actions = launched_actions(monkeypatch, share_dir() / "launch" / "cell.launch.py", {"cell": "real"})
    (driver,) = [action for action in actions if action[0] == "LifecycleNode"]
    assert (driver[2]["executable"], driver[2]["name"]) == ("ur5_driver", LIFECYCLE_NODES["ur5_driver"])
    assert [kwargs["executable"] for kind, _, kwargs in actions if kind == "Node"] == [
        executable for _, executable in CELLS["real"] if executable not in LIFECYCLE_NODES]
    matches_driver = ("matches_action", (driver,), {})
    # (the stand-ins record each action as (kind, args, kwargs))
    (configure,) = [kwargs["event"][2] for kind, _, kwargs in actions if kind == "EmitEvent"]
    assert configure == {"lifecycle_node_matcher": matches_driver,
                         "transition_id": Transition.TRANSITION_CONFIGURE}
    (handler,) = [args[0][2] for kind, args, _ in actions if kind == "RegisterEventHandler"]
    assert handler["target_lifecycle_node"] == driver and handler["goal_state"] == "inactive"
    (activate,) = handler["entities"]
    assert activate[2]["event"][2] == {"lifecycle_node_matcher": matches_driver,
                                       "transition_id": Transition.TRANSITION_ACTIVATE}


def test_the_simulated_cell_has_no_lifecycle_node(monkeypatch):
    actions = launched_actions(monkeypatch, share_dir() / "launch" / "cell.launch.py", {})
    assert {kind for kind, _, _ in actions} == {"Node"}


# ------------------------------------------------------------------------------------ namespace and driver
@pytest.mark.parametrize("given,namespace", [("/cell_a", "/cell_a"), ("cell_a", "/cell_a"),
                                             ("/cell_a/", "/cell_a"), ("plant/line_2", "/plant/line_2"),
                                             ("", ""), ("/", "")])
def test_a_namespace_is_made_absolute_and_the_root_is_none(given, namespace):
    assert namespace_of(given) == namespace


@pytest.mark.parametrize("given", ["cell-a", "/2cell", "/cell a", "/cell_a//b"])
def test_a_namespace_ros_cannot_take_is_refused_naming_the_argument(given):
    with pytest.raises(ValueError, match=r"namespace .*each part must start with a letter"):
        namespace_of(given)


def test_the_launcher_starts_every_node_in_the_namespace_first_thing_after_ros_args(capsys):
    commands = printed_commands(capsys, "--namespace", "cell_a")
    assert [c[1:4] for c in commands] == [["--ros-args", "-r", "__ns:=/cell_a"]] * len(CELLS["sim"])
    files = ["--params-file", str(SIM_CONFIG), "--params-file", str(CALIBRATION)]
    assert all(command[4:] == files for command in commands)


def test_the_launcher_sets_the_real_drivers_address_and_dry_run_after_the_files(capsys):
    commands = printed_commands(capsys, "--cell", "real", "--robot-ip", "10.0.0.2", "--dry-run", "false")
    by_name = {pathlib.Path(c[0]).name: c for c in commands}
    assert by_name["ur5_driver"][-4:] == ["-p", "robot_ip:=10.0.0.2", "-p", "dry_run:=false"]
    assert all("-p" not in command for name, command in by_name.items() if name != "ur5_driver")


@pytest.mark.parametrize("argv,says", [
    (["--namespace", "cell-a"], "--namespace 'cell-a': each part must start with a letter"),
    (["--robot-ip", "10.0.0.2"], "--robot-ip and --dry-run are the real cell's: add --cell real"),
    (["--dry-run", "false"], "--robot-ip and --dry-run are the real cell's: add --cell real"),
])
def test_the_launcher_refuses_a_bad_namespace_and_driver_settings_on_the_simulated_cell(capsys, argv, says):
    with pytest.raises(SystemExit) as stop:
        launch_cell_main(["--print", *argv])
    assert stop.value.code == 2 and says in capsys.readouterr().err


LAUNCH_FILE = ROOT / "bringup" / "launch" / "cell.launch.py"


def test_the_launch_file_declares_the_cells_arguments(monkeypatch):
    declared = declared_arguments(monkeypatch, LAUNCH_FILE)
    assert set(declared) == {"cell", "namespace", "robot_ip", "dry_run", "camera", "rviz", "config",
                             "calibration", "security", "keystore"}
    defaults = {name: kwargs["default_value"] for name, kwargs in declared.items()}
    assert {name: defaults[name] for name in ("cell", "namespace", "robot_ip", "dry_run", "camera", "rviz")} \
        == {"cell": "sim", "namespace": "", "robot_ip": "", "dry_run": "", "camera": "false", "rviz": "false"}


def test_the_launch_file_starts_every_node_in_the_namespace(monkeypatch):
    nodes = launched_nodes(monkeypatch, LAUNCH_FILE, {"namespace": "cell_a"})
    assert len(nodes) == len(CELLS["sim"]) and {node["namespace"] for node in nodes} == {"/cell_a"}
    assert {node["namespace"] for node in launched_nodes(monkeypatch, LAUNCH_FILE, {})} == {None}


def test_the_launch_files_robot_ip_and_dry_run_are_the_real_drivers_parameters_after_its_files(monkeypatch):
    nodes = {node["executable"]: node["parameters"] for node in launched_nodes(
        monkeypatch, LAUNCH_FILE, {"cell": "real", "robot_ip": "10.0.0.2", "dry_run": "false"})}
    files = [str(SIM_CONFIG), str(REAL_CONFIG), str(CALIBRATION)]
    assert nodes["ur5_driver"] == [*files, {"robot_ip": "10.0.0.2", "dry_run": False}]
    assert all(parameters == files for executable, parameters in nodes.items() if executable != "ur5_driver")


@pytest.mark.parametrize("arguments", [{"robot_ip": "10.0.0.2"}, {"dry_run": "false"}, {"camera": "true"}])
def test_the_launch_file_refuses_real_cell_arguments_on_the_simulated_cell(monkeypatch, arguments):
    with pytest.raises(ValueError, match="are the real cell's: add cell:=real"):
        launched_nodes(monkeypatch, LAUNCH_FILE, arguments)


@pytest.mark.parametrize("namespace", ["", "/cell_a"])
def test_camera_true_includes_the_realsense_launch_with_the_cells_profiles_in_the_namespace(monkeypatch,
                                                                                          namespace):
    actions = launched_actions(monkeypatch, LAUNCH_FILE, {"cell": "real", "camera": "true",
                                                          "namespace": namespace})
    (camera,) = [action for action in actions if action[0] in ("IncludeLaunchDescription", "GroupAction")]
    if namespace:
        kind, ((push, include),), _ = camera
        assert kind == "GroupAction" and push == ("PushRosNamespace", ("/cell_a",), {})
    else:
        include = camera
    kind, (source,), kwargs = include
    assert kind == "IncludeLaunchDescription"
    _, ((_, (path,), _),), _ = source  # PythonLaunchDescriptionSource(PathJoinSubstitution([...]))
    assert path == [("FindPackageShare", ("realsense2_camera",), {}), "launch", "rs_launch.py"]
    arguments = dict(kwargs["launch_arguments"])
    assert arguments["align_depth.enable"] == "true" and arguments["publish_tf"] == "false"
    assert arguments["rgb_camera.color_profile"] == arguments["depth_module.depth_profile"] == "640,480,30"
    # the driver's default names under the cell's namespace are the ones heightmap_node subscribes to
    camera_prefix = f"{arguments['camera_namespace']}/{arguments['camera_name']}/"
    assert all(topic.startswith(camera_prefix)
               for topic in (names.COLOR_TOPIC, names.DEPTH_TOPIC, names.CAMERA_INFO_TOPIC))


def test_rviz_true_starts_rviz2_with_the_cells_config_in_its_namespace(monkeypatch):
    nodes = launched_nodes(monkeypatch, LAUNCH_FILE, {"rviz": "true", "namespace": "/cell_a"})
    (rviz,) = [node for node in nodes if node["package"] == "rviz2"]
    assert rviz["namespace"] == "/cell_a" and rviz["arguments"] == ["-d", str(config_dir() / "cell.rviz")]
    assert not [node for node in launched_nodes(monkeypatch, LAUNCH_FILE, {}) if node["package"] == "rviz2"]
