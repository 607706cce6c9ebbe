"""Action pixel <-> gripper pose: crop pixel + rotation index -> heightmap pixel -> base_link (x, y, z, yaw).

yaw = rotation_yaw(i) is the push direction or the grasp's finger-closing axis (Primitive.msg); the
network rotates its input so that this direction is +column (network.rotation_grid), and since
(col, row) maps to (x, y) without mirroring (cell.pixel_to_base), image and base yaw agree.

Heights follow VPG's rules, adapted to our gripper frame (TCP = fingertips' lower ends,
ur5_driver_sim config): a grasp puts the fingertips `grasp_depth` below the highest point near the
pixel, never lower than `grasp_min_tip` above the table; a push starts with the closed fingertips
`push_depth` below the local top, never lower than `push_min_tip` (the driver's guarded descent stops
on anything in the way).

Grasp clearance: the grasp's guarded descent stops as soon as the gripper touches anything, so a grasp
whose open fingers would land on a neighbour, or whose palm would meet a tall pile beside the object,
closes above the object it was meant for. A grasp counts as clear when the fingertips can get at least
`finger_overlap` below the local top at its pixel: the heightmap under both pads (cell.GRASP_OPENING
apart, cell.FINGER_THICKNESS by cell.FINGER_WIDTH) lies that low, and under the palm
(cell.PALM_HALF_EXTENTS, cell.FINGER_LENGTH above the tips) no higher than the fingers are long.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from impurity_common import cell
from impurity_common.grid import HeightmapGrid
from impurity_common.parameters import check_fields, param

from .network import GRASP, PUSH


@dataclass(frozen=True)
class PoseRules:
    """How deep pushes and grasps go (module docstring); the policy node's parameters of the same names."""

    grasp_depth: float = param(0.03, "Grasp fingertips below the local top (m; VPG's grasp depth)",
                               low=0.0, high=0.2)
    grasp_min_tip: float = param(0.005, "Lowest grasp fingertip height above the table (m): low, rounded "
                                 "blocks slip from fingers closed higher", low=0.0, high=0.2)
    push_depth: float = param(0.02, "Push fingertips below the local top at the start pixel (m)",
                              low=0.0, high=0.2)
    push_min_tip: float = param(0.01, "Lowest push fingertip height above the table (m)", low=0.0, high=0.2)
    local_radius_px: int = param(3, "Heightmap px around a pixel whose highest point is its local top (a "
                                 "(2r+1)^2 window)", low=0, high=20)
    finger_overlap: float = param(0.015, "finger_clearance: the pads must reach this far below the local top "
                                  "at the grasp pixel (m)", low=0.0, high=0.1)

    def __post_init__(self):
        check_fields(self)


@dataclass(frozen=True)
class ActionPose:
    primitive: int
    rotation: int
    heightmap_pixel: tuple  # (row, col)
    x: float
    y: float
    z: float
    yaw: float


def crop_to_heightmap(crop_pixel, crop_origin) -> tuple:
    return int(crop_pixel[0]) + int(crop_origin[0]), int(crop_pixel[1]) + int(crop_origin[1])


def heightmap_to_crop(heightmap_pixel, crop_origin) -> tuple:
    return int(heightmap_pixel[0]) - int(crop_origin[0]), int(heightmap_pixel[1]) - int(crop_origin[1])


def yaw_to_rotation(yaw: float, num_rotations: int = cell.NUM_ROTATIONS) -> int:
    step = 2.0 * math.pi / num_rotations
    return int(round(yaw / step)) % num_rotations


def local_top(height: np.ndarray, row: int, col: int, radius: int) -> float:
    """Highest point (m above the table) within `radius` px of (row, col); 0 off the map."""
    r0, r1 = max(row - radius, 0), min(row + radius + 1, height.shape[0])
    c0, c1 = max(col - radius, 0), min(col + radius + 1, height.shape[1])
    if r1 <= r0 or c1 <= c0:
        return 0.0
    window = np.nan_to_num(height[r0:r1, c0:c1], nan=0.0)
    return float(max(window.max(), 0.0))


def local_top_map(height: np.ndarray, radius_px: int) -> np.ndarray:
    """local_top at every pixel at once (float32, NaN as 0, negatives kept)."""
    window = np.ones((2 * radius_px + 1, 2 * radius_px + 1), np.uint8)
    return cv2.dilate(np.nan_to_num(height, nan=0.0).astype(np.float32), window)


