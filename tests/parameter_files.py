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
