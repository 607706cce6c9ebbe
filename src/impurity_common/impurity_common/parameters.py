"""Parameter descriptors for the cell's nodes, written once."""

from rcl_interfaces.msg import ParameterDescriptor


def describe(text: str) -> ParameterDescriptor:
    """Read-only: every node reads its parameters once at start-up and never re-reads them."""
    return ParameterDescriptor(description=text, read_only=True)
