"""The attention module (paper Algorithm 1) on one colour + height map pair.

    salient regions m_0..m_k <- VOCUS2 saliency of the colour heightmap
    if the best region m_t is contrasted enough:  TARGET, 112 x 112 crops centred on the target, mask =
                                                  m_t grown to the whole target object
    elif DBSCAN finds a cluster c_t that can hide something:  OCCLUDED_REGION, crops centred on c_t,
                                                              all-one mask
    else:  NONE (no visible impurity and nowhere one could hide)

Saliency runs on the orthographic colour heightmap (224 x 224), not on the camera image: the crops
are cut from the heightmaps anyway, the map is 6x smaller, and 1 px = 2 mm everywhere.

Cell-specific choices on top of the paper, all parameters (see AttentionParams):
- `background`: before saliency, cells that are table (lower than `density.occupied_height`) or
  unseen are painted with the median colour of the objects. The saliency of an object then measures
  its contrast against the other objects - the product - and not against the table, so an isolated
  product block is not mistaken for an impurity ("table" keeps the plain heightmap, as the paper;
  on the tuning scenes it halves the margin between targets and clean scenes).
- salient regions are restricted to object cells, and a region must cover `min_region_area`.
- the target mask is m_t grown to the whole object (`mask_chroma_tolerance`): m_t alone is often
  only the most contrasted part of the target, and the policy uses the mask as "where the target is".
- the decision is relative to the scene (`contrast = "relative"`, issue 17): saliency runs on lightness
  and shading-free chromaticity (I, RG / I, BY / I: a lit and a shaded face of one block have the same
  chromaticity, so block shading does not read as colour contrast), and each conspicuity map is
  divided by its own mean over the object cells - the product's typical contrast in
  that channel - and the relative saliency is their maximum. A region is an impurity when its mean
  relative saliency reaches `min_relative_contrast`: "this much more contrasted than the product usually
  is", whatever the product's colour and the exposure (a brighter or darker image scales every
  conspicuity map alike; the ratio is unchanged). Taking the maximum over channels keeps an impurity
  that differs from the product in one channel only (lightness: slate in coal; hue: a green flake among
  blue ones) from being averaged away by the shading contrast every product block has in I.
  `contrast = "absolute"` is the earlier rule (mean saliency >= `min_target_contrast`, opponent-colour
  units, calibrated for red among blue only).
- `decision = "verifier"` (the default since the eighth session): instead of those thresholds on the best
  region, a learned region verifier (verifier.py, a logistic model of fifteen scene-relative features,
  fitted on tuning palettes only) scores the best three regions and the most probable one is the target
  when it reaches the model's threshold; `decision = "rule"` keeps the thresholds.
The thresholds and the verifier are calibrated on rendered tuning scenes by scripts/calibrate_attention.py.

DBSCAN only runs when no target is visible: Algorithm 1 uses its result only then, and it is the
more expensive half.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import cv2
import numpy as np

from impurity_common import cell
from impurity_common.cell import crop_centered  # noqa: F401 (part of this module's API)
from impurity_common.colour import ProductReference, mask_colour
from impurity_common.enums import AttentionMode  # AttentionResult.MODE_* (re-exported)
from impurity_common.grid import HeightmapGrid

from .density import Cluster, DensityParams, find_clusters, select_occluded_region
from .saliency import (
    CELL_SALIENCY,
    CHANNELS,
    CHROMA_MIN_INTENSITY,
    MIN_CHANNEL_LEVEL,
    SaliencyParams,
    normalised,
    opponent_chromaticity,
    opponent_colour,
    vocus2,
)
from .verifier import RegionVerifier, candidate_features, default_verifier

CANDIDATE_FRACTION = 0.5  # relative_saliency: the peak's region, cells above this x the peak
CANDIDATE_GROWTH = 4  # px (8 mm) around the peak's region also left out of the product level
MIN_PRODUCT_SHARE = 0.25  # fewer object cells than this share left for the level: keep the first pass
MASK_PRODUCT_MARGIN = 6  # px around the salient region left out of the product's colour (grow_target_mask)
MEDIAN_SAMPLES = 2000  # object cells sampled for the objects' median colour


@dataclass(frozen=True)
class AttentionParams:
    saliency: SaliencyParams = CELL_SALIENCY
    density: DensityParams = DensityParams()
    crop_size: int = cell.CROP_SIZE
    region_fraction: float = 0.5  # a salient region: connected object cells >= this x the peak saliency
    min_region_area: int = 30  # px (2 mm cells): smaller regions are specks, not objects
    # the lightness map's weight against the two chromatic ones (relative_saliency). Every product block has
    # shading contrast in I and none in RG / I, BY / I, so a heap of product reads as salient in I.
    # scripts/calibrate_attention.py, tuning palettes: at 5 % false TARGET, weight 1.0 finds 88.4 % of the
    # impurities, 0.7 93.9 %.
    lightness_weight: float = 0.7
    # a lone salient region with no other object cell in view (nothing for the verifier to compare it with)
    # is a target from this mean relative saliency on. Chosen by scripts/calibrate_attention.py on tuning
    # palettes: 93.5 % found at 3.2 % false TARGET.
    min_relative_contrast: float = 4.4
    # The target mask: object cells connected to m_t whose shading-free chroma (RG, BY divided by
    # intensity) lies within this distance of m_t's.
    mask_chroma_tolerance: float = 0.5
    # the verifier's last look before NONE: with no heap that could hide an impurity left, the likeliest
    # region is attended as a TARGET from this probability on (the grasp verdict judges what was lifted).
    verifier_last_look: float = 0.391
    # the verifier's threshold on a stall look (attend's closer=True, asked for by the picking loop after
    # pushes that found nothing).
    stall_look_threshold: float = 0.134
    verifier: RegionVerifier | None = None  # None: the shipped model (verifier_model.py)
    # the impurity network (impurity_net.ImpurityNet) a model that reads NETWORK_FEATURES runs on the view;
    # None: the shipped weights (impurity_net.SHIPPED_NETWORK), read once.
    impurity_net: object = None
    # with a known_product (product_memory.known_product) handed to attend, while a heap that could hide a
    # target is left: a region whose grown mask's median colour lies within known_product_delta_e (CIE76) of
    # more than known_product_max_share of the remembered product colours is product, whatever its
    # probability; the next likeliest region is judged instead.
    known_product_delta_e: float = 4.0
    known_product_max_share: float = 0.01

    def __post_init__(self):
        if self.crop_size < 2 or self.crop_size % 2:
            raise ValueError(f"crop_size must be even and >= 2, got {self.crop_size}")
        if not 0.0 < self.verifier_last_look < 1.0:
            raise ValueError(f"verifier_last_look must be a probability in (0, 1), got "
                             f"{self.verifier_last_look}")
        if not 0.0 < self.stall_look_threshold < 1.0:
            raise ValueError(f"stall_look_threshold must be a probability in (0, 1), got "
                             f"{self.stall_look_threshold}")
        if not self.known_product_delta_e > 0.0:
            raise ValueError(f"known_product_delta_e must be > 0 (CIE76 dE), got "
                             f"{self.known_product_delta_e}")
        if not 0.0 <= self.known_product_max_share < 1.0:
            raise ValueError(f"known_product_max_share must be a share in [0, 1), got "
                             f"{self.known_product_max_share}")
        if not 0.0 < self.lightness_weight <= 1.0:
            raise ValueError(f"lightness_weight must be in (0, 1], got {self.lightness_weight}")
        if not 0.0 < self.region_fraction < 1.0:
            raise ValueError(f"region_fraction must be in (0, 1), got {self.region_fraction}")
        if not self.mask_chroma_tolerance > 0.0:
            raise ValueError(f"mask_chroma_tolerance must be > 0, got {self.mask_chroma_tolerance}")


@dataclass
class SalientRegion:
    mask: np.ndarray  # (rows, cols) bool
    area: int  # px
    score: float  # mean saliency over the region
    peak: float
    centroid: tuple  # (row, col) float


@dataclass
class AttentionOutput:
    mode: AttentionMode
    score: float  # TARGET: mean saliency of m_t; OCCLUDED_REGION: cluster height (m); NONE: 0
    center: tuple  # (row, col) heightmap pixel of the crop centre
    center_xy: tuple  # (x, y) base_link, m
    crop_origin: tuple  # (row0, col0) heightmap pixel of the crop's (0, 0); may be negative
    color_crop: np.ndarray  # (S, S, 3) uint8, zero-padded outside the map
    height_crop: np.ndarray  # (S, S) float32 m
    mask: np.ndarray  # (S, S) uint8: 255 on m_t (TARGET), all 255 (OCCLUDED_REGION), 0 (NONE)
    saliency: np.ndarray  # (rows, cols) float32, the full saliency map
    regions: list = field(default_factory=list)  # SalientRegion, best first
    clusters: list = field(default_factory=list)  # Cluster, best first (empty when not computed)
    target_region: SalientRegion | None = None  # m_t, the salient region
    target_mask: np.ndarray | None = None  # (rows, cols) bool: m_t grown to the whole target object(s)
    cluster: Cluster | None = None
    reason: str = ""  # one line: why this mode
    last_look: bool = False  # TARGET from a last look (no heap left; the decision itself said no target)


def sanitize(color: np.ndarray, height: np.ndarray) -> tuple:
    """Check shapes and types; NaN/inf heights become 0 (unseen), negative heights 0 (table)."""
    if color.ndim != 3 or color.shape[2] != 3 or color.dtype != np.uint8:
        raise ValueError(f"colour heightmap must be (H, W, 3) uint8, got {color.shape} {color.dtype}")
    if height.shape != color.shape[:2]:
        raise ValueError(f"height map {height.shape} does not match colour map {color.shape[:2]}")
    height = np.nan_to_num(height.astype(np.float32, copy=False), nan=0.0, posinf=0.0, neginf=0.0)
    return color, np.maximum(height, 0.0)


def saliency_input(color: np.ndarray, objects: np.ndarray) -> np.ndarray:
    """The image VOCUS2 sees: non-object cells take the objects' median colour, so that contrast is
    measured against the product, not the table."""
    if not np.any(objects):
        return color
    object_colors = color[objects]
    # the median of at most ~2000 evenly spread object cells: the same colour, a fifth of the time
    step = max(1, len(object_colors) // MEDIAN_SAMPLES)
    painted = color.copy()
    painted[~objects] = np.median(object_colors[::step], axis=0).astype(np.uint8)
    return painted


def relative_saliency(conspicuity: dict, objects: np.ndarray, lightness_weight: float = 1.0) -> np.ndarray:
    """(H, W) float32: max over the I, RG, BY conspicuity maps of each map divided by its product level,
    the map's mean over the object cells (module docstring). Dimensionless: 1 = as contrasted as the
    product on average. Two passes: the region around the first pass's peak (connected cells >=
    CANDIDATE_FRACTION of the peak, grown by CANDIDATE_GROWTH px) is left out of the levels of the
    second, so that an impurity covering much of a sparse scene does not set the level it is judged
    against (with the mean over all objects, an impurity covering a share f of them scores at most 1/f).
    """
    if not np.any(objects):
        return np.zeros(objects.shape, np.float32)
    weights = {"I": lightness_weight, "RG": 1.0, "BY": 1.0}
    first = _relative(conspicuity, objects, weights)
    peak = np.unravel_index(int(np.argmax(np.where(objects, first, -1.0))), first.shape)
    above = (objects & (first >= CANDIDATE_FRACTION * float(first[peak]))).astype(np.uint8)
    _, labels = cv2.connectedComponents(above, connectivity=8)
    candidate = labels == labels[peak]
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * CANDIDATE_GROWTH + 1,) * 2)
    product = objects & ~(cv2.dilate(candidate.astype(np.uint8), kernel) > 0)
    if np.count_nonzero(product) < MIN_PRODUCT_SHARE * np.count_nonzero(objects):
        return first  # nearly everything stands out: no product to compare with
    return _relative(conspicuity, product, weights)


def _relative(conspicuity: dict, reference: np.ndarray, weights: dict) -> np.ndarray:
    planes = []
    for name in CHANNELS:
        plane = conspicuity[name]
        planes.append(weights[name] * plane / max(float(plane[reference].mean()), MIN_CHANNEL_LEVEL))
    return np.max(planes, axis=0).astype(np.float32)


def scene_saliency(color: np.ndarray, objects: np.ndarray, params: AttentionParams) -> np.ndarray:
    """The relative saliency map (H, W) float32 the decision reads (dimensionless)."""
    return scene_maps(color, objects, params)[0]


def scene_maps(color: np.ndarray, objects: np.ndarray, params: AttentionParams) -> tuple:
    """(relative saliency (H, W) float32, conspicuity): VOCUS2's chromaticity-space conspicuity maps by
    channel name ("I", "RG", "BY"; the verifier's features)."""
    image = saliency_input(color, objects)
    maps = vocus2(image, params.saliency, keep_features=True, colour_space="chromaticity")
    return relative_saliency(maps.conspicuity, objects, params.lightness_weight), maps.conspicuity


def salient_regions(saliency: np.ndarray, objects: np.ndarray, params: AttentionParams) -> list:
    """Connected object cells at >= region_fraction x the peak saliency, best (mean saliency) first."""
    if not np.any(objects):
        return []
    peak = float(saliency[objects].max())
    if peak <= 0.0:
        return []
    candidate = (objects & (saliency >= params.region_fraction * peak)).astype(np.uint8)
    count, labels, stats, centroids = cv2.connectedComponentsWithStats(candidate, connectivity=8)
    regions = []
    for label in range(1, count):
        area = int(stats[label, cv2.CC_STAT_AREA])
        if area < params.min_region_area:
            continue
        mask = labels == label
        values = saliency[mask]
        regions.append(SalientRegion(mask=mask, area=area, score=float(values.mean()),
                                     peak=float(values.max()),
                                     centroid=(float(centroids[label][1]), float(centroids[label][0]))))
    regions.sort(key=lambda r: r.score, reverse=True)
    return regions


def chroma(color: np.ndarray) -> np.ndarray:
    """(H, W, 2): opponent RG and BY divided by intensity - the same for a lit and a shaded face of
    one object, different for objects of different colour."""
    return opponent_chromaticity(color)[..., 1:]


def grow_target_mask(color: np.ndarray, objects: np.ndarray, region: SalientRegion,
                     tolerance: float, reach: int) -> np.ndarray:
    """The whole object(s) behind a salient region: object cells of the region's colour, connected
    to the region and at most `reach` cells from its centroid (so a look-alike pile cannot drag the
    crop away). The salient region alone is often just the most contrasted part of a target.
    "Of the region's colour": within `tolerance` of the region's median chroma (RG / I, BY / I), and
    nearer to the region's median colour than to the product's (the objects outside the region), in
    (RG / I, BY / I, log I) - a nearest-centroid test that needs no palette-specific threshold, so a
    lighter slate among coal of nearly the same chroma does not grow into the coal."""
    values = chroma(color)
    reference = np.median(values[region.mask], axis=0)
    similar = objects & (np.linalg.norm(values - reference, axis=2) <= tolerance)
    features = np.concatenate([values, np.log(np.maximum(opponent_colour(color)[..., :1],
                                                         CHROMA_MIN_INTENSITY))], axis=2)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * MASK_PRODUCT_MARGIN + 1,) * 2)
    product = objects & ~(cv2.dilate(region.mask.astype(np.uint8), kernel) > 0)
    if np.any(product):
        target_colour = np.median(features[region.mask], axis=0)
        product_colour = np.median(features[product], axis=0)
        similar &= (np.linalg.norm(features - target_colour, axis=2)
                    < np.linalg.norm(features - product_colour, axis=2))
    rows, cols = np.ogrid[:color.shape[0], :color.shape[1]]
    similar &= (np.abs(rows - region.centroid[0]) <= reach) & (np.abs(cols - region.centroid[1]) <= reach)
    # the region's own cells count only where they share its colour: a wide saliency blur lets the
    # region spill onto the product around the impurity
    count, labels = cv2.connectedComponents(similar.astype(np.uint8), connectivity=8)
    touched = np.unique(labels[region.mask & similar])
    grown = np.isin(labels, touched[touched > 0])
    return grown if grown.any() else region.mask


