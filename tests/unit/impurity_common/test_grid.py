"""The heightmap grid as a Heightmap message describes it (resolution, origin, image size)."""

import math

import pytest

from impurity_common.grid import HeightmapGrid


def test_a_grid_from_its_origin_covers_rows_by_cols_cells():
    grid = HeightmapGrid.from_origin(0.002, 0.276, -0.224, 0.0, rows=224, cols=224)
    assert grid.shape == (224, 224)
    assert grid.x_max == pytest.approx(0.724) and grid.y_max == pytest.approx(0.224)
    assert grid.contains(0.5, 0.0) and not grid.contains(0.74, 0.0)


@pytest.mark.parametrize("resolution,rows,cols", [(0.0, 224, 224), (-0.002, 224, 224), (math.nan, 224, 224),
                                                  (math.inf, 224, 224), (0.002, 0, 224), (0.002, 224, 0)])
def test_a_grid_that_cannot_exist_is_refused_naming_its_resolution_and_size(resolution, rows, cols):
    with pytest.raises(ValueError, match=f"got {resolution} m, {rows} x {cols} px"):
        HeightmapGrid.from_origin(resolution, 0.276, -0.224, 0.0, rows, cols)
