"""Synthetic RGB-D frames of boxes on a table, seen by the cell's overhead camera.

For unit tests and benchmarks that must not depend on the simulator: a box is an axis-aligned
footprint with a height and a colour; every pixel sees the highest box top its ray meets (side faces
are ignored, which is exact for a camera looking straight down at the box centres' heights).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impurity_common import cell
from impurity_common.grid import HeightmapGrid

from .heightmap import default_camera_pose, default_intrinsics, pose_matrix

TABLE_COLOR = (150, 150, 150)
PRODUCT_COLOR = (40, 120, 200)
IMPURITY_COLOR = (220, 60, 40)


@dataclass(frozen=True)
class Box:
    x: float  # centre, base_link (m)
    y: float
    size_x: float
    size_y: float
    height: float  # top above the table (m)
    color: tuple
    label: int


@dataclass
class Frame:
    color: np.ndarray  # (H, W, 3) uint8 RGB
    depth: np.ndarray  # (H, W) float32 m along the optical axis
    labels: np.ndarray  # (H, W) int32 box label, 0 = table
    intrinsics: np.ndarray
    camera_pose: np.ndarray


def render_boxes(boxes, width: int = cell.CAMERA_WIDTH, height: int = cell.CAMERA_HEIGHT,
                 intrinsics=None, camera_pose=None, table_color=TABLE_COLOR) -> Frame:
    k = default_intrinsics() if intrinsics is None else np.asarray(intrinsics, dtype=np.float64)
    pose = default_camera_pose() if camera_pose is None else np.asarray(camera_pose, dtype=np.float64)
    cols, rows = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    rays = pose[:3, :3] @ np.stack([(cols - k[0, 2]) / k[0, 0], (rows - k[1, 2]) / k[1, 1],
                                    np.ones_like(cols)]).reshape(3, -1)
    origin = pose[:3, 3]
    if abs(rays[2]).min() < 1e-6:
        raise ValueError("a camera ray is parallel to the table")
    surface_z = np.full(width * height, cell.TABLE_Z)
    labels = np.zeros(width * height, dtype=np.int32)
    colors = np.tile(np.array(table_color, dtype=np.uint8), (width * height, 1))
    for box in sorted(boxes, key=lambda b: b.height):  # highest last: it wins where it is hit
        top = cell.TABLE_Z + box.height
        t = (top - origin[2]) / rays[2]
        hit_x, hit_y = origin[0] + t * rays[0], origin[1] + t * rays[1]
        hit = ((np.abs(hit_x - box.x) <= box.size_x / 2) & (np.abs(hit_y - box.y) <= box.size_y / 2)
               & (t > 0))
        surface_z[hit] = top
        labels[hit] = box.label
        colors[hit] = box.color
    t_surface = (surface_z - origin[2]) / rays[2]
    # depth along the optical axis = the camera-frame z of the hit point
    depth = t_surface * (pose[:3, 2] @ rays)
    return Frame(color=colors.reshape(height, width, 3),
                 depth=depth.reshape(height, width).astype(np.float32), labels=labels.reshape(height, width),
                 intrinsics=k, camera_pose=pose)


def random_boxes(seed: int, num_product: int = 20, num_impurities: int = 1, size: float = 0.03,
                 heap: bool = False, product_color=PRODUCT_COLOR, impurity_color=IMPURITY_COLOR) -> list:
    """Product boxes of one colour and impurity boxes of another, scattered (or heaped) in the
    workspace; labels 1..n, impurities last. Seeded."""
    rng = np.random.default_rng(seed)
    (x0, x1), (y0, y1) = cell.WORKSPACE_X, cell.WORKSPACE_Y
    margin = 0.04
    boxes = []
    centre = rng.uniform([x0 + 0.12, y0 + 0.12], [x1 - 0.12, y1 - 0.12])
    for i in range(num_product + num_impurities):
        is_impurity = i >= num_product
        if heap:
            x, y = centre + rng.normal(0.0, 0.04, 2)
            h = size * (1 + rng.integers(0, 3))
        else:
            x, y = rng.uniform(x0 + margin, x1 - margin), rng.uniform(y0 + margin, y1 - margin)
            h = size
        boxes.append(Box(float(x), float(y), size, size, float(h),
                         impurity_color if is_impurity else product_color, i + 1))
    return boxes


def overhead_camera(distance: float = cell.CAMERA_POSITION[2] - cell.TABLE_Z, width: int = cell.CAMERA_WIDTH,
                    height: int = cell.CAMERA_HEIGHT, fx: float | None = None,
                    centre: tuple = cell.CAMERA_POSITION[:2]) -> tuple:
    """(intrinsics, camera_pose) of a camera `distance` m above the table looking straight down at
    `centre` (x, y), image x along +x_base as the cell's camera; `fx` (= fy, px) defaults to the cell
    camera's field of view at this width. Pass both to render_boxes."""
    focal = cell.CAMERA_FX * width / cell.CAMERA_WIDTH if fx is None else float(fx)
    intrinsics = np.array([[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0],
                           [0.0, 0.0, 1.0]])
    pose = pose_matrix((centre[0], centre[1], cell.TABLE_Z + distance), cell.CAMERA_ORIENTATION)
    return intrinsics, pose


def footprint_labels(boxes, grid: HeightmapGrid = HeightmapGrid()) -> np.ndarray:
    """(rows, cols) int32 ground truth on `grid`: the label of the highest box whose footprint holds
    the cell's centre, 0 (table) elsewhere - what a perfect heightmap would show."""
    rows, cols = grid.shape
    x = grid.x_min + (np.arange(cols) + 0.5) * grid.resolution
    y = grid.y_min + (np.arange(rows) + 0.5) * grid.resolution
    labels = np.zeros((rows, cols), dtype=np.int32)
    for box in sorted(boxes, key=lambda b: b.height):  # highest last: it is what a camera sees
        inside = ((np.abs(y - box.y) <= box.size_y / 2)[:, None]
                  & (np.abs(x - box.x) <= box.size_x / 2)[None, :])
        labels[inside] = box.label
    return labels