def attend(color: np.ndarray, height: np.ndarray, params: AttentionParams = AttentionParams(),
           grid: HeightmapGrid = HeightmapGrid(),
           known_product: ProductReference | None = None, closer: bool = False) -> AttentionOutput:
    """Algorithm 1 on a colour heightmap (H, W, 3) uint8 and a height map (H, W) float32 m. known_product: the
    colours of an earlier view that showed product only (product_memory); with a heap left, a region coloured
    like them is not a target (AttentionParams.known_product_max_share). closer: a stall look (the picking
    loop's, after pushes that found nothing): the verifier's threshold is AttentionParams.stall_look_threshold
    and the reason says "(stall look)"."""
    color, height = sanitize(color, height)
    objects = height > params.density.occupied_height
    saliency, conspicuity = scene_maps(color, objects, params)
    regions = salient_regions(saliency, objects, params)
    best = regions[0] if regions else None

    @functools.cache
    def dense_clusters() -> list:
        """The height map's dense clusters (density.find_clusters), computed once."""
        return find_clusters(height, grid.resolution, params.density)

    masks: dict = {}

    def grown(region: SalientRegion) -> np.ndarray:
        """`region`'s mask grown to the whole object (grow_target_mask), computed once per region."""
        if id(region) not in masks:
            masks[id(region)] = grow_target_mask(color, objects, region, params.mask_chroma_tolerance,
                                                 reach=params.crop_size // 2)
        return masks[id(region)]

    def target(region: SalientRegion, reason: str, clusters=(), looked: bool = False) -> AttentionOutput:
        """TARGET on `region`, its mask grown to the whole object; looked: given as a last look."""
        target_cells = grown(region)
        rows, cols = np.nonzero(target_cells)
        return _output(AttentionMode.TARGET, region.score, (rows.mean(), cols.mean()), color, height,
                       saliency, params, grid, regions=regions, clusters=clusters, target_region=region,
                       mask_cells=target_cells, reason=reason, last_look=looked)

    last_look_region = None  # (the likeliest region, why), when a last look may take it
    no_target = "no salient region"
    if regions:
        model = params.verifier or default_verifier()
        least, view = model.threshold, ""
        if closer:
            least, view = params.stall_look_threshold, " (stall look)"
        network = (params.impurity_net or shipped_network()) if model.reads_network else None
        candidates, features = zip(*candidate_features(color, height, objects, conspicuity, regions,
                                                       oriented=model.reads_oriented, network=network),
                                   strict=True)
        if features[0] is None:  # one region, every object in view: nothing to compare with, so
            # saliency decides alone
            probability = np.array([1.0 if best.score >= params.min_relative_contrast else 0.0])
        else:
            probability = model.probability(np.array(features))
        known = ""  # regions passed over as the known product's colour
        order = [int(i) for i in np.argsort(-probability, kind="stable")]
        if known_product is not None and select_occluded_region(dense_clusters()) is not None:
            for i in list(order):
                share = known_product.share_near(mask_colour(color, grown(candidates[i])),
                                                 params.known_product_delta_e)
                if share > params.known_product_max_share:
                    order.remove(i)
                    known += (f"; region {i + 1} ({probability[i]:.2f}) coloured like "
                              f"{100 * share:.1f} % of the known product > "
                              f"{100 * params.known_product_max_share:.1f} %")
                else:
                    break  # the likeliest region left decides: the others' masks need not be grown
        if not order:
            order, probability = [0], np.zeros(len(candidates))
        k = order[0]
        if probability[k] >= least:
            return target(candidates[k], f"salient region {k + 1} of {len(regions)} "
                                         f"({candidates[k].area} px): impurity probability "
                                         f"{probability[k]:.2f} >= {least:.2f}{view}{known}")
        no_target = (f"no salient region is an impurity: the likeliest, region {k + 1} of "
                     f"{len(regions)}, {probability[k]:.2f} < {least:.2f}{view}{known}")
        if params.verifier_last_look <= probability[k]:
            last_look_region = (candidates[k], f"last look (no heap could hide an impurity): salient "
                                               f"region {k + 1} of {len(regions)} ({candidates[k].area} "
                                               f"px): impurity probability {probability[k]:.2f} >= "
                                               f"{params.verifier_last_look:.2f}")
    clusters = dense_clusters()
    chosen = select_occluded_region(clusters)
    if chosen is None and last_look_region is not None:
        return target(*last_look_region, clusters, looked=True)
    if chosen is not None:
        return _output(AttentionMode.OCCLUDED_REGION, chosen.height, chosen.centroid, color, height,
                       saliency, params, grid, regions=regions, clusters=clusters, cluster=chosen,
                       reason=f"{no_target}; cluster of {chosen.area * 1e4:.1f} cm^2, "
                              f"{chosen.height * 100:.1f} cm high")
    why_not = ("no dense cluster" if not clusters else
               f"largest cluster {clusters[0].area * 1e4:.1f} cm^2, {clusters[0].height * 100:.1f} cm high "
               f"is too small or too low to hide a target")
    centre = ((height.shape[0] - 1) / 2.0, (height.shape[1] - 1) / 2.0)
    return _output(AttentionMode.NONE, 0.0, centre, color, height, saliency, params, grid,
                   regions=regions, clusters=clusters, reason=f"{no_target}; {why_not}")


@functools.cache
def shipped_network():
    """The shipped impurity network (impurity_net.read_network()), read once per process; torch is imported
    only here, when a model reads NETWORK_FEATURES."""
    from .impurity_net import read_network
    return read_network()


def _output(mode, score, centroid, color, height, saliency, params, grid, regions=(), clusters=(),
            target_region=None, cluster=None, mask_cells=None, reason="", last_look=False) -> AttentionOutput:
    size = params.crop_size
    center_row, center_col = int(round(centroid[0])), int(round(centroid[1]))
    color_crop, origin = crop_centered(color, center_row, center_col, size)
    height_crop, _ = crop_centered(height, center_row, center_col, size)
    if mode == AttentionMode.TARGET:
        mask, _ = crop_centered(mask_cells.astype(np.uint8) * np.uint8(255), center_row, center_col, size)
    elif mode == AttentionMode.OCCLUDED_REGION:
        mask = np.full((size, size), 255, dtype=np.uint8)
    else:
        mask = np.zeros((size, size), dtype=np.uint8)
    return AttentionOutput(
        mode=mode, score=float(score), center=(center_row, center_col),
        center_xy=grid.pixel_to_base(center_row, center_col), crop_origin=origin,
        color_crop=color_crop, height_crop=height_crop.astype(np.float32), mask=mask, saliency=saliency,
        regions=list(regions), clusters=list(clusters), target_region=target_region,
        target_mask=mask_cells if mode == AttentionMode.TARGET else None, cluster=cluster,
        reason=reason, last_look=last_look)


MODE_COLORS = {AttentionMode.TARGET: (255, 40, 40), AttentionMode.OCCLUDED_REGION: (255, 200, 0),
               AttentionMode.NONE: (128, 128, 128)}


def debug_image(color: np.ndarray, output: AttentionOutput, alpha: float = 0.5) -> np.ndarray:
    """RGB picture for rqt / Foxglove: the colour heightmap blended with the (normalised) saliency
    map, the chosen crop box, the target region or cluster outline, and the mode as text."""
    heat = cv2.applyColorMap((normalised(output.saliency) * 255).astype(np.uint8), cv2.COLORMAP_JET)
    heat = cv2.cvtColor(heat, cv2.COLOR_BGR2RGB)
    picture = cv2.addWeighted(color, 1.0 - alpha, heat, alpha, 0.0)
    outline = None
    if output.target_mask is not None:
        outline = output.target_mask
    elif output.cluster is not None:
        outline = output.cluster.mask
    if outline is not None:
        contours, _ = cv2.findContours(outline.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(picture, contours, -1, (255, 255, 255), 1)
    color_box = MODE_COLORS[output.mode]
    if output.mode != AttentionMode.NONE:
        row0, col0 = output.crop_origin
        size = output.mask.shape[0]
        cv2.rectangle(picture, (col0, row0), (col0 + size - 1, row0 + size - 1), color_box, 2)
    cv2.putText(picture, output.mode.name, (3, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, color_box, 1, cv2.LINE_AA)
    why = reason_summary(output.reason)
    if why:
        cv2.putText(picture, why, (3, picture.shape[0] - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.3, (255, 255, 255),
                    1, cv2.LINE_AA)
    return picture


REASON_CHARS = 48  # debug_image: the reason's first clause, cut to what fits a 224 px picture


def reason_summary(reason: str) -> str:
    """The first clause of an AttentionOutput.reason (up to ';'), cut to REASON_CHARS, for the overlay:
    e.g. "salient region 2 of 5 (412 px): impurity probability 0.91 >= 0.76" keeps its probability."""
    first = reason.split(";")[0].strip()
    if len(first) <= REASON_CHARS:
        return first
    return "..." + first[-(REASON_CHARS - 3):]  # the end holds the figures that decided


def target_opponent_colour(color: np.ndarray, region: SalientRegion) -> np.ndarray:
    """Mean (I, RG, BY) of a region: what made it stand out (for logs and calibration)."""
    return opponent_colour(color)[region.mask].mean(axis=0)
