"""Node parameters from one dataclass: what ROS is told (type, default, description, range) and the one
line a bad value gets (no rclpy, no node)."""

import array
import enum
import importlib
import math
import pathlib
from dataclasses import dataclass

import pytest
import yaml
from parameter_files import flatten
from rcl_interfaces.msg import ParameterType

from impurity_common.parameters import (
    ROS_PARAMETERS,
    SHARED_PARAMETERS,
    InvalidParameter,
    ParameterError,
    UnknownParameter,
    allowed,
    build,
    check_fields,
    check_value,
    close_names,
    command_line_overrides,
    command_line_problem,
    descriptor,
    format_value,
    increasing,
    override_problem,
    param,
    parameter_specs,
    parameters_help,
    ros_given,
    unknown_parameters,
)

ROOT = pathlib.Path(__file__).resolve().parents[3]


class Colour(enum.StrEnum):
    RED = "red"
    BLUE = "blue"


@dataclass(frozen=True)
class Group:
    low_sigma: float = param(2.0, "Centre blur (px)", low=0.1, high=50.0)
    high_sigma: float = param(6.0, "Surround blur (px)", low=0.1, high=100.0)

    def __post_init__(self):
        if self.high_sigma <= self.low_sigma:
            raise InvalidParameter("high_sigma", f"is not above low_sigma ({self.low_sigma})")


@dataclass(frozen=True)
class Example:
    resolution: float = param(0.002, "Heightmap cell size (m)", low=0.0005, high=0.05)
    offset: float = param(0, "An int default for a double")
    count: int = param(3, "Number of things", low=1, high=10)
    crop: int = param(112, "Crop side (cells)", low=2, high=448, step=2)
    enabled: bool = param(True, "Switch")
    mode: str = param("arm", "How to move", choices=("arm", "floating"))
    colour: Colour = param(Colour.RED, "A str enum")
    bounds: tuple[float, ...] = param((0.2, 0.7), "[min, max] (m)", length=2, low=-5.0, high=5.0,
                                      check=increasing)
    topics: tuple[str, ...] = param(("/a", "/b"), "Topic names")
    group: Group = Group()


def specs():
    return {spec.name: spec for spec in parameter_specs(Example)}


def defaults() -> dict:
    return {spec.name: spec.default for spec in parameter_specs(Example)}


def build_with(**changes):
    values = defaults()
    values.update({name.replace("__", "."): value for name, value in changes.items()})
    return build("example", Example, values)


# ------------------------------------------------------------------------------------ dataclass -> specs
def test_each_field_becomes_one_parameter_in_declaration_order():
    assert list(specs()) == ["resolution", "offset", "count", "crop", "enabled", "mode", "colour", "bounds",
                             "topics", "group.low_sigma", "group.high_sigma"]


def test_python_types_map_to_ros_parameter_types():
    types = {name: spec.ros_type for name, spec in specs().items()}
    assert types["resolution"] == ParameterType.PARAMETER_DOUBLE
    assert types["count"] == ParameterType.PARAMETER_INTEGER
    assert types["enabled"] == ParameterType.PARAMETER_BOOL
    assert types["mode"] == types["colour"] == ParameterType.PARAMETER_STRING
    assert types["bounds"] == ParameterType.PARAMETER_DOUBLE_ARRAY
    assert types["topics"] == ParameterType.PARAMETER_STRING_ARRAY


def test_defaults_are_given_to_ros_in_its_types():
    values = defaults()
    assert values["offset"] == 0.0 and isinstance(values["offset"], float)  # strict ROS typing: 0.0, not 0
    assert values["bounds"] == [0.2, 0.7]
    assert values["colour"] == "red"


def test_a_nested_dataclass_prefixes_its_parameters_with_the_field_name():
    assert specs()["group.low_sigma"].path == ("group", "low_sigma")


def test_a_field_without_param_is_refused():
    @dataclass(frozen=True)
    class Bare:
        rate: float = 1.0

    with pytest.raises(TypeError, match="param"):
        parameter_specs(Bare)


def test_an_empty_array_default_keeps_the_type_of_its_annotation():
    @dataclass(frozen=True)
    class Empty:
        topics: tuple[str, ...] = param((), "Topics")

    (spec,) = parameter_specs(Empty)
    assert spec.ros_type == ParameterType.PARAMETER_STRING_ARRAY and spec.default == []
    assert build("example", Empty, {"topics": []}) == Empty()


