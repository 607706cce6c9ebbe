"""The attention module (paper Algorithm 1) on one colour + height map pair, as a pipeline of stages:

    regions   find_regions: VOCUS2 saliency of the colour heightmap, relative to the product's own
              contrast; salient regions m_0..m_k of object cells, best first
    verifier  verify: a learned region verifier (verifier.py) scores the best TOP_REGIONS regions; the
              likeliest is the target when it reaches the model's threshold (decision_threshold: the
              stall look's, on attend's closer=True)
    product   pass_over_known_product: with a known product and a heap left, a region coloured like the
              memory   product is passed over and the next likeliest judged
    heaps     Heaps: DBSCAN clusters of the height map; the largest that could hide an impurity is the
              OCCLUDED_REGION
    looks     with no target and no heap, the likeliest region is still a TARGET from the model's last
              look on (last_look); else NONE

A TARGET's crops (112 x 112) are centred on the target and its mask is m_t grown to the whole object
(grow_target_mask); an OCCLUDED_REGION's are centred on the cluster with an all-one mask.

Saliency runs on the orthographic colour heightmap (224 x 224, 1 px = 2 mm), not on the camera image: the
crops are cut from the heightmaps anyway and the map is 6x smaller. Before saliency, cells that are table
or unseen take the objects' median colour (saliency_input), so that an object's saliency is its contrast
against the other objects - the product - and not against the table. Saliency is relative to the scene
(relative_saliency): VOCUS2 runs on lightness and shading-free chromaticity (I, RG / I, BY / I), each
conspicuity map is divided by its mean over the object cells and the maximum over channels is taken, so
neither the product's colour nor the exposure sets the scale.
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
from impurity_common.parameters import check_fields, param

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
from .unknown_height import UNKNOWN_HEIGHT, unknown_regions
from .verifier import RegionVerifier, candidate_features, default_verifier

CANDIDATE_FRACTION = 0.5  # relative_saliency: the peak's region, cells above this x the peak
CANDIDATE_GROWTH = 4  # px (8 mm) around the peak's region also left out of the product level
MIN_PRODUCT_SHARE = 0.25  # fewer object cells than this share left for the level: keep the first pass
MASK_PRODUCT_MARGIN = 6  # px around the salient region left out of the product's colour (grow_target_mask)
MEDIAN_SAMPLES = 2000  # object cells sampled for the objects' median colour


@dataclass(frozen=True)
class AttentionParams:
    """Every setting of attend; the ROS parameters of the attention node (bringup/config/cell.yaml, section
    attention), but for the model objects (ros=False)."""

    saliency: SaliencyParams = CELL_SALIENCY
    density: DensityParams = DensityParams()
    crop_size: int = param(cell.CROP_SIZE, "Side of the target- and cluster-centric crops (cells)",
                           low=2, high=2 * cell.HEIGHTMAP_SIZE, step=2)
    region_fraction: float = param(0.5, "A salient region: connected object cells at >= this x the peak "
                                   "saliency", low=0.01, high=0.99)
    min_region_area: int = param(30, "Smallest salient region (cells of 2 mm): smaller ones are specks",
                                 low=1, high=cell.HEIGHTMAP_SIZE ** 2)
    # chosen on rendered scenes of the tuning palettes: at 5 % false TARGET, 1.0 finds 88.4 %, 0.7 93.9 %
    lightness_weight: float = param(0.7, "Weight of the lightness conspicuity map against the chromatic ones "
                                    "(product shading is salient in lightness only)", low=0.01, high=1.0)
    # chosen on rendered scenes of the tuning palettes: 93.5 % found at 3.2 % false TARGET
    min_relative_contrast: float = param(4.4, "A lone salient region with no other object in view (nothing "
                                         "for the verifier to compare it with) is a target from this mean "
                                         "relative saliency on", low=0.0)
    mask_chroma_tolerance: float = param(0.5, "Target mask: object cells connected to the salient region "
                                         "whose chroma (RG / I, BY / I) lies within this of the region's",
                                         low=0.001)
    known_product_delta_e: float = param(4.0, "With a known product and a heap left: CIE76 distance within "
                                         "which a product colour counts as a region's colour", low=0.1,
                                         high=100.0)
    # delta_e 4, share 1 %: on invisible tuning episodes, 98 % of the TARGET grasps on a target kept and 90 %
    # of those on product caught
    known_product_max_share: float = param(0.01, "With a known product and a heap left: a region coloured "
                                           "like more than this share of it is passed over", low=0.0,
                                           high=0.999)
    verifier: RegionVerifier | None = param(None, "The region verifier; None: the shipped model "
                                            "(verifier.default_verifier)", ros=False)
    impurity_net: object = param(None, "The impurity network (impurity_net.ImpurityNet) a model reading "
                                 "NETWORK_FEATURES runs; None: the shipped weights", ros=False)

    def __post_init__(self):
        check_fields(self)


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
    height: np.ndarray | None = None  # (rows, cols) float32 m: the height map the decision read (unknown
    #                                   regions at UNKNOWN_HEIGHT, other unknown cells 0)


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


# ------------------------------------------------------------------------------------------ the stages
@dataclass
class Scene:
    """A view as the stages read it (find_regions): color (H, W, 3) uint8, height (H, W) float32 m (NaN and
    negative heights 0), objects (H, W) bool, saliency (H, W) float32 relative saliency, conspicuity
    VOCUS2's chromaticity-space maps by channel name, regions SalientRegion best first."""

    color: np.ndarray
    height: np.ndarray
    objects: np.ndarray
    saliency: np.ndarray
    conspicuity: dict
    regions: list


