"""Which salient regions are impurities: a learned region verifier. It scores each of the TOP_REGIONS best
salient regions with a logistic model of FEATURES, all relative to the scene (so neither the product's colour
nor the exposure sets them), and attention takes the most probable region when its probability reaches the
model's threshold.

Features of a region m among the object cells O (FEATURES, in this order). P is the product: O minus m
grown by PRODUCT_MARGIN px (O minus m when that leaves nothing). A region with no other object cell in view
has no features (nothing to compare with).

Of the region (REGION_FEATURES, region_features):
- colour_contrast: log(1 + d), d the Mahalanobis distance of m's mean colour from the colours of O \\ m
  (impurity_common.colour.region_contrast with least spread MIN_SPREAD RGB, shading allowance SHADING and
  channels clipped at SATURATION on half of the product left out), d capped at COLOUR_CAP. Its least
  spread is in RGB, so unlike the other features it shrinks in a much darker image (the model was fitted
  with the default palette at exposure x0.5 and x2 among its scenes);
- relative_rg, relative_by, relative_i: log of m's mean VOCUS2 conspicuity in RG / I, in BY / I and in I
  over that map's mean on P (floor saliency.MIN_CHANNEL_LEVEL; ratios below MIN_RATIO count as MIN_RATIO):
  how much more contrasted than the product usually is, per channel;
- off_colour_share: the share of m's cells whose colour is off the colours of O \\ m
  (impurity_common.colour.off_colours: rare among the other objects);
- height_spread: the standard deviation of the heights over m (m). A block's visible face is flat; the
  salient parts of a product heap that are not impurities are mostly its shadowed gaps and edges;
- lightness_offset: (median of L over m - median of L over P) / (standard deviation of L over P + 1e-3), L
  the log of the opponent intensity I (saliency.opponent_colour, floor saliency.CHROMA_MIN_INTENSITY): how
  much lighter or darker than the product, in the product's own spread (exposure scales I, so it cancels);
- dark_share: the share of m's cells darker (L) than the product's darkest DARK_QUANTILE.
  Both read cells with no channel clipped (>= SATURATION) only, and are 0 when m or P has none.
- oriented_contrast, oriented_lightness, oriented_off_share (oriented_features): m against
  product faces of the same orientation. Under one directional light a face's shading, and at a long
  exposure its clipping (a blue product's lit faces turn cyan), is a function of its normal, which the
  heightmap gives. The product's log I, RG / I and BY / I are fitted over P as a quadratic in the local slope
  (least squares on 1, gx, gy, gx^2, gy^2, gx gy; slopes of the heightmap smoothed by a Gaussian of
  SLOPE_SIGMA px), and m is read by its residuals r: log(1 + d), d the Mahalanobis distance of m's mean r
  under P's residual covariance (+ ORIENTED_RIDGE I), capped at COLOUR_CAP; the median log-I residual over m
  in P's residual spread; the share of m's cells whose own r lies beyond ORIENTED_OFF (Mahalanobis). They
  read cells with at least one channel below SATURATION only, and are unknown (NaN)
  with fewer than ORIENTED_MIN_PRODUCT such product cells or none in m. A model reads an unknown feature as
  its fitted mean: it adds nothing to the score (RegionVerifier.probability).
Of the region among the others (CONTEXT_FEATURES, context_features):
- rank: 0 for the most salient region, 1, 2;
- log_regions: log of the number of salient regions in view;
- best_over_next: log of the best region's mean saliency over the second's (log 2 with one region);
- log_object_share: log of the share of the view's cells that hold objects. The model knows it only over
  the range its tuning scenes span (12-28 % of a 448 mm view): like every feature it is clipped to the
  fitted range (RegionVerifier.low / high), so a fuller view counts as the fullest it was fitted on.

Of the impurity network's map (NETWORK_FEATURES, network_features; impurity_net.py):
- network_mean: the mean over m of the network's per-cell impurity probability;
- network_high: its 90th percentile over m (NETWORK_QUANTILE): a region that covers an impurity's top and
  some product around it still reads high.
  Read only when a network is given (candidate_features' rows are then ALL_FEATURES, else FEATURES).

A model reads the features it was fitted on (RegionVerifier.features, by name, any of ALL_FEATURES); the
shipped one reads them all.

The model is data: checkpoints/verifier.json beside the impurity network (read_verifier, write_verifier), its
fields those of RegionVerifier, with the thresholds that go with its probabilities (threshold, last_look,
stall_look). It is fitted by `python -m impurity_learning.calibrate verifier` (its thresholds by
`... thresholds`) on tuning palettes and tuning seeds only (first views and the picking loop's views after its
pushes and grasps); its provenance field gives the figures. Pure numpy: no scikit-learn at run time.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import pathlib
from dataclasses import dataclass

import cv2
import numpy as np

from impurity_common.colour import off_colours, region_contrast

from .checkpoints import SOURCE_CHECKPOINTS, shipped_path
from .heightmap import CLIPPED_LEVEL
from .saliency import CHROMA_MIN_INTENSITY, MIN_CHANNEL_LEVEL, opponent_chromaticity

TOP_REGIONS = 3  # salient regions scored, best first
ORIENTED_FEATURES = ("oriented_contrast", "oriented_lightness", "oriented_off_share")
REGION_FEATURES = ("colour_contrast", "relative_rg", "relative_by", "relative_i", "off_colour_share",
                   "height_spread", "lightness_offset", "dark_share") + ORIENTED_FEATURES
CONTEXT_FEATURES = ("rank", "log_regions", "best_over_next", "log_object_share")
FEATURES = REGION_FEATURES + CONTEXT_FEATURES  # a row without the network (candidate_features' default)
NETWORK_FEATURES = ("network_mean", "network_high")
ALL_FEATURES = FEATURES + NETWORK_FEATURES  # a row with the network
# The product-colour reference (impurity_common.colour.ProductReference) of colour_contrast; the known product
# (product_memory) shares its least spread
MIN_SPREAD = 4.0  # RGB, least spread of the product's colours
SHADING = 0.1  # colour_contrast's shading allowance (ProductReference shading)
SATURATION = float(CLIPPED_LEVEL)  # colour_contrast: channels clipped (at the camera's ceiling, as the
# heightmap node's exposure warning reads it) on half of the product left out;
# lightness_offset, dark_share: cells with a channel at this level are not read
COLOUR_CAP = 100.0  # Mahalanobis distances above this count as this (and "no other object" as well)
PRODUCT_MARGIN = 4  # px (8 mm) around the region left out of the product level
MIN_RATIO = 1e-3  # relative_*: ratios below this count as this (log)
DARK_QUANTILE = 0.01  # dark_share: darker than this quantile of the product's log intensity
SLOPE_SIGMA = 1.0  # px: the heightmap's Gaussian smoothing before its slopes (Sobel) are read
ORIENTED_MIN_PRODUCT = 50  # product cells the orientation fit needs (else the oriented features are 0)
ORIENTED_RIDGE = 1e-4  # added to the residual covariance's diagonal (a flat product has almost none)
ORIENTED_OFF = 3.0  # oriented_off_share: a cell's residual beyond this Mahalanobis distance
LOG_I_FLOOR = 0.02  # log I of the orientation fit: intensities below this count as this
NETWORK_QUANTILE = 0.9  # network_high: this quantile of the network's probability over the region


@dataclass(frozen=True)
class RegionVerifier:
    """A logistic model over FEATURES: p = 1 / (1 + exp(-(coef . (clip(x, low, high) - mean) / scale +
    intercept))). mean, scale, coef, low, high: one value per feature (low / high: the range the fitting
    rows spanned; a feature outside it counts as its nearest end, so a view unlike any the model was fitted
    on cannot drive the linear score anywhere); threshold: the least probability that makes a target;
    last_look and stall_look: attention's look thresholds, matched to this model's probabilities."""

    mean: tuple
    scale: tuple
    coef: tuple
    intercept: float
    threshold: float
    low: tuple
    high: tuple
    last_look: float  # the last look's least probability (attention, no heap left)
    stall_look: float  # the stall look's threshold (attend's closer=True)
    provenance: str = ""
    features: tuple = FEATURES  # the names it was fitted on, a subset of FEATURES, in the order of its values

    def __post_init__(self):
        unknown = [name for name in self.features if name not in ALL_FEATURES]
        if unknown or len(set(self.features)) != len(self.features) or not self.features:
            raise ValueError(f"RegionVerifier.features must be distinct names of ALL_FEATURES "
                             f"({', '.join(ALL_FEATURES)}), got {self.features}")
        for name in ("mean", "scale", "coef", "low", "high"):
            if len(getattr(self, name)) != len(self.features):
                raise ValueError(f"RegionVerifier.{name} needs {len(self.features)} values "
                                 f"({', '.join(self.features)}), got {len(getattr(self, name))}")
        if not all(s > 0 for s in self.scale):
            raise ValueError(f"RegionVerifier.scale must be > 0, got {self.scale}")
        if not all(lo <= hi for lo, hi in zip(self.low, self.high, strict=True)):
            raise ValueError(f"RegionVerifier.low must not exceed high, got {self.low} / {self.high}")
        for name in ("threshold", "last_look", "stall_look"):
            if not 0.0 < getattr(self, name) < 1.0:
                raise ValueError(f"RegionVerifier.{name} must be a probability in (0, 1), got "
                                 f"{getattr(self, name)}")

    @classmethod
    def from_dict(cls, fields: dict) -> RegionVerifier:
        """A model from its fields as dataclasses.asdict gives them (verifier.json's content): lists read as
        tuples. ValueError (naming them) for missing or unknown fields."""
        names = {f.name for f in dataclasses.fields(cls)}
        required = {f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING}
        unknown, missing = sorted(set(fields) - names), sorted(required - set(fields))
        if unknown or missing:
            raise ValueError(f"a verifier model needs the fields {', '.join(sorted(required))}; unknown: "
                             f"{', '.join(unknown) or 'none'}, missing: {', '.join(missing) or 'none'}")
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})

    @property
    def reads_oriented(self) -> bool:
        """Whether the model reads any of ORIENTED_FEATURES (else candidate_features may skip them)."""
        return any(name in ORIENTED_FEATURES for name in self.features)

    @property
    def reads_network(self) -> bool:
        """Whether the model reads NETWORK_FEATURES (then attend runs the impurity network on the view)."""
        return any(name in NETWORK_FEATURES for name in self.features)

    def probability(self, features: np.ndarray) -> np.ndarray:
        """(N, len(FEATURES)) or (N, len(ALL_FEATURES)) -> (N,) probabilities that each region is an impurity
        (the model reads its own `features` columns, so a model reading NETWORK_FEATURES needs rows of
        ALL_FEATURES; an unknown value, NaN, counts as that feature's fitted mean)."""
        columns = [ALL_FEATURES.index(name) for name in self.features]
        features = np.atleast_2d(np.asarray(features, dtype=np.float64))[:, columns]
        features = np.clip(features, self.low, self.high)  # NaN stays NaN
        z = np.nan_to_num((features - np.asarray(self.mean)) / np.asarray(self.scale), nan=0.0)
        logit = z @ np.asarray(self.coef) + self.intercept
        return 1.0 / (1.0 + np.exp(-logit))


def region_features(color: np.ndarray, height: np.ndarray, objects: np.ndarray, conspicuity: dict,
                    region: np.ndarray, oriented: bool = True,
                    planes: ViewPlanes | None = None) -> np.ndarray | None:
    """(len(REGION_FEATURES),) float64 of one region (module docstring). color (H, W, 3) uint8, height
    (H, W) float32 m, objects and region (H, W) bool (region not empty, within objects), conspicuity:
    VOCUS2's chromaticity-space maps by channel name ("I", "RG", "BY"), each (H, W) float32. None when no
    other object cell is in view: there is no product to compare with (attention then lets saliency
    decide alone). oriented False: ORIENTED_FEATURES are left 0, not computed (for a
    model that does not read them: they are the costliest). planes: the view's ViewPlanes when
    several regions of one view are read (computed here when None; the features are the same)."""
    region = np.asarray(region, dtype=bool)
    others = objects & ~region
    if not others.any():
        return None
    contrast = min(region_contrast(color, region, objects, MIN_SPREAD, SHADING, SATURATION), COLOUR_CAP)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * PRODUCT_MARGIN + 1,) * 2)
    product = objects & ~(cv2.dilate(region.astype(np.uint8), kernel) > 0)
    if not product.any():
        product = others
    ratios = {}
    for name in ("RG", "BY", "I"):
        plane = conspicuity[name]
        level = max(float(plane[product].mean()), MIN_CHANNEL_LEVEL)
        ratios[name] = math.log(max(float(plane[region].mean()) / level, MIN_RATIO))
    off_share = float(np.mean(off_colours(color, others, region)[region]))
    if planes is None:
        planes = ViewPlanes.of(color, height if oriented else None)
    offset, dark = lightness_features(color, region, product, planes)
    facing = oriented_features(color, height, region, product, planes) if oriented else (0.0, 0.0, 0.0)
    return np.array([math.log1p(contrast), ratios["RG"], ratios["BY"], ratios["I"], off_share,
                     float(np.std(height[region])), offset, dark, *facing])


