"""Files of network weights (written with torch.save), read with checks whose errors say which file and why:
missing, unreadable, another format version, tensors that do not fit the network. One place for the policy's
checkpoints (impurity_policy.core.checkpoint) and attention's impurity network
(impurity_attention.core.impurity_net): each passes its own error class and its words for the file and the
network. torch is imported only when a file is read, so importing this module costs nothing.
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping


def read_versioned(path, what: str, version: int, error: type[Exception], *,
                   weights_only: bool = True) -> dict:
    """The dict torch.save stored in `path` (on the CPU), checked to carry `format_version` == `version`.

    `what` names the file in messages ("checkpoint", "impurity network"). Raises `error` with
    "<what> <path> does not exist", "... cannot be read: <why>", "... has no format_version (not a <what>
    file)" or "... has format version V, this code reads version N". `weights_only` as torch.load's
    (True: tensors and plain containers only)."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise error(f"{what} {path} does not exist")
    import torch  # here, not at import: this module is imported where torch may be absent

    try:
        data = torch.load(path, map_location="cpu", weights_only=weights_only)
    except Exception as reason:  # noqa: BLE001 - any unreadable file gets the same clear message
        raise error(f"{what} {path} cannot be read: {reason}") from reason
    if not isinstance(data, dict) or "format_version" not in data:
        raise error(f"{what} {path} has no format_version (not a {what} file)")
    if data["format_version"] != version:
        raise error(f"{what} {path} has format version {data['format_version']}, this code reads version "
                    f"{version}")
    return data


def check_tensors(weights: Mapping, reference: Mapping, where: str, network: str,
                  error: type[Exception]) -> None:
    """Raise `error` unless `weights` (name -> tensor) holds exactly the names of `reference` (a network's
    state_dict) with the same shapes: "<where> does not match <network>: missing [...], unexpected [...]"
    (at most five of each) or "<where>: tensor 'name' has shape (...), <network> needs (...)"."""
    missing = sorted(set(reference) - set(weights))
    unexpected = sorted(set(weights) - set(reference))
    if missing or unexpected:
        raise error(f"{where} does not match {network}: missing {missing[:5]}, unexpected {unexpected[:5]}")
    for name, tensor in reference.items():
        if tuple(weights[name].shape) != tuple(tensor.shape):
            raise error(f"{where}: tensor '{name}' has shape {tuple(weights[name].shape)}, {network} needs "
                        f"{tuple(tensor.shape)}")
