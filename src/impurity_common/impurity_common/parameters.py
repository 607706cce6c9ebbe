"""Node parameters declared from ONE typed structure: a frozen dataclass whose fields carry a default, a
description and optional limits. `declare_parameters(node, Type)` declares every field (read-only, typed,
with a FloatingPointRange/IntegerRange where a range is given), reads the values back, checks them and
returns a populated instance. A bad value (wrong type, out of range, not a choice, failing a check)
raises ParameterError, whose text is ONE line naming the node, the parameter, the value and what is
allowed; `node_main.spin_node` prints that line to stderr and exits with status 2, never a traceback.
An override (yaml or -p) for a name the node does not declare, usually a misspelling, is a ParameterError
too (UnknownParameter: the name and the closest declared names), but for the names ROS gives every node
and the camera pose the calibration file gives every node (ros_given).

    @dataclass(frozen=True)
    class HeightmapParams:
        resolution: float = param(0.002, "Heightmap cell size (m)", low=0.0005, high=0.05)
        workspace_x: tuple[float, ...] = param((0.276, 0.724), "[x_min, x_max] in base_link (m)",
                                               length=2, check=increasing)
        depth_encoding: str = param("16UC1", "Aligned depth encoding", choices=("16UC1", "32FC1"))
        scenario: Scenario = param(Scenario.RANDOM, "Scene built at start")  # str enum: its values
        saliency: SaliencyParameters = SaliencyParameters()  # nested: parameters saliency.<field>

    class HeightmapNode(Node):
        def __init__(self):
            super().__init__("heightmap")
            self.params = declare_parameters(self, HeightmapParams)  # self.params.resolution ...

Field types: float (ROS double), int (integer), bool, str, a str Enum (string, its values are the
choices, returned as the member), tuple[float | int | str | bool, ...] (ROS arrays; `length`,
`low`/`high` apply per element), and a nested parameters dataclass (names prefixed "<field>.", as
`saliency: {center_sigma: 2.0}` in a yaml). Ranges are inclusive, as ROS's. Rules between fields go
in the dataclass's __post_init__: `raise InvalidParameter("stop_layer", "must be >= start_layer (2)")`,
after `check_fields(self)`, which checks every field against its own limits, so that an instance built in
code is checked as a node's values are (its refusal is an InvalidParameter of one line, as ParameterError's).
A field that is no ROS parameter (a model object set in code) is declared `param(None, "...", ros=False)`:
it is left out of the parameters and keeps its default.

Importing this module imports no ROS package, so a pure core can declare its parameters with `param`: the
pure part (parameter_specs, check_value, build, ParameterError's line, unknown_parameters, parameters_help)
needs none; descriptor imports rcl_interfaces and declare_parameters rclpy when called.
"""

from __future__ import annotations

import array
import dataclasses
import difflib
import enum
import math
import numbers
import textwrap
import typing
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from impurity_common import cell

PARAMETER_ERROR_EXIT_CODE = 2  # what a node exits with when a parameter is bad (argparse's usage code)
_METADATA_KEY = "impurity_parameter"
_INT64 = (-(2 ** 63), 2 ** 63 - 1)

# ROS parameter type name -> (rcl_interfaces ParameterType constant's name, Python element type, words for
# messages); the constant is looked up when a descriptor is built, so this module imports no ROS package
_SCALARS = {
    "double": ("PARAMETER_DOUBLE", float, "a double"),
    "integer": ("PARAMETER_INTEGER", int, "an integer"),
    "bool": ("PARAMETER_BOOL", bool, "a bool"),
    "string": ("PARAMETER_STRING", str, "a string"),
}
_PLURALS = {"double": "doubles", "integer": "integers", "bool": "bools", "string": "strings"}
_TYPE_WORDS = {float: "double", int: "integer", bool: "bool", str: "string"}

# Names a node may be given without declaring them in its dataclass (unknown_parameters lets them pass).
# rclpy declares these on every node (TimeSource, TypeDescriptionService); launch files set use_sim_time.
ROS_PARAMETERS = frozenset({"use_sim_time", "start_type_description_service"})
# rclpy's per-topic QoS overrides (QoSOverridingOptions), declared when a publisher or subscription that
# takes them is created, which may be after declare_parameters.
ROS_PARAMETER_PREFIXES = ("qos_overrides.",)
# The camera pose: bringup/config/camera_calibration.yaml gives it to every node in a `/**` section; only
# the nodes that read it declare it (camera_position_param, camera_orientation_param).
SHARED_PARAMETERS = frozenset({"camera_position", "camera_orientation"})


