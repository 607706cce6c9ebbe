"""Checkpoints of the push-grasp network: reading and checking them (format version, network config,
every tensor's shape), and the network the policy node runs. Writing them is the trainer's job
(impurity_learning.trainer), with the same format version.

Errors: CheckpointError, whose message says which file and why (missing, unreadable, another format
version, another network).
"""

from __future__ import annotations

import pathlib

from impurity_common.weights_file import check_tensors, read_versioned

from .network import NetworkConfig, QNetwork, resolve_device

CHECKPOINT_FORMAT_VERSION = 1
# The shipped network in the source tree (a ROS install also has it in the package's share dir:
# policy_node.default_checkpoint).
SHIPPED_CHECKPOINT = pathlib.Path(__file__).resolve().parents[2] / "checkpoints" / "policy.pt"


class CheckpointError(RuntimeError):
    """A checkpoint that this code cannot use; the message says why."""


def read_checkpoint(path, expected: NetworkConfig | None = None) -> dict:
    """Load and check a checkpoint: format version, network config and every tensor's shape."""
    data = read_versioned(path, "checkpoint", CHECKPOINT_FORMAT_VERSION, CheckpointError, weights_only=False)
    try:
        stored = NetworkConfig.from_dict(data["network_config"])
    except (KeyError, TypeError) as error:
        raise CheckpointError(f"checkpoint {path} has an unreadable network_config: {error}") from error
    if expected is not None and stored != expected:
        raise CheckpointError(f"checkpoint {path} was made for network {stored}, expected {expected}")
    check_tensors(data.get("online", {}), QNetwork(stored).state_dict(), f"checkpoint {path}", "the network",
                  CheckpointError)
    return data


def load_network(path, expected: NetworkConfig | None = None, device: str = "cpu") -> QNetwork:
    """The online network of a checkpoint, in eval mode, on `device` (network.resolve_device): what the
    policy node runs. CheckpointError as read_checkpoint; ValueError for an unusable device."""
    data = read_checkpoint(path, expected)
    net = QNetwork(NetworkConfig.from_dict(data["network_config"]))
    net.load_state_dict(data["online"])
    return net.to(resolve_device(device)).eval()
