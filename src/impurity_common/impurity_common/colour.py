"""How far a colour stands apart from a product's colours: a Mahalanobis distance from the colours of the
product's cells (decisions relative to the scene, not to a palette). numpy and OpenCV (the L*a*b*
conversion); no ROS.

Used by attention (is the best salient region's colour unlike the other objects'?) and by the grasp
verdict (is the lifted region's colour unlike the product's in the episode's first view?), each with its
own least spread (`min_spread`, chosen with its thresholds on tuning scenes). Attention also takes a
reference as the known product (a view that showed product only) and asks what share of its colours lies
near a region's colour in CIE L*a*b* (`share_near`, core/product_memory.py of impurity_attention).

    reference = ProductReference.from_view(color, height, target_mask, 4.0, min_object_height=0.008)
    reference.contrast(rgb)  # dimensionless: about 1 for the product's own colours
    reference.share_near(mask_colour(color, mask), 4.0)  # 0-1: the share within CIE76 dE 4
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import cv2
import numpy as np

# Shading (Lambertian: a face turned from the light scales the surface's RGB by a factor) moves a colour
# along the direction of the product's mean colour. `shading` grants the product that much spread along that
# axis, as a share of the mean colour's length: a shaded face of a product block is then near the product
# even when the first view showed only lit faces, while a colour off the axis (another hue) stays far.
# The product's colour covariance gets a ridge on its diagonal: RIDGE_SHARE of its mean variance per axis
# (an axis along which the product hardly varies would make every colour off it infinitely far; being a
# share, the ridge scales with brightness as the covariance does), and at least min_spread**2.
RIDGE_SHARE = 0.05
REFERENCE_CELLS = 4096  # most product cells a ProductReference keeps (an even subsample)
# A camera channel at its ceiling (a light product, a long exposure) reads 255 whatever the light: shading
# does not scale it, so a shaded face of a saturated product is not on the product's mean-colour axis.
# `saturation` leaves such channels out of the comparison: those in which at least SATURATED_SHARE of the
# product's colours reach the level. When every channel is saturated all three are kept (no colour is left).
SATURATED_SHARE = 0.5
# off_colours: a reference's colours as a histogram of OFF_COLOUR_BINS per RGB channel, smoothed over each
# bin's 26 neighbours; a colour is off the reference where that density is below the density of the
# reference's own OFF_COLOUR_QUANTILE least likely cells (1 %: one reference cell in a hundred is "off").
OFF_COLOUR_BINS = 16
OFF_COLOUR_QUANTILE = 0.01


@dataclass(frozen=True)
class ProductReference:
    """The product's colours, to judge how far a region's colour stands apart from them.

    colors: (N, 3) float64 RGB of object cells; channels (3,) bool: those compared (all but saturated
    ones, module comment); mean (C,) and covariance (C, C) of the compared channels, the covariance with its
    ridge added on the diagonal (RIDGE_SHARE of the mean variance, at least min_spread**2) and, with
    shading > 0, (shading * |mean|)**2 along the mean colour's direction (module comment).
    """

    colors: np.ndarray
    mean: np.ndarray
    covariance: np.ndarray
    channels: np.ndarray = field(default_factory=lambda: np.ones(3, bool))

    @classmethod
    def from_colors(cls, colors: np.ndarray, min_spread: float, shading: float = 0.0,
                    saturation: float | None = None) -> ProductReference:
        """From (N, 3) RGB colours; min_spread: the least standard deviation (RGB) granted on every axis
        (a one-colour product under flat light would otherwise make every other colour infinitely far);
        shading: standard deviation granted along the mean colour's direction, as a share of its length
        (0 = none); saturation: the channel level (RGB, e.g. 250 of 255) from which a channel counts as
        clipped, None = compare every channel (module comment). ValueError when N is 0, min_spread <= 0,
        shading < 0 or saturation <= 0."""
        colors = np.asarray(colors, dtype=np.float64).reshape(-1, 3)
        if len(colors) == 0:
            raise ValueError("a product reference needs at least one object cell")
        if not min_spread > 0:
            raise ValueError(f"min_spread must be > 0 (RGB), got {min_spread}")
        if not shading >= 0:
            raise ValueError(f"shading must be >= 0 (a share of the mean colour), got {shading}")
        if saturation is not None and not saturation > 0:
            raise ValueError(f"saturation must be > 0 (an RGB level) or None, got {saturation}")
        if len(colors) > REFERENCE_CELLS:
            colors = colors[np.linspace(0, len(colors) - 1, REFERENCE_CELLS).astype(int)]
        channels = np.ones(3, bool)
        if saturation is not None:
            channels = np.mean(colors >= float(saturation), axis=0) < SATURATED_SHARE
            if not channels.any():
                channels[:] = True
        compared = colors[:, channels]
        size = int(channels.sum())
        covariance = np.cov(compared.T).reshape(size, size) if len(compared) > 1 else np.zeros((size, size))
        ridge = max(RIDGE_SHARE * float(np.trace(covariance)) / size, float(min_spread) ** 2)
        mean = compared.mean(axis=0)
        covariance = covariance + ridge * np.eye(size)
        length = float(np.linalg.norm(mean))
        if shading > 0 and length > 0:
            axis = mean / length
            covariance = covariance + (float(shading) * length) ** 2 * np.outer(axis, axis)
        return cls(colors, mean, covariance, channels)

    @classmethod
    def from_view(cls, color: np.ndarray, height: np.ndarray, target_mask: np.ndarray | None,
                  min_spread: float, min_object_height: float,
                  shading: float = 0.0) -> ProductReference | None:
        """From a colour (H, W, 3) uint8 and height (H, W) m view: object cells (height >
        min_object_height m: the caller's notion of an object) outside target_mask ((H, W) bool, or None),
        shading as in from_colors. None without such cells."""
        objects = np.asarray(height) > min_object_height
        if np.shape(color) != (*objects.shape, 3):
            raise ValueError(f"color {np.shape(color)} and height {objects.shape} must share one (H, W)")
        if target_mask is not None:
            objects &= ~np.asarray(target_mask).astype(bool)
        if not objects.any():
            return None
        return cls.from_colors(np.asarray(color)[objects], min_spread, shading)

    def contrast(self, rgb) -> float:
        """Mahalanobis distance of an RGB colour from the product's colours (mean, covariance):
        dimensionless, so one threshold serves dark and light products, one shade or several; the
        product's own shading (darker faces of the same hue) lies along its covariance and counts little."""
        offset = np.asarray(rgb, dtype=np.float64)[self.channels] - self.mean
        return float(np.sqrt(offset @ np.linalg.solve(self.covariance, offset)))

    @functools.cached_property
    def lab_colors(self) -> np.ndarray:
        """(N, 3) float32: `colors` in CIE L*a*b* (lab()), converted once."""
        return lab(self.colors)

    def share_near(self, colour_lab, delta_e: float) -> float:
        """The share (0-1) of the product's colours within CIE76 distance `delta_e` of the L*a*b* colour
        `colour_lab` (3,) (lab() scale): how common that colour is in the product."""
        distance = np.linalg.norm(self.lab_colors - np.asarray(colour_lab, dtype=np.float32), axis=1)
        return float(np.mean(distance <= delta_e))


def lab(color: np.ndarray) -> np.ndarray:
    """RGB colours (..., 3), 0-255 (uint8 or float) -> (N, 3) float32 CIE L*a*b* (OpenCV's scale for float
    input: L* 0-100, a* and b* about -128..127; D65 white)."""
    rgb = np.asarray(color, dtype=np.float32).reshape(-1, 1, 3) / 255.0
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab).reshape(-1, 3)


