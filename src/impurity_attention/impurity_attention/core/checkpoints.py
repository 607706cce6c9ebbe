"""Where the shipped model files are: src/impurity_attention/checkpoints/ in the source tree, installed by
setup.py into the package's share dir (share/impurity_attention/checkpoints/)."""

from __future__ import annotations

import pathlib

SOURCE_CHECKPOINTS = pathlib.Path(__file__).resolve().parents[2] / "checkpoints"


def shipped_path(name: str) -> pathlib.Path:
    """The shipped file `name` (e.g. "verifier.json"): the package's share dir (a ROS install) when it has it,
    else the source tree's SOURCE_CHECKPOINTS / name."""
    try:
        from ament_index_python.packages import get_package_share_directory

        installed = pathlib.Path(get_package_share_directory("impurity_attention")) / "checkpoints" / name
        if installed.is_file():
            return installed
    except Exception:  # noqa: BLE001 - no ament index or no such package: the source tree
        pass
    return SOURCE_CHECKPOINTS / name
