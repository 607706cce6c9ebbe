"""The Jazzy `main` idiom, written once for every node of the cell."""

import rclpy
from rclpy.executors import ExternalShutdownException


def spin_node(node_factory, args=None, executor=None) -> None:
    """Init, build the node, spin until Ctrl-C or shutdown, then clean up."""
    rclpy.init(args=args)
    node = None
    try:
        node = node_factory()
        if executor is None:
            rclpy.spin(node)
        else:
            executor.add_node(node)
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