# ------------------------------------------------------------------------------------ descriptors
def test_descriptor_is_read_only_typed_and_described():
    result = descriptor(specs()["resolution"])
    assert result.read_only and result.type == ParameterType.PARAMETER_DOUBLE
    assert result.description == "Heightmap cell size (m)"
    assert result.additional_constraints == "a double in [0.0005, 0.05]"


def test_double_bounds_become_a_floating_point_range():
    (fp_range,) = descriptor(specs()["resolution"]).floating_point_range
    assert (fp_range.from_value, fp_range.to_value, fp_range.step) == (0.0005, 0.05, 0.0)


def test_integer_bounds_become_an_integer_range_with_its_step():
    (int_range,) = descriptor(specs()["count"]).integer_range
    assert (int_range.from_value, int_range.to_value, int_range.step) == (1, 10, 1)
    assert descriptor(specs()["crop"]).integer_range[0].step == 2


def test_a_single_bound_leaves_the_other_side_open():
    @dataclass(frozen=True)
    class OneSided:
        delay: float = param(0.0, "s", low=0.0)

    (spec,) = parameter_specs(OneSided)
    assert descriptor(spec).floating_point_range[0].to_value == math.inf
    assert allowed(spec) == "a double >= 0.0"


def test_parameters_without_bounds_get_no_ros_range():
    result = descriptor(specs()["offset"])
    assert not result.floating_point_range and not result.integer_range


def test_array_limits_are_described_in_words_only():
    result = descriptor(specs()["bounds"])
    assert not result.floating_point_range
    assert result.additional_constraints == "a list of 2 doubles, each in [-5.0, 5.0]"


def test_choices_and_str_enums_are_described_as_their_values():
    assert allowed(specs()["mode"]) == "one of: arm, floating"
    assert allowed(specs()["colour"]) == "one of: red, blue"


# ------------------------------------------------------------------------------------ checking values
def test_allowed_values_pass():
    assert all(check_value(spec, spec.default) is None for spec in specs().values())


def test_a_value_of_another_type_is_named_by_its_type():
    assert check_value(specs()["resolution"], "abc") == "is a string"


def test_an_integer_for_a_double_says_how_to_write_it():
    assert check_value(specs()["resolution"], 1) == "is an integer (write 1.0 for a double)"


def test_a_value_outside_the_bounds_is_out_of_range():
    assert check_value(specs()["resolution"], -1.0) == "is out of range"
    assert check_value(specs()["count"], 11) == "is out of range"


def test_nan_is_out_of_range_of_a_bounded_double():
    assert check_value(specs()["resolution"], math.nan) == "is out of range"


def test_an_integer_between_steps_is_refused():
    assert check_value(specs()["crop"], 111) == "is not on a step"


def test_a_string_outside_the_choices_is_refused():
    assert check_value(specs()["mode"], "wheels") == "is not one of the choices"
    assert check_value(specs()["colour"], "green") == "is not one of the choices"


def test_arrays_are_checked_for_length_element_type_and_element_range():
    bounds = specs()["bounds"]
    assert check_value(bounds, [0.2]) == "has 1 element"
    assert check_value(bounds, ["a", "b"]) == "is a list of strings"
    assert check_value(bounds, [0.2, 9.0]) == "has an element out of range"


def test_arrays_as_rclpy_returns_them_are_accepted():
    assert check_value(specs()["bounds"], array.array("d", [0.2, 0.7])) is None


def test_a_field_check_runs_after_the_type_and_range_checks():
    assert check_value(specs()["bounds"], [0.7, 0.2]) == "is not increasing ([min, max] with min < max)"


# ------------------------------------------------------------------------------------ building
def test_build_returns_the_dataclass_with_tuples_enums_and_nested_groups():
    result = build_with(resolution=0.004, colour="blue", bounds=array.array("d", [0.1, 0.3]),
                        group__low_sigma=1.0)
    assert result.resolution == 0.004
    assert result.colour is Colour.BLUE
    assert result.bounds == (0.1, 0.3)
    assert result.group == Group(low_sigma=1.0)


def test_a_bad_value_is_one_line_naming_node_parameter_value_and_range():
    with pytest.raises(ParameterError) as refused:
        build_with(resolution=-1.0)
    assert str(refused.value) == ("example: parameter resolution:=-1.0 is out of range; "
                                  "expected a double in [0.0005, 0.05]")


def test_a_wrong_type_is_one_line_with_the_value_as_given():
    with pytest.raises(ParameterError) as refused:
        build_with(resolution="abc")
    assert str(refused.value) == ("example: parameter resolution:='abc' is a string; "
                                  "expected a double in [0.0005, 0.05]")


