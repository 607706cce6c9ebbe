"""The checkout the cell runs from, where runs/ (episode records, logs) and docs/ (evaluation results) are."""

import os
import pathlib


def root() -> pathlib.Path:
    """IMPURITY_CELL_ROOT (scripts/env.sh sets it to the checkout), else the working directory."""
    return pathlib.Path(os.environ.get("IMPURITY_CELL_ROOT") or os.getcwd())
