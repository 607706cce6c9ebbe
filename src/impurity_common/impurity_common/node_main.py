"""The Jazzy `main` idiom, written once for every node of the cell."""

import sys

import rclpy
from rclpy.executors import ExternalShutdownException

from impurity_common.parameters import PARAMETER_ERROR_EXIT_CODE, ParameterError


def spin_node(node_factory, args=None, executor_factory=None) -> None:
    """Init, build the node (and executor, e.g. MultiThreadedExecutor), spin until Ctrl-C or
    shutdown, then clean up. Factories run after rclpy.init, as executors need a context.

    A bad parameter (ParameterError from parameters.declare_parameters) ends the process with its one
    line on stderr and exit status 2, no traceback."""
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