def test_a_rule_between_fields_names_the_field_with_its_group_prefix():
    with pytest.raises(ParameterError) as refused:
        build_with(group__high_sigma=1.0)
    assert str(refused.value) == ("example: parameter group.high_sigma:=1.0 is not above low_sigma (2.0); "
                                  "expected a double in [0.1, 100.0]")
    assert refused.value.parameter == "group.high_sigma" and refused.value.value == 1.0


def test_an_error_line_never_spans_lines():
    error = ParameterError("node", "is wrong:\n  first\n  second", "name", 1.0, "a double")
    assert "\n" not in str(error)


def test_values_are_shown_as_written_after_colon_equals():
    assert format_value(True) == "true"
    assert format_value("abc") == "'abc'"
    assert format_value(array.array("d", [0.5, 1.0])) == "[0.5, 1.0]"
    assert format_value(Colour.RED) == "'red'"


# ------------------------------------------------------------------------------------ unknown names
DECLARED = ["resolution", "group.low_sigma", "group.high_sigma", "push_end_margin", "push_depth", "rules",
            "rules_disabled"]


def test_an_override_of_a_name_not_declared_is_unknown():
    assert unknown_parameters(["resolution", "resolutoin", "rulez"], DECLARED) == ["resolutoin", "rulez"]
    assert unknown_parameters(["resolution", "group.low_sigma"], DECLARED) == []


def test_the_names_ros_gives_every_node_are_never_unknown():
    given = ["use_sim_time", "start_type_description_service",
             "qos_overrides./heightmap.publisher.reliability", "qos_overrides./clock.subscription.depth"]
    assert unknown_parameters(given, DECLARED) == []
    assert ROS_PARAMETERS == {"use_sim_time", "start_type_description_service"}
    assert ros_given("qos_overrides./a.publisher.depth") and not ros_given("qos_override")


def test_the_camera_pose_is_shared_as_the_calibration_file_gives_it_to_every_node():
    assert unknown_parameters(["camera_position", "camera_orientation"], DECLARED) == []
    calibration = yaml.safe_load((ROOT / "bringup" / "config" / "camera_calibration.yaml").read_text())
    every_node = set(flatten(calibration["/**"]["ros__parameters"]))
    assert every_node and every_node <= SHARED_PARAMETERS


def test_the_closest_declared_names_come_first_and_none_when_nothing_is_close():
    assert close_names("push_end_margn", DECLARED)[0] == "push_end_margin"
    assert close_names("rulez", DECLARED)[0] == "rules"
    assert close_names("low_sigma", DECLARED) == ["group.low_sigma"]  # the group prefix forgotten
    assert close_names("zzz", DECLARED) == []


def test_an_unknown_parameter_is_one_line_naming_node_name_value_closest_names_and_how_to_list_them():
    error = UnknownParameter("policy", {"push_end_margn": 0.1}, DECLARED, "/cell/policy")
    assert str(error) == ("policy: unknown parameter push_end_margn:=0.1 (did you mean push_end_margin?); "
                          "the node's parameters: --help on its executable, or `ros2 param list "
                          "/cell/policy` while it runs")
    assert isinstance(error, ParameterError)  # spin_node: exit status 2
    assert error.parameter == "push_end_margn" and error.value == 0.1
    assert error.suggestions == {"push_end_margn": ["push_end_margin"]}


def test_several_unknown_parameters_are_named_in_one_line_sorted():
    error = UnknownParameter("policy", {"zzz": "x", "rulez": "none", "group.mid_sigma": 3.0}, DECLARED)
    assert "\n" not in str(error)
    assert str(error).startswith("policy: unknown parameters group.mid_sigma:=3.0 (did you mean "
                                 "group.high_sigma or group.low_sigma?), rulez:='none' (did you mean "
                                 "rules?), zzz:='x' (no declared name is close); ")
    assert "`ros2 param list /policy`" in str(error)


def test_parameters_help_gives_each_name_with_its_default_what_it_allows_and_its_description():
    text = parameters_help(Example, width=40)
    lines = text.splitlines()
    assert lines[:2] == ["  resolution:=0.002  (a double in [0.0005, 0.05])", "      Heightmap cell size (m)"]
    assert "  mode:='arm'  (one of: arm, floating)" in lines
    assert "  bounds:=[0.2, 0.7]  (a list of 2 doubles, each in [-5.0, 5.0])" in lines
    assert "  group.high_sigma:=6.0  (a double in [0.1, 100.0])" in lines
    assert all(len(line) <= 40 for line in lines if line.startswith("      "))