def lightness_features(color: np.ndarray, region: np.ndarray, product: np.ndarray,
                       planes: ViewPlanes | None = None) -> tuple:
    """(lightness_offset, dark_share) of `region` against `product` (module docstring), both (H, W) bool,
    read on cells with no channel at or above SATURATION only: a clipped cell's lightness is unknown (a
    light product at a long exposure is all 255). (0.0, 0.0) when either has no such cell. planes: the
    view's ViewPlanes (computed here when None)."""
    if planes is None:
        planes = ViewPlanes.of(color)
    own = planes.lightness[region & planes.unclipped]
    reference = planes.lightness[product & planes.unclipped]
    if not own.size or not reference.size:
        return 0.0, 0.0
    offset = float((np.median(own) - np.median(reference)) / (np.std(reference) + 1e-3))
    return offset, float(np.mean(own < np.quantile(reference, DARK_QUANTILE)))


@dataclass(frozen=True)
class ViewPlanes:
    """What lightness_features and oriented_features read of a whole view, the same for every region of it
    (computed once per view by candidate_features). unclipped (H, W) bool: cells with no channel at or above
    SATURATION; lightness (H, W) float32: L, the log of the opponent intensity I (floor
    CHROMA_MIN_INTENSITY). For oriented_features only (None when built without a height map): readable
    (H, W) bool, cells with at least one channel below SATURATION; gx, gy (H, W) float32, the slopes of the
    heightmap smoothed by a Gaussian of SLOPE_SIGMA px (Sobel / 8: m per cell); chroma (H, W, 3) float32,
    log I (floor LOG_I_FLOOR), RG / I and BY / I (saliency.opponent_chromaticity)."""

    unclipped: np.ndarray
    lightness: np.ndarray
    readable: np.ndarray | None = None
    gx: np.ndarray | None = None
    gy: np.ndarray | None = None
    chroma: np.ndarray | None = None

    @classmethod
    def of(cls, color: np.ndarray, height: np.ndarray | None = None) -> ViewPlanes:
        """From a view's color (H, W, 3) uint8 and, for the oriented planes, height (H, W) m."""
        chroma = opponent_chromaticity(np.asarray(color))  # its I plane is opponent_colour's, unfloored
        below = np.asarray(color) < SATURATION
        lightness = np.log(np.maximum(chroma[..., 0], CHROMA_MIN_INTENSITY))
        if height is None:
            return cls(np.all(below, axis=-1), lightness)
        smooth = cv2.GaussianBlur(np.asarray(height, dtype=np.float32), (0, 0), SLOPE_SIGMA)
        return cls(np.all(below, axis=-1), lightness, readable=np.any(below, axis=-1),
                   gx=cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / 8.0,  # the fit is the same at any scale
                   gy=cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3) / 8.0,
                   chroma=np.concatenate([np.log(np.maximum(chroma[..., :1], LOG_I_FLOOR)), chroma[..., 1:]],
                                         axis=-1))


