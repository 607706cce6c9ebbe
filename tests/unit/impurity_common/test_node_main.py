"""node_main's --help, without starting rclpy: which arguments ask for it, the usage text, and the
parameters dataclass of each node found from its class alone."""

import importlib
import pathlib
import subprocess
import sys
import types
from dataclasses import dataclass

import pytest

from impurity_common import node_main
from impurity_common.node_main import exit_if_help, own_arguments, parameters_of, usage, wants_help
from impurity_common.parameters import param


@dataclass(frozen=True)
class Inner:
    sigma: float = param(2.0, "Blur (px)", low=0.1)


@dataclass(frozen=True)
class Example:
    resolution: float = param(0.002, "Heightmap cell size (m)", low=0.0005, high=0.05)
    inner: Inner = Inner()


class ExampleNode:  # stands in for an rclpy Node subclass: parameters_of never builds it
    pass


# ------------------------------------------------------------------------------------ asking for help
def test_the_arguments_outside_ros_sections_are_the_executables_own():
    assert own_arguments(["prog", "-x", "--ros-args", "-p", "a:=1", "--", "-y", "--ros-args", "-r",
                          "b:=c"]) == ["prog", "-x", "-y"]


@pytest.mark.parametrize("args", [["node", "-h"], ["node", "--help"],
                                  ["node", "--help", "--ros-args", "-p", "a:=1"],
                                  ["node", "--ros-args", "-p", "a:=1", "--", "-h"]])
def test_h_or_help_among_the_executables_own_arguments_asks_for_help(args):
    assert wants_help(args)


@pytest.mark.parametrize("args", [["node"], ["node", "--ros-args", "-p", "a:=1"],
                                  ["node", "--ros-args", "--params-file", "--help"],
                                  ["node", "--ros-args", "-h"], ["node", "--helpful"]])
def test_arguments_of_ros_or_other_words_do_not(args):
    assert not wants_help(args)


def test_help_prints_the_usage_and_exits_0_before_anything_starts(capsys):
    with pytest.raises(SystemExit) as exited:
        exit_if_help(["node", "--help"], Example, "Example node: does things.", executable="example_node")
    assert exited.value.code == 0
    assert capsys.readouterr().out == usage("example_node", "Example node: does things.", Example) + "\n"


def test_without_help_nothing_is_printed(capsys):
    exit_if_help(["node", "--ros-args", "-p", "a:=1"], Example)
    assert capsys.readouterr().out == ""


# ------------------------------------------------------------------------------------ the usage text
def test_the_usage_names_the_executable_and_how_parameters_are_given():
    text = usage("example_node", "Example node: does things.")
    assert text.splitlines()[0] == ("usage: example_node [-h] [--ros-args [-p NAME:=VALUE]... "
                                    "[--params-file FILE]...]")
    assert "Example node: does things." in text
    assert "-p NAME:=VALUE" in text and "--params-file" in text and "ros__parameters:" in text
    assert "example_node --ros-args --params-file bringup/config/cell.yaml -p NAME:=VALUE" in text
    assert "exit status 2" in text


def test_the_usage_lists_the_parameters_with_defaults_bounds_and_descriptions():
    text = usage("example_node", None, Example)
    assert "  resolution:=0.002  (a double in [0.0005, 0.05])\n      Heightmap cell size (m)" in text
    assert "  inner.sigma:=2.0  (a double >= 0.1)\n      Blur (px)" in text


def test_without_the_dataclass_the_usage_says_how_to_list_the_parameters_of_the_running_node():
    text = usage("example_node")
    assert "ros2 param list /NODE" in text and "ros2 param describe /NODE NAME" in text
    assert ":=0.002" not in text


# ------------------------------------------------------------------------------------ the node's dataclass
def test_the_parameters_of_a_node_are_the_outermost_parameters_dataclass_of_its_module():
    assert parameters_of(ExampleNode) is Example  # Inner is nested in Example


