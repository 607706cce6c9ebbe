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
from impurity_common.colour import ProductReference, mask_colour, region_contrast
from impurity_common.enums import AttentionMode  # AttentionResult.MODE_* (re-exported)
from impurity_common.grid import HeightmapGrid

from .density import Cluster, DensityParams, find_clusters, select_occluded_region
from .heightmap import clipped_view
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

BACKGROUNDS = ("objects", "table")
CONTRASTS = ("relative", "absolute")
DECISIONS = ("rule", "verifier")
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
    background: str = "objects"  # "objects": paint table/unseen cells with the objects' median colour
    region_fraction: float = 0.5  # a salient region: connected object cells >= this x the peak saliency
    min_region_area: int = 30  # px (2 mm cells): smaller regions are specks, not objects
    contrast: str = "relative"  # CONTRASTS: how the best region is judged (module docstring)
    # relative: the lightness map's weight against the two chromatic ones. Every product block has
    # shading contrast in I (faces at different angles to the light) and none in RG / I, BY / I, so a
    # heap of product reads as salient in I. scripts/calibrate_attention.py, tuning palettes, scenes
    # without a visible impurity including heaps: at 5 % false TARGET, weight 1.0 finds 88.4 % of the
    # impurities, 0.7 93.9 %, 0.5 94.2 % (but its best region misses more impurities: 96.8 vs 99.0 %).
    lightness_weight: float = 0.7
    # relative: mean relative saliency of m_t below this -> no visible target. Chosen by
    # `scripts/calibrate_attention.py palette-sweep` (since replaced by rule-sweep) on tuning palettes and
    # tuning seeds only (29 palettes and the default at exposure x0.5 and x2; 310 scenes with a visible
    # impurity, 279 without: clean scenes and heaps hiding every target): saliency alone meets no aim pair
    # (>= 95 % found, <= 5 % false TARGET); 4.4 is the lowest within the false-TARGET aim: 93.5 % found,
    # 3.2 % false TARGET.
    min_relative_contrast: float = 4.4
    # relative: the best region must also stand apart in colour from the other object cells: the
    # Mahalanobis distance of its mean colour from theirs (impurity_common.colour.ProductReference, least
    # spread color_min_spread RGB) at least this; 0 = no colour test. A floor, not a detector: late in an
    # episode the few products left can outshine each other in saliency (a lone slab, a small block at
    # the edge) while having the product's colour, and the cell grasps at them until its failure limit.
    # 2.0, chosen on tuning palettes and seeds only: under min_relative_contrast 4.4 every floor up to 2.5
    # keeps the 93.5 % found in first views and lowers false TARGET from 3.2 to 1.4 %
    # (docs/attention_palette_sweep.txt), and 2.0 gives the most episodes ended by attention's NONE with
    # no impurity left, 30/30 against 26/30 without (1.5: 29, 2.5: 27; scripts/calibrate_episode_end.py,
    # docs/episode_end/tuning.txt). A detector built on it (palette-sweep's best triple, min_relative_contrast
    # 2.7, min_color_contrast 3.0: 95.5 % found, 2.2 % false TARGET on tuning scenes) found 86.7 % on
    # held-out palettes (the first set, now retired) against 91.7 % for saliency alone: not adopted.
    min_color_contrast: float = 2.0
    color_min_spread: float = 4.0
    # relative: two physical corrections of the colour test, off by default (0). color_shading: the other
    # objects' colours get this much spread along their mean colour's direction, as a share of its length
    # (a shaded face of a product block has its RGB scaled, so it stays near the product while another hue
    # stays far). color_saturation: channels in which at least half the other objects reach this 8-bit level
    # are left out (a channel at the camera's ceiling is not scaled by shading). Tried on 2026-11-30 (sixth
    # session; README "Perception", docs/experiments.md): with both on, `scripts/calibrate_attention.py
    # rule-sweep` finds 95.1 % at 0.8 % false TARGET on 101 tuning palettes, against 89.1 % at 1 % with
    # neither. On the held-out sets (the second and the first, both retired since) three rules built on them
    # found 83.3 / 83.3 / 75.8 % against 80.0 % and 93.3 / 80.8 / 75.8 % against 92.5 % for the rule below:
    # no clear gain, and the first of them grasped twice as many product blocks in the default palette's
    # heaps (6 against 3 in 20 invisible episodes). Not adopted.
    color_shading: float = 0.0
    color_saturation: float = 0.0
    # relative: a second way to be a target, for a region distinct in colour. Its saliency contrast may
    # fall short of min_relative_contrast when a scene holds two impurities: the second one, left in the
    # product's level, raises the level the first is judged against (most misses on the tuning scenes:
    # the best region is the impurity, contrast 3.4-4.3, colour contrast 2.3-5.2). A best region whose
    # colour contrast (as min_color_contrast's) reaches distinct_color_contrast is a target from
    # min_relative_contrast_distinct on; 0 = this path off. Chosen by `scripts/calibrate_attention.py
    # palette-sweep` on tuning palettes and seeds only, under the rule above: the most impurities found
    # with no more false TARGETs than the rule alone (93.5 -> 96.5 % found, false TARGET 1.4 % both); every
    # saliency threshold from 2.0 to 3.3 ties with 4.0, and the middle is taken
    # (docs/attention_palette_sweep.txt).
    distinct_color_contrast: float = 4.0
    min_relative_contrast_distinct: float = 2.7
    # relative: a last look before NONE, 0 = off. When the best region is no target and no heap could hide
    # one, the episode would end there, with any impurity the thresholds above missed left behind. A best
    # region of at least last_look_contrast relative saliency and last_look_color_contrast colour contrast
    # is then attended as a TARGET instead: one grasp at the most suspicious object before calling the
    # scene clean (the grasp verdict still judges what was lifted).
    last_look_contrast: float = 0.0
    last_look_color_contrast: float = 0.0
    # absolute: mean saliency of m_t below this: no visible target. Tuning scenes (seeds 0-99, default
    # palette only, saliency ABSOLUTE_SALIENCY = (2, 6)): targets >= 0.054, scenes without impurity
    # <= 0.021; 0.034 is their geometric mean. Use it with saliency=ABSOLUTE_SALIENCY.
    min_target_contrast: float = 0.034
    # The target mask: object cells connected to m_t whose shading-free chroma (RG, BY divided by
    # intensity) lies within this distance of m_t's. 0 = the salient region itself.
    mask_chroma_tolerance: float = 0.5
    # relative: how a target is decided (DECISIONS; contrast "absolute" keeps min_target_contrast). "rule":
    # the thresholds above, on the best region (is_target). "verifier": the learned region verifier
    # (verifier.py) scores the best TOP_REGIONS regions and the most probable one is a target when its
    # probability reaches verifier_threshold (0 = the model's own); the thresholds above are then unused (the
    # last look still reads them). "verifier" since the eighth session: on tuning palettes and seeds only,
    # palette-grouped cross-validation 97.4 % found at 1.2 % false TARGET against the rule's 92.1 % at
    # 2.1 % (on 96 tuning palettes rendered afresh later: 92.4 % at 0.7 % against 85.9 % at 1.6 %), and on
    # 204 truth-counted tuning episodes grasp success 88.4 -> 91.5 % and completion
    # 96.5 -> 98.6 % (tuning palettes, mean of the three scenarios), the default palette's grasp success
    # 98.3 / 95.0 / 85.8 -> 98.3 / 92.5 / 89.2 % (docs/experiments.md, eighth section).
    decision: str = "verifier"
    verifier_threshold: float = 0.0
    # verifier: a last look before NONE, 0 = off. When no heap could hide an impurity, the likeliest region
    # is attended as a TARGET from this probability on: one grasp at the most suspicious object before
    # the scene is called clean (the grasp verdict judges what was lifted). On 300 truth-counted episodes
    # on tuning palettes nothing was chosen on (random-96 ... 191 and the named ones, seeds 71000+), 22
    # ended with attention seeing neither an impurity nor a heap while one was in view; in 18 the impurity
    # was the likeliest region, at 0.00-0.67 against the threshold 0.69. In their last views a last look
    # takes the impurity in 10 and none of 9 clean last views for every value from 0.25 to 0.40; 0.35 was
    # adopted by a criterion written beforehand: with it those 300 episodes complete 281 instead of 272
    # (14 more targets in 21 more grasps), the default palette's 60 tuning episodes are unchanged, and
    # 40 tuning episodes counted by perception end clean as often (38) with as few impurities left (2).
    # docs/experiments.md, tenth section. A refit moves the probabilities, so the value goes with the model:
    # 0.52 for the twenty-first session's (fifteen features), by the same rule on views the choosing model
    # was not fitted on (a model fitted on the even-index palettes' loop views, read on the odd-index ones'
    # 16 views where the last look decides: no clean view and 2 impurities taken from 0.46 to 0.58;
    # docs/experiments_s21/last_look.py, docs/experiments.md, twenty-first section). 0.391 for the network
    # model (seventeen features, shipped in the thirty-seventh session): the least value at which it lets
    # through no more of the verifier fit's 2933 tuning scenes without a visible impurity than the fifteen-
    # feature model did at 0.52 (127 each; docs/experiments_s36/match_thresholds.py, thirty-sixth section).
    verifier_last_look: float = 0.391
    # verifier: the threshold of a stall look (attend's closer=True), which the picking loop asks for on the
    # EpisodeLimits.stall_look_views-th OCCLUDED_REGION view in a row (picking's module docstring); 0 = off
    # (a closer look then decides as any other). 0.25 lies between the reads of missed targets (0.07-0.54
    # in most views of stalled challenging episodes) and of the product pieces that were likeliest there
    # (0.00-0.14) in the twenty-seventh session's replays on tuning data; tested in the thirtieth session
    # (200 challenging episodes, criterion not met on an interval touching 0) and adopted in the
    # thirty-first on 400 more, read as make eval reads (docs/experiments.md, thirty-first section). 0.134
    # for the network model (thirty-seventh session), matched to 0.25 of the fifteen-feature model as the
    # last look was (331 against 333 of the 2933 clean tuning scenes; docs/experiments_s36/match.txt).
    stall_look_threshold: float = 0.134
    # verifier: on a clipped view (heightmap.clipped_view: half the object cells at 250+ of 255 in one
    # channel, when the heightmap node warns about exposure), a target needs at least this probability; 0 =
    # the same threshold as elsewhere. Off: tried in the twelfth session and not adopted. Clipping changes a
    # light product's hue on its lit faces only (a blue product at exposure x2: lit faces cyan, shaded ones
    # still blue), so a shaded face can look like an impurity. 0.8 was chosen on the default palette's tuning
    # scenes at x2 (seeds 30000+, 35000+, 40000+: false TARGETs 16 -> about 6 of 600, x1 4, every impurity
    # still found; 65 instead of 67 of the tuning palettes' 81 clipped views with an impurity, no change on
    # their own-layout scenes). On a fresh tuning set (45000+) it gave 8 instead of 10 false TARGETs of 300 at
    # x2 against 1 at x1: over the 2-point aim, so the criterion written beforehand failed
    # (docs/experiments.md, twelfth section). A lever for a cell whose camera cannot be kept from clipping; a
    # camera that does not clip is the remedy (the heightmap node's exposure warning names the camera
    # parameters). It applies to the decision only: with no heap left, the last look still takes the likeliest
    # region from verifier_last_look on. It reads the colours attention receives: with the heightmap node's
    # colour_adaptation on, the transferred colours are rarely clipped, so it seldom applies.
    verifier_clipped_threshold: float = 0.0
    # verifier: while a heap that could hide a target is left (density.select_occluded_region), a target needs
    # at least this probability; 0 = the same threshold as elsewhere. Off: tried in the sixteenth session and
    # not adopted (on 200 fresh invisible tuning episodes 0.85 raised grasp success by 2.1 points, but the
    # paired interval, -1.5 to +6.0, reached below 0; 44 -> 33 product pieces grasped). In picking, a
    # TARGET on a product object costs a grasp and throws the product away: in 52 invisible episodes on
    # tuning palettes (seeds 99 800-99 851, docs/experiments_s16/grasps_tuning.jsonl) 8 of the 23 failed
    # grasps were TARGETs under 0.85 (as attention's reason rounds it), each at least 7.6 cm from any target,
    # and 1 of the 102 grasps that lifted a target was under 0.85; on the default palette 7 of 19 and 0 of
    # 102. First views hold few such regions (docs/experiments_s16/heap_probe.txt): the views after pushes
    # do. With a heap left a push is the other choice, so an uncertain region can wait; with none left the
    # threshold above and the last look apply as before. docs/experiments.md, sixteenth section.
    verifier_heap_threshold: float = 0.0
    verifier: RegionVerifier | None = None  # None: the shipped model (verifier_model.py)
    # verifier: the impurity network (impurity_net.ImpurityNet) a model that reads NETWORK_FEATURES runs on
    # the view; None: the shipped weights (impurity_net.SHIPPED_NETWORK), read once. Unused otherwise.
    impurity_net: object = None
    # verifier, with a known_product (product_memory.known_product) handed to attend, while a heap that could
    # hide a target is left (density.select_occluded_region): a region whose grown mask's median colour lies
    # within known_product_delta_e (CIE76) of more than known_product_max_share of the remembered product
    # colours is product, whatever its probability; the next likeliest region is judged instead. With no heap
    # left the cell would otherwise call the scene clean, so the verifier decides alone. From 60 invisible
    # tuning episodes with a grasp on product (twenty-fifth section of docs/experiments.md,
    # docs/experiments_s25/temporal_screen.py): dE 4 and 1 % kept 98 % of the TARGET grasps on a target and
    # caught 90 % of those on product. Without a known_product nothing changes.
    known_product_delta_e: float = 4.0
    known_product_max_share: float = 0.01
    # verifier, building the known product (product_memory.known_product): leave out the region attention
    # would take at the last look's threshold (verifier_last_look) in that view, a near miss that may be an
    # impurity the decision missed; its colour is then not remembered as product. On a challenging tuning
    # episode the first view's likeliest region was the target at 0.56, under the threshold; remembered as
    # product, it was passed over for the rest of the episode (30 pushes, no grasp). Adopted in the
    # twenty-seventh session on fresh tuning seeds 8 700-9 099 (docs/experiments.md): grasp success
    # invisible / random / challenging -0.2 / 0.0 / -0.9 points, completion unchanged, 397 of 400
    # episodes alike.
    known_product_near_miss: bool = True

    def __post_init__(self):
        if self.crop_size < 2 or self.crop_size % 2:
            raise ValueError(f"crop_size must be even and >= 2, got {self.crop_size}")
        if self.background not in BACKGROUNDS:
            raise ValueError(f"background '{self.background}' not one of {BACKGROUNDS}")
        if self.contrast not in CONTRASTS:
            raise ValueError(f"contrast '{self.contrast}' not one of {CONTRASTS}")
        if self.decision not in DECISIONS:
            raise ValueError(f"decision '{self.decision}' not one of {DECISIONS}")
        if not 0.0 <= self.verifier_threshold < 1.0:
            raise ValueError(f"verifier_threshold must be a probability in [0, 1) (0 = the model's own), got "
                             f"{self.verifier_threshold}")
        if not 0.0 <= self.verifier_clipped_threshold < 1.0:
            raise ValueError(f"verifier_clipped_threshold must be a probability in [0, 1) (0 = off), got "
                             f"{self.verifier_clipped_threshold}")
        if not 0.0 <= self.verifier_heap_threshold < 1.0:
            raise ValueError(f"verifier_heap_threshold must be a probability in [0, 1) (0 = off), got "
                             f"{self.verifier_heap_threshold}")
        if not 0.0 <= self.verifier_last_look < 1.0:
            raise ValueError(f"verifier_last_look must be a probability in [0, 1) (0 = off), got "
                             f"{self.verifier_last_look}")
        if not 0.0 <= self.stall_look_threshold < 1.0:
            raise ValueError(f"stall_look_threshold must be a probability in [0, 1) (0 = off), got "
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
        if not self.min_color_contrast >= 0.0:
            raise ValueError(f"min_color_contrast must be >= 0, got {self.min_color_contrast}")
        if not self.color_min_spread > 0.0:
            raise ValueError(f"color_min_spread must be > 0 (RGB), got {self.color_min_spread}")
        if not 0.0 <= self.color_saturation <= 255.0:
            raise ValueError(f"color_saturation must be in [0, 255] (8-bit RGB; 0 = off), got "
                             f"{self.color_saturation}")
        if not self.color_shading >= 0.0:
            raise ValueError(f"color_shading must be >= 0 (a share of the mean colour), got "
                             f"{self.color_shading}")
        if not self.distinct_color_contrast >= 0.0:
            raise ValueError("distinct_color_contrast must be >= 0 (0 = off), got "
                             f"{self.distinct_color_contrast}")
        if not (self.last_look_contrast >= 0.0 and self.last_look_color_contrast >= 0.0):
            raise ValueError("last_look_contrast and last_look_color_contrast must be >= 0 (0 = off), got "
                             f"{self.last_look_contrast}, {self.last_look_color_contrast}")
        if not self.min_relative_contrast_distinct >= 0.0:
            raise ValueError("min_relative_contrast_distinct must be >= 0, got "
                             f"{self.min_relative_contrast_distinct}")

    @property
    def uses_verifier(self) -> bool:
        """Whether attend decides with the verifier (decision "verifier" with contrast "relative"): only then
        are the verifier's thresholds, the known product and the stall look read."""
        return self.decision == "verifier" and self.contrast == "relative"

    @property
    def stall_look_applies(self) -> bool:
        """Whether attend's closer=True changes anything: the verifier decides, stall_look_threshold > 0."""
        return self.uses_verifier and self.stall_look_threshold > 0


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


def saliency_input(color: np.ndarray, objects: np.ndarray, background: str) -> np.ndarray:
    """The image VOCUS2 sees: with background "objects", non-object cells take the objects' median
    colour so that contrast is measured against the product, not the table."""
    if background == "table" or not np.any(objects):
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
    """The saliency map the decision reads: relative (dimensionless) or absolute (opponent-colour
    units), per params.contrast."""
    return scene_maps(color, objects, params)[0]


def scene_maps(color: np.ndarray, objects: np.ndarray, params: AttentionParams) -> tuple:
    """(saliency as scene_saliency, conspicuity): relative contrast also gives VOCUS2's chromaticity-space
    conspicuity maps by channel name (the verifier's features), absolute an empty dict."""
    image = saliency_input(color, objects, params.background)
    if params.contrast == "absolute":
        return vocus2(image, params.saliency).saliency, {}
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
    if tolerance <= 0:
        return region.mask
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
    colours of an earlier view that showed product only (product_memory); with the verifier and a heap left, a
    region coloured like them is not a target (AttentionParams.known_product_max_share). closer: a stall look
    (the picking loop's, after pushes that found nothing): the verifier's threshold is
    AttentionParams.stall_look_threshold instead of verifier_threshold, a clipped view's threshold still
    applies, and the reason says "(stall look)"; no effect with stall_look_threshold 0 or another decision."""
    color, height = sanitize(color, height)
    objects = height > params.density.occupied_height
    saliency, conspicuity = scene_maps(color, objects, params)
    regions = salient_regions(saliency, objects, params)
    best = regions[0] if regions else None
    threshold = params.min_relative_contrast if params.contrast == "relative" else params.min_target_contrast

    @functools.cache
    def colour() -> float:
        """The best region's colour contrast (region_color_contrast; inf without a best region), computed
        once and only when a decision reads it (the verifier does not)."""
        return region_color_contrast(color, objects, best, params) if best is not None else float("inf")

    @functools.cache
    def dense_clusters() -> list:
        """The height map's dense clusters (density.find_clusters), computed once: by the heap threshold's
        test when it applies, and for an occluded region or NONE."""
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

    last_look_region = None  # verifier: (the likeliest region, why), when a last look may take it
    if params.uses_verifier:
        no_target = "no salient region"
        if regions:
            model = params.verifier or default_verifier()
            least = params.verifier_threshold or model.threshold
            view = ""
            if closer and params.stall_look_applies:
                least, view = params.stall_look_threshold, " (stall look)"
            clipped = params.verifier_clipped_threshold > least and clipped_view(color, objects)
            if clipped:
                least = params.verifier_clipped_threshold
            view += " (clipped view)" if clipped else ""
            if (params.verifier_heap_threshold > least
                    and select_occluded_region(dense_clusters()) is not None):
                least = params.verifier_heap_threshold
                view += " (heap left)"
            network = (params.impurity_net or shipped_network()) if model.reads_network else None
            candidates, features = zip(*candidate_features(color, height, objects, conspicuity, regions,
                                                           oriented=model.reads_oriented, network=network),
                                       strict=True)
            if features[0] is None:  # one region, every object in view: nothing to compare with, so
                # saliency decides alone, as the rule does (a colour contrast of inf)
                probability = np.array([1.0 if is_target(best.score, float("inf"), params) else 0.0])
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
            if 0 < params.verifier_last_look <= probability[k]:
                last_look_region = (candidates[k], f"last look (no heap could hide an impurity): salient "
                                                   f"region {k + 1} of {len(regions)} ({candidates[k].area} "
                                                   f"px): impurity probability {probability[k]:.2f} >= "
                                                   f"{params.verifier_last_look:.2f}")
    elif best is not None and is_target(best.score, colour(), params):
        return target(best, f"salient region of {best.area} px, contrast {best.score:.4f}, colour contrast "
                            f"{colour():.2f}")
    elif best is None:
        no_target = "no salient region"
    elif best.score < threshold:
        no_target = f"best region {params.contrast} contrast {best.score:.4f} < {threshold:.4f}"
        if params.contrast == "relative" and params.distinct_color_contrast > 0:
            no_target += (f" (colour contrast {colour():.2f}; a region distinct in colour, >= "
                          f"{params.distinct_color_contrast:.2f}, needs "
                          f"{params.min_relative_contrast_distinct:.2f})")
    else:
        no_target = (f"best region's colour contrast {colour():.2f} < {params.min_color_contrast:.2f} "
                     "(coloured like the other objects)")
    clusters = dense_clusters()
    chosen = select_occluded_region(clusters)
    if chosen is None and last_look_region is not None:
        return target(*last_look_region, clusters, looked=True)
    if chosen is None and best is not None and last_look(best.score, colour(), params):
        return target(best, f"last look (no heap could hide an impurity): salient region of {best.area} px, "
                            f"contrast {best.score:.4f} >= {params.last_look_contrast:.2f}, colour contrast "
                            f"{colour():.2f} >= {params.last_look_color_contrast:.2f}", clusters, looked=True)
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


def is_target(score, colour, params: AttentionParams):
    """Whether the best salient region is an impurity, from its contrast `score` (relative saliency, or
    opponent-colour units with contrast "absolute") and its colour contrast `colour` (region_color_contrast;
    inf when nothing to compare with): relative - score >= min_relative_contrast and colour >=
    min_color_contrast, or a region distinct in colour (a finite colour >= distinct_color_contrast > 0)
    with score >= min_relative_contrast_distinct; absolute - score >= min_target_contrast.
    Scalars give a bool; arrays of scores and colours (one per region) give a bool array."""
    score, colour = np.asarray(score, dtype=float), np.asarray(colour, dtype=float)
    if params.contrast != "relative":
        decided = score >= params.min_target_contrast
    else:
        salient = (score >= params.min_relative_contrast) & (colour >= params.min_color_contrast)
        distinct = (params.distinct_color_contrast > 0) & np.isfinite(colour) & \
            (colour >= params.distinct_color_contrast) & (score >= params.min_relative_contrast_distinct)
        decided = salient | distinct
    return bool(decided) if decided.ndim == 0 else decided


def last_look(score, colour, params: AttentionParams) -> bool:
    """Whether a best region that is no target is grasped anyway when nothing else is left (no heap):
    relative contrast only, last_look_contrast > 0, score >= last_look_contrast and colour (as in
    is_target; inf when nothing to compare with) >= last_look_color_contrast."""
    return (params.contrast == "relative" and params.last_look_contrast > 0
            and score >= params.last_look_contrast and colour >= params.last_look_color_contrast)


def region_color_contrast(color: np.ndarray, objects: np.ndarray, region: SalientRegion,
                          params: AttentionParams) -> float:
    """How far a salient region's mean colour stands apart from the other object cells' colours:
    ProductReference.contrast (Mahalanobis, dimensionless) with least spread params.color_min_spread,
    shading allowance params.color_shading and saturated channels (params.color_saturation) left out.
    color (H, W, 3) uint8, objects (H, W) bool. inf when no other object cell is in view (nothing to
    compare with: the saliency decides alone)."""
    contrast = region_contrast(color, region.mask, objects, params.color_min_spread, params.color_shading,
                               params.color_saturation or None)
    return float("inf") if contrast is None else contrast


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