def oriented_features(color: np.ndarray, height: np.ndarray, region: np.ndarray,
                      product: np.ndarray, planes: ViewPlanes | None = None) -> tuple:
    """(oriented_contrast, oriented_lightness, oriented_off_share) of `region` against `product` (module
    docstring; both (H, W) bool, color (H, W, 3) uint8, height (H, W) m), read on cells with at least one
    channel below SATURATION: a cell clipped in every channel (a light product at a long exposure, all 255)
    says nothing about its face's orientation, while a face clipped in some channels (a blue product's lit
    faces turned cyan) still does. Unknown, (nan, nan, nan), with fewer than ORIENTED_MIN_PRODUCT such
    product cells or no such region cell: a model reads an unknown feature as its fitted mean
    (RegionVerifier.probability), where 0 would read as "like the product" to a model that weighs them.
    planes: ViewPlanes.of(color, height), passed when several regions of one view are read."""
    if planes is None or planes.chroma is None:
        planes = ViewPlanes.of(color, height)
    region, product = region & planes.readable, product & planes.readable
    if int(product.sum()) < ORIENTED_MIN_PRODUCT or not region.any():
        return math.nan, math.nan, math.nan

    def design(cells: np.ndarray) -> np.ndarray:
        x, y = planes.gx[cells].astype(np.float64), planes.gy[cells].astype(np.float64)
        return np.stack([np.ones_like(x), x, y, x * x, y * y, x * y], axis=1)

    own, reference = planes.chroma[region].astype(np.float64), planes.chroma[product].astype(np.float64)
    beta = np.linalg.lstsq(design(product), reference, rcond=None)[0]
    residual_p, residual_m = reference - design(product) @ beta, own - design(region) @ beta
    inverse = np.linalg.inv(np.cov(residual_p, rowvar=False) + ORIENTED_RIDGE * np.eye(3))
    mean = residual_m.mean(axis=0)
    distance = math.sqrt(max(float(mean @ inverse @ mean), 0.0))
    per_cell = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", residual_m, inverse, residual_m), 0.0))
    lightness = float(np.median(residual_m[:, 0]) / (np.std(residual_p[:, 0]) + 1e-3))
    return math.log1p(min(distance, COLOUR_CAP)), lightness, float(np.mean(per_cell > ORIENTED_OFF))


