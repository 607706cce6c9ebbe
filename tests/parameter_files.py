"""Reading a ROS parameter file's sections in tests."""


def flatten(section: dict, prefix: str = "") -> dict:
    """{"a": {"b": 1}, "c": 2} -> {"a.b": 1, "c": 2}: a node's ros__parameters as its parameter names
    (nested groups joined by "."), as rclpy declares them."""
    flat = {}
    for key, value in section.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


def as_declared(context, node_name: str, ros_args: list[str], defaults: dict) -> dict:
    """{name: value} that a node `node_name` started with `ros_args` ("--ros-args", "--params-file",
    path, ..., "-p", "name:=value") gets when it declares each name with its default: rcl's own reading of
    parameter files and overrides, with the same precedence a started node has.

    The node lives in `context` (the session's one rclpy context) and takes only its own arguments
    (`use_global_arguments=False`), so reading a file costs no new DDS participant: a participant per
    read, created and torn down ~50 times beside graph tests that kill nodes, once hung CI inside DDS.
    """
    import rclpy

    node = rclpy.create_node(node_name, context=context, cli_args=ros_args,
                             use_global_arguments=False, start_parameter_services=False,
                             enable_rosout=False)
    try:
        return {name: node.declare_parameter(name, default).value for name, default in defaults.items()}
    finally:
        node.destroy_node()
