"""bringup/config/cell.yaml as rcl reads it: the shared /** section reaches every node that declares
its parameters, and a `-p` override still beats the file (rcl lets a node's own section override
`-p` when a /** section comes before it in the file, so the shared section stays last)."""

import pathlib

import pytest
import rclpy

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONFIG = ROOT / "bringup" / "config" / "cell.yaml"


def parameter_as_read(node_name: str, name: str, default, *overrides: str):
    """The value node `node_name` gets for `name` with cell.yaml and the `-p` overrides given."""
    context = rclpy.Context()
    args = ["test", "--ros-args", "--params-file", str(CONFIG)]
    for override in overrides:
        args += ["-p", override]
    rclpy.init(args=args, context=context)
    try:
        node = rclpy.create_node(node_name, context=context)
        try:
            return node.declare_parameter(name, default).value
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


@pytest.mark.parametrize("node_name", ["heightmap", "sim_cell"])
def test_the_camera_pose_comes_from_the_shared_section(node_name):
    assert list(parameter_as_read(node_name, "camera_position", [0.0, 0.0, 0.0])) == [0.5, 0.0, 0.75]


def test_a_command_line_override_beats_the_file():
    assert parameter_as_read("policy", "max_age", 1.0) == 5.0  # the file's value
    assert parameter_as_read("policy", "max_age", 1.0, "max_age:=1000000000.0") == 1e9