def context_features(objects: np.ndarray, regions: list, rank: int) -> np.ndarray:
    """(len(CONTEXT_FEATURES),) float64: region `rank` (0-based) among `regions` (salient regions, best
    first, not empty) in a view whose object cells are `objects` (module docstring)."""
    following = regions[1].score if len(regions) > 1 else regions[0].score / 2.0
    return np.array([float(rank), math.log(len(regions)),
                     math.log(regions[0].score / max(following, 1e-6)),
                     math.log(max(float(np.mean(objects)), 1e-6))])


def network_features(probability: np.ndarray, region: np.ndarray) -> np.ndarray:
    """(len(NETWORK_FEATURES),) float64 of `region` ((H, W) bool, not empty) on the impurity network's map
    `probability` ((H, W) in [0, 1], ImpurityNet.probability)."""
    values = np.asarray(probability)[np.asarray(region, dtype=bool)]
    return np.array([float(values.mean()), float(np.quantile(values, NETWORK_QUANTILE))])


def candidate_features(color: np.ndarray, height: np.ndarray, objects: np.ndarray, conspicuity: dict,
                       regions: list, oriented: bool = True, network=None) -> list:
    """[(region, features or None)] for the TOP_REGIONS best of `regions` (salient regions, best first): what
    attention scores and verifier-fit learns from; features (len(FEATURES),) float64, or (len(ALL_FEATURES),)
    with a network. Arguments as region_features; network: an impurity_net.ImpurityNet run once on the view
    for NETWORK_FEATURES (None: rows without them, and torch is not needed)."""
    candidates = []
    planes = ViewPlanes.of(color, height if oriented else None)
    probability = None if network is None or not regions else network.probability(color, height, objects)
    for rank, region in enumerate(regions[:TOP_REGIONS]):
        own = region_features(color, height, objects, conspicuity, region.mask, oriented, planes)
        row = None if own is None else np.concatenate([own, context_features(objects, regions, rank)])
        if row is not None and probability is not None:
            row = np.concatenate([row, network_features(probability, region.mask)])
        candidates.append((region, row))
    return candidates