def mask_colour(color: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(3,) the median L*a*b* colour (lab()) of the cells of `mask` (H, W) bool, not empty, in `color`
    (H, W, 3) uint8."""
    return np.median(lab(np.asarray(color)[np.asarray(mask, dtype=bool)]), axis=0)


def region_contrast(color: np.ndarray, region: np.ndarray, objects: np.ndarray,
                    min_spread: float, shading: float = 0.0, saturation: float | None = None) -> float | None:
    """ProductReference.contrast of a region's mean colour against the other object cells of the same
    view (objects outside the region): how far the region stands apart from the rest. color (H, W, 3)
    uint8, region and objects (H, W) bool (region not empty), min_spread, shading and saturation as in
    from_colors. None when no other object cell is in view (nothing to compare with)."""
    region = np.asarray(region, dtype=bool)
    others = np.asarray(objects, dtype=bool) & ~region
    if not others.any():
        return None
    rgb = np.asarray(color)
    reference = ProductReference.from_colors(rgb[others], min_spread, shading, saturation)
    return reference.contrast(rgb[region].astype(np.float64).mean(axis=0))


def off_colours(color: np.ndarray, reference: np.ndarray, judged: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool: the cells of a colour image (H, W, 3) uint8 whose colour lies off the colours of the
    `reference` cells ((H, W) bool, not empty): a histogram of OFF_COLOUR_BINS per channel of the
    reference's colours, smoothed over each bin's 26 neighbours, below the density of the reference's own
    OFF_COLOUR_QUANTILE least likely cells. A per-cell test with no shape: used by the region verifier
    (the share of a region's cells off the other objects' colours) and by evaluation.colour_separable.
    judged: (H, W) bool, the only cells judged (the rest come out False; the reference's histogram and
    quantile are the same), when only some are read: it saves the work on the others."""
    reference = np.asarray(reference, dtype=bool)
    bins, side = OFF_COLOUR_BINS, OFF_COLOUR_BINS + 2  # a bin of padding each side: 26 neighbours for all
    rgb = np.asarray(color)
    own = (rgb[reference].astype(np.int64) * bins) // 256
    counts = np.bincount(((own[:, 0] + 1) * side + own[:, 1] + 1) * side + own[:, 2] + 1,
                         minlength=side ** 3).astype(np.float64).reshape((side,) * 3)
    smooth = sum(counts[1 + dr:bins + 1 + dr, 1 + dg:bins + 1 + dg, 1 + db:bins + 1 + db]
                 for dr in (-1, 0, 1) for dg in (-1, 0, 1) for db in (-1, 0, 1))
    level = np.quantile(smooth[own[:, 0], own[:, 1], own[:, 2]], OFF_COLOUR_QUANTILE)
    if judged is None:
        index = (rgb.astype(np.int64) * bins) // 256
        return smooth[index[..., 0], index[..., 1], index[..., 2]] < level
    judged = np.asarray(judged, dtype=bool)
    index = (rgb[judged].astype(np.int64) * bins) // 256
    off = np.zeros(reference.shape, dtype=bool)
    off[judged] = smooth[index[:, 0], index[:, 1], index[:, 2]] < level
    return off