def action_z(primitive: int, height: np.ndarray, row: int, col: int, rules: PoseRules = PoseRules(),
             table_z: float = cell.TABLE_Z) -> float:
    top = local_top(height, row, col, rules.local_radius_px)
    if primitive == GRASP:
        return table_z + max(top - rules.grasp_depth, rules.grasp_min_tip)
    if primitive == PUSH:
        return table_z + max(top - rules.push_depth, rules.push_min_tip)
    raise ValueError(f"unknown primitive {primitive}")


@functools.lru_cache(maxsize=64)
def footprint_kernel(yaw: float, along: tuple, across: float, resolution: float) -> np.ndarray:
    """uint8 footprint around a grasp pixel of the gripper parts whose distance from the centre along
    the closing axis `yaw` (+col = +x) lies within `along` (m, both sides) and across it within
    `across` (m). Cached: every decision asks for the same 16 kernels; treat the array as read-only."""
    half = int(math.ceil(along[1] / resolution)) + 1
    rows, cols = np.mgrid[-half:half + 1, -half:half + 1] * resolution
    distance_along = np.abs(cols * math.cos(yaw) + rows * math.sin(yaw))
    distance_across = np.abs(-cols * math.sin(yaw) + rows * math.cos(yaw))
    eps = 1e-9  # pixel centres on an edge count as inside, whatever the rounding of cos and sin
    inside = ((distance_along >= along[0] - eps) & (distance_along <= along[1] + eps)
              & (distance_across <= across + eps))
    return inside.astype(np.uint8)


def finger_kernel(yaw: float, resolution: float = cell.HEIGHTMAP_RESOLUTION,
                  opening: float = cell.GRASP_OPENING) -> np.ndarray:
    """Both open finger pads around a grasp pixel (footprint_kernel)."""
    return footprint_kernel(yaw, (opening / 2.0, opening / 2.0 + cell.FINGER_THICKNESS),
                            cell.FINGER_WIDTH / 2.0, resolution)


def palm_kernel(yaw: float, resolution: float) -> np.ndarray:
    """The palm's footprint around a grasp pixel (footprint_kernel)."""
    return footprint_kernel(yaw, (0.0, cell.PALM_HALF_EXTENTS[0]), cell.PALM_HALF_EXTENTS[1], resolution)