def test_a_module_with_no_parameters_dataclass_or_two_outermost_ones_gives_none(monkeypatch):
    assert parameters_of(node_main.spin_node) is None  # node_main defines none

    @dataclass(frozen=True)
    class Other:
        rate: float = param(1.0, "Hz")

    module = types.ModuleType("two_parameter_classes")
    for value in (Example, Inner, Other, ExampleNode):
        monkeypatch.setattr(value, "__module__", module.__name__)
        setattr(module, value.__name__, value)
    monkeypatch.setitem(sys.modules, module.__name__, module)
    assert parameters_of(ExampleNode) is None
    delattr(module, "Other")
    assert parameters_of(ExampleNode) is Example


# Every node main() that calls spin_node: its Node class -> the dataclass it declares (declare_parameters)
SPIN_NODE_NODES = {
    "ur5_driver_sim.sim_cell": ("SimCellNode", "SimCellParameters"),
    "ur5_driver_rtde.ur5_driver_node": ("Ur5DriverNode", "Ur5DriverParameters"),
    "impurity_attention.heightmap_node": ("HeightmapNode", "HeightmapNodeParameters"),
    "impurity_attention.attention_node": ("AttentionNode", "AttentionNodeParameters"),
    "impurity_policy.policy_node": ("PolicyNode", "PolicyParameters"),
    "impurity_policy.episode_node": ("EpisodeNode", "EpisodeParameters"),
    "impurity_viz.cell_state_publisher": ("CellStatePublisher", "CellStateParameters"),
    "impurity_viz.decision_markers": ("DecisionMarkers", "DecisionMarkersParameters"),
}


@pytest.mark.parametrize("module_name", [
    pytest.param(name, marks=pytest.mark.simulator) if name.startswith("ur5_driver_sim.") else name
    for name in SPIN_NODE_NODES])
def test_every_spin_node_node_lists_the_parameters_it_declares(module_name):
    module = importlib.import_module(module_name)
    node_class, parameters_class = SPIN_NODE_NODES[module_name]
    assert parameters_of(getattr(module, node_class)) is getattr(module, parameters_class)
    assert f"declare_parameters(self, {parameters_class})" in pathlib.Path(module.__file__).read_text()


# ------------------------------------------------------------------------------------ stopping on signals
STOP_SCRIPT = """
import os, signal, sys
import rclpy
from impurity_common.node_main import init_with_stop_event
stop = init_with_stop_event([])
for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGINT):
    os.kill(os.getpid(), sig)
    if not stop.wait(10.0):
        sys.exit(3)
    # the context is still valid: the node can still finish its work (close a bag, wait for readers)
    print(sig.name, stop.is_set(), rclpy.ok(), flush=True)
    stop.clear()
rclpy.shutdown()
"""


def test_with_the_stop_event_signals_only_set_it_and_leave_the_context_valid():
    """What bag_recorder and bag_replay rely on to close cleanly on Ctrl-C: no KeyboardInterrupt, no
    shut-down context under a spin_once (a separate process: it replaces the signal handlers)."""
    run = subprocess.run([sys.executable, "-c", STOP_SCRIPT], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split("\n")[:3] == ["SIGINT True True", "SIGTERM True True", "SIGINT True True"]


# ------------------------------------------------------------------ overrides rcl cannot read
def test_an_override_rcl_cannot_read_ends_the_process_with_one_line_before_rclpy_starts(capsys):
    args = ["heightmap_node", "--ros-args", "-p", "camera_position:=[0.5,0.0,1]"]
    with pytest.raises(SystemExit) as stop:
        node_main.exit_if_unreadable_overrides(args, "heightmap_node")
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("heightmap_node: parameter camera_position:=[0.5,0.0,1] ")
    assert err.rstrip().endswith("write every number as a float: camera_position:=[0.5,0.0,1.0]")
    node_main.exit_if_unreadable_overrides([*args[:3], "camera_position:=[0.5,0.0,1.0]"])  # returns
