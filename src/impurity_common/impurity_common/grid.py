"""The heightmap grid: which base_link rectangle a heightmap covers and at what resolution, in one
place. The heightmap node builds its maps on it, the Heightmap message carries it (resolution and
origin; the size is the images'), and every consumer rebuilds it from the message
(`HeightmapGrid.from_origin`, or conversions.grid_from_heightmap) instead of assuming the defaults.

Pixel (row, col) covers x = x_min + (col + 0.5) * resolution, y = y_min + (row + 0.5) * resolution
(base_link, m); heights are measured from table_z. Defaults: cell.WORKSPACE_X/Y at
cell.HEIGHTMAP_RESOLUTION (224 x 224 px of 2 mm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import cell

MAX_HEIGHT = 0.30  # m above the table; higher points (gripper, arm, noise) are not scene content


@dataclass(frozen=True)
class HeightmapGrid:
    """The workspace grid: pixel (row, col) covers x = x_min + (col + 0.5) * resolution,
    y = y_min + (row + 0.5) * resolution (base_link); heights are measured from table_z."""

    x_min: float = cell.WORKSPACE_X[0]
    x_max: float = cell.WORKSPACE_X[1]
    y_min: float = cell.WORKSPACE_Y[0]
    y_max: float = cell.WORKSPACE_Y[1]
    resolution: float = cell.HEIGHTMAP_RESOLUTION
    table_z: float = cell.TABLE_Z
    max_height: float = MAX_HEIGHT

    def __post_init__(self):
        if not (self.resolution > 0 and self.x_max > self.x_min and self.y_max > self.y_min):
            raise ValueError(f"degenerate heightmap grid {self}")

    @property
    def rows(self) -> int:
        return int(round((self.y_max - self.y_min) / self.resolution))

    @property
    def cols(self) -> int:
        return int(round((self.x_max - self.x_min) / self.resolution))

    @property
    def shape(self) -> tuple:
        return self.rows, self.cols

    def pixel_to_base(self, row: float, col: float) -> tuple:
        return cell.pixel_to_base(row, col, self.resolution, self.x_min, self.y_min)

    def base_to_pixel(self, x: float, y: float) -> tuple:
        return cell.base_to_pixel(x, y, self.resolution, self.x_min, self.y_min)

    @classmethod
    def from_origin(cls, resolution: float, x_min: float, y_min: float, table_z: float, rows: int,
                    cols: int, max_height: float = MAX_HEIGHT) -> HeightmapGrid:
        """The grid of a heightmap whose pixel (0, 0) has its corner at (x_min, y_min) and which has
        rows x cols pixels of `resolution` m (what a Heightmap message carries). ValueError when
        degenerate (resolution <= 0 or not finite, no pixels)."""
        if not (math.isfinite(resolution) and resolution > 0 and rows > 0 and cols > 0):
            raise ValueError(f"heightmap grid needs a finite resolution > 0 m and a non-empty size, got "
                             f"{resolution} m, {rows} x {cols} px")
        return cls(x_min=x_min, x_max=x_min + cols * resolution, y_min=y_min, y_max=y_min + rows * resolution,
                   resolution=resolution, table_z=table_z, max_height=max_height)

    def contains(self, x: float, y: float) -> bool:
        """(x, y) in base_link lies on the grid (the workspace)."""
        return self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max