def find_regions(color: np.ndarray, height: np.ndarray, params: AttentionParams) -> Scene:
    """The regions stage: a checked view (sanitize; ValueError for bad shapes or types), its object cells
    (higher than params.density.occupied_height), relative saliency and salient regions."""
    color, height = sanitize(color, height)
    objects = height > params.density.occupied_height
    saliency, conspicuity = scene_maps(color, objects, params)
    return Scene(color, height, objects, saliency, conspicuity, salient_regions(saliency, objects, params))


@dataclass
class Verdict:
    """The verifier's reading of a view's best regions (verify): candidates, up to verifier.TOP_REGIONS
    SalientRegions best first; probability (len(candidates),) float64 that each is an impurity; order, the
    candidates' indices from the likeliest (stable on ties)."""

    candidates: tuple
    probability: np.ndarray
    order: list


def verify(scene: Scene, params: AttentionParams, model: RegionVerifier) -> Verdict:
    """The verifier stage on a scene with at least one region. A lone region with every object cell in it
    has nothing to compare with: it is an impurity (probability 1) when its mean relative saliency reaches
    params.min_relative_contrast, else 0."""
    network = (params.impurity_net or shipped_network()) if model.reads_network else None
    rows = candidate_features(scene.color, scene.height, scene.objects, scene.conspicuity, scene.regions,
                              oriented=model.reads_oriented, network=network)
    candidates, features = zip(*rows, strict=True)
    if features[0] is None:
        probability = np.array([1.0 if scene.regions[0].score >= params.min_relative_contrast else 0.0])
    else:
        probability = model.probability(np.array(features))
    return Verdict(candidates, probability, [int(i) for i in np.argsort(-probability, kind="stable")])


def decision_threshold(model: RegionVerifier, closer: bool) -> tuple:
    """(least probability of a target, what the reason adds): the model's threshold, or on a stall look
    (closer) the model's stall_look and " (stall look)"."""
    return (model.stall_look, " (stall look)") if closer else (model.threshold, "")


def last_look(probability: float, model: RegionVerifier) -> bool:
    """Whether the likeliest region, no target, is taken all the same when no heap could hide an impurity:
    from the model's last_look on (one grasp at the most suspicious object before the scene is called
    clean; the grasp verdict judges what was lifted)."""
    return probability >= model.last_look


def pass_over_known_product(verdict: Verdict, known_product: ProductReference, colour_of,
                            params: AttentionParams) -> tuple:
    """The product-memory stage: (order, probability, note). From the likeliest on, a candidate whose colour
    (colour_of(index) -> (3,) L*a*b*: its grown mask's median colour, colour.mask_colour) lies within
    params.known_product_delta_e of more than params.known_product_max_share of the known product's colours
    is left out of the order, and the first one that is not stops the pass (the others' masks are not
    read). With every candidate left out, the order is [0] at probability 0. note: the reason's account of
    the regions passed over ("" for none)."""
    order, note = list(verdict.order), ""
    for i in list(order):
        share = known_product.share_near(colour_of(i), params.known_product_delta_e)
        if share > params.known_product_max_share:
            order.remove(i)
            note += (f"; region {i + 1} ({verdict.probability[i]:.2f}) coloured like {100 * share:.1f} % of "
                     f"the known product > {100 * params.known_product_max_share:.1f} %")
        else:
            break
    if not order:
        return [0], np.zeros(len(verdict.candidates)), note
    return order, verdict.probability, note


class Heaps:
    """The heaps stage: the height map's DBSCAN clusters (density.find_clusters), computed once, when first
    read; occluded_region is the best cluster that could hide an impurity, or None."""

    def __init__(self, height: np.ndarray, resolution: float, params: DensityParams):
        self._height, self._resolution, self._params = height, resolution, params

    @functools.cached_property
    def clusters(self) -> list:
        return find_clusters(self._height, self._resolution, self._params)

    @property
    def occluded_region(self) -> Cluster | None:
        return select_occluded_region(self.clusters)


