"""The Jazzy `main` idiom, written once for every node of the cell: spin_node. `-h`/`--help` among an
executable's own arguments prints its usage and parameters and exits 0 before rclpy starts (exit_if_help).
"""

import ctypes
import ctypes.util
import dataclasses
import pathlib
import signal
import sys
import textwrap
import threading
import typing
from collections.abc import Sequence

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from impurity_common.parameters import (
    PARAMETER_ERROR_EXIT_CODE,
    ParameterError,
    command_line_problem,
    parameter_specs,
    parameters_help,
)

MALLOC_ARENAS = 2  # glibc malloc arenas per node process (M_ARENA_MAX; glibc's default is 8 x cores)
_M_ARENA_MAX = -8  # mallopt parameter number (glibc malloc.h)


def bound_malloc_arenas(arenas: int = MALLOC_ARENAS) -> bool:
    """Cap glibc's malloc arenas, as MALLOC_ARENA_MAX=2 would. glibc gives threads that allocate at once
    arenas of their own; the executor and DDS threads that deserialise 0.5 MB heightmap messages at
    camera rate then fragment them, and a node's resident memory creeps up over hours. Measured with
    `python benchmarks/soak_graph.py --episodes 60`: episode_node grew 0.19 MB per episode (episodes
    10 -> 30) with glibc's default and 0.02 MB per episode with 2 arenas. Call before any thread starts;
    False (and nothing changed) where the C library is not glibc."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return bool(libc.mallopt(_M_ARENA_MAX, int(arenas)))
    except (OSError, AttributeError):
        return False


def init_with_stop_event(args=None, signals=(signal.SIGINT, signal.SIGTERM)) -> threading.Event:
    """rclpy.init without rclpy's signal handlers; instead each of `signals` only sets the returned event.
    For executables that spin in their own loop with bounded `spin_once(timeout)` (bag_recorder,
    bag_replay) and must finish their work (close a bag, wait for reliable readers) after Ctrl-C.

    Why not rclpy's handlers: they shut the context down from another thread and then raise
    KeyboardInterrupt in the main thread, in no fixed order; a spin_once that starts in between fails
    with RCLError ("the given context is not valid") and the KeyboardInterrupt then lands in the
    clean-up, so Ctrl-C ended the process by SIGINT instead of exit 0 (seen in CI on bag_replay)."""
    exit_if_unreadable_overrides(args)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for sig in signals:
        signal.signal(sig, lambda *_: stop.set())
    return stop


HELP_FLAGS = ("-h", "--help")


def own_arguments(args: Sequence[str]) -> list[str]:
    """The arguments of `args` outside its ROS sections (`--ros-args` up to `--` or the end), as
    rclpy.utilities.remove_ros_args keeps them, without rclpy: ["x", "--ros-args", "-p", "a:=1", "--",
    "y"] -> ["x", "y"]."""
    own, in_ros = [], False
    for arg in args:
        if arg == "--ros-args":
            in_ros = True
        elif in_ros and arg == "--":
            in_ros = False
        elif not in_ros:
            own.append(arg)
    return own


def wants_help(args: Sequence[str]) -> bool:
    """True when `-h` or `--help` is among the executable's own arguments (own_arguments); `-p name:=-h`
    or a file named --help after --ros-args is ROS's, not a request for help."""
    return any(arg in HELP_FLAGS for arg in own_arguments(args))


def usage(executable: str, description: str | None = None, parameters=None) -> str:
    """The --help text of a node executable: how to give parameters (`--ros-args -p NAME:=VALUE`, a
    parameter file) and, when `parameters` (the node's parameters dataclass) is given, each parameter
    with its default, what it allows and its description (parameters.parameters_help); without it,
    how to list them on the running node."""
    lines = [f"usage: {executable} [-h] [--ros-args [-p NAME:=VALUE]... [--params-file FILE]...]", ""]
    if description:
        lines += [*textwrap.wrap(description, 100), ""]
    lines += [
        "Parameters are read once, at start (they are read-only): `-p NAME:=VALUE` after --ros-args, the",
        "value as YAML (0.5, 3, true, text, [0.1, 0.2]), or a YAML parameter file (--params-file FILE, a",
        "section `<node name>:` or `/**:` holding `ros__parameters:`); a later one wins:",
        f"  {executable} --ros-args --params-file bringup/config/cell.yaml -p NAME:=VALUE",
        "A value the node cannot run with, or a name it does not declare, ends it with one line on stderr",
        f"and exit status {PARAMETER_ERROR_EXIT_CODE}. Other ROS arguments (-r FROM:=TO, --log-level LEVEL) "
        "as for any ROS node.",
        "",
    ]
    if parameters is not None:
        lines += ["parameters (NAME:=DEFAULT  (what it allows), then what it is):",
                  parameters_help(parameters)]
    else:
        lines += ["Its parameters, with defaults, bounds and descriptions, while it runs (`ros2 node list`",
                  "names the node): `ros2 param list /NODE` and `ros2 param describe /NODE NAME`."]
    return "\n".join(lines)