@dataclass(frozen=True)
class Limits:
    """What a field allows besides its type (kept in the dataclass field's metadata by `param`)."""

    description: str
    low: float | None = None  # inclusive; per element for arrays
    high: float | None = None  # inclusive; per element for arrays
    step: float | None = None  # scalars: allowed values are low + k * step (needs low)
    choices: tuple | None = None  # strings: the allowed values
    length: int | None = None  # arrays: the number of elements
    check: Callable[[typing.Any], str | None] | None = None  # value -> None, or what is wrong with it


def param(default, description: str, *, low: float | None = None, high: float | None = None,
          step: float | None = None, choices: Sequence | None = None, length: int | None = None,
          check: Callable[[typing.Any], str | None] | None = None, ros: bool = True):
    """A parameter field: `resolution: float = param(0.002, "Heightmap cell size (m)", low=0.0005)`.
    `check(value)` returns None when the value is fine, else a short phrase of what is wrong with it
    ("must be increasing"); it runs after the type, range, choices and length checks passed.
    ros=False: a field of the dataclass that is no ROS parameter (an object such as a model, set in code):
    parameter_specs leaves it out and build gives it its default."""
    if not ros:
        return dataclasses.field(default=default, metadata={_METADATA_KEY: NOT_ROS})
    if isinstance(default, list):
        default = tuple(default)
    limits = Limits(description, low, high, step, tuple(choices) if choices is not None else None, length,
                    check)
    return dataclasses.field(default=default, metadata={_METADATA_KEY: limits})


NOT_ROS = "not a ROS parameter"  # the metadata of a param(..., ros=False) field


class InvalidParameter(ValueError):
    """Raised by a parameters dataclass's __post_init__ (a rule between fields, or check_fields): names the
    field. With `value` (check_fields), str() is one line as a ParameterError's without the node:
    "heap_sigma_px:=-0.5 is out of range; expected a double in [0.0, 56.0]"."""

    def __init__(self, field: str, problem: str, value=None, allowed: str | None = None):
        line = f"{field} {problem}" if value is None else f"{field}:={format_value(value)} {problem}"
        if allowed:
            line += f"; expected {allowed}"
        super().__init__(" ".join(line.split()))
        self.field, self.problem = field, problem


class ParameterError(Exception):
    """A node's parameter has a value it cannot run with; str() is the one line to show the user."""

    def __init__(self, node: str, problem: str, parameter: str | None = None, value=None,
                 allowed: str | None = None):
        self.node, self.problem, self.parameter = node, problem, parameter
        self.value, self.allowed = value, allowed
        if parameter is None:
            line = f"{node}: invalid parameters: {problem}"
        else:
            line = f"{node}: parameter {parameter}:={format_value(value)} {problem}"
            if allowed:
                line += f"; expected {allowed}"
        super().__init__(" ".join(line.split()))  # one line, whatever a check's text holds


class UnknownParameter(ParameterError):
    """Overrides (yaml or -p) for names the node declares no parameter of, usually misspellings. str() is
    one line: the node, each unknown name with its value and the closest declared names, and how to list
    the node's parameters:

        policy: unknown parameter push_end_margn:=0.1 (did you mean push_end_margin?); the node's
        parameters: --help on its executable, or `ros2 param list /policy` while it runs

    `unknown` is {name: value} of the unknown names, `suggestions` {name: [closest declared names]}."""

    def __init__(self, node: str, unknown: dict, declared: Iterable[str], fully_qualified_name: str = ""):
        declared = list(declared)
        self.unknown = dict(sorted(unknown.items()))
        self.suggestions = {name: close_names(name, declared) for name in self.unknown}
        words = []
        for name, value in self.unknown.items():
            close = self.suggestions[name]
            hint = f"did you mean {' or '.join(close)}?" if close else "no declared name is close"
            words.append(f"{name}:={format_value(value)} ({hint})")
        plural = "s" if len(words) > 1 else ""
        listing = f"`ros2 param list {fully_qualified_name or '/' + node}` while it runs"
        problem = (f"unknown parameter{plural} {', '.join(words)}; the node's parameters: --help on its "
                   f"executable, or {listing}")
        Exception.__init__(self, " ".join(f"{node}: {problem}".split()))
        self.node, self.problem, self.parameter = node, problem, next(iter(self.unknown), None)
        self.value = self.unknown.get(self.parameter)
        self.allowed = None