def test_a_long_description_is_wrapped_under_its_parameter():
    @dataclass(frozen=True)
    class Long:
        rate: float = param(1.0, "word " * 30)

    lines = parameters_help(Long, width=50).splitlines()
    assert lines[0] == "  rate:=1.0  (a double)"
    assert len(lines) > 2 and all(line.startswith("      word") and len(line) <= 50 for line in lines[1:])


# ------------------------------------------------------------------------------------ the cell's nodes
# Each node -> (module, its parameters dataclass), imported per case: the runtime's cases never import the
# simulator (a CPython 3.12 venv has no PyBullet).
NODE_PARAMETERS = {
    "heightmap": ("impurity_attention.heightmap_node", "HeightmapNodeParameters"),
    "attention": ("impurity_attention.attention_node", "AttentionNodeParameters"),
    "sim_cell": ("ur5_driver_sim.sim_cell", "SimCellParameters"),
    "bag_recorder": ("impurity_bags.bag_recorder_node", "BagRecorderParameters"),
    "bag_replay": ("impurity_bags.bag_replay_node", "BagReplayParameters"),
}


def node_parameters(node: str) -> type:
    module, name = NODE_PARAMETERS[node]
    return getattr(importlib.import_module(module), name)


def nodes(*names: str) -> list:
    """The nodes as parametrize values, the simulator's marked as needing it."""
    return [pytest.param(node, marks=pytest.mark.simulator) if NODE_PARAMETERS[node][0].startswith(
        "ur5_driver_sim.") else node for node in names]


@pytest.mark.parametrize("node", nodes(*NODE_PARAMETERS))
def test_every_node_accepts_its_own_defaults(node):
    cls = node_parameters(node)
    build(node, cls, {spec.name: spec.default for spec in parameter_specs(cls)})


@pytest.mark.parametrize("node", nodes("heightmap", "attention", "sim_cell"))
def test_cell_yaml_names_only_declared_parameters_with_allowed_values(node):
    cls = node_parameters(node)
    config = flatten(yaml.safe_load((ROOT / "bringup" / "config" / "cell.yaml").read_text())["/**/" + node]
                     ["ros__parameters"])
    specs_by_name = {spec.name: spec for spec in parameter_specs(cls)}
    assert set(config) <= set(specs_by_name), f"unknown parameters {set(config) - set(specs_by_name)}"
    build(node, cls, {**{name: spec.default for name, spec in specs_by_name.items()}, **config})


# ------------------------------------------------------------------------------ fields that are no parameters
@dataclass(frozen=True)
class WithModel:
    rate: float = param(1.0, "Rate (Hz)", low=0.0)
    model: object = param(None, "A model object set in code", ros=False)


def test_a_field_marked_ros_false_is_no_parameter_and_keeps_its_default():
    assert [spec.name for spec in parameter_specs(WithModel)] == ["rate"]
    built = build("node", WithModel, {"rate": 2.0})
    assert built.rate == 2.0 and built.model is None


