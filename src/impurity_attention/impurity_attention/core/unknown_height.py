"""Cells of unknown height: what the colour camera sees and the depth camera does not measure.

A stereo depth camera returns no depth (0 in 16UC1, NaN in 32FC1) on surfaces it cannot match: black and
glossy pieces, whose colour the colour image shows plainly. The heightmap places such a pixel where its
ray meets the table plane and keeps its colour there as "height unknown" (core.heightmap: Heightmaps.unknown;
NaN in the /heightmap message's height). Most holes are harmless - the thin stereo shadow beside a tall
object, specks of noise - but a compact, object-sized region of unknown height coloured unlike the table
is something lying there that the depth does not show: an `UnknownRegion`, a candidate for attention
(core.attention.attend), which gives it UNKNOWN_HEIGHT so that it is an object for saliency, the verifier
and the crops, and looks at it when nothing else is to be done.

Pure numpy / OpenCV; no rclpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from impurity_common import cell
from impurity_common.colour import lab

# An object-sized region: at least MIN_CELLS cells (2 mm: 1.2 cm^2, attention's smallest salient region) and
# at most MAX_CELLS (100 cm^2; the largest block, a 60 x 76 mm slab, covers 46 cm^2).
MIN_CELLS = 30
MAX_CELLS = 2500
# Compact: at least this share of its convex hull (an L- or C-shaped shadow around an object is not)...
MIN_SOLIDITY = 0.6
# ... and at least 2 x this many cells thick (1 cm): the stereo shadow beside a block 3 cm high is 2 mm
# wide at the cell's 0.75 m (a D435's 50 mm baseline), a line of cells.
MIN_HALF_WIDTH = 2.5
# Coloured unlike the table: CIE76 distance (colour.lab) of its median colour from the table's median (seen
# cells no higher than the occupied height); a depth hole on the bare table (glare, a dark stain) is nearer.
MIN_TABLE_DELTA_E = 15.0
# The height an unknown region is given (m): twice the occupied height, so that it counts as an object
# with margin, and low, so that a grasp aimed at it goes deep rather than closing above a flat piece
# (fingertips never go below cell.MIN_TIP_HEIGHT).
UNKNOWN_HEIGHT = 2 * cell.OCCUPIED_HEIGHT


@dataclass(frozen=True)
class UnknownRegion:
    """A compact, object-sized region of unknown height coloured unlike the table."""

    mask: np.ndarray  # (H, W) bool
    area: int  # cells
    centroid: tuple  # (row, col) float
    delta_e: float  # CIE76 distance of its median colour from the table's; inf: no table in view


def table_colour(color: np.ndarray, height: np.ndarray, seen: np.ndarray,
                 occupied_height: float = cell.OCCUPIED_HEIGHT) -> np.ndarray | None:
    """(3,) median L*a*b* colour of the table cells (seen, no higher than occupied_height), or None."""
    table = seen & (height <= occupied_height)
    if not table.any():
        return None
    colours = color[table]
    step = max(1, len(colours) // 4000)  # an even subsample is the same median
    return np.median(lab(colours[::step]), axis=0)


def unknown_regions(color: np.ndarray, height: np.ndarray, unknown: np.ndarray,
                    occupied_height: float = cell.OCCUPIED_HEIGHT, min_cells: int = MIN_CELLS) -> list:
    """The UnknownRegions of a colour heightmap (H, W, 3) uint8, height (H, W) m (0 or NaN where unknown)
    and unknown (H, W) bool (cells of colour without depth), largest first (module constants above)."""
    unknown = np.asarray(unknown, dtype=bool)
    if np.count_nonzero(unknown) < min_cells:
        return []
    height = np.nan_to_num(np.asarray(height, dtype=np.float32), nan=0.0)
    table = table_colour(color, height, ~unknown, occupied_height)
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(unknown.astype(np.uint8),
                                                                       connectivity=8)
    regions = []
    for label in range(1, count):
        area = int(stats[label, cv2.CC_STAT_AREA])
        if not min_cells <= area <= MAX_CELLS:
            continue
        x, y, w, h = (int(stats[label, k]) for k in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                                     cv2.CC_STAT_HEIGHT))
        mask = labels == label
        window = np.pad(mask[y:y + h, x:x + w], 1).astype(np.uint8)
        if cv2.distanceTransform(window, cv2.DIST_L2, 5).max() < MIN_HALF_WIDTH:
            continue
        contours, _ = cv2.findContours(window, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        hull = cv2.contourArea(cv2.convexHull(np.concatenate(contours)))
        if hull > 0 and area / hull < MIN_SOLIDITY:
            continue
        delta_e = (float("inf") if table is None
                   else float(np.linalg.norm(np.median(lab(color[mask]), axis=0) - table)))
        if delta_e < MIN_TABLE_DELTA_E:
            continue
        regions.append(UnknownRegion(mask=mask, area=area, delta_e=delta_e,
                                     centroid=(float(centroids[label][1]), float(centroids[label][0]))))
    regions.sort(key=lambda r: r.area, reverse=True)
    return regions


def unknown_height_warning(regions: list, resolution: float) -> str | None:
    """One line naming the cause of unknown-height regions in view and the camera settings that help;
    None without regions."""
    if not regions:
        return None
    sizes = ", ".join(f"{r.area * resolution * resolution * 1e4:.1f} cm^2" for r in regions[:3])
    return (f"{len(regions)} object-sized region(s) ({sizes}) coloured unlike the table have no depth: a "
            "black or glossy piece the depth camera does not measure. They reach the heightmap as height "
            "unknown (NaN) and attention takes them as candidates at a guessed height. Help the depth camera "
            "(realsense-ros): raise the projector's laser power (depth_module.emitter_enabled 1, "
            "depth_module.laser_power), lengthen the depth exposure (depth_module.enable_auto_exposure, "
            "depth_module.exposure), or fill holes (hole_filling_filter.enable true: a hole then takes its "
            "neighbours' depth, often the table's)")
