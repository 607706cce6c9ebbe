"""The Jazzy `main` idiom, written once for every node of the cell."""

import ctypes
import ctypes.util
import sys

import rclpy
from rclpy.executors import ExternalShutdownException

from impurity_common.parameters import PARAMETER_ERROR_EXIT_CODE, ParameterError

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


def spin_node(node_factory, args=None, executor_factory=None) -> None:
    """Init, build the node (and executor, e.g. MultiThreadedExecutor), spin until Ctrl-C or
    shutdown, then clean up. Factories run after rclpy.init, as executors need a context.

    A bad parameter (ParameterError from parameters.declare_parameters) ends the process with its one
    line on stderr and exit status 2, no traceback. Malloc arenas are bounded first
    (bound_malloc_arenas), so memory stays flat over long runs."""
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
