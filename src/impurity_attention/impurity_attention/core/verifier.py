"""Which salient regions are impurities: a learned region verifier (issue 17, eighth session).

The thresholds rule (attention.is_target) judges the best salient region alone, by its relative saliency and
its colour contrast. On tuning palettes it misses impurities whose region is the best one but whose
contrast falls short (the product's shading is as salient), and it cannot take the second region when the
first is a shadow. The verifier scores each of the TOP_REGIONS best regions with a logistic model of
FEATURES, all relative to the scene (so neither the product's colour nor the exposure sets them), and
attention takes the most probable region when its probability reaches the model's threshold.

Features of a region m among the object cells O (FEATURES, in this order):
A region with no other object cell in view has no features (nothing to compare with).

- colour_contrast: log(1 + d), d the Mahalanobis distance of m's mean colour from the colours of O \\ m
  (impurity_common.colour.region_contrast with least spread MIN_SPREAD RGB, shading allowance SHADING and
  channels clipped at SATURATION on half of the product left out), d capped at COLOUR_CAP. Its least
  spread is in RGB, so unlike the other features it shrinks in a much darker image (the model was fitted
  with the default palette at exposure x0.5 and x2 among its scenes);
- relative_rg, relative_by: log of m's mean VOCUS2 conspicuity in RG / I and in BY / I over that map's
  mean on the product P = O minus m grown by PRODUCT_MARGIN px (floor saliency.MIN_CHANNEL_LEVEL): how much
  more contrasted in hue than the product usually is, per chromatic channel;
- off_colour_share: the share of m's cells whose colour is off the colours of O \\ m
  (impurity_common.colour.off_colours: rare among the other objects);
- height_spread: the standard deviation of the heights over m (m). A block's visible face is flat; the
  salient parts of a product heap that are not impurities are mostly its shadowed gaps and edges.

The model (verifier_model.py, written by `scripts/calibrate_attention.py verifier-fit`) is fitted on tuning
palettes and tuning seeds only; that script's docstring and the model file give its figures. Pure numpy: no
scikit-learn at run time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from impurity_common.colour import off_colours, region_contrast

from .saliency import MIN_CHANNEL_LEVEL

TOP_REGIONS = 3  # salient regions scored, best first
FEATURES = ("colour_contrast", "relative_rg", "relative_by", "off_colour_share", "height_spread")
MIN_SPREAD = 4.0  # RGB, the colour test's least spread (AttentionParams.color_min_spread's value)
SHADING = 0.1  # colour_contrast's shading allowance (ProductReference shading)
SATURATION = 250.0  # colour_contrast: channels clipped at this level on half of the product left out
COLOUR_CAP = 100.0  # Mahalanobis distances above this count as this (and "no other object" as well)
PRODUCT_MARGIN = 4  # px (8 mm) around the region left out of the product level
MIN_RATIO = 1e-3  # relative_rg / relative_by: ratios below this count as this (log)


@dataclass(frozen=True)
class RegionVerifier:
    """A logistic model over FEATURES: p = 1 / (1 + exp(-(coef . (x - mean) / scale + intercept))).
    mean, scale, coef: one value per feature; threshold: the least probability that makes a target."""

    mean: tuple
    scale: tuple
    coef: tuple
    intercept: float
    threshold: float
    provenance: str = ""

    def __post_init__(self):
        for name in ("mean", "scale", "coef"):
            if len(getattr(self, name)) != len(FEATURES):
                raise ValueError(f"RegionVerifier.{name} needs {len(FEATURES)} values "
                                 f"({', '.join(FEATURES)}), got {len(getattr(self, name))}")
        if not all(s > 0 for s in self.scale):
            raise ValueError(f"RegionVerifier.scale must be > 0, got {self.scale}")
        if not 0.0 < self.threshold < 1.0:
            raise ValueError(f"RegionVerifier.threshold must be a probability in (0, 1), got "
                             f"{self.threshold}")

    def probability(self, features: np.ndarray) -> np.ndarray:
        """(N, len(FEATURES)) -> (N,) probabilities that each region is an impurity."""
        features = np.atleast_2d(np.asarray(features, dtype=np.float64))
        z = (features - np.asarray(self.mean)) / np.asarray(self.scale)
        logit = z @ np.asarray(self.coef) + self.intercept
        return 1.0 / (1.0 + np.exp(-logit))


def region_features(color: np.ndarray, height: np.ndarray, objects: np.ndarray, conspicuity: dict,
                    region: np.ndarray) -> np.ndarray | None:
    """(len(FEATURES),) float64 of one region (module docstring). color (H, W, 3) uint8, height (H, W)
    float32 m, objects and region (H, W) bool (region not empty, within objects), conspicuity: VOCUS2's
    chromaticity-space maps by channel name ("RG", "BY"), each (H, W) float32. None when no other object
    cell is in view: there is no product to compare with (attention then lets saliency decide alone, as
    the rule does)."""
    region = np.asarray(region, dtype=bool)
    others = objects & ~region
    if not others.any():
        return None
    contrast = min(region_contrast(color, region, objects, MIN_SPREAD, SHADING, SATURATION), COLOUR_CAP)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    product = objects & ~(cv2.dilate(region.astype(np.uint8), kernel) > 0)
    if not product.any():
        product = others
    ratios = []
    for name in ("RG", "BY"):
        plane = conspicuity[name]
        level = max(float(plane[product].mean()), MIN_CHANNEL_LEVEL)
        ratios.append(math.log(max(float(plane[region].mean()) / level, MIN_RATIO)))
    off_share = float(np.mean(off_colours(color, others)[region]))
    return np.array([math.log1p(contrast), *ratios, off_share, float(np.std(height[region]))])


def candidate_features(color: np.ndarray, height: np.ndarray, objects: np.ndarray, conspicuity: dict,
                       regions: list) -> list:
    """[(region, features or None)] for the TOP_REGIONS best of `regions` (salient regions, best first):
    what attention scores and verifier-fit learns from. Arguments as region_features."""
    return [(region, region_features(color, height, objects, conspicuity, region.mask))
            for region in regions[:TOP_REGIONS]]


def default_verifier() -> RegionVerifier:
    """The shipped model (verifier_model.py)."""
    from .verifier_model import MODEL
    return MODEL