@dataclass(frozen=True)
class ParameterSpec:
    """One ROS parameter of a parameters dataclass, flattened (nested groups prefixed)."""

    name: str  # ROS name, e.g. "saliency.center_sigma"
    path: tuple  # attribute path in the dataclass, e.g. ("saliency", "center_sigma")
    kind: str  # "double" | "integer" | "bool" | "string"
    array: bool
    default: typing.Any  # as ROS takes it: float, int, bool, str or a list of those
    limits: Limits
    enum_type: type | None = None  # a str Enum the string value is turned into

    @property
    def description(self) -> str:
        return self.limits.description

    @property
    def ros_type(self) -> int:
        from rcl_interfaces.msg import ParameterType

        name = _SCALARS[self.kind][0]
        return getattr(ParameterType, f"{name}_ARRAY" if self.array else name)

    @property
    def choices(self) -> tuple | None:
        if self.enum_type is not None:
            return tuple(member.value for member in self.enum_type)
        return self.limits.choices


# ------------------------------------------------------------------------------------ dataclass -> specs
def parameter_specs(cls, prefix: str = "", path: tuple = ()) -> list[ParameterSpec]:
    """Every parameter of the dataclass `cls`, nested dataclass fields flattened into "<field>.<name>"."""
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"{cls!r} is not a dataclass")
    hints = typing.get_type_hints(cls)
    specs = []
    for field in dataclasses.fields(cls):
        annotation = hints[field.name]
        if dataclasses.is_dataclass(annotation):
            specs += parameter_specs(annotation, f"{prefix}{field.name}.", path + (field.name,))
            continue
        limits = field.metadata.get(_METADATA_KEY)
        if limits is NOT_ROS:
            continue
        if limits is None:
            raise TypeError(f"{cls.__name__}.{field.name}: declare it with param(default, description, ...)")
        specs.append(_spec(f"{prefix}{field.name}", path + (field.name,), annotation, field.default, limits))
    return specs


def _spec(name: str, path: tuple, annotation, default, limits: Limits) -> ParameterSpec:
    where = f"parameter {name}"
    enum_type = None
    array = typing.get_origin(annotation) in (tuple, list)
    if array:
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        if len(set(args)) != 1:
            raise TypeError(f"{where}: arrays are tuple[<one type>, ...], got {annotation}")
        element = args[0]
    else:
        element = annotation
    if isinstance(element, type) and issubclass(element, enum.Enum) and not array:
        if not issubclass(element, str):
            raise TypeError(f"{where}: only str enums can be parameters, got {element.__name__}")
        enum_type, element = element, str
    kind = next((k for k, (_, py_type, _) in _SCALARS.items() if element is py_type), None)
    if kind is None:
        raise TypeError(f"{where}: unsupported type {annotation}")
    if default is dataclasses.MISSING:
        raise TypeError(f"{where}: needs a default")
    if array:
        default = [_ros_scalar(kind, v) for v in default]
    else:
        default = _ros_scalar(kind, default.value if isinstance(default, enum.Enum) else default)
    return ParameterSpec(name, path, kind, array, default, limits, enum_type)


def _ros_scalar(kind: str, value):
    if kind == "double" and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


# ------------------------------------------------------------------------------------ descriptor
def allowed(spec: ParameterSpec) -> str:
    """What the parameter accepts, in words: "a double in [0.0005, 0.05]", "one of: arm, floating"."""
    limits = spec.limits
    if spec.choices is not None and not spec.array:
        return "one of: " + ", ".join(str(c) for c in spec.choices)
    if spec.kind == "bool" and not spec.array:
        return "true or false"
    if spec.array:
        count = f"{limits.length} " if limits.length is not None else ""
        text = f"a list of {count}{_PLURALS[spec.kind]}"
        bounds = _bounds_text(limits)
        return f"{text}, each {bounds}" if bounds else text
    text = _SCALARS[spec.kind][2]
    bounds = _bounds_text(limits)
    if bounds:
        text += f" {bounds}"
    if limits.step:
        text += f" in steps of {limits.step}"
    return text