def _max_pool2(image: np.ndarray) -> np.ndarray:
    rows, cols = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    return image[:rows, :cols].reshape(rows // 2, 2, cols // 2, 2).max(axis=(1, 3))


def grasp_clearance(height: np.ndarray, crop_origin, size: int, rules: PoseRules = PoseRules(),
                    num_rotations: int = cell.NUM_ROTATIONS,
                    resolution: float = cell.HEIGHTMAP_RESOLUTION) -> np.ndarray:
    """(R, S, S) bool over a crop of the full heightmap `height` (m): True where a grasp at that pixel
    and rotation is clear (module docstring). Off the map counts as table. The palm, 140 mm long, is
    checked on a 2x max-pooled map (conservative, and 16x cheaper than at full resolution)."""
    half_turn = num_rotations // 2  # rotation r and r + R/2 close along the same axis
    clear = _clearance_at_yaws(height, crop_origin, size, [cell.rotation_yaw(r) for r in range(half_turn)],
                               rules, resolution)
    return np.concatenate([clear, clear])


def grasp_clear_at(height: np.ndarray, heightmap_pixel, yaw: float, rules: PoseRules = PoseRules(),
                   resolution: float = cell.HEIGHTMAP_RESOLUTION) -> bool:
    """Whether a grasp at `heightmap_pixel` (row, col) of the full heightmap `height` (m), its fingers
    closing along `yaw` (rad, any: not only a rotation index's), is clear, as grasp_clearance judges it."""
    return bool(_clearance_at_yaws(height, heightmap_pixel, 2, [yaw], rules, resolution)[0, 0, 0])


def _clearance_at_yaws(height: np.ndarray, crop_origin, size: int, yaws, rules: PoseRules,
                       resolution: float) -> np.ndarray:
    """(len(yaws), S, S) bool: grasp_clearance for closing axes `yaws` (rad)."""
    finger_kernels = [finger_kernel(yaw, resolution) for yaw in yaws]
    palm_kernels = [palm_kernel(yaw, 2 * resolution) for yaw in yaws]
    margin = 2 * (max(k.shape[0] for k in palm_kernels) // 2) + rules.local_radius_px + 2
    margin += margin % 2  # even, so the pooled map lines up with the crop
    span = size + 2 * margin + size % 2
    heights = np.maximum(np.nan_to_num(height, nan=0.0), 0.0).astype(np.float32)
    region, _ = cell.crop_centered(heights, int(crop_origin[0]) - margin + span // 2,
                                   int(crop_origin[1]) - margin + span // 2, span)
    pooled = _max_pool2(region)
    reachable = local_top_map(region, rules.local_radius_px) - rules.finger_overlap  # tips must get this low
    clear = np.empty((len(yaws), size, size), dtype=bool)
    inner = (slice(margin, margin + size), slice(margin, margin + size))
    for i, (fingers, palm) in enumerate(zip(finger_kernels, palm_kernels, strict=True)):
        under_palm = np.repeat(np.repeat(cv2.dilate(pooled, palm), 2, axis=0), 2, axis=1)
        lowest_tips = np.maximum(cv2.dilate(region, fingers), under_palm - cell.FINGER_LENGTH)
        clear[i] = (lowest_tips <= reachable)[inner]
    return clear


def heap_top(height_crop: np.ndarray, valid: np.ndarray, sigma_px: float) -> tuple:
    """(row, col) of the highest point of the smoothed height crop inside `valid` (bool, S x S): the
    pile most likely to hide something, and where a push should scatter it."""
    smooth = cv2.GaussianBlur(np.nan_to_num(height_crop, nan=0.0).astype(np.float32), (0, 0), sigma_px)
    row, col = np.unravel_index(int(np.argmax(np.where(valid, smooth, -np.inf))), smooth.shape)
    return int(row), int(col)


def pushes_starting_on_flank(height_crop: np.ndarray, point, band: tuple, radius_px: int) -> np.ndarray:
    """(S, S) bool: True where a push would start on the flank of the pile whose top is `point` (row,
    col): the local top there (within `radius_px`, as in action_z) lies within `band` (low, high) times
    the height at `point`. Started on the pile's top a push only sweeps what lies on it, started on the
    table it shoves the pile's base as a whole; from mid-height it breaks the pile open."""
    top = float(np.nan_to_num(height_crop[int(point[0]), int(point[1])], nan=0.0))
    local = local_top_map(height_crop, radius_px)
    return (local >= band[0] * top) & (local < band[1] * top)


def target_on_top(height_crop: np.ndarray, mask: np.ndarray, radius_px: int, tolerance: float) -> np.ndarray:
    """(S, S) bool: True where the highest point within `radius_px` (as in action_z) is the target's
    (mask > 0), give or take `tolerance` m. A grasp's height comes from that local top, so a grasp on a
    sliver of target under a slab closes on the slab and lifts it instead."""
    top_of_target = local_top_map(np.where(mask > 0, height_crop, 0.0), radius_px)
    return local_top_map(height_crop, radius_px) <= top_of_target + tolerance


def target_core(mask: np.ndarray, depth_px: float) -> np.ndarray:
    """(S, S) bool: the target's (mask > 0) pixels that lie at most `depth_px` less deep inside it (distance
    to its edge) than its deepest pixel: the middle of the target. The net, trained on random scenes
    only, also values grasps near a small block's edge, and those close beside it (grasps 10 mm off a
    free 26 mm cube closed on nothing)."""
    depth = cv2.distanceTransform((mask > 0).astype(np.uint8), cv2.DIST_L2, 5)
    return (mask > 0) & (depth >= depth.max() - depth_px)


TOP_ERODE_PX = 2  # top_slope: mask cells this close to its edge are left out (slopes there are steps)
TOP_SMOOTHING_PX = 1.0  # top_slope: Gaussian sigma (px) of the height crop before its slopes are taken
TOP_MIN_CELLS = 10  # top_slope: with fewer inner cells than this, no slope is read


def top_slope(height_crop: np.ndarray, mask: np.ndarray, resolution: float) -> float | None:
    """m/m: the root-mean-square slope of the target's top along its steepest axis, sqrt(l1) of the slope
    tensor J = mean(g g^T) over the mask's inner cells (TOP_ERODE_PX in from its edge; g the height gradient
    after a TOP_SMOOTHING_PX Gaussian, heights in m, `resolution` m per px, +x = +col, +y = +row). A flat top
    reads about 0.1, a half cylinder lying down 0.6, an upright prism 1.3, a flat face tilted by t about
    tan(t). None with fewer than TOP_MIN_CELLS inner cells."""
    inner = cv2.erode((mask > 0).astype(np.uint8), np.ones((2 * TOP_ERODE_PX + 1,) * 2, np.uint8)) > 0
    if np.count_nonzero(inner) < TOP_MIN_CELLS:
        return None
    heights = np.nan_to_num(height_crop, nan=0.0).astype(np.float32)
    smooth = cv2.GaussianBlur(heights, (0, 0), TOP_SMOOTHING_PX)
    g_row, g_col = np.gradient(smooth)
    gx, gy = g_col[inner] / resolution, g_row[inner] / resolution
    tensor = np.array([[np.mean(gx * gx), np.mean(gx * gy)], [np.mean(gx * gy), np.mean(gy * gy)]])
    (_, high), _ = np.linalg.eigh(tensor)
    return math.sqrt(max(high, 0.0))


FACE_MIN_CELLS = 20  # face_direction: a target mask with fewer cells has no outline to read


def face_direction(mask: np.ndarray, min_fill: float) -> float | None:
    """The direction (rad in [0, pi/2), image = base_link yaw) of a face normal of the target's top outline,
    or None when the outline is not a rectangle. The target is the largest connected part of the mask's cells
    (mask > 0); its least-area rectangle (cv2.minAreaRect over the cells' centres, +col = +x, +row = +y) gives
    the faces when the cells fill at least `min_fill` of it (a square or rectangular top: a cube or a slab
    seen from above fills about 0.9-1.0 of it; a disc fills pi/4, 0.79 of its square). Fewer than
    FACE_MIN_CELLS cells: None. The other normal is this + pi/2."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats((mask > 0).astype(np.uint8), connectivity=8)
    if count < 2:
        return None
    largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    rows, cols = np.nonzero(labels == largest)
    if len(rows) < FACE_MIN_CELLS:
        return None
    points = np.stack([cols, rows], axis=1).astype(np.float32)
    (_, _), (width, height), angle = cv2.minAreaRect(points)
    area = (width + 1.0) * (height + 1.0)  # the rectangle through the cells' centres, plus half a cell around
    if len(rows) < min_fill * area:
        return None
    return math.radians(angle) % (math.pi / 2)


def turn_onto(yaw, direction: float, period: float):
    """The signed turn (rad, in [-period/2, period/2)) that brings `yaw` (rad, a float or an array) onto the
    nearest of the directions `direction` + k `period` (rad)."""
    return (direction - yaw + period / 2) % period - period / 2


def pixels_near(mask: np.ndarray, radius_px: int) -> np.ndarray:
    """(S, S) bool: within `radius_px` of the mask (mask > 0)."""
    region = (mask > 0).astype(np.uint8)
    if radius_px > 0:
        disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius_px + 1, 2 * radius_px + 1))
        region = cv2.dilate(region, disk)
    return region > 0


def pushes_passing(point, size: int, radius_px: float, num_rotations: int = cell.NUM_ROTATIONS,
                   resolution: float = cell.HEIGHTMAP_RESOLUTION,
                   length: float = cell.PUSH_LENGTH) -> np.ndarray:
    """(R, S, S) bool: True where a push from that crop pixel along rotation r's yaw sweeps its
    fingertips within `radius_px` of `point` (row, col) on the way (the push path, a segment)."""
    rows, cols = np.mgrid[:size, :size].astype(np.float64)
    to_row, to_col = point[0] - rows, point[1] - cols
    steps = length / resolution
    passing = np.empty((num_rotations, size, size), dtype=bool)
    for r in range(num_rotations):
        yaw = cell.rotation_yaw(r)
        d_col, d_row = math.cos(yaw), math.sin(yaw)
        along = np.clip(to_col * d_col + to_row * d_row, 0.0, steps)
        passing[r] = np.hypot(to_col - along * d_col, to_row - along * d_row) <= radius_px
    return passing


def _push_edge_rooms(crop_origin, size: int, num_rotations: int, grid: HeightmapGrid, length: float):
    """For each rotation r, (r, edges): edges holds, for the workspace edges +x, -x, +y, -y of `grid`,
    (the push direction's component towards that edge, (S, S) room in m between the push's end and it),
    for a push of `length` from every crop pixel along rotation r's yaw."""
    rows, cols = np.mgrid[:size, :size].astype(np.float64)
    x, y = grid.pixel_to_base(rows + int(crop_origin[0]), cols + int(crop_origin[1]))
    for r in range(num_rotations):
        yaw = cell.rotation_yaw(r)
        dx, dy = math.cos(yaw), math.sin(yaw)
        end_x, end_y = x + length * dx, y + length * dy
        yield r, ((dx, grid.x_max - end_x), (-dx, end_x - grid.x_min), (dy, grid.y_max - end_y),
                  (-dy, end_y - grid.y_min))


def pushes_ending_inside(crop_origin, size: int, margin: float, num_rotations: int = cell.NUM_ROTATIONS,
                         grid: HeightmapGrid = HeightmapGrid(),
                         length: float = cell.PUSH_LENGTH) -> np.ndarray:
    """(R, S, S) bool: True where a push from that crop pixel along rotation r's yaw ends at least
    `margin` (m) inside the workspace, the heightmap's `grid` (what the fingers shove ahead of them
    lands beyond the end)."""
    inside = np.empty((num_rotations, size, size), dtype=bool)
    for r, edges in _push_edge_rooms(crop_origin, size, num_rotations, grid, length):
        inside[r] = np.logical_and.reduce([room >= margin for _, room in edges])
    return inside


EDGE_APPROACH = 0.3  # pushes_not_toward_near_edge: a push approaches an edge when its unit direction's
# component towards it is at least this (within 72.5 degrees of the edge's outward normal; of the 16
# rotations, the 7 within 67.5 degrees either side of it do)


def pushes_not_toward_near_edge(crop_origin, size: int, margin: float,
                                num_rotations: int = cell.NUM_ROTATIONS,
                                grid: HeightmapGrid = HeightmapGrid(),
                                length: float = cell.PUSH_LENGTH) -> np.ndarray:
    """(R, S, S) bool: False where a push from that crop pixel along rotation r's yaw approaches a
    workspace edge (the heightmap's `grid`; its direction's component towards the edge at least
    EDGE_APPROACH) and ends less than `margin` (m) from that edge. What a push drives through a pile
    travels on beyond its end, in its direction: a push along an edge, or away from it, keeps it."""
    kept = np.ones((num_rotations, size, size), dtype=bool)
    for r, edges in _push_edge_rooms(crop_origin, size, num_rotations, grid, length):
        for component, room in edges:
            if component >= EDGE_APPROACH:
                kept[r] &= room >= margin
    return kept


def action_pose(primitive: int, rotation: int, crop_pixel, crop_origin, height: np.ndarray,
                rules: PoseRules = PoseRules(), grid: HeightmapGrid = HeightmapGrid()) -> ActionPose:
    """Crop pixel + rotation index -> pose in base_link; `height` is the full heightmap (m) on `grid`.
    ValueError when the pixel lies off the heightmap."""
    row, col = crop_to_heightmap(crop_pixel, crop_origin)
    if not (0 <= row < height.shape[0] and 0 <= col < height.shape[1]):
        raise ValueError(f"action pixel {(row, col)} is outside the {height.shape} heightmap")
    x, y = grid.pixel_to_base(row, col)
    return ActionPose(primitive, int(rotation) % cell.NUM_ROTATIONS, (row, col), x, y,
                      action_z(primitive, height, row, col, rules, grid.table_z), cell.rotation_yaw(rotation))


def pose_to_action(x: float, y: float, yaw: float, crop_origin,
                   grid: HeightmapGrid = HeightmapGrid()) -> tuple:
    """Inverse of action_pose for (x, y, yaw): (rotation index, crop pixel)."""
    heightmap_pixel = grid.base_to_pixel(x, y)
    return yaw_to_rotation(yaw), heightmap_to_crop(heightmap_pixel, crop_origin)


def push_end(pose: ActionPose, length: float = cell.PUSH_LENGTH) -> tuple:
    """(x, y) where a push from `pose` ends."""
    return pose.x + length * math.cos(pose.yaw), pose.y + length * math.sin(pose.yaw)