def test_importing_the_module_imports_no_ros_package():
    import subprocess
    import sys

    code = ("import sys, impurity_common.parameters; "
            "print(sorted(m for m in sys.modules if m.startswith(('rclpy', 'rcl_interfaces'))))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == "[]"


def test_the_attention_nodes_defaults_build_attentions_own_defaults():
    import dataclasses

    from impurity_attention.attention_node import AttentionNodeParameters
    from impurity_attention.core.attention import AttentionParams

    cls = AttentionNodeParameters
    built = build("attention", cls, {spec.name: spec.default for spec in parameter_specs(cls)})
    assert AttentionParams(**{f.name: getattr(built, f.name) for f in dataclasses.fields(AttentionParams)}) \
        == AttentionParams()


# ------------------------------------------------------------------------------------ check_fields
@dataclass(frozen=True)
class Checked:
    rate: float = param(1.0, "Rate (Hz)", low=0.1, high=10.0)
    count: int = param(3, "Number of things", low=1)
    crop: int = param(112, "Crop side (cells)", low=2, high=448, step=2)
    mode: str = param("arm", "How to move", choices=("arm", "floating"))
    colour: Colour = param(Colour.RED, "A str enum")
    bounds: tuple[float, ...] = param((0.2, 0.7), "[min, max] (m)", length=2, low=-5.0, high=5.0,
                                      check=increasing)
    group: Group = Group()
    model: object = param(None, "A model object set in code", ros=False)

    def __post_init__(self):
        check_fields(self)


def test_check_fields_passes_the_defaults_and_allowed_values():
    Checked()
    Checked(rate=10.0, count=1, crop=2, mode="floating", colour=Colour.BLUE, bounds=(-5.0, 5.0))


@pytest.mark.parametrize("field, value", [("rate", 0.05), ("rate", 11.0), ("rate", math.nan), ("count", 0),
                                          ("crop", 111), ("mode", "legs"), ("colour", "green"),
                                          ("bounds", (0.7, 0.2)), ("bounds", (0.2,)), ("bounds", (0.2, 6.0)),
                                          ("bounds", (math.nan, 0.5))])
def test_check_fields_refuses_a_value_its_param_limits_refuse_naming_the_field(field, value):
    with pytest.raises(InvalidParameter, match=f"^{field}:=") as refused:
        Checked(**{field: value})
    assert refused.value.field == field


def test_check_fields_refusal_is_a_value_error_of_one_line_with_the_value_and_what_is_allowed():
    with pytest.raises(ValueError) as refused:
        Checked(rate=20.0)
    assert str(refused.value) == "rate:=20.0 is out of range; expected a double in [0.1, 10.0]"


def test_check_fields_checks_numbers_of_another_numeric_type_as_the_fields_type():
    import numpy as np

    Checked(rate=2, count=np.int64(4), bounds=np.array([0.1, 0.3]))
    with pytest.raises(InvalidParameter, match="rate"):
        Checked(rate=np.float32(20.0))


def test_check_fields_refuses_a_value_of_another_kind_by_its_type():
    with pytest.raises(InvalidParameter, match="count:=2.5 is a double"):
        Checked(count=2.5)
    with pytest.raises(InvalidParameter, match="mode:=true is a bool"):
        Checked(mode=True)


def test_check_fields_leaves_nested_groups_and_fields_that_are_no_parameters_alone():
    model = object()
    assert Checked(model=model).model is model
    with pytest.raises(InvalidParameter, match="high_sigma"):  # the group's own rule, when it is built
        Group(low_sigma=5.0, high_sigma=4.0)


def test_a_dataclass_whose_post_init_checks_its_fields_builds_from_ros_values_as_before():
    built = build("node", Checked, {spec.name: spec.default for spec in parameter_specs(Checked)})
    assert built == Checked()
    with pytest.raises(ParameterError, match="^node: parameter rate:=20.0 is out of range; expected"):
        build("node", Checked, {**{spec.name: spec.default for spec in parameter_specs(Checked)},
                                "rate": 20.0})


# ------------------------------------------------------------------ command-line overrides rcl cannot read
@pytest.mark.parametrize("value, fix", [
    ("[0.5,0.0,1]", "camera_position:=[0.5,0.0,1.0]"),
    ("[1, 2.5]", "camera_position:=[1.0,2.5]"),
    ("[0x10,2.5]", "camera_position:=[16.0,2.5]"),
    ("[1e3,2]", "camera_position:=[1e3,2.0]"),
])
def test_a_list_of_integers_and_floats_is_refused_with_the_fix(value, fix):
    problem = override_problem("camera_position", value)
    assert problem.startswith(f"parameter camera_position:={value} mixes integers and floats in one list")
    assert problem.endswith(f"write every number as a float: {fix}")


@pytest.mark.parametrize("value, kinds", [("[1,true]", "booleans and integers"),
                                          ("[a,1]", "integers and strings")])
def test_a_list_of_other_mixed_types_is_refused_naming_them(value, kinds):
    assert f"mixes {kinds} in one list" in override_problem("p", value)


@pytest.mark.parametrize("value", ["[1,2]", "[0.5,0.0,1.0]", "[yes,no]", "[1e3,2.0]", "[]", "1", "abc",
                                   "['a','1']", "[a,b]"])
def test_values_rcl_reads_are_not_refused(value):
    assert override_problem("p", value) is None


def test_only_the_overrides_in_ros_sections_are_checked():
    args = ["node", "-p", "a:=[1,2.5]", "--ros-args", "-p", "b:=[1,2]", "--param", "c:=[0.5,1]", "--",
            "-p", "d:=[1,2.5]"]
    assert command_line_overrides(args) == [("b", "[1,2]"), ("c", "[0.5,1]")]
    assert command_line_problem(args).startswith("parameter c:=[0.5,1] mixes integers and floats")
    assert command_line_problem(["node", "--ros-args", "-p", "b:=[1,2]"]) is None
    assert command_line_overrides([]) == [] and command_line_overrides(["node", "--ros-args", "-p"]) == []