def _bounds_text(limits: Limits) -> str:
    if limits.low is not None and limits.high is not None:
        return f"in [{limits.low}, {limits.high}]"
    if limits.low is not None:
        return f">= {limits.low}"
    if limits.high is not None:
        return f"<= {limits.high}"
    return ""


def descriptor(spec: ParameterSpec):
    """The read-only, typed ROS descriptor (rcl_interfaces ParameterDescriptor): description, the allowed
    values in words (additional_constraints) and, for scalar doubles and integers with bounds, the ROS
    range."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

    result = ParameterDescriptor(name=spec.name, type=spec.ros_type, description=spec.description,
                                 additional_constraints=allowed(spec), read_only=True)
    limits = spec.limits
    if spec.array or (limits.low is None and limits.high is None):
        return result
    if spec.kind == "double":
        result.floating_point_range = [FloatingPointRange(
            from_value=float(limits.low if limits.low is not None else -math.inf),
            to_value=float(limits.high if limits.high is not None else math.inf),
            step=float(limits.step or 0.0))]
    elif spec.kind == "integer":
        result.integer_range = [IntegerRange(
            from_value=int(limits.low if limits.low is not None else _INT64[0]),
            to_value=int(limits.high if limits.high is not None else _INT64[1]),
            step=int(limits.step or 1))]
    return result


# ------------------------------------------------------------------------------------ checking
def format_value(value) -> str:
    """A value as a user would write it after `-p name:=`: 0.002, 'abc', [0.5, 0.0], true."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, enum.Enum):
        value = value.value
    if isinstance(value, str):
        return repr(value)
    if _is_list(value):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return repr(value)


def _is_list(value) -> bool:
    return isinstance(value, list | tuple | array.array)


def _kind_of(value) -> str:
    """The ROS words for a value's type, e.g. "a string", "a list of integers"."""
    kind = _TYPE_WORDS.get(type(value))
    if kind is not None:
        return _SCALARS[kind][2]
    if _is_list(value):
        kinds = {_TYPE_WORDS.get(type(v)) for v in value}
        if len(kinds) == 1 and None not in kinds:
            return f"a list of {_PLURALS[kinds.pop()]}"
        return "a list"
    return f"a {type(value).__name__}"


def _is_kind(kind: str, value) -> bool:
    if kind == "double":
        return isinstance(value, float)
    if kind == "integer":
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, _SCALARS[kind][1])


def _in_bounds(limits: Limits, value) -> bool:
    tolerance = 1e-9 * max(1.0, abs(value))
    if limits.low is not None and value < limits.low - tolerance:
        return False
    return not (limits.high is not None and value > limits.high + tolerance)


def _in_range(limits: Limits, value) -> bool:
    """Within the bounds; a non-finite double is out of any bound (NaN compares with nothing)."""
    bounded = limits.low is not None or limits.high is not None
    if bounded and isinstance(value, float) and not math.isfinite(value):
        return False
    return _in_bounds(limits, value)


def check_value(spec: ParameterSpec, value) -> str | None:
    """None when `value` (as ROS gives it) is allowed, else what is wrong, e.g. "is out of range"."""
    limits = spec.limits
    if spec.array:
        if not _is_list(value) or not all(_is_kind(spec.kind, v) for v in value):
            return f"is {_kind_of(value)}"
        if limits.length is not None and len(value) != limits.length:
            return f"has {len(value)} element{'s' if len(value) != 1 else ''}"
        if spec.kind in ("double", "integer") and not all(_in_range(limits, v) for v in value):
            return "has an element out of range"
    else:
        if not _is_kind(spec.kind, value):
            hint = f" (write {float(value)} for a double)" if spec.kind == "double" and _is_kind(
                "integer", value) else ""
            return f"is {_kind_of(value)}{hint}"
        if spec.kind in ("double", "integer"):
            if not _in_range(limits, value):
                return "is out of range"
            if limits.step and limits.low is not None:
                steps = (value - limits.low) / limits.step
                if abs(steps - round(steps)) > 1e-6:
                    return "is not on a step"
        if spec.choices is not None and value not in spec.choices:
            return "is not one of the choices"
    if limits.check is not None:
        return limits.check(tuple(value) if spec.array else value)
    return None


