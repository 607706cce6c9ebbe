"""The Jazzy `main` idiom, written once for every node of the cell."""

import rclpy
from rclpy.executors import ExternalShutdownException


def spin_node(node_factory, args=None, executor_factory=None) -> None:
    """Init, build the node (and executor, e.g. MultiThreadedExecutor), spin until Ctrl-C or
    shutdown, then clean up. Factories run after rclpy.init, as executors need a context."""
    rclpy.init(args=args)
    node = None
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
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
