"""A node's command line: an override of a parameter the node does not declare (a misspelling) ends it at
once with one line (node, name, the closest declared names, how to list them) and exit status 2, while
the names ROS and the calibration file give every node pass; `--help` prints the usage and the node's
parameters and exits 0 before rclpy starts."""

import importlib

import pytest
import rclpy
from rclpy.parameter import Parameter

from impurity_bringup.cell_nodes import CELLS, parameter_files, ros_arguments
from impurity_common.node_main import parameters_of
from impurity_common.parameters import PARAMETER_ERROR_EXIT_CODE, UnknownParameter, declare_parameters
from ros_harness import ros_args, spin_until

# executable -> (module, Node class, the node's name: its section in a parameter file)
NODES = {
    "sim_cell": ("ur5_driver_sim.sim_cell", "SimCellNode", "sim_cell"),
    "ur5_driver": ("ur5_driver_rtde.ur5_driver_node", "Ur5DriverNode", "ur5_driver"),
    "heightmap_node": ("impurity_attention.heightmap_node", "HeightmapNode", "heightmap"),
    "attention_node": ("impurity_attention.attention_node", "AttentionNode", "attention"),
    "policy_node": ("impurity_policy.policy_node", "PolicyNode", "policy"),
    "episode_node": ("impurity_policy.episode_node", "EpisodeNode", "episode"),
    "cell_state_publisher": ("impurity_viz.cell_state_publisher", "CellStatePublisher",
                             "cell_state_publisher"),
    "decision_markers": ("impurity_viz.decision_markers", "DecisionMarkers", "decision_markers"),
}


def parameters_class(executable: str):
    module, node_class, _ = NODES[executable]
    return parameters_of(getattr(importlib.import_module(module), node_class))


# ------------------------------------------------------------------------------------ in process
@pytest.fixture
def node_started_with(rcl_context):
    """A node named like one of the cell's, with its own `args` (as a process started with them: rcl
    reads them the same way) and `overrides` ({name: value}), in the session's context; destroyed at
    teardown."""
    made = []

    def make(name: str, args=(), **overrides):
        node = rclpy.create_node(name, context=rcl_context, cli_args=list(args), use_global_arguments=False,
                                 parameter_overrides=[Parameter(key, value=value)
                                                      for key, value in overrides.items()])
        made.append(node)
        return node

    yield make
    for node in made:
        node.destroy_node()


def test_an_override_no_declared_parameter_has_is_refused_with_the_closest_names(node_started_with):
    node = node_started_with("policy", push_end_margn=0.1)
    with pytest.raises(UnknownParameter) as refused:
        declare_parameters(node, parameters_class("policy_node"))
    assert str(refused.value).startswith("policy: unknown parameter push_end_margn:=0.1 (did you mean "
                                         "push_end_margin")
    assert "ros2 param list /policy" in str(refused.value)


def test_the_names_ros_and_the_calibration_give_every_node_are_not_refused(node_started_with):
    node = node_started_with("policy", ["--ros-args", "-p", "use_sim_time:=true", "-p",
                                        "qos_overrides./policy/primitive.publisher.depth:=5"],
                             camera_position=[0.5, 0.0, 0.75], start_type_description_service=False)
    declare_parameters(node, parameters_class("policy_node"))
    assert node.get_parameter("use_sim_time").value is True


@pytest.mark.parametrize("cell,executable", [(cell, executable) for cell in CELLS
                                             for _, executable in CELLS[cell]])
def test_every_node_takes_its_cells_parameter_files_as_the_launchers_pass_them(node_started_with, cell,
                                                                                 executable):
    node = node_started_with(NODES[executable][2], ros_arguments(parameter_files(cell)))
    declare_parameters(node, parameters_class(executable))  # no UnknownParameter, no bad value


# ------------------------------------------------------------------------------------ node processes
MISSPELLED = {
    "policy": ("impurity_policy", "policy_node", "push_end_margn", 0.1,
               "policy: unknown parameter push_end_margn:=0.1 (did you mean push_end_margin"),
    "nested": ("impurity_attention", "attention_node", "saliency.center_sigm", 2.0,
               "attention: unknown parameter saliency.center_sigm:=2.0 (did you mean saliency.center_sigma"),
    "own-main": ("impurity_bags", "bag_replay", "rat", 2.0,
                 "bag_replay: unknown parameter rat:=2.0 (did you mean rate"),
}


@pytest.mark.parametrize("case", list(MISSPELLED), ids=list(MISSPELLED))
def test_a_node_started_with_a_misspelled_parameter_exits_2_with_one_line(ros_node, launch, case):
    package, executable, name, value, expected = MISSPELLED[case]
    proc = launch(package, executable, ros_args({name: value}))
    spin_until(ros_node, lambda: not proc.alive, 60.0, f"{executable} to exit")
    output = proc.output()
    assert proc.process.returncode == PARAMETER_ERROR_EXIT_CODE, output
    assert "Traceback" not in output
    naming = [line for line in output.splitlines() if name in line]
    assert len(naming) == 1 and naming[0].startswith(expected), output
    assert naming[0].endswith("while it runs"), output


def test_help_prints_the_usage_and_parameters_and_exits_0_before_rclpy_starts(ros_node, launch, tmp_path):
    log_dir = tmp_path / "ros_log"  # rclpy.init writes a log file here: it stays absent
    proc = launch("impurity_attention", "heightmap_node", ["--help", "--ros-args", "-p", "resolution:=0.004"],
                  env={"ROS_LOG_DIR": str(log_dir)})
    spin_until(ros_node, lambda: not proc.alive, 60.0, "heightmap_node --help to exit")
    output = proc.output()
    assert proc.process.returncode == 0, output
    assert output.startswith("usage: heightmap_node [-h] [--ros-args [-p NAME:=VALUE]..."), output
    assert "Heightmap node: camera colour + aligned depth" in output
    assert "  resolution:=0.002  (a double in [0.0005, 0.05])\n      Heightmap cell size" in output
    assert not log_dir.exists(), "rclpy was initialised"


@pytest.mark.parametrize("executable, parameter", [("bag_recorder", "output"), ("bag_replay", "bag")])
def test_help_on_the_bag_tools_starts_no_recording_or_replay(ros_node, launch, tmp_path, executable,
                                                             parameter):
    """Their main() does not go through spin_node: they ask exit_if_help themselves, first."""
    log_dir, target = tmp_path / "ros_log", tmp_path / "bag"
    proc = launch("impurity_bags", executable, ["--help", "--ros-args", "-p", f"{parameter}:={target}"],
                  env={"ROS_LOG_DIR": str(log_dir)})
    spin_until(ros_node, lambda: not proc.alive, 60.0, f"{executable} --help to exit")
    output = proc.output()
    assert proc.process.returncode == 0, output
    assert output.startswith(f"usage: {executable} "), output
    assert f"  {parameter}:=" in output
    assert not log_dir.exists() and not target.exists()