SHIPPED_VERIFIER = "verifier.json"  # the shipped model, beside the impurity network (checkpoints.py)
SOURCE_VERIFIER = SOURCE_CHECKPOINTS / SHIPPED_VERIFIER  # its copy in the source tree


def read_verifier(path=None) -> RegionVerifier:
    """The model in the JSON file `path` (None: the shipped one, checkpoints.shipped_path(SHIPPED_VERIFIER)):
    an object of RegionVerifier's fields (write_verifier). ValueError naming the file for a file that is not
    such a model; OSError when it cannot be read."""
    path = pathlib.Path(path) if path is not None else shipped_path(SHIPPED_VERIFIER)
    try:
        return RegionVerifier.from_dict(json.loads(path.read_text()))
    except (ValueError, TypeError) as error:
        raise ValueError(f"verifier model {path}: {error}") from None


def write_verifier(model: RegionVerifier, path) -> None:
    """Write `model` to the JSON file `path` (read_verifier reads it back equal): one line per field."""
    fields = dataclasses.asdict(model)
    lines = [f"  {json.dumps(name)}: {json.dumps(list(value) if isinstance(value, tuple) else value)}"
             for name, value in fields.items()]
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("{\n" + ",\n".join(lines) + "\n}\n")


@functools.cache
def default_verifier() -> RegionVerifier:
    """The shipped model (read_verifier()), read once per process."""
    return read_verifier()
