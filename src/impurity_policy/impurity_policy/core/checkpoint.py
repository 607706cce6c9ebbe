"""Checkpoints of the push-grasp network: reading and checking them (format version, network config,
every tensor's shape), and the network the policy node runs. Writing them is the trainer's job
(impurity_learning.trainer), with the same format version.

Errors: CheckpointError, whose message says which file and why (missing, unreadable, another format
version, another network).
"""

from __future__ import annotations

import pathlib

import torch

from .network import NetworkConfig, QNetwork, resolve_device

CHECKPOINT_FORMAT_VERSION = 1
# The shipped network in the source tree (a ROS install also has it in the package's share dir:
# policy_node.default_checkpoint).
SHIPPED_CHECKPOINT = pathlib.Path(__file__).resolve().parents[2] / "checkpoints" / "policy.pt"


class CheckpointError(RuntimeError):
    """A checkpoint that this code cannot use; the message says why."""


def read_checkpoint(path, expected: NetworkConfig | None = None) -> dict:
    """Load and check a checkpoint: format version, network config and every tensor's shape."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint {path} does not exist")
    try:
        data = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as error:  # noqa: BLE001 - any unreadable file gets the same clear message
        raise CheckpointError(f"checkpoint {path} cannot be read: {error}") from error
    if not isinstance(data, dict) or "format_version" not in data:
        raise CheckpointError(f"checkpoint {path} is not an impurity_policy checkpoint (no format_version)")
    if data["format_version"] != CHECKPOINT_FORMAT_VERSION:
        raise CheckpointError(f"checkpoint {path} has format version {data['format_version']}, this code "
                              f"reads version {CHECKPOINT_FORMAT_VERSION}")
    try:
        stored = NetworkConfig.from_dict(data["network_config"])
    except (KeyError, TypeError) as error:
        raise CheckpointError(f"checkpoint {path} has an unreadable network_config: {error}") from error
    if expected is not None and stored != expected:
        raise CheckpointError(f"checkpoint {path} was made for network {stored}, expected {expected}")
    reference = QNetwork(stored).state_dict()
    weights = data.get("online", {})
    missing = sorted(set(reference) - set(weights))
    unexpected = sorted(set(weights) - set(reference))
    if missing or unexpected:
        raise CheckpointError(f"checkpoint {path} does not match the network: missing {missing[:5]}, "
                              f"unexpected {unexpected[:5]}")
    for name, tensor in reference.items():
        if tuple(weights[name].shape) != tuple(tensor.shape):
            raise CheckpointError(f"checkpoint {path}: tensor '{name}' has shape "
                                  f"{tuple(weights[name].shape)}, the network needs {tuple(tensor.shape)}")
    return data


def load_network(path, expected: NetworkConfig | None = None, device: str = "cpu") -> QNetwork:
    """The online network of a checkpoint, in eval mode, on `device` (network.resolve_device): what the
    policy node runs. CheckpointError as read_checkpoint; ValueError for an unusable device."""
    data = read_checkpoint(path, expected)
    net = QNetwork(NetworkConfig.from_dict(data["network_config"]))
    net.load_state_dict(data["online"])
    return net.to(resolve_device(device)).eval()