def check_fields(instance) -> None:
    """Check the parameter fields of a parameters dataclass instance against their param() limits (type,
    range, step, choices, length, check), as a node's values are checked; call it first in __post_init__,
    which keeps only the rules between fields. InvalidParameter (a ValueError, one line naming the field,
    the value and what is allowed) for the first field that fails. A number of another numeric type than
    the field's (an int or numpy scalar for a double, a numpy integer for an integer) is checked as the
    field's type; nested parameters dataclasses check themselves when built, ros=False fields are skipped."""
    for spec in _field_specs(type(instance)):
        value = getattr(instance, spec.path[0])
        problem = check_value(spec, _as_ros(spec, value))
        if problem is not None:
            raise InvalidParameter(spec.name, problem, value, allowed(spec))


_FIELD_SPECS: dict[type, list[ParameterSpec]] = {}


def _field_specs(cls) -> list[ParameterSpec]:
    """The specs of `cls`'s own parameter fields (not those of nested groups), computed once per class."""
    specs = _FIELD_SPECS.get(cls)
    if specs is None:
        specs = _FIELD_SPECS[cls] = [spec for spec in parameter_specs(cls) if len(spec.path) == 1]
    return specs


def _as_ros(spec: ParameterSpec, value):
    """A field's Python value in the type ROS would give it (numbers to the field's kind, sequences such as
    tuples or numpy vectors as lists, str enum members as their values), for check_value; anything else
    unchanged (check_value names it)."""
    if spec.array and not isinstance(value, str) and hasattr(value, "__len__") and hasattr(value, "__iter__"):
        return [_as_ros_scalar(spec.kind, element) for element in value]
    if isinstance(value, enum.Enum) and spec.enum_type is not None:
        return value.value
    return _as_ros_scalar(spec.kind, value)


def _as_ros_scalar(kind: str, value):
    if isinstance(value, bool):
        return value
    if kind == "double" and isinstance(value, numbers.Real):
        return float(value)
    if kind == "integer" and isinstance(value, numbers.Integral):
        return int(value)
    return value


def error(node_name: str, spec: ParameterSpec, value, problem: str) -> ParameterError:
    return ParameterError(node_name, problem, spec.name, value, allowed(spec))


def build(node_name: str, cls, values: dict):
    """The dataclass instance for `values` ({ROS name: value as ROS gives it}); ParameterError (one
    line) for a value `check_value` refuses or a rule of the dataclass's __post_init__."""
    specs = parameter_specs(cls)
    for spec in specs:
        problem = check_value(spec, values[spec.name])
        if problem is not None:
            raise error(node_name, spec, values[spec.name], problem)
    return _construct(node_name, cls, {spec.path: _python_value(spec, values[spec.name]) for spec in specs},
                      specs, ())


def _python_value(spec: ParameterSpec, value):
    if spec.array:
        return tuple(value)
    if spec.enum_type is not None:
        return spec.enum_type(value)
    return value


def _construct(node_name: str, cls, values: dict, specs: list, path: tuple):
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for field in dataclasses.fields(cls):
        field_path = path + (field.name,)
        if field.metadata.get(_METADATA_KEY) is NOT_ROS:
            continue  # its default
        if dataclasses.is_dataclass(hints[field.name]):
            kwargs[field.name] = _construct(node_name, hints[field.name], values, specs, field_path)
        else:
            kwargs[field.name] = values[field_path]
    try:
        return cls(**kwargs)
    except InvalidParameter as rule:
        spec = next((s for s in specs if s.path == path + (rule.field,)), None)
        if spec is None:
            raise ParameterError(node_name, str(rule)) from None
        raise error(node_name, spec, values[spec.path], rule.problem) from None
    except ValueError as failure:
        raise ParameterError(node_name, str(failure)) from None


# ------------------------------------------------------------------------------------ unknown names
def ros_given(name: str) -> bool:
    """True for a name a node may be given without declaring it: ROS_PARAMETERS, a ROS_PARAMETER_PREFIXES
    name, or SHARED_PARAMETERS (given to every node by the calibration file's `/**` section)."""
    return name in ROS_PARAMETERS or name in SHARED_PARAMETERS or name.startswith(ROS_PARAMETER_PREFIXES)