def attend(color: np.ndarray, height: np.ndarray, params: AttentionParams = AttentionParams(),
           grid: HeightmapGrid = HeightmapGrid(),
           known_product: ProductReference | None = None, closer: bool = False,
           unknown: np.ndarray | None = None) -> AttentionOutput:
    """Algorithm 1 on a colour heightmap (H, W, 3) uint8 and a height map (H, W) float32 m (module docstring).
    known_product: the colours of an earlier view that showed product only (product_memory); closer: a stall
    look (the picking loop's, after pushes that found nothing), judged at the model's stall_look threshold;
    unknown: (H, W) bool, cells of colour without depth (the /heightmap message's NaN heights): the unknown
    regions among them (core.unknown_height) are objects of UNKNOWN_HEIGHT, judged with the others, and the
    largest is a TARGET to look at (last_look) where the answer would otherwise be NONE.
    ValueError for bad shapes or types."""
    holes = [] if unknown is None else unknown_regions(color, height, unknown, params.density.occupied_height,
                                                       params.min_region_area)
    if holes:
        height = np.nan_to_num(np.asarray(height, dtype=np.float32), nan=0.0)
        for hole in holes:
            height[hole.mask] = np.maximum(height[hole.mask], np.float32(UNKNOWN_HEIGHT))
    scene = find_regions(color, height, params)
    heaps = Heaps(scene.height, grid.resolution, params.density)
    masks: dict = {}

    def grown(region: SalientRegion) -> np.ndarray:
        """`region`'s mask grown to the whole object (grow_target_mask), computed once per region."""
        if id(region) not in masks:
            masks[id(region)] = grow_target_mask(scene.color, scene.objects, region,
                                                 params.mask_chroma_tolerance, reach=params.crop_size // 2)
        return masks[id(region)]

    def target(region: SalientRegion, reason: str, clusters=(), looked: bool = False) -> AttentionOutput:
        target_cells = grown(region)
        rows, cols = np.nonzero(target_cells)
        return _output(AttentionMode.TARGET, region.score, (rows.mean(), cols.mean()), scene, params, grid,
                       clusters=clusters, target_region=region, mask_cells=target_cells, reason=reason,
                       last_look=looked)

    looked_at = None  # (the likeliest region, why) when a last look may take it
    no_target = "no salient region"
    if scene.regions:
        model = params.verifier or default_verifier()
        verdict = verify(scene, params, model)
        least, view = decision_threshold(model, closer)
        order, probability, known = verdict.order, verdict.probability, ""
        if known_product is not None and heaps.occluded_region is not None:
            def colour_of(i: int) -> np.ndarray:
                return mask_colour(scene.color, grown(verdict.candidates[i]))

            order, probability, known = pass_over_known_product(verdict, known_product, colour_of, params)
        k = order[0]
        region, of = verdict.candidates[k], f"{k + 1} of {len(scene.regions)}"
        if probability[k] >= least:
            return target(region, f"salient region {of} ({region.area} px): impurity probability "
                                  f"{probability[k]:.2f} >= {least:.2f}{view}{known}")
        no_target = (f"no salient region is an impurity: the likeliest, region {of}, {probability[k]:.2f} < "
                     f"{least:.2f}{view}{known}")
        if last_look(probability[k], model):
            looked_at = (region, f"last look (no heap could hide an impurity): salient region {of} "
                                 f"({region.area} px): impurity probability {probability[k]:.2f} >= "
                                 f"{model.last_look:.2f}")
    clusters, chosen = heaps.clusters, heaps.occluded_region
    if chosen is None and looked_at is not None:
        return target(*looked_at, clusters, looked=True)
    if chosen is None and holes:
        hole = holes[0]
        return _output(AttentionMode.TARGET, float(scene.saliency[hole.mask].mean()), hole.centroid, scene,
                       params, grid, clusters=clusters, mask_cells=hole.mask, last_look=True,
                       reason=f"{no_target}; look at a region of unknown height ({hole.area} px coloured "
                              f"unlike the table, delta E {hole.delta_e:.0f}, no depth: black or glossy?)")
    if chosen is not None:
        return _output(AttentionMode.OCCLUDED_REGION, chosen.height, chosen.centroid, scene, params, grid,
                       clusters=clusters, cluster=chosen,
                       reason=f"{no_target}; cluster of {chosen.area * 1e4:.1f} cm^2, "
                              f"{chosen.height * 100:.1f} cm high")
    why_not = ("no dense cluster" if not clusters else
               f"largest cluster {clusters[0].area * 1e4:.1f} cm^2, {clusters[0].height * 100:.1f} cm high "
               f"is too small or too low to hide a target")
    centre = ((scene.height.shape[0] - 1) / 2.0, (scene.height.shape[1] - 1) / 2.0)
    return _output(AttentionMode.NONE, 0.0, centre, scene, params, grid, clusters=clusters,
                   reason=f"{no_target}; {why_not}")


@functools.cache
def shipped_network():
    """The shipped impurity network (impurity_net.read_network()), read once per process; torch is imported
    only here, when a model reads NETWORK_FEATURES."""
    from .impurity_net import read_network
    return read_network()


def _output(mode, score, centroid, scene: Scene, params, grid, clusters=(), target_region=None, cluster=None,
            mask_cells=None, reason="", last_look=False) -> AttentionOutput:
    color, height, saliency, regions = scene.color, scene.height, scene.saliency, scene.regions
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
        reason=reason, last_look=last_look, height=height)


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
