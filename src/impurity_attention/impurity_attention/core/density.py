"""Density-based occluded-region inference (paper section 5.1.2): DBSCAN on the occupied cells of the
height map; the largest dense cluster is where a hidden impurity most likely lies.

Points are the heightmap cells standing higher than `occupied_height` above the table, taken on a
coarser sub-grid (`stride`) so that DBSCAN sees at most (224 / stride)^2 points, in metres (x, y).
A core point needs `min_samples` occupied points within `eps`:
with eps = 15 mm on a 6 mm sub-grid (21 grid points in reach) that is ~60 % of its neighbourhood
filled, i.e. objects packed close together; sparse, scattered objects are noise and form no cluster.
Measured on rendered tuning scenes: the same choices as a 4 mm grid with
eps = 12 mm, in half the time (~6 ms).

"No hidden target can remain" (paper Fig. 5): a cluster whose height (the `height_percentile` of
its cells, robust to a single spike) is below `min_cluster_height` is one layer of objects with
nothing underneath, and one whose area is below `min_cluster_area` is too small to hide an object.
`min_cluster_height` is 4 cm, above the tallest single object of the simulated scenes (the heaps' bars and
pillars stand 3.2-3.6 cm), chosen by how episodes counted by perception end on tuning palettes
(`python -m impurity_learning.calibrate episode-end`: attention's NONE with no impurity left in 86.7 % of
30 episodes at 4 cm, 33.3 % at 3 cm). On a real cell: the height of the tallest single product piece plus
a margin. Among the clusters that pass both tests the one of the largest volume (the sum of its cells'
heights) is chosen: hiding a target takes material on top of it (on rendered tuning scenes it held a hidden
target in 17/18 invisible scenes, the largest area in 14/18); when none passes, there is no occluded region
to explore.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.cluster import DBSCAN

from impurity_common import cell
from impurity_common.parameters import check_fields, param


@dataclass(frozen=True)
class DensityParams:
    """DBSCAN's occluded-region search (ROS parameters density.*)."""

    occupied_height: float = param(cell.OCCUPIED_HEIGHT, "Cells higher than this above the table are "
                                   "objects, for saliency and DBSCAN alike (m)", low=0.0, high=0.5)
    stride: int = param(3, "Sub-grid step of the DBSCAN points (cells)", low=1, high=32)
    eps: float = param(0.015, "DBSCAN neighbourhood radius (m)", low=0.001, high=0.5)
    min_samples: int = param(12, "DBSCAN points within eps (itself included) that make a core point",
                             low=1, high=10000)
    min_cluster_height: float = param(0.04, "Lower clusters cannot hide a target (m): the tallest single "
                                      "product piece plus a margin", low=0.0, high=1.0)
    min_cluster_area: float = param(0.0025, "Smaller clusters cannot hide a target (m^2)", low=0.0, high=1.0)
    height_percentile: float = param(90.0, "A cluster's height is this percentile of its cells' heights (%)",
                                     low=0.0, high=100.0)

    def __post_init__(self):
        check_fields(self)


@dataclass
class Cluster:
    label: int  # DBSCAN label
    label_map: np.ndarray  # (rows, cols) int32: DBSCAN label of every cell, -1 = noise / not occupied
    area: float  # m^2
    height: float  # m, `height_percentile` of the cells' heights
    volume: float  # m^3
    centroid: tuple  # (row, col) float, heightmap pixels
    score: float
    passes: bool  # tall and large enough to hide a target

    @property
    def mask(self) -> np.ndarray:
        """(rows, cols) bool: the cluster's cells."""
        return self.label_map == self.label


def find_clusters(height: np.ndarray, resolution: float, params: DensityParams = DensityParams()) -> list:
    """DBSCAN clusters of the occupied cells, best first (passing clusters before failing ones)."""
    stride = params.stride
    sub = height[::stride, ::stride]
    occupied = np.isfinite(sub) & (sub > params.occupied_height)
    if np.count_nonzero(occupied) < params.min_samples:
        return []
    sub_rows, sub_cols = np.nonzero(occupied)
    spacing = stride * resolution
    points = np.column_stack([sub_rows * spacing, sub_cols * spacing])
    # ball_tree: the fastest of sklearn's neighbour searches on these few thousand grid points
    labels = DBSCAN(eps=params.eps, min_samples=params.min_samples, algorithm="ball_tree").fit_predict(points)

    # Each sub-grid point stands for a stride x stride block of cells; a cluster's full-resolution
    # mask is the union of its blocks, restricted to occupied cells.
    occupied_full = np.isfinite(height) & (height > params.occupied_height)
    label_sub = np.full(sub.shape, -1, dtype=np.int32)
    label_sub[sub_rows, sub_cols] = labels
    row_of = np.arange(height.shape[0])[:, None] // stride
    col_of = np.arange(height.shape[1])[None, :] // stride
    label_full = label_sub[row_of, col_of]
    label_full = np.where(occupied_full, label_full, -1).astype(np.int32)

    cell_area = resolution * resolution
    cells = np.flatnonzero(label_full >= 0)
    cell_labels = label_full.reshape(-1)[cells]
    order = np.argsort(cell_labels, kind="stable")
    cells, cell_labels = cells[order], cell_labels[order]
    cell_heights = height.reshape(-1)[cells]
    starts = np.flatnonzero(np.r_[True, cell_labels[1:] != cell_labels[:-1]]) if cells.size else []
    ends = np.r_[starts[1:], cells.size] if cells.size else []
    clusters = []
    for start, end in zip(starts, ends, strict=True):
        heights = cell_heights[start:end]
        rows, cols = np.divmod(cells[start:end], height.shape[1])
        area = (end - start) * cell_area
        cluster_height = float(np.percentile(heights, params.height_percentile))
        volume = float(heights.sum()) * cell_area
        clusters.append(Cluster(
            label=int(cell_labels[start]), label_map=label_full, area=area, height=cluster_height,
            volume=volume, centroid=(float(rows.mean()), float(cols.mean())),
            score=volume,
            passes=cluster_height >= params.min_cluster_height and area >= params.min_cluster_area))
    clusters.sort(key=lambda c: (c.passes, c.score), reverse=True)
    return clusters


def select_occluded_region(clusters: list) -> Cluster | None:
    """The cluster to explore: the best one that could hide a target, or None (nothing can remain)."""
    return clusters[0] if clusters and clusters[0].passes else None