def unknown_parameters(given: Iterable[str], declared: Iterable[str]) -> list[str]:
    """The names of `given` (the overrides a node was started with) that are neither `declared` nor
    ros_given, sorted: the ones a node refuses."""
    declared = set(declared)
    return sorted(name for name in set(given) if name not in declared and not ros_given(name))


def close_names(name: str, declared: Iterable[str], count: int = 3) -> list[str]:
    """Up to `count` names of `declared` closest to `name`, closest first (difflib.get_close_matches, its
    default cutoff 0.6); [] when none is close."""
    return difflib.get_close_matches(name, sorted(set(declared)), n=count)


def parameters_help(cls, width: int = 100) -> str:
    """The parameters of the dataclass `cls` for a --help text, in declaration order: the name, its
    default as `-p` takes it and what it allows, then the description wrapped to `width` columns:

          resolution:=0.002  (a double in [0.0005, 0.05])
              Heightmap cell size (m)
    """
    lines = []
    for spec in parameter_specs(cls):
        lines.append(f"  {spec.name}:={format_value(spec.default)}  ({allowed(spec)})")
        lines += textwrap.wrap(spec.description, width, initial_indent=" " * 6, subsequent_indent=" " * 6)
    return "\n".join(lines)


# ------------------------------------------------------------------------------------ the node side
def declare_parameters(node, cls):
    """Declare every parameter of the dataclass `cls` on `node` (read-only, typed, described, ranged),
    read the values (defaults, yaml, -p) back and return the `cls` instance. ParameterError (one line:
    node, parameter, value, what is allowed) for a value of the wrong type, out of range, not a choice,
    or refused by a check or by the dataclass's rules; UnknownParameter (a ParameterError: the names and the
    closest declared ones) for an override of a name the node has not declared by then, unless ros_given.
    Call it once per node, after any parameter the node declares itself with node.declare_parameter."""
    from rclpy.exceptions import ParameterException, ParameterUninitializedException
    from rclpy.parameter import Parameter

    values = {}
    for spec in parameter_specs(cls):
        # an empty list tells rclpy no element type: declare those by type, their value stays unset
        default = spec.default if spec.default != [] else Parameter.Type(spec.ros_type)
        try:
            node.declare_parameter(spec.name, default, descriptor(spec))
        except ParameterException as refused:  # rclpy: wrong type, or outside the descriptor's range
            value = _override(node, spec.name)
            raise error(node.get_name(), spec, value,
                        check_value(spec, value) or str(refused)) from None
        try:
            values[spec.name] = node.get_parameter(spec.name).value
        except ParameterUninitializedException:  # declared by type, not overridden
            values[spec.name] = spec.default
    _refuse_unknown(node)
    return build(node.get_name(), cls, values)


def _refuse_unknown(node) -> None:
    """UnknownParameter for the overrides (yaml, -p) the node started with whose names it has not declared.
    rclpy keeps them all in `_parameter_overrides` (see _override); with allow_undeclared_parameters
    False, the ones of undeclared names are never looked at again."""
    overrides = getattr(node, "_parameter_overrides", {})
    declared = node.list_parameters([], 0).names  # depth 0: every name (DEPTH_RECURSIVE)
    unknown = unknown_parameters(overrides, declared)
    if unknown:
        raise UnknownParameter(node.get_name(), {name: overrides[name].value for name in unknown}, declared,
                               node.get_fully_qualified_name())


def _override(node, name: str):
    """The value a yaml or -p gave `name` (what rclpy refused). rclpy keeps the overrides in this
    attribute (since Dashing) and has no public getter for them."""
    override = getattr(node, "_parameter_overrides", {}).get(name)
    return override.value if override is not None else None


# ------------------------------------------------------------------------------------ common checks
def increasing(values) -> str | None:
    """check= for [min, max] pairs (workspace bounds)."""
    if any(b <= a for a, b in zip(values, values[1:], strict=False)):
        return "is not increasing ([min, max] with min < max)"
    return None


def nonzero_norm(values) -> str | None:
    """check= for quaternions: they are normalised, but a zero (or non-finite) one has no rotation."""
    norm = math.sqrt(sum(v * v for v in values))
    return None if math.isfinite(norm) and norm > 1e-9 else "has no rotation (norm 0)"


def topic_names(values) -> str | None:
    """check= for lists of ROS topic names (relative or absolute): none empty, none with a blank."""
    bad = [v for v in values if not v or any(c.isspace() for c in v)]
    return f"has names that are not topic names: {', '.join(repr(v) for v in bad)}" if bad else None


