"""declare_parameters on real nodes: what `ros2 param describe` shows, and a node started with a bad value
ends at once with one line (node, parameter, value, what is allowed), exit status 2, no traceback."""

from dataclasses import dataclass

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter

from impurity_common.parameters import PARAMETER_ERROR_EXIT_CODE, ParameterError, declare_parameters, param
from ros_harness import ros_args, spin_until


@dataclass(frozen=True)
class Example:
    resolution: float = param(0.002, "Heightmap cell size (m)", low=0.0005, high=0.05)
    workspace_x: tuple[float, ...] = param((0.276, 0.724), "[x_min, x_max] (m)", length=2)
    mode: str = param("arm", "How to move", choices=("arm", "floating"))
    disabled: tuple[str, ...] = param((), "Names left out")


@pytest.fixture
def make_node(ros_node):  # ros_node: rclpy is initialised for the session
    nodes = []

    def make(**overrides):
        node = rclpy.create_node("parameters_test", parameter_overrides=[
            Parameter(name, value=value) for name, value in overrides.items()])
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.destroy_node()


# ------------------------------------------------------------------------------------ in process
def test_declared_parameters_come_back_as_the_dataclass_with_overrides_applied(make_node):
    result = declare_parameters(make_node(resolution=0.004), Example)
    assert result == Example(resolution=0.004)


def test_an_empty_list_default_is_declared_by_type_and_takes_a_list_override(make_node):
    assert declare_parameters(make_node(), Example).disabled == ()
    node = make_node(disabled=["a", "b"])
    assert declare_parameters(node, Example).disabled == ("a", "b")
    assert node.describe_parameter("disabled").type == ParameterType.PARAMETER_STRING_ARRAY


def test_declared_parameters_are_described_read_only_and_ranged(make_node):
    node = make_node()
    declare_parameters(node, Example)
    described = node.describe_parameter("resolution")
    assert described.read_only and described.description == "Heightmap cell size (m)"
    assert described.floating_point_range[0].from_value == 0.0005
    assert node.describe_parameter("workspace_x").additional_constraints == "a list of 2 doubles"


def test_an_override_outside_the_ros_range_is_one_parameter_error(make_node):
    with pytest.raises(ParameterError) as refused:
        declare_parameters(make_node(resolution=-1.0), Example)
    assert str(refused.value) == ("parameters_test: parameter resolution:=-1.0 is out of range; "
                                  "expected a double in [0.0005, 0.05]")


def test_an_override_of_the_wrong_type_is_one_parameter_error(make_node):
    with pytest.raises(ParameterError) as refused:
        declare_parameters(make_node(resolution="abc"), Example)
    assert str(refused.value) == ("parameters_test: parameter resolution:='abc' is a string; "
                                  "expected a double in [0.0005, 0.05]")


def test_an_override_rclpy_accepts_is_still_checked_against_choices(make_node):
    with pytest.raises(ParameterError, match=r"mode:='wheels' is not one of the choices; expected one of: "):
        declare_parameters(make_node(mode="wheels"), Example)


# ------------------------------------------------------------------------------------ node processes
RESOLUTION_RANGE = "expected a double in [0.0005, 0.05]"
BAD_STARTS = {
    "out-of-range": ("impurity_attention", "heightmap_node", {"resolution": -1.0},
                     f"heightmap: parameter resolution:=-1.0 is out of range; {RESOLUTION_RANGE}"),
    "wrong-type": ("impurity_attention", "heightmap_node", {"resolution": "abc"},
                   f"heightmap: parameter resolution:='abc' is a string; {RESOLUTION_RANGE}"),
    "rule-between-fields": ("impurity_attention", "attention_node", {"saliency.surround_sigma": 1.0},
                            "attention: parameter saliency.surround_sigma:=1.0 is not above center_sigma"),
    "unknown-scenario": ("ur5_driver_sim", "sim_cell", {"initial_scenario": "tidy"},
                         "sim_cell: parameter initial_scenario:='tidy' is not one of the choices; "
                         "expected one of: random, challenging, invisible, file, empty"),
    "own-main": ("impurity_bags", "bag_replay", {"rate": 0.0},
                 "bag_replay: parameter rate:=0.0 is out of range; expected a double in [0.001, 1000.0]"),
    # rcl itself cannot read a list of integers and floats: refused before rclpy starts
    "mixed-list": ("impurity_attention", "heightmap_node", {"camera_position": [0.5, 0.0, 1]},
                   "heightmap_node: parameter camera_position:=[0.5,0.0,1] mixes integers and floats in one "
                   "list, which ROS cannot read; write every number as a float: "
                   "camera_position:=[0.5,0.0,1.0]"),
    "own-main-mixed-list": ("impurity_bags", "bag_replay", {"topics": ["/a", 1]},
                            "bag_replay: parameter topics:=[/a,1] mixes integers and strings in one list"),
}


@pytest.mark.parametrize("case", list(BAD_STARTS), ids=list(BAD_STARTS))
def test_a_node_started_with_a_bad_parameter_exits_2_with_one_line(ros_node, launch, case):
    package, executable, parameters, expected = BAD_STARTS[case]
    proc = launch(package, executable, ros_args(parameters))
    spin_until(ros_node, lambda: not proc.alive, 60.0, f"{executable} to exit")
    output = proc.output()
    name = next(iter(parameters))
    assert proc.process.returncode == PARAMETER_ERROR_EXIT_CODE, output
    assert "Traceback" not in output
    naming = [line for line in output.splitlines() if name in line]
    assert len(naming) == 1 and naming[0].startswith(expected), output