def exit_if_help(args: Sequence[str] | None = None, parameters=None, description: str | None = None,
                 executable: str | None = None) -> None:
    """When `args` (default sys.argv) asks for help (wants_help), print usage() to stdout and exit 0
    (SystemExit) before anything starts; else return. `executable` defaults to sys.argv[0]'s name.
    Call it first in a main() that does not use spin_node (spin_node calls it)."""
    args = sys.argv if args is None else args
    if wants_help(args):
        print(usage(executable or pathlib.Path(sys.argv[0]).name, description, parameters), flush=True)
        sys.exit(0)


def exit_if_unreadable_overrides(args: Sequence[str] | None = None, executable: str | None = None) -> None:
    """When a `-p NAME:=VALUE` of `args` (default sys.argv) is one rcl cannot read (a list mixing
    integers and floats, parameters.command_line_problem), print one line naming the executable (default
    sys.argv[0]'s name), the parameter and the fix to stderr and exit with PARAMETER_ERROR_EXIT_CODE
    before rclpy starts (rcl would end in a traceback); else return. spin_node and init_with_stop_event
    call it."""
    args = sys.argv if args is None else args
    problem = command_line_problem(args)
    if problem is not None:
        print(f"{executable or pathlib.Path(sys.argv[0]).name}: {problem}", file=sys.stderr, flush=True)
        sys.exit(PARAMETER_ERROR_EXIT_CODE)


def parameters_of(node_factory):
    """The parameters dataclass of a node class, found without building it: the one dataclass defined in
    the class's module whose fields are all parameters (parameters.param or nested groups) and which no
    other one there nests (e.g. attention_node's AttentionNodeParameters, not its SaliencyParameters).
    None when the module defines no such dataclass or more than one."""
    module = sys.modules.get(getattr(node_factory, "__module__", None) or "")
    if module is None:
        return None
    candidates = []
    for value in vars(module).values():
        if not (isinstance(value, type) and dataclasses.is_dataclass(value)
                and value.__module__ == module.__name__):
            continue
        try:
            if parameter_specs(value):
                candidates.append(value)
        except (TypeError, NameError):  # not a parameters dataclass
            continue
    nested = {hint for cls in candidates for hint in typing.get_type_hints(cls).values()}
    outermost = [cls for cls in candidates if cls not in nested]
    return outermost[0] if len(outermost) == 1 else None


def _description_of(node_factory) -> str | None:
    """The first paragraph (its summary) of the docstring of the module that defines `node_factory`."""
    module = sys.modules.get(getattr(node_factory, "__module__", None) or "")
    doc = (module.__doc__ or "").strip() if module is not None else ""
    return " ".join(doc.split("\n\n")[0].split()) or None


def spin_node(node_factory, args=None, executor_factory=None, *, parameters=None,
              description: str | None = None) -> None:
    """Init, build the node (and executor, e.g. MultiThreadedExecutor), spin until Ctrl-C or
    shutdown, then clean up. Factories run after rclpy.init, as executors need a context.

    `-h`/`--help` among the executable's own arguments (`args`, default sys.argv; not after --ros-args)
    prints the usage and exits 0 before rclpy starts, nothing built (exit_if_help). It lists the
    parameters of `parameters` (the node's parameters dataclass; default: parameters_of(node_factory))
    under `description` (default: the first line of node_factory's module docstring).

    A bad parameter or an unknown one (ParameterError from parameters.declare_parameters), or a `-p`
    override rcl cannot read (exit_if_unreadable_overrides), ends the process with its one line on stderr
    and exit status 2, no traceback. Malloc arenas are bounded first
    (bound_malloc_arenas), so memory stays flat over long runs."""
    if wants_help(sys.argv if args is None else args):
        exit_if_help(args, parameters or parameters_of(node_factory),
                     description or _description_of(node_factory))
    exit_if_unreadable_overrides(args)
    bound_malloc_arenas()
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = node_factory()
        if executor_factory is None:
            rclpy.spin(node)
        else:
            executor = executor_factory()
            executor.add_node(node)
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ParameterError as error:
        print(error, file=sys.stderr, flush=True)
        code = PARAMETER_ERROR_EXIT_CODE
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    if code:
        sys.exit(code)