def camera_position_param():
    """The camera pose's position, declared the same way by every node that reads the calibration file
    (bringup/config/camera_calibration.yaml): heightmap_node, cell_state_publisher, sim_cell."""
    return param(cell.CAMERA_POSITION, "Camera optical frame origin in base_link (m): [x, y, z] (from "
                 "hand-eye calibration)", length=3, low=-5.0, high=5.0)


def camera_orientation_param():
    """The camera pose's orientation (see camera_position_param)."""
    return param(cell.CAMERA_ORIENTATION, "Camera optical frame orientation in base_link: quaternion "
                 "[x, y, z, w]", length=4, check=nonzero_norm)


# ------------------------------------------------------------------ command-line overrides rcl cannot read
# YAML words rcl's parameter parser reads as booleans (rcl_yaml_param_parser); any other plain word that
# is a whole integer (C strtoll, base 0) is an integer, a whole number (strtod) a double, else a string.
_YAML_BOOLEANS = frozenset("y Y yes Yes YES true True TRUE on On ON "
                           "n N no No NO false False FALSE off Off OFF".split())
_KIND_WORDS = {"bool": "booleans", "integer": "integers", "double": "floats", "string": "strings"}


def _yaml_scalar_kind(text: str) -> str:
    """The type rcl gives one plain YAML scalar of a `-p` value: bool, integer, double or string."""
    if text[:1] in ("'", '"'):
        return "string"
    if text in _YAML_BOOLEANS:
        return "bool"
    try:
        if "_" not in text:  # Python reads 1_000 as a number, C does not
            int(text, 0)
            return "integer"
    except ValueError:
        pass
    try:
        if "_" not in text:
            float(text)
            return "double"
    except ValueError:
        pass
    return "string"


def override_problem(name: str, value: str) -> str | None:
    """Why rcl cannot read the command-line override `-p name:=value`, in words naming the parameter and
    the fix, or None when it can (as far as checked here: a flat YAML list whose elements are not all of
    one type, which rcl refuses with a traceback: "Sequence should be of same type"). E.g. ("camera_position",
    "[0.5,0.0,1]") -> "parameter camera_position:=[0.5,0.0,1] mixes integers and floats in one list, which
    ROS cannot read; write every number as a float: camera_position:=[0.5,0.0,1.0]"."""
    text = value.strip()
    if not (text.startswith("[") and text.endswith("]")) or any(c in text[1:-1] for c in "[]{}'\""):
        return None
    elements = [element.strip() for element in text[1:-1].split(",")]
    if elements == [""]:
        return None
    kinds = [_yaml_scalar_kind(element) for element in elements]
    if len(set(kinds)) < 2:
        return None
    if set(kinds) == {"integer", "double"}:
        fixed = [f"{float(int(e, 0))!r}" if kind == "integer" else e
                 for e, kind in zip(elements, kinds, strict=True)]
        return (f"parameter {name}:={text} mixes integers and floats in one list, which ROS cannot read; "
                f"write every number as a float: {name}:=[{','.join(fixed)}]")
    mixed = " and ".join(_KIND_WORDS[k] for k in sorted(set(kinds)))
    return (f"parameter {name}:={text} mixes {mixed} in one list, which ROS cannot read; write every element "
            "as one type (quote words: ['a','b'])")


def command_line_overrides(args: Sequence[str]) -> list[tuple[str, str]]:
    """(name, value) of each `-p NAME:=VALUE` / `--param NAME:=VALUE` in the ROS sections of `args`
    (`--ros-args` up to `--` or the end), in order."""
    args, overrides, in_ros = list(args), [], False
    for index, arg in enumerate(args):
        following = args[index + 1] if index + 1 < len(args) else ""
        if arg == "--ros-args":
            in_ros = True
        elif in_ros and arg == "--":
            in_ros = False
        elif in_ros and arg in ("-p", "--param") and ":=" in following:
            name, _, value = following.partition(":=")
            overrides.append((name, value))
    return overrides


def command_line_problem(args: Sequence[str]) -> str | None:
    """override_problem of the first `-p` override in `args` that rcl cannot read, or None."""
    for name, value in command_line_overrides(args):
        problem = override_problem(name, value)
        if problem is not None:
            return problem
    return None
