"""What the product looked like before anything moved: the colours of a view known to show no impurity.

In an invisible scene the first view shows product only (attention finds no target in it). After pushes the
region verifier sometimes calls a product piece an impurity (docs/experiments.md, twenty-third section: about
half of the grasps that separate tuning palettes from the default one in invisible scenes). Those pieces are
coloured like much of the first view; a revealed impurity is coloured like almost none of it. On 60 invisible
tuning episodes (twenty-fifth section, `docs/experiments_s25/temporal_screen.py`) a bound of 1 % of the first
view's object cells within CIE76 dE 4 of a target mask's median colour kept 98 % of the TARGET grasps on a
target and caught 90 % of those on product.

`ProductColours.from_view` keeps a view's object colours (CIE L*a*b*, OpenCV's float scale: L* 0-100);
`share_near` answers what share of them lies within a colour distance of a given colour. attention.attend
takes one as `known_product` and, while a heap that could hide a target is left, passes over a region whose
grown mask is coloured like more than `AttentionParams.known_product_max_share` of it. Who decides that a view
shows product only (the picking loop, from attention's answer on the episode's first view) is the caller's
business: this module only remembers.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

MAX_SAMPLES = 20_000  # object cells kept (every n-th, in raster order): the share is read to 1e-4 or better


def lab(color: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 RGB -> (N, 3) float32 CIE L*a*b* (OpenCV: L* 0-100, a* b* about -128..127)."""
    rgb = np.asarray(color, dtype=np.float32).reshape(-1, 1, 3) / 255.0
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab).reshape(-1, 3)


@dataclass(frozen=True)
class ProductColours:
    """The L*a*b* colours (N, 3) of the object cells of a view that shows product only."""

    samples: np.ndarray

    @classmethod
    def from_view(cls, color: np.ndarray, objects: np.ndarray) -> ProductColours | None:
        """From a colour heightmap (H, W, 3) uint8 and its object cells (H, W) bool; None when the view has
        no object cell. ValueError on mismatched shapes."""
        color, objects = np.asarray(color), np.asarray(objects, dtype=bool)
        if color.ndim != 3 or color.shape[:2] != objects.shape or color.shape[2] != 3:
            raise ValueError(f"color must be (H, W, 3) and objects (H, W), got {color.shape} and "
                             f"{objects.shape}")
        cells = color[objects]
        if len(cells) == 0:
            return None
        stride = max(1, -(-len(cells) // MAX_SAMPLES))
        return cls(lab(cells[::stride]))

    def share_near(self, colour_lab, delta_e: float) -> float:
        """The share (0-1) of the remembered colours within CIE76 distance `delta_e` of `colour_lab` (3,)."""
        distance = np.linalg.norm(self.samples - np.asarray(colour_lab, dtype=np.float32), axis=1)
        return float(np.mean(distance <= delta_e))


def mask_colour(color: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(3,) the median L*a*b* colour of the cells of `mask` (H, W) bool in `color` (H, W, 3) uint8."""
    return np.median(lab(np.asarray(color)[np.asarray(mask, dtype=bool)]), axis=0)
